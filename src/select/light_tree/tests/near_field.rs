//! The root's table: at its grid points each root lane's Σ Φ_i / max(d_i², ε), here summed over
//! the lane's lights one by one, in f64, from their bounds as given to the build; read between
//! them by trilinear interpolation; and each lane's bound R on its lights' distance from its
//! power centre, against the lights one by one.

use super::*;
use crate::select::light_tree::traverse::binary_tree;

#[test]
fn the_root_table_holds_each_lanes_power_over_squared_distance() {
    let mut rng = Rand::new(17);
    let scene = random_scene(&mut rng, 3000);
    let (bvh, order) = LightBvh::build(&scene.bounds);
    let field = bvh.near.as_ref().expect("a tree with extent has a table");
    let root = &bvh.nodes[0];
    // Lane k holds tree ids first[k] up to the next used lane's first.
    let ends: [usize; LANES] = std::array::from_fn(|k| {
        root.first[k + 1..]
            .iter()
            .find(|&&f| f != EMPTY_LANE)
            .map_or(bvh.len(), |&next| next as usize)
    });
    let floor = f64::from(near_field::floor(field.cell));
    let (mut sum_ratio, mut count, mut worst) = (0.0, 0, 1.0f64);
    let [nx, ny, nz] = field.dims;
    for point in (0..nx * ny * nz).step_by(37) {
        let at = [point % nx, (point / nx) % ny, point / (nx * ny)];
        let x = field.lo + field.cell * Vec3::from_array(at.map(|a| a as f32));
        for k in (0..LANES).filter(|&k| root.first[k] != EMPTY_LANE) {
            let exact: f64 = (root.first[k] as usize..ends[k])
                .map(|id| {
                    let b = &scene.bounds[order[id] as usize];
                    let centre = ((b.lo + b.hi) * 0.5).as_dvec3();
                    f64::from(b.phi) / centre.distance_squared(x.as_dvec3()).max(floor)
                })
                .sum();
            let ratio = f64::from(field.points[point][k]) / exact;
            sum_ratio += ratio;
            count += 1;
            worst = worst.max(ratio.max(1.0 / ratio));
        }
    }
    let mean = sum_ratio / count as f64;
    println!("{count} sums: mean ratio {mean:.4}, worst factor {worst:.3}");
    // Far clusters are counted at their power centre (beyond 4 R, each light's 1/d² within a
    // factor (4/3)² of the centre's; beyond 4 sphere radii within (5/3)²), small ones (R ≤ a
    // quarter cell) within 2.25 of it; the rest exactly up to Φ's bfloat16 coding.
    assert!(worst < (5.0f64 / 3.0).powi(2), "worst factor {worst}");
    assert!((mean - 1.0).abs() < 0.02, "mean ratio {mean}");
}

#[test]
fn the_table_is_read_between_grid_points_by_trilinear_interpolation() {
    let mut rng = Rand::new(19);
    let scene = random_scene(&mut rng, 500);
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let field = bvh.near.as_ref().expect("a table");
    let [nx, ny, _] = field.dims;
    let value = |i: usize, j: usize, k: usize| field.points[i + nx * (j + ny * k)];
    let position = |t: Vec3| field.lo + field.cell * t;
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs());
    for (i, j, k) in [(0, 0, 0), (1, 2, 3), (3, 1, 2)] {
        let corner = value(i, j, k);
        let at = field.at(position(Vec3::new(i as f32, j as f32, k as f32)));
        let at = at.expect("a grid point lies inside the grid");
        assert!(
            (0..LANES).all(|l| close(at[l], corner[l])),
            "{at:?} {corner:?}"
        );
        // A quarter of the way along x and halfway along y, z: the weights of the eight corners.
        let t = Vec3::new(i as f32 + 0.25, j as f32 + 0.5, k as f32 + 0.5);
        let at = field.at(position(t)).expect("inside");
        for (l, &read) in at.iter().enumerate() {
            let mut expected = 0.0;
            for (dx, wx) in [(0, 0.75), (1, 0.25)] {
                for dy in 0..2 {
                    for dz in 0..2 {
                        expected += wx * 0.25 * value(i + dx, j + dy, k + dz)[l];
                    }
                }
            }
            assert!(close(read, expected), "lane {l}: {read} against {expected}");
        }
    }
}

