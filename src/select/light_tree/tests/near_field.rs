//! The tables of the root and of its children: at their grid points each of the node's lanes'
//! Σ Φ_i / max(d_i², ε) and its split by direction, here summed over the lane's lights one by
//! one, in f64, from their bounds as given to the build; read between them (T by trilinear
//! interpolation, the direction shares from the nearest point); and each lane's bound R on its
//! lights' distance from its power centre, against the lights one by one.

use super::*;
use crate::select::light_tree::traverse::binary_tree;

/// `count` random emitters (seeded by `seed`), their tree and its leaf order.
fn random_tree(seed: u64, count: usize) -> (Scene, LightBvh, Vec<u32>) {
    let scene = random_scene(&mut Rand::new(seed), count);
    let (bvh, order) = LightBvh::build(&scene.bounds);
    (scene, bvh, order)
}

#[test]
fn the_tables_hold_each_lanes_power_over_squared_distance() {
    let (scene, bvh, order) = random_tree(17, 3000);
    let root = &bvh.nodes[0];
    let root_ends = lane_ends(root, bvh.len());
    // The root's table, then each child's, with the end of the child's range of tree ids.
    let mut tables = vec![(0, bvh.len())];
    for k in (0..LANES).filter(|&k| root.interior & (1 << k) != 0) {
        tables.push((root.child(k) as usize, root_ends[k]));
    }
    assert!(tables.len() > 4, "{} tables", tables.len());
    for (index, end) in tables {
        let field = bvh.near.of(index).expect("a node with extent has a table");
        let node = &bvh.nodes[index];
        let ends = lane_ends(node, end);
        let floor = f64::from(near_field::floor(field.cell));
        let (mut sum_ratio, mut count, mut worst) = (0.0, 0, 1.0f64);
        let (mut sum_share_error, mut shares, mut worst_share_error) = (0.0, 0, 0.0f64);
        let [nx, ny, nz] = field.dims;
        for point in (0..nx * ny * nz).step_by(if index == 0 { 37 } else { 5 }) {
            let at = [point % nx, (point / nx) % ny, point / (nx * ny)];
            let x = field.lo + field.cell * Vec3::from_array(at.map(|a| a as f32));
            for k in (0..LANES).filter(|&k| node.first[k] != EMPTY_LANE) {
                // T, and D for the six directions (+x, −x, +y, …), light by light.
                let (mut exact, mut toward) = (0.0f64, [0.0f64; 6]);
                for &light in &order[node.first[k] as usize..ends[k]] {
                    let b = &scene.bounds[light as usize];
                    let centre = ((b.lo + b.hi) * 0.5).as_dvec3();
                    let term = f64::from(b.phi) / centre.distance_squared(x.as_dvec3()).max(floor);
                    exact += term;
                    let omega = (centre - x.as_dvec3()).normalize_or_zero();
                    for a in 0..3 {
                        toward[2 * a + usize::from(omega[a] < 0.0)] += term * omega[a].abs();
                    }
                }
                let ratio = f64::from(field.plain(point)[k]) / exact;
                sum_ratio += ratio;
                count += 1;
                worst = worst.max(ratio.max(1.0 / ratio));
                for (d, &exact_d) in toward.iter().enumerate() {
                    let share = f64::from(field.share(point, d)[k]);
                    let error = (share - exact_d / exact).abs();
                    sum_share_error += error;
                    shares += 1;
                    worst_share_error = worst_share_error.max(error);
                }
            }
        }
        let mean = sum_ratio / count as f64;
        let mean_share_error = sum_share_error / shares as f64;
        println!(
            "node {index}: {count} sums: mean ratio {mean:.4}, worst factor {worst:.3}; \
             direction shares D / T: mean error {mean_share_error:.4}, worst {worst_share_error:.3}"
        );
        // Far clusters are counted at their power centre (beyond 4 R, each light's 1/d² within
        // a factor (4/3)² of the centre's; beyond 4 sphere radii within (5/3)²), small ones
        // (R ≤ a quarter cell) within 2.25 of it; the rest exactly up to Φ's bfloat16 coding.
        assert!(count > 300, "node {index}: {count} sums");
        assert!(
            worst < (5.0f64 / 3.0).powi(2),
            "node {index}: worst factor {worst}"
        );
        assert!((mean - 1.0).abs() < 0.02, "node {index}: mean ratio {mean}");
        // Each share is coded to within 1/30, and a far cluster's lights lie within asin(1/4)
        // of its centre's direction, so a component of ω is off by at most the chord
        // 2·sin(asin(1/4)/2) ≈ 0.25 for them: 0.29 at worst, a few hundredths on average. A
        // table whose shares were another axis's or sign's would be off by ~0.3 on average.
        assert!(
            worst_share_error < 0.29,
            "node {index}: worst share error {worst_share_error}"
        );
        assert!(
            mean_share_error < 0.02,
            "node {index}: mean share error {mean_share_error}"
        );
    }
}

