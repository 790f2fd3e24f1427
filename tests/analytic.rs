//! Rendered pixels against Lambert's polygon formula: a Lambertian plane (albedo ρ) lit by four
//! one-sided emissive quads, unoccluded, seen from above by a camera that does not see the
//! emitters. Each pixel's expected value is ρ·E(x)/π averaged over the pixel's footprint on the
//! plane (8×8 midpoint quadrature), computed here independently of the renderer.

use crate::lambert;
use crate::top_view::TopView;

use glam::{DVec3, Vec3};
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::scene::{Material, Scene, Triangle};
use manylights::select::SelectorKind;

const RHO: f32 = 0.5;
/// The camera: 3.0 above the plane, 20.0° field of view, 24×24 pixels.
const VIEW: TopView = TopView {
    height: 3.0,
    yfov_deg: 20.0,
    size: 24,
};

/// Emitters at height 0.6 facing −Z (down), around the camera's field of view:
/// (x0, y0, x1, y1, radiance).
const QUADS: [(f32, f32, f32, f32, f32); 4] = [
    (0.5, -0.6, 1.4, 0.4, 4.0),
    (-1.3, -0.8, -0.5, 0.9, 1.5),
    (-0.4, 0.55, 0.7, 1.2, 9.0),
    (-0.45, -1.5, 0.3, -0.55, 0.25),
];
const EMITTER_HEIGHT: f32 = 0.6;

fn quad_corners(x0: f32, y0: f32, x1: f32, y1: f32, z: f32) -> [Vec3; 4] {
    [
        Vec3::new(x0, y0, z),
        Vec3::new(x1, y0, z),
        Vec3::new(x1, y1, z),
        Vec3::new(x0, y1, z),
    ]
}

fn scene() -> Scene {
    let mut materials = vec![Material::lambert(Vec3::splat(RHO))];
    // The plane faces +Z: counter-clockwise seen from above.
    let [a, b, c, d] = quad_corners(-3.0, -3.0, 3.0, 3.0, 0.0);
    let mut tris = vec![Triangle::flat([a, b, c], 0), Triangle::flat([a, c, d], 0)];
    for &(x0, y0, x1, y1, radiance) in &QUADS {
        let m = materials.len() as u32;
        materials.push(Material::emitter(Vec3::splat(radiance), false));
        // Clockwise seen from above = front face pointing down at the plane.
        let [a, b, c, d] = quad_corners(x0, y0, x1, y1, EMITTER_HEIGHT);
        tris.push(Triangle::flat([a, c, b], m));
        tris.push(Triangle::flat([a, d, c], m));
    }
    let camera = VIEW.camera();
    Scene::new(tris, materials, Some(camera)).unwrap()
}

/// ρ/π · E at plane point (x, y), summed over the emissive quads.
fn exitant_radiance(x: f64, y: f64) -> f64 {
    let p = DVec3::new(x, y, 0.0);
    QUADS
        .iter()
        .map(|&(x0, y0, x1, y1, l)| {
            let poly = quad_corners(x0, y0, x1, y1, EMITTER_HEIGHT).map(|v| v.as_dvec3());
            lambert::irradiance(p, DVec3::Z, &poly, l as f64)
        })
        .sum::<f64>()
        * RHO as f64
        / std::f64::consts::PI
}

/// The expected pixel: the box filter's average of `radiance` over the pixel's footprint.
fn expected_pixel(i: u32, j: u32, radiance: fn(f64, f64) -> f64) -> f64 {
    VIEW.pixel(i, j, 8, radiance)
}

/// Renders the quad-lit plane and checks it against Lambert's formula.
fn check(selector: SelectorKind, strategy: Strategy, k: u32, n: u32, spp: u32) {
    check_scene(scene(), exitant_radiance, selector, strategy, k, n, spp);
}

