//! Resampled importance sampling (`ris`, `ris-mis`) against independent values: Lambert's polygon
//! formula for a diffuse plane under emissive quads (the expected pixel is ρ·E/π averaged over
//! its footprint, 6×6 midpoint quadrature), a plain estimator of another strategy on a glossy
//! plane, and measured variance ratios between M values on a many-light plane. Every pixel must
//! lie within 5σ of its expected value (σ from the pixels' own sample variances).

use crate::lambert;
use crate::top_view::TopView;

use crate::run;
use run::manylights;

use std::path::Path;

use glam::{DVec3, Vec3};
use manylights::film::Film;
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::scene::{Material, Scene, Triangle};
use manylights::select::SelectorKind;

const RHO: f32 = 0.5;
/// The camera: 3.0 above the plane, 20.0° field of view, 16×16 pixels.
const VIEW: TopView = TopView {
    height: 3.0,
    yfov_deg: 20.0,
    size: 16,
};

/// A planar emitter: its corners (counter-clockwise seen from the side it lights) and radiance.
#[derive(Clone, Copy)]
struct Emitter {
    corners: [Vec3; 4],
    radiance: f32,
}

/// A quad at height z between (x0, y0) and (x1, y1), facing down (−Z) or up (+Z).
fn horizontal(x0: f32, y0: f32, x1: f32, y1: f32, z: f32, down: bool, radiance: f32) -> Emitter {
    let [a, b, c, d] = [
        Vec3::new(x0, y0, z),
        Vec3::new(x1, y0, z),
        Vec3::new(x1, y1, z),
        Vec3::new(x0, y1, z),
    ];
    let corners = if down { [a, d, c, b] } else { [a, b, c, d] };
    Emitter { corners, radiance }
}

/// Four downward quads of different radiance around the camera's view (as tests/analytic.rs).
fn four_quads() -> Vec<Emitter> {
    [
        (0.5, -0.6, 1.4, 0.4, 4.0),
        (-1.3, -0.8, -0.5, 0.9, 1.5),
        (-0.4, 0.55, 0.7, 1.2, 9.0),
        (-0.45, -1.5, 0.3, -0.55, 0.25),
    ]
    .map(|(x0, y0, x1, y1, l)| horizontal(x0, y0, x1, y1, 0.6, true, l))
    .to_vec()
}

/// x of the vertical emitter that crosses the plane's horizon.
const WALL_X: f32 = 1.0;
const WALL_Z: (f32, f32) = (-0.4, 0.8);

/// Emitters whose candidates often have a zero target: a vertical quad facing −X whose lower
/// third lies below the plane (below every receiver's horizon), and a bright one-sided quad
/// facing up, away from the plane (power selection picks it most often; it never lights the
/// plane). Plus one downward quad that lights it normally. No emitter occludes another's light.
fn horizon_emitters() -> Vec<Emitter> {
    let (y0, y1) = (-0.6, 0.6);
    let (z0, z1) = WALL_Z;
    let wall = Emitter {
        corners: [
            Vec3::new(WALL_X, y0, z0),
            Vec3::new(WALL_X, y0, z1),
            Vec3::new(WALL_X, y1, z1),
            Vec3::new(WALL_X, y1, z0),
        ],
        radiance: 3.0,
    };
    vec![
        wall,
        horizontal(-0.5, 1.0, 0.5, 1.8, 0.6, false, 40.0),
        horizontal(-1.3, -0.8, -0.5, 0.9, 0.6, true, 1.5),
    ]
}

/// The plane z = 0 (facing +Z, 6×6) with `plane` material under `emitters`, seen from above by
/// a camera that sees only the plane.
fn scene(plane: Material, emitters: &[Emitter]) -> Scene {
    let mut materials = vec![plane];
    let [a, b, c, d] = horizontal(-3.0, -3.0, 3.0, 3.0, 0.0, false, 0.0).corners;
    let mut tris = vec![Triangle::flat([a, b, c], 0), Triangle::flat([a, c, d], 0)];
    for e in emitters {
        let m = materials.len() as u32;
        materials.push(Material::emitter(Vec3::splat(e.radiance), false));
        let [a, b, c, d] = e.corners;
        tris.push(Triangle::flat([a, b, c], m));
        tris.push(Triangle::flat([a, c, d], m));
    }
    let camera = VIEW.camera();
    Scene::new(tris, materials, Some(camera)).unwrap()
}