#[test]
fn lights_in_one_plane_get_a_table_around_it() {
    // Two panels at y = 1: no extent along y, a slab of grid there.
    let panel = |x: f32| LightBounds {
        lo: Vec3::new(x, 1.0, 0.0),
        hi: Vec3::new(x + 0.5, 1.0, 0.5),
        phi: 1.0,
        w: Vec3::NEG_Y,
        cos_theta_o: 1.0,
        cos_theta_e: 0.0,
        two_sided: false,
    };
    let (bvh, _) = LightBvh::build(&[panel(0.0), panel(0.3)]);
    let field = bvh.near.as_ref().expect("a table");
    assert!(field.at(Vec3::new(0.4, 1.0, 0.25)).is_some());
    assert!(field.at(Vec3::new(0.4, 0.0, 0.25)).is_none());
}

#[test]
fn each_lanes_reach_bounds_its_lights_distance_from_its_power_centre() {
    let mut rng = Rand::new(23);
    let scene = random_scene(&mut rng, 3000);
    let (binary, grid, order, points) = binary_tree(scene.bounds.len(), |i| scene.bounds[i]);
    let (nodes, reach) = collapse(&binary, &grid, &points);
    assert_eq!(reach.len(), nodes.len());
    // Every lane's lights one by one from their bounds, from the root down: (node, end of its
    // id range); a lane's lights run from its first id to the next used lane's.
    let (mut lanes, mut sum_slack) = (0, 0.0f64);
    let mut pending = vec![(0usize, order.len())];
    while let Some((index, end)) = pending.pop() {
        let node = &nodes[index];
        let decoded = Decoded::of(node);
        let used: Vec<usize> = (0..LANES)
            .filter(|&k| node.first[k] != EMPTY_LANE)
            .collect();
        for (i, &k) in used.iter().enumerate() {
            let lane_end = used
                .get(i + 1)
                .map_or(end, |&next| node.first[next] as usize);
            let c = Vec3::new(
                decoded.power_centre[0][k],
                decoded.power_centre[1][k],
                decoded.power_centre[2][k],
            );
            let farthest = order[node.first[k] as usize..lane_end]
                .iter()
                .map(|&light| {
                    let b = &scene.bounds[light as usize];
                    ((b.lo + b.hi) * 0.5).distance(c)
                })
                .fold(0.0f32, f32::max);
            let r = reach[index][k];
            // Up to the f32 rounding of the decoded centre (a few ulps of its coordinates).
            let rounding = 8.0 * f32::EPSILON * (c.abs().max_element() + farthest);
            assert!(
                r >= farthest - rounding,
                "lane {index}/{k}: reach {r} < farthest light {farthest}"
            );
            // A bound, not much above the truth: at most the lane's sphere diameter (plus the
            // power centre's coding step, √3 / 2 of radius / 127).
            assert!(
                r <= 2.0 * decoded.radius[k] * 1.01,
                "lane {index}/{k}: reach {r}, farthest {farthest}, radius {}",
                decoded.radius[k]
            );
            sum_slack += f64::from(r - farthest) / f64::from(decoded.radius[k].max(1e-30));
            lanes += 1;
            let child = node.child(k);
            if child & LIGHT_LANE == 0 {
                pending.push((child as usize, lane_end));
            }
        }
    }
    println!(
        "{lanes} lanes, mean (reach − farthest) / radius {:.3}",
        sum_slack / lanes as f64
    );
    assert!(lanes > 3000);
}