/// Renders and checks every pixel within 5σ (σ from its own sample variance) and the image mean
/// within 0.5% and within 5σ.
fn check_scene(
    scene: Scene,
    radiance: fn(f64, f64) -> f64,
    selector: SelectorKind,
    strategy: Strategy,
    k: u32,
    n: u32,
    spp: u32,
) {
    let prepared = PreparedScene::new(scene, selector);
    let estimator = prepared.estimator(strategy, k, n);
    let camera = prepared.scene.camera.clone().unwrap();
    let opts = RenderOptions::new(VIEW.size, VIEW.size, spp, 11);
    let (film, stats) = render(&estimator, &camera, &opts);
    assert_eq!(stats.nan_samples + stats.inf_samples, 0);

    let label = format!("{selector:?} {strategy:?} {k}x{n}");
    let (mut sum, mut expected_sum, mut var_sum) = (0.0, 0.0, 0.0);
    for j in 0..VIEW.size {
        for i in 0..VIEW.size {
            let px = &film.pixels[(j * VIEW.size + i) as usize];
            let expected = expected_pixel(i, j, radiance);
            let sigma = px.variance_of_mean().x.sqrt();
            assert!(
                sigma > 0.0,
                "{label}: pixel ({i},{j}) has no variance estimate"
            );
            assert!(
                (px.mean.x - expected).abs() < 5.0 * sigma,
                "{label}: pixel ({i},{j}) = {} but Lambert's formula gives {expected} (σ {sigma})",
                px.mean.x
            );
            // Grey light on a grey plane: all channels agree.
            assert!(
                (px.mean.x - px.mean.z).abs() <= 1e-6 * px.mean.x.abs(),
                "{label}"
            );
            sum += px.mean.x;
            expected_sum += expected;
            var_sum += px.variance_of_mean().x;
        }
    }
    let rel = (sum - expected_sum).abs() / expected_sum;
    let sigma_rel = var_sum.sqrt() / expected_sum;
    assert!(
        rel < 5.0 * sigma_rel,
        "{label}: image mean off by {rel:.2e} (σ {sigma_rel:.2e})"
    );
    assert!(
        rel < 0.005,
        "{label}: image mean off by {:.3}%",
        100.0 * rel
    );
}

#[test]
fn camera_sees_only_the_plane() {
    // The premise of the test: no emitter inside the view frustum at the emitters' height.
    let reach = (VIEW.height - EMITTER_HEIGHT) * (0.5 * VIEW.yfov_deg.to_radians()).tan();
    for &(x0, y0, x1, y1, _) in &QUADS {
        let outside = x0 > reach || x1 < -reach || y0 > reach || y1 < -reach;
        assert!(outside, "emitter ({x0},{y0})..({x1},{y1}) is visible");
    }
}

#[test]
fn emitters_do_not_overlap() {
    // Coplanar overlapping emitters would hide each other from traced rays but not from
    // Lambert's formula (which sums them).
    for (a, qa) in QUADS.iter().enumerate() {
        for qb in &QUADS[a + 1..] {
            let apart = qa.2 <= qb.0 || qb.2 <= qa.0 || qa.3 <= qb.1 || qb.3 <= qa.1;
            assert!(apart, "{qa:?} overlaps {qb:?}");
        }
    }
}

#[test]
fn power_selection_matches_lambert_for_every_kxn() {
    for (k, n) in [(1, 1), (4, 1), (1, 4)] {
        check(SelectorKind::Power, Strategy::LightArea, k, n, 1024);
    }
}

#[test]
fn uniform_selection_matches_lambert_for_every_kxn() {
    for (k, n) in [(1, 1), (4, 1), (1, 4)] {
        check(SelectorKind::Uniform, Strategy::LightArea, k, n, 1024);
    }
}

#[test]
fn cosine_hemisphere_matches_lambert() {
    check(SelectorKind::Power, Strategy::HemisphereCosine, 1, 1, 16384);
}

#[test]
fn uniform_hemisphere_matches_lambert() {
    check(
        SelectorKind::Power,
        Strategy::HemisphereUniform,
        1,
        1,
        16384,
    );
}

#[test]
fn bvh_selection_matches_lambert() {
    for (strategy, k, n) in [
        (Strategy::LightArea, 1, 1),
        (Strategy::LightArea, 4, 1),
        (Strategy::LightArea, 1, 4),
        (Strategy::LightSolidAngle, 1, 1),
        (Strategy::LightSolidAngle, 4, 1),
        (Strategy::Mis, 1, 1),
    ] {
        check(SelectorKind::Bvh, strategy, k, n, 1024);
    }
}

#[test]
fn oracle_selection_matches_lambert() {
    for strategy in [
        Strategy::LightArea,
        Strategy::LightSolidAngle,
        Strategy::Mis,
    ] {
        check(SelectorKind::Oracle, strategy, 1, 1, 1024);
    }
}