/// ρ/π · E at plane point (x, y) from the emitters that face it, each clipped to z ≥ 0 (the part
/// below is under the horizon). Only axis-aligned quads occur: clipping keeps a quad.
fn lambert_radiance(emitters: &[Emitter], x: f64, y: f64) -> f64 {
    let p = DVec3::new(x, y, 0.0);
    let irradiance: f64 = emitters
        .iter()
        .filter_map(|e| {
            let c = e.corners.map(|v| v.as_dvec3());
            let normal = (c[1] - c[0]).cross(c[2] - c[0]);
            if normal.dot(p - c[0]) <= 0.0 {
                return None; // the plane is behind this one-sided emitter
            }
            let clipped = c.map(|v| DVec3::new(v.x, v.y, v.z.max(0.0)));
            Some(lambert::irradiance(
                p,
                DVec3::Z,
                &clipped,
                e.radiance as f64,
            ))
        })
        .sum();
    irradiance * RHO as f64 / std::f64::consts::PI
}

/// The expected pixel (i, j): `radiance` averaged over the pixel's footprint on the plane.
fn expected_pixel(i: u32, j: u32, radiance: &dyn Fn(f64, f64) -> f64) -> f64 {
    VIEW.pixel(i, j, 6, radiance)
}

/// Renders `scene` with one configuration (fixed seed, independent numbers).
fn render_film(
    scene: Scene,
    selector: SelectorKind,
    strategy: Strategy,
    m: u32,
    spp: u32,
    seed: u64,
) -> Film {
    let prepared = PreparedScene::new(scene, selector);
    let estimator = prepared.estimator(strategy, 1, 1).with_candidates(m);
    let camera = prepared.scene.camera.clone().unwrap();
    let opts = RenderOptions::new(VIEW.size, VIEW.size, spp, seed);
    let (film, stats) = render(&estimator, &camera, &opts);
    assert_eq!(stats.nan_samples + stats.inf_samples, 0);
    film
}

/// Every pixel within 5σ of `expected(i, j)` (σ² = the pixel's variance of the mean plus
/// `expected_variance(i, j)`), and the image sum within 5σ of the expected sum.
fn check_film(
    label: &str,
    film: &Film,
    expected: &dyn Fn(u32, u32) -> f64,
    expected_variance: &dyn Fn(u32, u32) -> f64,
) {
    let (mut sum, mut expected_sum, mut var_sum) = (0.0, 0.0, 0.0);
    for j in 0..VIEW.size {
        for i in 0..VIEW.size {
            let px = &film.pixels[(j * VIEW.size + i) as usize];
            let want = expected(i, j);
            let var = px.variance_of_mean().x + expected_variance(i, j);
            let sigma = var.sqrt();
            assert!(sigma > 0.0, "{label}: pixel ({i},{j}) has no variance");
            assert!(
                (px.mean.x - want).abs() < 5.0 * sigma,
                "{label}: pixel ({i},{j}) = {} but expected {want} (σ {sigma})",
                px.mean.x
            );
            sum += px.mean.x;
            expected_sum += want;
            var_sum += var;
        }
    }
    let sigma = var_sum.sqrt();
    assert!(
        (sum - expected_sum).abs() < 5.0 * sigma,
        "{label}: image sum {sum} but expected {expected_sum} (σ {sigma})"
    );
}

/// Checks a configuration on a diffuse plane under `emitters` against Lambert's formula.
fn check_lambert(emitters: &[Emitter], selector: SelectorKind, strategy: Strategy, m: u32) {
    let film = render_film(
        scene(Material::lambert(Vec3::splat(RHO)), emitters),
        selector,
        strategy,
        m,
        512,
        11,
    );
    let radiance = |x, y| lambert_radiance(emitters, x, y);
    let label = format!("{selector:?} {strategy:?} M={m}");
    check_film(
        &label,
        &film,
        &|i, j| expected_pixel(i, j, &radiance),
        &|_, _| 0.0,
    );
}

