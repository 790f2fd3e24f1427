//! Samples at the edges: the solid-angle sampler at and around its thresholds, fireflies.

use super::*;

/// Solid angle of triangle `v` seen from p (Van Oosterom & Strackee 1983), in f64.
fn solid_angle(p: DVec3, v: [DVec3; 3]) -> f64 {
    let [a, b, c] = v.map(|x| x - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

#[test]
fn solid_angle_sampling_is_unbiased_at_and_around_its_thresholds() {
    // An equilateral emitter of circumradius R facing down at height h over the receiver, h
    // chosen by bisection so that the triangle subtends Ω from the receiver point.
    let radius = 1.0f64;
    let corners = [0.0f64, 1.0, 2.0].map(|k| {
        let a = std::f64::consts::TAU * k / 3.0;
        DVec3::new(radius * a.cos(), radius * a.sin(), 0.0)
    });
    let omega_at = |h: f64| solid_angle(DVec3::new(0.0, 0.0, -h), corners);
    let height_for = |omega: f64| {
        let (mut lo, mut hi) = (1e-9f64, 1e6f64);
        for _ in 0..200 {
            let mid = (lo * hi).sqrt();
            if omega_at(mid) > omega {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    };
    let min = manylights::lights::triangle::MIN_SPHERICAL_SOLID_ANGLE as f64;
    let max = manylights::lights::triangle::MAX_SPHERICAL_SOLID_ANGLE as f64;
    let two_pi = std::f64::consts::TAU;
    for omega in [
        1e-8,
        0.9 * min,
        min,
        1.1 * min,
        1.0,
        max - 0.01,
        max,
        max + 0.01,
        two_pi - 1e-3,
    ] {
        let h = height_for(omega);
        let z = h as f32;
        // Emitter at height z (facing −Z: clockwise seen from above) and the receiver at 0.
        let v = corners.map(|c| Vec3::new(c.x as f32, c.y as f32, z));
        let mut tris = square(Vec3::ZERO, 4.0, true, 0).to_vec();
        tris.push(Triangle::flat([v[0], v[2], v[1]], 1));
        let scene = receiver_under(tris, vec![Material::emitter(Vec3::splat(1.0), false)]);
        let target = Vec3::ZERO;
        let expected = lambert_radiance(&scene, target, Vec3::Z);
        let eye = Vec3::new(0.0, 0.0, 0.5 * z);
        let (px, stats) = probe(
            &scene,
            SelectorKind::Uniform,
            Strategy::LightSolidAngle,
            eye,
            target,
            40_000,
        );
        assert_matches(
            &format!("Ω = {omega:.4e} sr (h {h:.3e})"),
            &px,
            &stats,
            expected,
        );
    }
}

#[test]
fn fireflies_are_counted_where_a_rare_light_dominates_and_never_in_a_constant_scene() {
    // 1000 dim 1e-3 m² lights at 1 m and one 1e-6 m² light as bright as all of them together,
    // chosen uniformly: the bright light is picked with p = 1/1001 and its sample then weighs
    // ≈ 1001·E_bright ≈ 500 × the pixel mean: a firefly (> 100×) exactly when it is picked.
    let mut tris = square(Vec3::ZERO, 3.0, true, 0).to_vec();
    for i in 0..1000 {
        let c = Vec3::new(
            (i % 32) as f32 / 32.0 - 0.5,
            (i / 32) as f32 / 32.0 - 0.5,
            1.0,
        );
        let (a, b) = (Vec3::new(0.0, 0.045, 0.0), Vec3::new(0.045, 0.0, 0.0));
        tris.push(Triangle::flat([c, c + a, c + b], 1));
    }
    let dim = Scene::new(
        tris.clone(),
        vec![lambert_receiver(), Material::emitter(Vec3::ONE, false)],
        None,
    )
    .unwrap();
    let e_dim = lambert_radiance(&dim, Vec3::ZERO, Vec3::Z);
    let c = Vec3::new(0.0, 0.0, 1.0);
    let bright = [
        c,
        c + Vec3::new(0.0, 1.414e-3, 0.0),
        c + Vec3::new(1.414e-3, 0.0, 0.0),
    ];
    let bright_alone = Scene::new(
        vec![
            square(Vec3::ZERO, 3.0, true, 0)[0].clone(),
            Triangle::flat(bright, 1),
        ],
        vec![lambert_receiver(), Material::emitter(Vec3::ONE, false)],
        None,
    )
    .unwrap();
    let l_bright = (e_dim / lambert_radiance(&bright_alone, Vec3::ZERO, Vec3::Z)) as f32;
    tris.push(Triangle::flat(bright, 2));
    let scene = receiver_under(
        tris,
        vec![
            Material::emitter(Vec3::ONE, false),
            Material::emitter(Vec3::splat(l_bright), false),
        ],
    );
    let prepared = PreparedScene::new(scene, SelectorKind::Uniform);
    let estimator = prepared.estimator(Strategy::LightArea, 1, 1);
    let camera = look_at(Vec3::new(0.0, 0.0, 0.5), Vec3::ZERO, 0.01);
    let opts = RenderOptions::new(4, 4, 1024, 5);
    let (film, stats) = render(&estimator, &camera, &opts);
    let n = stats.camera_samples as f64;
    let p = 1.0 / 1001.0;
    let (expected, sigma) = (n * p, (n * p * (1.0 - p)).sqrt());
    let count = stats.fireflies as f64;
    assert!(
        stats.fireflies > 0 && (count - expected).abs() < 5.0 * sigma,
        "{} fireflies, expected {expected:.1} ± {sigma:.1}",
        stats.fireflies
    );
    assert!(stats.max_sample_luminance > 100.0 * film.image_mean());

    // A constant scene: the camera sees a black emitter, every sample is exactly Le.
    let le = Vec3::new(0.2, 0.3, 0.4);
    let scene = Scene::new(
        square(Vec3::ZERO, 1.0, true, 0).to_vec(),
        vec![Material::emitter(le, false)],
        None,
    )
    .unwrap();
    let prepared = PreparedScene::new(scene, SelectorKind::Power);
    let estimator = prepared.estimator(Strategy::LightArea, 1, 1);
    let (_, stats) = render(&estimator, &camera, &opts);
    assert_eq!(stats.fireflies, 0);
    assert_eq!(
        stats.max_sample_luminance,
        manylights::color::luminance(le) as f64
    );
}
