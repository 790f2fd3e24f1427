//! Every sampler on a smooth configuration — a Lambertian plane (albedo ρ) lit by one large
//! one-sided emissive quad, unoccluded, seen from above by a camera that does not see the
//! emitter — against the exact pixel values: ρ·E(x)/π from Lambert's polygon formula, averaged
//! over each pixel's footprint (16×16 midpoint quadrature), computed here independently of the
//! renderer.
//!
//! For each sampler, S seeds at spp = 4 … 64: the least-squares slope of ln MSE against ln spp
//! (independent: −1 ± 0.1; Sobol: steeper than −1.2; stratified, LHS, Halton: at least the
//! Monte Carlo rate, ≤ −0.9) and, at every spp, the image-mean error within 5σ, σ from the
//! spread of the S independent renders' image means (not from per-pixel sample variances,
//! which a correlated sampler overstates).

use crate::lambert;
use crate::top_view::TopView;

use glam::{DVec3, Vec3};
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::measure::fit::fit_loglog;
use manylights::sampling::rng::derive_seed;
use manylights::sampling::sampler::SamplerKind;
use manylights::scene::{Material, Scene, Triangle};
use manylights::select::SelectorKind;

const RHO: f64 = 0.5;
const RADIANCE: f64 = 3.0;
/// The camera: 3.0 above the plane, 20.0° field of view, 16×16 pixels.
const VIEW: TopView = TopView {
    height: 3.0,
    yfov_deg: 20.0,
    size: 16,
};
const SEEDS: u64 = 8;
const SPPS: [u32; 5] = [4, 8, 16, 32, 64];
/// The emitter: x0, y0, x1, y1 at height `EMITTER_HEIGHT`, facing down, beside the view cone
/// (which is 0.42 wide at that height).
const QUAD: (f32, f32, f32, f32) = (0.5, -1.0, 2.0, 1.0);
const EMITTER_HEIGHT: f32 = 0.6;

fn quad_corners(z: f32) -> [Vec3; 4] {
    let (x0, y0, x1, y1) = QUAD;
    [
        Vec3::new(x0, y0, z),
        Vec3::new(x1, y0, z),
        Vec3::new(x1, y1, z),
        Vec3::new(x0, y1, z),
    ]
}

fn scene() -> Scene {
    let materials = vec![
        Material::lambert(Vec3::splat(RHO as f32)),
        Material::emitter(Vec3::splat(RADIANCE as f32), false),
    ];
    let (a, b, c, d) = (
        Vec3::new(-3.0, -3.0, 0.0),
        Vec3::new(3.0, -3.0, 0.0),
        Vec3::new(3.0, 3.0, 0.0),
        Vec3::new(-3.0, 3.0, 0.0),
    );
    let [e, f, g, h] = quad_corners(EMITTER_HEIGHT);
    let tris = vec![
        Triangle::flat([a, b, c], 0),
        Triangle::flat([a, c, d], 0),
        // Clockwise seen from above: the front face points down at the plane.
        Triangle::flat([e, g, f], 1),
        Triangle::flat([e, h, g], 1),
    ];
    let camera = VIEW.camera();
    Scene::new(tris, materials, Some(camera)).unwrap()
}

/// ρ/π · E at plane point (x, y), E from Lambert's polygon formula (`lambert`).
fn exitant_radiance(x: f64, y: f64) -> f64 {
    let p = DVec3::new(x, y, 0.0);
    let poly = quad_corners(EMITTER_HEIGHT).map(|v| v.as_dvec3());
    lambert::irradiance(p, DVec3::Z, &poly, RADIANCE) * RHO / std::f64::consts::PI
}

/// The box filter's average of the exitant radiance over pixel (i, j)'s footprint.
fn expected_pixel(i: u32, j: u32) -> f64 {
    VIEW.pixel(i, j, 16, exitant_radiance)
}

/// Per spp: each seed's (MSE against the exact pixels, image mean).
struct Measured {
    mse: Vec<Vec<f64>>,
    image_mean: Vec<Vec<f64>>,
}

fn measure(prepared: &PreparedScene, expected: &[f64], sampler: SamplerKind) -> Measured {
    let estimator = prepared.estimator(Strategy::LightArea, 1, 1);
    let camera = prepared.scene.camera.clone().unwrap();
    let mut m = Measured {
        mse: Vec::new(),
        image_mean: Vec::new(),
    };
    for (level, &spp) in SPPS.iter().enumerate() {
        let (mut mses, mut means) = (Vec::new(), Vec::new());
        for seed in 0..SEEDS {
            let opts = RenderOptions {
                sampler,
                ..RenderOptions::new(VIEW.size, VIEW.size, spp, derive_seed(level as u64, seed))
            };
            let (film, stats) = render(&estimator, &camera, &opts);
            assert_eq!(stats.nan_samples + stats.inf_samples, 0);
            // The plane is grey: the green channel stands for all three.
            let values: Vec<f64> = film.pixels.iter().map(|p| p.mean.y).collect();
            let n = values.len() as f64;
            mses.push(
                values
                    .iter()
                    .zip(expected)
                    .map(|(v, e)| (v - e).powi(2))
                    .sum::<f64>()
                    / n,
            );
            means.push(values.iter().sum::<f64>() / n);
        }
        m.mse.push(mses);
        m.image_mean.push(means);
    }
    m
}

#[test]
fn every_sampler_is_unbiased_and_converges_at_its_rate() {
    let prepared = PreparedScene::new(scene(), SelectorKind::Power);
    let expected: Vec<f64> = (0..VIEW.size)
        .flat_map(|j| (0..VIEW.size).map(move |i| expected_pixel(i, j)))
        .collect();
    let truth = expected.iter().sum::<f64>() / expected.len() as f64;
    let kinds = [
        SamplerKind::Independent,
        SamplerKind::Stratified,
        SamplerKind::Lhs,
        SamplerKind::Halton,
        SamplerKind::Sobol,
    ];
    for kind in kinds {
        let m = measure(&prepared, &expected, kind);
        for (level, means) in m.image_mean.iter().enumerate() {
            let s = means.len() as f64;
            let mean = means.iter().sum::<f64>() / s;
            let sd = (means.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (s - 1.0)).sqrt();
            let sigma = sd / s.sqrt();
            assert!(
                (mean - truth).abs() < 5.0 * sigma,
                "{kind:?} at {} spp: image mean {mean} vs exact {truth} (σ {sigma:.2e})",
                SPPS[level]
            );
        }
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for (level, mses) in m.mse.iter().enumerate() {
            for &e in mses {
                xs.push(SPPS[level] as f64);
                ys.push(e);
            }
        }
        let fit = fit_loglog(&xs, &ys).expect("MSEs are positive and finite");
        let mean_mse: Vec<String> = m
            .mse
            .iter()
            .map(|v| format!("{:.2e}", v.iter().sum::<f64>() / v.len() as f64))
            .collect();
        println!(
            "{kind:?}: MSE slope {:.3} (95% [{:.3}, {:.3}]), MSE at spp {SPPS:?}: {}",
            fit.slope,
            fit.slope_interval[0],
            fit.slope_interval[1],
            mean_mse.join(", ")
        );
        match kind {
            SamplerKind::Independent => assert!(
                (fit.slope + 1.0).abs() < 0.1,
                "independent: slope {}",
                fit.slope
            ),
            SamplerKind::Sobol => assert!(fit.slope < -1.2, "sobol: slope {}", fit.slope),
            _ => assert!(fit.slope < -0.9, "{kind:?}: slope {}", fit.slope),
        }
    }
}