#[test]
fn camera_sees_only_the_plane() {
    // The premise of the Lambert tests: every emitter lies outside the view frustum.
    let tan = (0.5 * VIEW.yfov_deg.to_radians()).tan();
    for e in four_quads().iter().chain(&horizon_emitters()) {
        let outside = |axis: usize| {
            let reach = |v: &Vec3| (VIEW.height - v.z) * tan;
            e.corners.iter().all(|v| v[axis] > reach(v))
                || e.corners.iter().all(|v| v[axis] < -reach(v))
        };
        assert!(outside(0) || outside(1), "{:?} is visible", e.corners);
    }
}

#[test]
fn ris_matches_lambert_for_every_m() {
    for m in [1, 4, 16] {
        check_lambert(&four_quads(), SelectorKind::Power, Strategy::Ris, m);
    }
    check_lambert(&four_quads(), SelectorKind::Bvh, Strategy::Ris, 4);
}

#[test]
fn ris_mis_matches_lambert_for_every_m() {
    for m in [1, 4, 16] {
        check_lambert(&four_quads(), SelectorKind::Power, Strategy::RisMis, m);
    }
    check_lambert(&four_quads(), SelectorKind::Bvh, Strategy::RisMis, 4);
}

#[test]
fn zero_target_candidates_leave_no_bias() {
    // Candidates below the horizon and on the back of the bright upward quad get p̂ = 0 and are
    // never kept; the Σw they do not add is exactly the light they do not carry.
    for strategy in [Strategy::Ris, Strategy::RisMis] {
        for m in [1, 4, 16] {
            check_lambert(&horizon_emitters(), SelectorKind::Power, strategy, m);
        }
    }
}

#[test]
fn ris_with_one_candidate_is_light_solid_angle() {
    // M = 1 keeps the one candidate with Σw/p̂ = 1/p: the same numbers, the same image up to
    // f32 rounding.
    let s = || scene(Material::lambert(Vec3::splat(RHO)), &horizon_emitters());
    let ris = render_film(s(), SelectorKind::Power, Strategy::Ris, 1, 64, 3);
    let lsa = render_film(
        s(),
        SelectorKind::Power,
        Strategy::LightSolidAngle,
        1,
        64,
        3,
    );
    for (a, b) in ris.pixels.iter().zip(&lsa.pixels) {
        assert!(
            (a.mean - b.mean).abs().max_element() <= 1e-5 * b.mean.abs().max_element(),
            "{:?} vs {:?}",
            a.mean,
            b.mean
        );
    }
}

/// A glossy dielectric: GGX of the given roughness plus diffuse.
fn glossy(roughness: f32) -> Material {
    Material {
        roughness,
        specular: 1.0,
        ..Material::lambert(Vec3::splat(RHO))
    }
}

/// `check_film` against another render's pixels (no closed form), with both images' variances
/// in σ.
fn check_against(label: &str, film: &Film, reference: &Film) {
    let pixel = |i: u32, j: u32| &reference.pixels[(j * VIEW.size + i) as usize];
    let expected = |i: u32, j: u32| pixel(i, j).mean.x;
    let variance = |i: u32, j: u32| pixel(i, j).variance_of_mean().x;
    check_film(label, film, &expected, &variance);
}

#[test]
fn ris_on_a_glossy_plane_matches_mis() {
    // A rough dielectric (GGX α = 0.16 plus diffuse): no closed form, so the expectation is
    // that of light-and-BSDF MIS (an unbiased estimator tested against Lambert elsewhere).
    let s = || scene(glossy(0.4), &four_quads());
    let mis = render_film(s(), SelectorKind::Power, Strategy::Mis, 1, 2048, 5);
    for (strategy, m) in [
        (Strategy::Ris, 8),
        (Strategy::RisMis, 1),
        (Strategy::RisMis, 8),
    ] {
        let film = render_film(s(), SelectorKind::Power, strategy, m, 512, 7);
        check_against(&format!("glossy {strategy:?} M={m}"), &film, &mis);
    }
}

