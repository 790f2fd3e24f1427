//! The root's table: at its grid points each root lane's Σ Φ_i / max(d_i², ε), here summed over
//! the lane's lights one by one, in f64, from their bounds as given to the build.

use super::*;

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
    // Far clusters are counted at their power centre (distance > 4 radii: each light's 1/d² is
    // within a factor (5/3)² of the centre's), the rest exactly up to Φ's bfloat16 coding.
    assert!(worst < (5.0f64 / 3.0).powi(2), "worst factor {worst}");
    assert!((mean - 1.0).abs() < 0.02, "mean ratio {mean}");
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