#[test]
fn solid_angle_and_mis_match_lambert() {
    for (strategy, k, n) in [
        (Strategy::LightSolidAngle, 1, 1),
        (Strategy::LightSolidAngle, 1, 4),
        (Strategy::Mis, 1, 1),
        (Strategy::Mis, 4, 1),
    ] {
        check(SelectorKind::Power, strategy, k, n, 1024);
        check(SelectorKind::Uniform, strategy, k, n, 1024);
    }
}

#[test]
fn bsdf_sampling_matches_lambert() {
    check(SelectorKind::Power, Strategy::Bsdf, 1, 1, 16384);
}

// Punctual lights above the plane (the camera sees only the plane):
// a point light of intensity I at height h: E = I·cosθ/r² = I·h/r³;
// a spot light pointing down with cones (inner, outer): the same × glTF's falloff t²;
// a directional light of irradiance E0 at incidence θ0: E = E0·cosθ0.
const POINT: (f32, f32, f32, f32) = (0.3, -0.2, 0.8, 0.6); // x, y, h, I
                                                           // The spot is bright enough (Φ ≈ 20% of the total) that power selection picks it often: a light
                                                           // chosen in ~2% of samples leaves too few per pixel for a normal-theory 5σ test.
const SPOT: (f32, f32, f32, f32, f32, f32) = (-0.2, 0.1, 0.9, 40.0, 0.15, 0.3); // x, y, h, I, inner, outer
const SUN: (f32, f32) = (0.25, 0.4); // E0, θ0 (radians, tilted toward +x)

fn punctual_scene() -> Scene {
    use manylights::scene::{PunctualKind, PunctualLight};
    let base = scene();
    // Keep only the plane (the first two triangles).
    let plane = Scene::new(
        base.triangles[..2].to_vec(),
        vec![base.materials[0].clone()],
        base.camera,
    )
    .unwrap();
    let (x, y, h, i) = POINT;
    let (sx, sy, sh, si, inner, outer) = SPOT;
    let (e0, theta) = SUN;
    plane
        .with_punctual(vec![
            PunctualLight {
                kind: PunctualKind::Point,
                position: Vec3::new(x, y, h),
                direction: -Vec3::Z,
                intensity: Vec3::splat(i),
            },
            PunctualLight {
                kind: PunctualKind::Spot {
                    cos_inner: inner.cos(),
                    cos_outer: outer.cos(),
                },
                position: Vec3::new(sx, sy, sh),
                direction: -Vec3::Z,
                intensity: Vec3::splat(si),
            },
            PunctualLight {
                kind: PunctualKind::Directional,
                position: Vec3::ZERO,
                direction: Vec3::new(-theta.sin(), 0.0, -theta.cos()),
                intensity: Vec3::splat(e0),
            },
        ])
        .unwrap()
}

fn punctual_radiance(x: f64, y: f64) -> f64 {
    let (px, py, h, i) = POINT;
    let r2 = (x - px as f64).powi(2) + (y - py as f64).powi(2) + (h as f64).powi(2);
    let point = i as f64 * h as f64 / r2.powf(1.5);
    let (sx, sy, sh, si, inner, outer) = SPOT;
    let r2 = (x - sx as f64).powi(2) + (y - sy as f64).powi(2) + (sh as f64).powi(2);
    let cos = sh as f64 / r2.sqrt();
    let (ci, co) = ((inner as f64).cos(), (outer as f64).cos());
    let t = ((cos - co) / (ci - co)).clamp(0.0, 1.0);
    let spot = si as f64 * t * t * cos / r2;
    let (e0, theta) = SUN;
    let sun = e0 as f64 * (theta as f64).cos();
    RHO as f64 / std::f64::consts::PI * (point + spot + sun)
}

#[test]
fn punctual_lights_match_their_closed_forms() {
    // Delta lights need one sample each; spp only averages the pixel footprint and the choice.
    for selector in [
        SelectorKind::Uniform,
        SelectorKind::Power,
        SelectorKind::Bvh,
        SelectorKind::Oracle,
    ] {
        for strategy in [Strategy::LightArea, Strategy::Mis] {
            check_scene(
                punctual_scene(),
                punctual_radiance,
                selector,
                strategy,
                2,
                1,
                4096,
            );
        }
    }
}