#[test]
fn the_light_trees_lobe_factor_on_a_glossy_plane_matches_power_mis() {
    // A smoother dielectric (α = 0.04) under many lights: the tree weighs its lanes by the
    // specular lobe there, so its choices and their pmf differ from the diffuse importance's;
    // the expectation is that of power + mis, which knows no lobe.
    let s = || scene(glossy(0.2), &many_quads());
    let mis = render_film(s(), SelectorKind::Power, Strategy::Mis, 1, 2048, 5);
    for strategy in [Strategy::Mis, Strategy::LightSolidAngle] {
        let film = render_film(s(), SelectorKind::Bvh, strategy, 1, 1024, 11);
        check_against(&format!("glossy bvh {strategy:?}"), &film, &mis);
    }
}

/// 96 small downward quads over four decades of radiance around the view: many lights.
fn many_quads() -> Vec<Emitter> {
    let mut out = Vec::new();
    for a in 0..10 {
        for b in 0..10 {
            let (x, y) = (-2.0 + 0.4 * a as f32, -2.0 + 0.4 * b as f32);
            if x.abs() < 0.7 && y.abs() < 0.7 {
                continue; // above the view
            }
            let radiance = 10f32.powf(((a * 7 + b * 3) % 10) as f32 * 0.4 - 2.0);
            out.push(horizontal(x, y, x + 0.3, y + 0.3, 0.6, true, radiance));
        }
    }
    out
}

/// Mean over pixels of the variance of one camera sample (s² of the pixel's samples).
fn sample_variance(film: &Film) -> f64 {
    film.pixels
        .iter()
        .map(|p| p.variance_of_mean().x * p.count as f64)
        .sum::<f64>()
        / film.pixels.len() as f64
}

#[test]
fn variance_falls_with_m_on_many_lights() {
    let emitters = many_quads();
    let s = || scene(Material::lambert(Vec3::splat(RHO)), &emitters);
    for strategy in [Strategy::Ris, Strategy::RisMis] {
        let v: Vec<f64> = [1, 4, 16]
            .map(|m| sample_variance(&render_film(s(), SelectorKind::Power, strategy, m, 256, 9)))
            .to_vec();
        eprintln!("{strategy:?}: per-sample variance at M = 1, 4, 16: {v:?}");
        assert!(
            v[1] < 0.7 * v[0] && v[2] < 0.7 * v[1],
            "{strategy:?}: variance does not fall with M: {v:?}"
        );
    }
}

#[test]
fn m_is_a_usage_error_for_strategies_that_do_not_resample() {
    let dir = tempfile::tempdir().unwrap();
    let cornell = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let out = dir.path().join("o.exr");
    let o = manylights(&[
        "render",
        cornell.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--strategy",
        "mis",
        "--m",
        "4",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--m 4 applies to"));
    assert!(!out.exists());
}

#[test]
fn bench_sweeps_m_for_the_resampling_strategies_only() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("cornell.glb");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb"),
        &scene,
    )
    .unwrap();
    let json = dir.path().join("b.json");
    let o = manylights(&[
        "bench",
        scene.to_str().unwrap(),
        "--width",
        "8",
        "--spp",
        "2",
        "--repeat",
        "1",
        "--reference-spp",
        "16",
        "--strategies",
        "mis,ris,ris-mis",
        "--m",
        "1,4",
        "--baseline",
        "power:ris:1x1:m4",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let got: Vec<(String, u64)> = rows
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["strategy"].as_str().unwrap().to_owned(),
                r["m"].as_u64().unwrap(),
            )
        })
        .collect();
    let want = [
        ("mis", 1),
        ("ris", 1),
        ("ris", 4),
        ("ris-mis", 1),
        ("ris-mis", 4),
    ];
    assert_eq!(got, want.map(|(s, m)| (s.to_owned(), m)));
    assert!(rows
        .as_array()
        .unwrap()
        .iter()
        .all(|r| r["baseline"] == "power:ris:1x1:m4:2"));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("power:ris-mis:1x1:m4"), "{table}");
}