#[test]
fn the_table_is_read_between_grid_points_by_interpolation_and_the_nearest_points_shares() {
    let (_, bvh, _) = random_tree(19, 500);
    let field = bvh.near.of(0).expect("a table");
    let [nx, ny, _] = field.dims;
    let index = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
    // T, and T times the share facing −y (what a receiver facing −y reads).
    let value = |i: usize, j: usize, k: usize| field.plain(index(i, j, k));
    let facing = |i: usize, j: usize, k: usize| -> [f32; LANES] {
        let (t, share) = (value(i, j, k), field.share(index(i, j, k), 3));
        std::array::from_fn(|l| t[l] * share[l])
    };
    let position = |t: Vec3| field.lo + field.cell * t;
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(b.abs());
    for (i, j, k) in [(0, 0, 0), (1, 2, 3), (3, 1, 2)] {
        let (corner, corner_facing) = (value(i, j, k), facing(i, j, k));
        let grid_point = position(Vec3::new(i as f32, j as f32, k as f32));
        let at = field.at(grid_point, Vec3::NEG_Y);
        let at = at.expect("a grid point lies inside the grid");
        assert!(
            (0..LANES).all(|l| close(at.plain[l], corner[l])),
            "{at:?} {corner:?}"
        );
        // The directed sums to within rounding of T's size (a corner with no light on the −y
        // side reads 0 there, up to its neighbours' rounding-sized weights).
        let near_in_t = |l: usize, a: f32, b: f32| (a - b).abs() <= 1e-5 * corner[l];
        assert!(
            (0..LANES).all(|l| near_in_t(l, at.directed[l], corner_facing[l])),
            "{at:?} {corner_facing:?}"
        );
        // Between grid points: T by trilinear interpolation, the shares of the nearest point.
        let t = Vec3::new(i as f32 + 0.25, j as f32 + 0.7, k as f32 + 0.4);
        let at = field.at(position(t), Vec3::NEG_Y).expect("inside");
        let nearest_share = field.share(index(i, j + 1, k), 3);
        for (l, share) in nearest_share.iter().enumerate() {
            let mut expected = 0.0;
            for (dx, wx) in [(0, 0.75), (1, 0.25)] {
                for (dy, wy) in [(0, 0.3), (1, 0.7)] {
                    for (dz, wz) in [(0, 0.6), (1, 0.4)] {
                        expected += wx * wy * wz * value(i + dx, j + dy, k + dz)[l];
                    }
                }
            }
            let expected_facing = expected * share;
            let (read, read_facing) = (at.plain[l], at.directed[l]);
            assert!(close(read, expected), "lane {l}: {read} against {expected}");
            assert!(
                (read_facing - expected_facing).abs() <= 1e-5 * expected,
                "lane {l}: {read_facing} against {expected_facing}"
            );
        }
    }
}

#[test]
fn a_receiver_off_the_axes_weighs_the_direction_sums_by_its_normal_squared() {
    let (_, bvh, _) = random_tree(29, 800);
    let field = bvh.near.of(0).expect("a table");
    let p = field.lo + field.cell * Vec3::new(2.3, 1.6, 3.7);
    let n = Vec3::new(0.6, -0.48, 0.64);
    // The table read facing each axis alone (+x, −y, +z: n's signs).
    let along = [Vec3::X, Vec3::NEG_Y, Vec3::Z].map(|a| field.at(p, a).expect("inside"));
    let at = field.at(p, n).expect("inside");
    for l in 0..LANES {
        let expected: f32 = (0..3).map(|a| n[a] * n[a] * along[a].directed[l]).sum();
        let read = at.directed[l];
        assert!(
            (read - expected).abs() <= 1e-5 * expected.max(read),
            "lane {l}: {read} against {expected}"
        );
        // Each share is at most 1 and the weights n_a² sum to 1.
        assert!(read <= at.plain[l] * (1.0 + 1e-5), "lane {l}: {read} > T");
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
    let field = bvh.near.of(0).expect("a table");
    assert!(field.at(Vec3::new(0.4, 1.0, 0.25), Vec3::NEG_Y).is_some());
    assert!(field.at(Vec3::new(0.4, 0.0, 0.25), Vec3::NEG_Y).is_none());
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
        let ends = lane_ends(node, end);
        for k in (0..LANES).filter(|&k| node.first[k] != EMPTY_LANE) {
            let lane_end = ends[k];
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

#[test]
fn the_sums_are_the_same_in_eight_lanes() {
    if !crate::cpu::has_avx2_fma() {
        println!("no AVX2 here: only one copy of the sums to compare");
        return;
    }
    let scene = random_scene(&mut Rand::new(29), 3000);
    let (binary, grid, _, points) = binary_tree(scene.bounds.len(), |i| scene.bounds[i]);
    let (nodes, reach) = collapse(&binary, &grid, &points);
    let field = NearField::build(&nodes, &reach, &points, 0, near_field::ROOT_TABLE, false)
        .expect("a table");
    let [nx, ny, nz] = field.dims;
    let mut opened = 0;
    for point in 0..nx * ny * nz {
        let at = [point % nx, (point / nx) % ny, point / (nx * ny)];
        let x = field.lo + field.cell * Vec3::from_array(at.map(|a| a as f32));
        let [(plain, toward), (plain8, toward8)] =
            [false, true].map(|avx2| near_field::sums_at(&nodes, &reach, field.cell, x, avx2));
        assert_eq!(
            plain.map(f32::to_bits),
            plain8.map(f32::to_bits),
            "point {point}"
        );
        for (d, d8) in toward.iter().zip(&toward8) {
            assert_eq!(d.map(f32::to_bits), d8.map(f32::to_bits), "point {point}");
        }
        opened += usize::from(plain.iter().any(|&t| t > 0.0));
    }
    assert!(opened > 0);
}
