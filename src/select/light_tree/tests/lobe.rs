//! The specular lobe factor: the pmf keeps exactly the support of the diffuse importance (of a
//! walk that descends every lane; the diffuse walk, which chooses inside far lanes by power, has
//! a support at least as large), `sample_with` and `pmf_with` agree bit for bit and sum to the
//! reachable mass, a light in the lobe gains probability, and each lane's factor is the one
//! written with angles.

use super::*;

#[test]
fn a_lobe_keeps_the_support_and_the_exact_pmf() {
    let mut rng = Rand::new(21);
    let mut checked = 0;
    for &count in &[1, 3, 100, 2000] {
        let scene = random_scene(&mut rng, count);
        let (bvh, _) = LightBvh::build(&scene.bounds);
        let descending = LightBvh {
            prefix: None,
            ..bvh.clone()
        };
        for (p, n) in receivers(&mut rng, &scene, 40) {
            let lobe = random_lobe(&mut rng, n);
            assert_eq!(bvh.root_with(p, n, lobe).is_some(), bvh.can_reach(p, n));
            let mut total = 0.0;
            for l in 0..bvh.len() {
                let (plain, glossy) = (descending.pmf(p, n, l), bvh.pmf_with(p, n, lobe, l));
                assert_eq!(plain > 0.0, glossy > 0.0, "light {l} p {p} n {n} {lobe:?}");
                assert!(
                    plain == 0.0 || bvh.pmf(p, n, l) > 0.0,
                    "light {l} p {p} n {n}"
                );
                total += glossy;
            }
            if bvh.can_reach(p, n) {
                let mass = total + dead_end_mass(&bvh, p, n, lobe);
                assert!((mass - 1.0).abs() < 1e-6, "{mass}");
            }
            for _ in 0..20 {
                if let Some((l, pmf)) = bvh.sample_with(p, n, lobe, rng.f64()) {
                    assert_eq!(pmf.to_bits(), bvh.pmf_with(p, n, lobe, l).to_bits());
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 1000, "{checked}");
}

#[test]
fn a_light_in_the_lobe_gains_probability() {
    // Two equal lights above the receiver at ±x, facing down; the mirror direction points at +x.
    let light = |x: f32| LightBounds {
        lo: Vec3::new(x - 0.05, -0.05, 1.0),
        hi: Vec3::new(x + 0.05, 0.05, 1.0),
        phi: 1.0,
        w: -Vec3::Z,
        cos_theta_o: 1.0,
        cos_theta_e: 0.0,
        two_sided: false,
    };
    let (bvh, order) = LightBvh::build(&[light(1.0), light(-1.0)]);
    let right = order.iter().position(|&i| i == 0).unwrap();
    let (p, n) = (Vec3::ZERO, Vec3::Z);
    let lobe = Lobe {
        r: Vec3::new(1.0, 0.0, 1.0).normalize(),
        sharpness: 50.0,
        gain: 100.0,
    };
    let (plain, glossy) = (bvh.pmf(p, n, right), bvh.pmf_with(p, n, lobe, right));
    assert!((plain - 0.5).abs() < 1e-6, "{plain}");
    assert!(glossy > 0.9 && glossy < 1.0, "{glossy}");
}

/// The lobe factor (glossy / plain importance of a lane) against 1 + g/(1 + λ(1 − cos θm))²
/// written with angles in f64, θm = max(0, ∠(r, c − p) − θb), r read as it is.
#[test]
fn lane_lobe_factor_matches_the_factor_written_with_angles() {
    let mut rng = Rand::new(41);
    let scene = random_scene(&mut rng, 2000);
    let (bvh, _) = LightBvh::build(&scene.bounds);
    let mut compared = 0;
    for (p, n) in receivers(&mut rng, &scene, 300) {
        if n == Vec3::ZERO {
            continue;
        }
        let lobe = random_lobe(&mut rng, n);
        for node in &bvh.nodes {
            let plain = importances(node, p, n, &Lobe::NONE, None, 0.0).importance;
            let glossy = importances(node, p, n, &lobe, None, 0.0).importance;
            let decoded = Decoded::of(node);
            for k in (0..LANES).filter(|&k| node.first[k] != EMPTY_LANE) {
                let (a, b) = (f64::from(plain[k]), f64::from(glossy[k]));
                // Away from the clamps of the importance.
                if !(a > 1e-30 && b < 1e30) {
                    continue;
                }
                let c = DVec3::from_array(decoded.centre.map(|c| f64::from(c[k])));
                let (to_c, r) = (c - p.as_dvec3(), f64::from(decoded.radius[k]));
                let d = to_c.length();
                if (d - r).abs() < 1e-3 * r {
                    continue;
                }
                let theta_b = if d > r {
                    (r / d).asin()
                } else {
                    std::f64::consts::FRAC_PI_2
                };
                let cos_m = lobe.r.as_dvec3().dot(to_c) / d;
                let theta_m = (cos_m.clamp(-1.0, 1.0).acos() - theta_b).max(0.0);
                let t = 1.0 + f64::from(lobe.sharpness) * (1.0 - theta_m.cos());
                let expected = 1.0 + f64::from(lobe.gain) / (t * t);
                // An error of δ in cos θm moves the factor by at most 2λδ/t of itself.
                let slack = 1e-4 + 2.0 * f64::from(lobe.sharpness) * 1e-5 / t;
                assert!(
                    ((b / a) / expected - 1.0).abs() <= slack,
                    "lane {k} p {p}: factor {} vs {expected} {lobe:?}",
                    b / a
                );
                compared += 1;
            }
        }
    }
    println!("{compared} lobe factors compared");
    assert!(compared > 1000, "{compared}");
}
