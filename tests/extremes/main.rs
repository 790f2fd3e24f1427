//! The renderer at its edges (issue 6): shading points on or a micrometre from an emitter,
//! grazing emission and reception, degenerate and non-finite geometry, 1e6 m and 1e-4 m scenes,
//! radiance from 1e-20 to 1e20, a million lights, zero power, the solid-angle sampler at its
//! thresholds, fireflies and long accumulations. Every expected value is computed here
//! independently: Lambert's polygon formula for irradiance, brute-force sums for pmfs, exact
//! constants. Statistical checks allow 5σ, σ from the render's own variance of the mean.

use crate::common;
use crate::lambert;
use crate::shapes;
pub(crate) use shapes::{closed_box, quad};

mod accumulation;
mod geometry;
mod power;
mod samples;

use glam::{DVec3, Mat4, Vec3};
use manylights::film::PixelStats;
use manylights::integrator::{render, PreparedScene, RenderOptions, RenderStats, Strategy};
use manylights::lights::Lights;
use manylights::sampling::rng::PixelRng;
use manylights::scene::{load_gltf, Camera, CameraChoice, Material, Scene, Triangle};
use manylights::select::{oracle, LightSelector, Lobe, SelectorKind, ShadingContext};

pub(crate) const RHO: f32 = 0.5;

/// A horizontal square of half-size `h` centred at `c`; `up` picks the front face (+Z or −Z).
pub(crate) fn square(c: Vec3, h: f32, up: bool, m: u32) -> [Triangle; 2] {
    let p = |x: f32, y: f32| c + Vec3::new(x * h, y * h, 0.0);
    if up {
        quad(p(-1., -1.), p(1., -1.), p(1., 1.), p(-1., 1.), m)
    } else {
        quad(p(-1., -1.), p(-1., 1.), p(1., 1.), p(1., -1.), m)
    }
}

/// A camera node at `eye` whose −Z looks at `target`.
pub(crate) fn look_at(eye: Vec3, target: Vec3, yfov: f32) -> Camera {
    let forward = (target - eye).normalize();
    let hint = if forward.y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let right = forward.cross(hint).normalize();
    let up = right.cross(forward);
    let m = Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        (-forward).extend(0.0),
        eye.extend(1.0),
    );
    Camera::from_world_matrix("probe".into(), &m, yfov, Some(1.0)).expect("valid camera")
}

/// One pixel whose footprint is a point: `spp` camera samples of the radiance leaving `target`
/// toward `eye` (a 1×1 render through a 1e-5 rad field of view).
pub(crate) fn probe(
    scene: &Scene,
    selector: SelectorKind,
    strategy: Strategy,
    eye: Vec3,
    target: Vec3,
    spp: u32,
) -> (PixelStats, RenderStats) {
    let prepared = PreparedScene::new(scene.clone(), selector);
    let estimator = prepared.estimator(strategy, 1, 1);
    let opts = RenderOptions::new(1, 1, spp, 17);
    let (film, stats) = render(&estimator, &look_at(eye, target, 1e-5), &opts);
    (film.pixels[0], stats)
}

/// Exitant radiance ρ/π · Σ L·Ω⊥ of a Lambertian receiver at p (unit normal n) from the
/// one-sided emissive triangles of `scene` (Lambert's formula; zero behind an emitter).
pub(crate) fn lambert_radiance(scene: &Scene, p: Vec3, n: Vec3) -> f64 {
    let rho = scene.materials[receiver_material(scene, p)].base_color.x as f64;
    let mut e = 0.0;
    for t in &scene.triangles {
        let m = &scene.materials[t.material as usize];
        if !m.is_emissive() {
            continue;
        }
        let facing = t.geometric_normal().dot(p - t.positions[0]);
        if facing > 0.0 || m.double_sided {
            let triangle = t.positions.map(|v| v.as_dvec3());
            e += lambert::irradiance(p.as_dvec3(), n.as_dvec3(), &triangle, m.emission.x as f64);
        }
    }
    rho / std::f64::consts::PI * e
}

/// The material of the first non-emissive triangle whose plane holds p (the receiver).
pub(crate) fn receiver_material(scene: &Scene, p: Vec3) -> usize {
    scene
        .triangles
        .iter()
        .find(|t| {
            let n = t.geometric_normal();
            (n.dot(p - t.positions[0])).abs() < 1e-7 * (1.0 + p.length())
                && !scene.materials[t.material as usize].is_emissive()
        })
        .map_or(0, |t| t.material as usize)
}

/// Asserts finite samples and |mean − expected| ≤ 5σ (plus 1e-5·expected for f32 rounding of
/// the estimator's per-sample arithmetic, which matters only where σ ≈ 0).
pub(crate) fn assert_matches(label: &str, px: &PixelStats, stats: &RenderStats, expected: f64) {
    assert_within(label, px, stats, (expected, expected));
}

/// As `assert_matches`, for a truth known to lie in [lo, hi].
pub(crate) fn assert_within(
    label: &str,
    px: &PixelStats,
    stats: &RenderStats,
    (lo, hi): (f64, f64),
) {
    assert_eq!(
        stats.nan_samples + stats.inf_samples,
        0,
        "{label}: non-finite samples"
    );
    let sigma = px.variance_of_mean().x.sqrt();
    let m = px.mean.x;
    let err = (lo - m).max(m - hi).max(0.0);
    assert!(
        err <= 5.0 * sigma + 1e-5 * hi.abs(),
        "{label}: mean {m} but Lambert gives [{lo}, {hi}] (σ {sigma:.3e}, {:.1}σ)",
        err / sigma
    );
}

/// Lambert's value over the shading points the renderer can compute for `target` on a receiver
/// of half-size `extent`: its barycentric interpolation rounds x and y by up to a few ULPs of
/// the receiver's vertex coordinates (4 · ε · extent covers it).
pub(crate) fn lambert_range(scene: &Scene, target: Vec3, extent: f32) -> (f64, f64) {
    let d = 4.0 * f32::EPSILON * extent;
    [Vec3::ZERO, Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y]
        .map(|o| lambert_radiance(scene, target + o * d, Vec3::Z))
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

pub(crate) fn lambert_receiver() -> Material {
    Material::lambert(Vec3::splat(RHO))
}

/// A scene of `tris` whose material 0 is the Lambertian receiver and materials 1.. are
/// `emitters`, without camera.
pub(crate) fn receiver_under(tris: Vec<Triangle>, emitters: Vec<Material>) -> Scene {
    let materials = std::iter::once(lambert_receiver())
        .chain(emitters)
        .collect();
    Scene::new(tris, materials, None).unwrap()
}
