//! The rendered plane against Lambert's formula, and textured power and light-BVH selection
//! against uniform selection and BSDF sampling.

use super::*;

/// ρ/π · Σ_triangles L_k · E_k at plane point (x, y), with L_k the texel under triangle k.
pub(crate) fn plane_radiance(x: f64, y: f64) -> DVec3 {
    let p = DVec3::new(x, y, 0.0);
    let rho = srgb_decode(ALBEDO_CODE);
    emitter_triangles(Uvs::TexelCentres)
        .iter()
        .map(|(tri, uv)| {
            emission(uv[0], (CLAMP, CLAMP)) * lambert::irradiance(p, DVec3::Z, tri, 1.0)
        })
        .sum::<DVec3>()
        * rho
        / std::f64::consts::PI
}

/// The box filter's average of the plane's radiance over pixel (i, j) (8×8 midpoint quadrature).
pub(crate) fn expected_pixel(i: u32, j: u32) -> DVec3 {
    let t = (0.5 * YFOV_DEG.to_radians()).tan();
    let q = 8;
    let mut sum = DVec3::ZERO;
    for a in 0..q {
        for b in 0..q {
            let sx = (2.0 * (i as f64 + (a as f64 + 0.5) / q as f64) / SIZE as f64 - 1.0) * t;
            let sy = (1.0 - 2.0 * (j as f64 + (b as f64 + 0.5) / q as f64) / SIZE as f64) * t;
            sum += plane_radiance(CAMERA_X + CAMERA_HEIGHT * sx, CAMERA_HEIGHT * sy);
        }
    }
    sum / (q * q) as f64
}

pub(crate) fn render_scene(
    scene: &Scene,
    selector: SelectorKind,
    strategy: Strategy,
    spp: u32,
) -> manylights::film::Film {
    let prepared = PreparedScene::new(scene.clone(), selector);
    let estimator = prepared.estimator(strategy, 1, 1);
    let camera = prepared.scene.camera.clone().unwrap();
    let opts = RenderOptions::new(SIZE, SIZE, spp, 5);
    let (film, stats) = render(&estimator, &camera, &opts);
    assert_eq!(stats.nan_samples + stats.inf_samples, 0);
    film
}

#[test]
pub(crate) fn camera_sees_only_the_plane() {
    let reach = (CAMERA_HEIGHT - Z_E) * (0.5 * YFOV_DEG.to_radians()).tan();
    assert!(X0 > CAMERA_X + reach, "the emitter is visible");
}

#[test]
pub(crate) fn texel_constant_emitter_lights_the_plane_as_lambert_predicts() {
    let scene = scene(Uvs::TexelCentres);
    // Constant emission per triangle: each light's power is its texel's, exactly.
    let lights = Lights::from_scene(&scene);
    let triangles = emitter_triangles(Uvs::TexelCentres);
    for l in &lights.lights {
        let Light::Triangle(light) = l else { continue };
        let (_, uv) = triangles[light.triangle as usize];
        let expected = luminance64(emission(uv[0], (CLAMP, CLAMP)));
        let got = luminance(light.radiance) as f64;
        assert!(
            (got - expected).abs() <= 1e-5 * expected.max(1e-3),
            "{got} vs {expected}"
        );
    }
    let film = render_scene(&scene, SelectorKind::Power, Strategy::LightSolidAngle, 512);
    let (mut sum, mut expected_sum, mut var_sum) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for j in 0..SIZE {
        for i in 0..SIZE {
            let px = &film.pixels[(j * SIZE + i) as usize];
            let expected = expected_pixel(i, j);
            let sigma = px.variance_of_mean().map(f64::sqrt);
            for k in 0..3 {
                assert!(
                    (px.mean[k] - expected[k]).abs() < 5.0 * sigma[k],
                    "pixel ({i},{j}) channel {k}: {} but Lambert gives {} (σ {})",
                    px.mean[k],
                    expected[k],
                    sigma[k]
                );
            }
            sum += px.mean;
            expected_sum += expected;
            var_sum += px.variance_of_mean();
        }
    }
    for k in 0..3 {
        let error = (sum[k] - expected_sum[k]).abs();
        let sigma = var_sum[k].sqrt();
        assert!(
            error < 5.0 * sigma,
            "channel {k}: image sum {} vs Lambert {} (σ {sigma})",
            sum[k],
            expected_sum[k]
        );
    }
}

/// Per 4×4 block and channel: (sum of pixel means, sum of their variances of the mean).
pub(crate) fn blocks(film: &manylights::film::Film) -> Vec<(DVec3, DVec3)> {
    let b = 4;
    let mut out = vec![(DVec3::ZERO, DVec3::ZERO); ((SIZE / b) * (SIZE / b)) as usize];
    for j in 0..SIZE {
        for i in 0..SIZE {
            let px = &film.pixels[(j * SIZE + i) as usize];
            let block = &mut out[((j / b) * (SIZE / b) + i / b) as usize];
            block.0 += px.mean;
            block.1 += px.variance_of_mean();
        }
    }
    out
}

#[test]
pub(crate) fn textured_power_and_bvh_selection_agree_with_uniform_selection_and_bsdf_sampling() {
    let scene = scene(Uvs::Continuous(COARSE));
    let baseline = blocks(&render_scene(
        &scene,
        SelectorKind::Uniform,
        Strategy::LightArea,
        512,
    ));
    assert!(baseline.iter().all(|b| b.0.min_element() > 0.0));
    for (selector, strategy, spp) in [
        (SelectorKind::Power, Strategy::LightSolidAngle, 128),
        (SelectorKind::Bvh, Strategy::LightSolidAngle, 128),
        (SelectorKind::Power, Strategy::Mis, 64),
        (SelectorKind::Uniform, Strategy::Bsdf, 512),
    ] {
        let other = blocks(&render_scene(&scene, selector, strategy, spp));
        for (n, (a, b)) in baseline.iter().zip(&other).enumerate() {
            for k in 0..3 {
                let sigma = (a.1[k] + b.1[k]).sqrt();
                assert!(
                    (a.0[k] - b.0[k]).abs() < 5.0 * sigma,
                    "{selector:?} {strategy:?} block {n} channel {k}: {} vs uniform {} (σ {sigma})",
                    b.0[k],
                    a.0[k]
                );
            }
        }
    }
}
