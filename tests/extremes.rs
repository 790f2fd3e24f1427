//! The renderer at its edges (issue 6): shading points on or a micrometre from an emitter,
//! grazing emission and reception, degenerate and non-finite geometry, 1e6 m and 1e-4 m scenes,
//! radiance from 1e-20 to 1e20, a million lights, zero power, the solid-angle sampler at its
//! thresholds, fireflies and long accumulations. Every expected value is computed here
//! independently: Lambert's polygon formula for irradiance, brute-force sums for pmfs, exact
//! constants. Statistical checks allow 5σ, σ from the render's own variance of the mean.

mod common;

use glam::{DVec3, Mat4, Vec3};
use manylights::film::PixelStats;
use manylights::integrator::{render, PreparedScene, RenderOptions, RenderStats, Strategy};
use manylights::lights::polygon::projected_solid_angle;
use manylights::lights::Lights;
use manylights::sampling::rng::PixelRng;
use manylights::sampling::sampler::SamplerKind;
use manylights::scene::{load_gltf, Camera, CameraChoice, Material, Scene, Triangle};
use manylights::select::{oracle, LightSelector, SelectorKind, ShadingContext};

const RHO: f32 = 0.5;

/// Two triangles of the quad a, b, c, d (counter-clockwise seen from the front).
fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3, m: u32) -> [Triangle; 2] {
    [Triangle::flat([a, b, c], m), Triangle::flat([a, c, d], m)]
}

/// A horizontal square of half-size `h` centred at `c`; `up` picks the front face (+Z or −Z).
fn square(c: Vec3, h: f32, up: bool, m: u32) -> [Triangle; 2] {
    let p = |x: f32, y: f32| c + Vec3::new(x * h, y * h, 0.0);
    if up {
        quad(p(-1., -1.), p(1., -1.), p(1., 1.), p(-1., 1.), m)
    } else {
        quad(p(-1., -1.), p(-1., 1.), p(1., 1.), p(1., -1.), m)
    }
}

/// A camera node at `eye` whose −Z looks at `target`.
fn look_at(eye: Vec3, target: Vec3, yfov: f32) -> Camera {
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
fn probe(
    scene: &Scene,
    selector: SelectorKind,
    strategy: Strategy,
    eye: Vec3,
    target: Vec3,
    spp: u32,
) -> (PixelStats, RenderStats) {
    let prepared = PreparedScene::new(scene.clone(), selector);
    let estimator = prepared.estimator(strategy, 1, 1);
    let opts = RenderOptions {
        width: 1,
        height: 1,
        spp,
        seed: 17,
        clamp: None,
        sampler: SamplerKind::Independent,
        first_sample: 0,
    };
    let (film, stats) = render(&estimator, &look_at(eye, target, 1e-5), &opts);
    (film.pixels[0], stats)
}

/// Exitant radiance ρ/π · Σ L·Ω⊥ of a Lambertian receiver at p (unit normal n) from the
/// one-sided emissive triangles of `scene` (Lambert's formula; zero behind an emitter).
fn lambert_radiance(scene: &Scene, p: Vec3, n: Vec3) -> f64 {
    let rho = scene.materials[receiver_material(scene, p)].base_color.x as f64;
    let mut e = 0.0;
    for t in &scene.triangles {
        let m = &scene.materials[t.material as usize];
        if !m.is_emissive() {
            continue;
        }
        let facing = t.geometric_normal().dot(p - t.positions[0]);
        if facing > 0.0 || m.double_sided {
            e += m.emission.x as f64 * projected_solid_angle(p, n, t.positions);
        }
    }
    rho / std::f64::consts::PI * e
}

/// The material of the first non-emissive triangle whose plane holds p (the receiver).
fn receiver_material(scene: &Scene, p: Vec3) -> usize {
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
fn assert_matches(label: &str, px: &PixelStats, stats: &RenderStats, expected: f64) {
    assert_within(label, px, stats, (expected, expected));
}

/// As `assert_matches`, for a truth known to lie in [lo, hi].
fn assert_within(label: &str, px: &PixelStats, stats: &RenderStats, (lo, hi): (f64, f64)) {
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
fn lambert_range(scene: &Scene, target: Vec3, extent: f32) -> (f64, f64) {
    let d = 4.0 * f32::EPSILON * extent;
    [Vec3::ZERO, Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y]
        .map(|o| lambert_radiance(scene, target + o * d, Vec3::Z))
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

fn lambert_receiver() -> Material {
    Material::lambert(Vec3::splat(RHO))
}

// ---------------------------------------------------------------------------------------------
// 1. Geometry

#[test]
fn shading_point_on_an_emitter_sees_its_own_emission_plus_the_other_lights() {
    // A floor that both emits (Le = 2) and reflects (ρ = 0.5), under a 1 m² ceiling emitter.
    let floor = Material {
        emission: Vec3::splat(2.0),
        ..lambert_receiver()
    };
    let mut tris = square(Vec3::ZERO, 1.0, true, 0).to_vec();
    tris.extend(square(Vec3::new(0.2, -0.1, 1.0), 0.5, false, 1));
    let scene = Scene::new(
        tris,
        vec![floor, Material::emitter(Vec3::splat(3.0), false)],
        None,
    )
    .unwrap();
    let target = Vec3::new(0.1, 0.05, 0.0);
    let expected = 2.0 + lambert_radiance(&scene, target, Vec3::Z);
    for strategy in [
        Strategy::LightArea,
        Strategy::LightSolidAngle,
        Strategy::Mis,
    ] {
        for selector in [SelectorKind::Uniform, SelectorKind::Bvh] {
            let eye = target + Vec3::new(0.3, 0.2, 0.5);
            let (px, stats) = probe(&scene, selector, strategy, eye, target, 20_000);
            assert_matches(&format!("{strategy:?} {selector:?}"), &px, &stats, expected);
        }
    }
}

#[test]
fn shading_point_a_micrometre_below_a_large_emitter_gets_pi_l() {
    // Receiver at z = 0; 1e-6 m above it a 2 km wide emitter facing down: E → π·L as r² → 0.
    // Built two ways: one triangle covering the point (Ω ≈ 2π − 1e-8 sr: sampled split at the
    // receiver's foot) and a fan of six triangles around it (each ≈ π/3 sr, sampled whole).
    let gap = 1e-6;
    let target = Vec3::new(3e-4, -2e-4, 0.0);
    let centre = target + Vec3::new(0.0, 0.0, gap);
    let rim = |k: u32, n: u32| {
        let a = std::f32::consts::TAU * (k as f32 + 0.3) / n as f32;
        centre + 1e3 * Vec3::new(a.cos(), a.sin(), 0.0)
    };
    // Clockwise seen from above: fronts facing down.
    let fan: Vec<Triangle> = (0..6)
        .map(|k| Triangle::flat([centre, rim(k + 1, 6), rim(k, 6)], 1))
        .collect();
    let single = vec![Triangle::flat([rim(0, 3), rim(2, 3), rim(1, 3)], 1)];
    for (label, emitter) in [("one triangle", single), ("fan of six", fan)] {
        let mut tris = square(Vec3::ZERO, 1.0, true, 0).to_vec();
        tris.extend(emitter);
        let scene = Scene::new(
            tris,
            vec![
                lambert_receiver(),
                Material::emitter(Vec3::splat(1.0), false),
            ],
            None,
        )
        .unwrap();
        let expected = lambert_radiance(&scene, target, Vec3::Z);
        assert!(
            (expected - RHO as f64).abs() < 1e-5,
            "premise: the emitter fills the hemisphere, E = π·L"
        );
        let eye = target + Vec3::new(0.0, 0.0, 0.5 * gap);
        for strategy in [Strategy::LightSolidAngle, Strategy::Mis] {
            let (px, stats) = probe(&scene, SelectorKind::Power, strategy, eye, target, 20_000);
            assert_matches(&format!("{strategy:?}, {label}"), &px, &stats, expected);
        }
    }
}

#[test]
fn grazing_emission_and_reception_stay_finite_and_match_lambert() {
    // A wall emitter in the plane x = 0.5 facing −X, standing on the receiver (its bottom edge
    // lies in the receiver's plane: cos θ → 0 at the receiver), seen from points whose view of
    // it goes from head-on to edge-on (cos θ' → 0, and exactly 0 in its plane).
    let wall = |y0: f32, y1: f32| {
        quad(
            Vec3::new(0.5, y0, 0.0),
            Vec3::new(0.5, y0, 1.0),
            Vec3::new(0.5, y1, 1.0),
            Vec3::new(0.5, y1, 0.0),
            1,
        )
    };
    let mut tris = square(Vec3::ZERO, 2.0, true, 0).to_vec();
    tris.extend(wall(-1.0, 1.0));
    let scene = Scene::new(
        tris,
        vec![
            lambert_receiver(),
            Material::emitter(Vec3::splat(4.0), false),
        ],
        None,
    )
    .unwrap();
    assert!(
        scene.triangles[2].geometric_normal().x < 0.0,
        "wall faces −X"
    );
    for (target, label) in [
        (Vec3::new(0.0, 0.0, 0.0), "facing"),
        (Vec3::new(0.5 - 1e-4, 1.5, 0.0), "nearly edge-on"),
        (Vec3::new(0.5, 1.5, 0.0), "edge-on"),
        (Vec3::new(0.5 - 1e-5, 0.0, 0.0), "at the wall's foot"),
    ] {
        // At the wall's foot the integrand peaks within 1e-5 m of the point, where area sampling
        // almost never lands (unbiased, but its variance is useless there).
        let strategies: &[Strategy] = if label == "at the wall's foot" {
            &[Strategy::LightSolidAngle, Strategy::Mis]
        } else {
            &[
                Strategy::LightArea,
                Strategy::LightSolidAngle,
                Strategy::Mis,
            ]
        };
        // Edge-on, the truth is 0 only for a point exactly in the wall's plane.
        let expected = lambert_range(&scene, target, 2.0);
        let eye = target + Vec3::new(-0.3, 0.1, 0.4);
        for &strategy in strategies {
            let (px, stats) = probe(&scene, SelectorKind::Bvh, strategy, eye, target, 20_000);
            assert_within(&format!("{label} {strategy:?}"), &px, &stats, expected);
        }
    }
}

#[test]
fn degenerate_triangles_in_a_file_are_skipped_counted_and_render_finite() {
    let dir = tempfile::tempdir().unwrap();
    #[rustfmt::skip]
    let positions = [
        0.0, 0.0, 0.0,  1.0, 0.0, 0.0,  0.0, 1.0, 0.0, // a good triangle
        0.0, 0.0, 0.0,  1.0, 0.0, 0.0,  2.0, 0.0, 0.0, // collinear
        0.5, 0.5, 0.0,  0.5, 0.5, 0.0,  1.0, 0.0, 0.0, // repeated vertex
        0.3, 0.3, 0.0,  0.3, 0.3, 0.0,  0.3, 0.3, 0.0, // a point
        1e-30, 0.0, 0.0,  0.0, 1e-30, 0.0, 0.0, 0.0, 0.0, // area 5e-61 rounds to 0 in f32
    ];
    let indices: Vec<u32> = (0..positions.len() as u32 / 3).collect();
    let path = common::write_gltf(
        dir.path(),
        "degenerate",
        &positions,
        Some((&indices, common::U32)),
        true,
    );
    let mut scene = load_gltf(path.as_ref(), &CameraChoice::First).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(scene.stats.degenerate_triangles, 4);
    // Light it and render: no NaN or Inf sample anywhere.
    scene.materials.push(Material::emitter(Vec3::ONE, true));
    let light = scene.materials.len() as u32 - 1;
    scene
        .triangles
        .extend(square(Vec3::new(0.3, 0.3, 0.5), 0.2, false, light));
    let prepared = PreparedScene::new(scene.clone(), SelectorKind::Bvh);
    let camera = look_at(Vec3::new(0.3, 0.3, 2.0), Vec3::new(0.3, 0.3, 0.0), 1.2);
    for strategy in [Strategy::LightSolidAngle, Strategy::Mis] {
        let estimator = prepared.estimator(strategy, 1, 1);
        let opts = RenderOptions {
            width: 16,
            height: 16,
            spp: 16,
            seed: 1,
            clamp: None,
            sampler: SamplerKind::Independent,
            first_sample: 0,
        };
        let (film, stats) = render(&estimator, &camera, &opts);
        assert_eq!(stats.nan_samples + stats.inf_samples, 0);
        assert!(film.image_mean() > 0.0 && film.image_mean().is_finite());
    }
}

#[test]
fn non_finite_positions_in_a_file_are_an_error_naming_the_accessor_and_vertex() {
    let dir = tempfile::tempdir().unwrap();
    for (bad, name) in [
        (f32::NAN, "nan"),
        (f32::INFINITY, "inf"),
        (f32::NEG_INFINITY, "neginf"),
    ] {
        let positions = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, bad, 0.0];
        let path = common::write_gltf(dir.path(), name, &positions, None, true);
        let err = load_gltf(path.as_ref(), &CameraChoice::First)
            .err()
            .unwrap_or_else(|| panic!("{name}: a non-finite position must not load"))
            .to_string();
        assert!(
            err.contains("POSITION (accessor 0) vertex 2 is not finite"),
            "{name}: {err}"
        );
        assert!(err.contains(&format!("{name}.gltf")), "{name}: {err}");
    }
}

/// A receiver square of half-size `extent` at z = 0 under one-sided emissive squares of
/// half-size `light` at the given centres (facing down), radiance `radiance`.
fn lit_plane(extent: f32, light: f32, centres: &[Vec3], radiance: f32) -> Scene {
    let mut tris = square(Vec3::ZERO, extent, true, 0).to_vec();
    for &c in centres {
        tris.extend(square(c, light, false, 1));
    }
    Scene::new(
        tris,
        vec![
            lambert_receiver(),
            Material::emitter(Vec3::splat(radiance), false),
        ],
        None,
    )
    .unwrap()
}

#[test]
fn megametre_scene_with_millimetre_lights_matches_lambert() {
    // A 2e6 m wide floor 1 m below a 40 m receiver patch (f32 cannot place a point on a 1e6 m
    // triangle closer than 6 cm), lit by 1 mm lights 1 m up, one of them behind an occluder.
    let lights = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.3, 0.1, 0.8),
        Vec3::new(-0.2, 0.4, 1.5),
    ];
    let mut scene = lit_plane(20.0, 5e-4, &lights, 1e6);
    scene
        .triangles
        .extend(square(Vec3::new(0.0, 0.0, -1.0), 1e6, true, 0));
    // A 1 cm occluder 1 cm above the point (2, 0, 0), with a light 1 cm above that.
    let hidden_light = Vec3::new(2.0, 0.0, 0.02);
    scene
        .triangles
        .extend(square(Vec3::new(2.0, 0.0, 0.01), 5e-3, true, 0));
    scene.triangles.extend(square(hidden_light, 5e-4, false, 1));
    let scene = Scene::new(scene.triangles, scene.materials, None).unwrap();
    let (lo, hi) = scene.bounds();
    assert!((hi - lo).max_element() >= 2e6, "premise: a 1e6 m scene");
    for selector in [SelectorKind::Power, SelectorKind::Bvh] {
        for strategy in [Strategy::LightArea, Strategy::LightSolidAngle] {
            for (target, eye_offset) in [
                (Vec3::new(0.05, -0.02, 0.0), Vec3::new(0.1, 0.0, 0.3)),
                // Under the occluder: the three open lights only.
                (Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.002, 0.0, 0.005)),
            ] {
                let expected = lambert_radiance(&scene, target, Vec3::Z)
                    - shadowed_share(&scene, target, hidden_light);
                let eye = target + eye_offset;
                let (px, stats) = probe(&scene, selector, strategy, eye, target, 20_000);
                let label = format!("1e6 m at {target} {selector:?} {strategy:?}");
                assert_matches(&label, &px, &stats, expected);
            }
        }
    }
}

/// The part of `lambert_radiance` at p that comes from the emitter square centred at `c`.
fn shadowed_share(scene: &Scene, p: Vec3, c: Vec3) -> f64 {
    let only: Vec<Triangle> = scene
        .triangles
        .iter()
        .filter(|t| {
            let centroid = (t.positions[0] + t.positions[1] + t.positions[2]) / 3.0;
            (centroid - c).length() < 1e-3 && scene.materials[t.material as usize].is_emissive()
        })
        .cloned()
        .chain(square(Vec3::ZERO, 1.0, true, 0))
        .collect();
    let sub = Scene::new(only, scene.materials.clone(), None).unwrap();
    lambert_radiance(&sub, p, Vec3::Z)
}

/// Scales every vertex by `s` (about the origin).
fn scaled(scene: &Scene, s: f32) -> Scene {
    let tris = scene
        .triangles
        .iter()
        .map(|t| Triangle::flat(t.positions.map(|p| p * s), t.material))
        .collect();
    Scene::new(tris, scene.materials.clone(), None).unwrap()
}

/// The six faces of the box lo..hi, fronts facing inward.
fn closed_box(lo: Vec3, hi: Vec3, m: u32) -> Vec<Triangle> {
    let p = |x: bool, y: bool, z: bool| {
        Vec3::new(
            if x { hi.x } else { lo.x },
            if y { hi.y } else { lo.y },
            if z { hi.z } else { lo.z },
        )
    };
    let (f, t) = (false, true);
    [
        quad(p(f, f, f), p(f, t, f), p(t, t, f), p(t, f, f), m), // z = lo, +Z (floor)
        quad(p(f, f, t), p(t, f, t), p(t, t, t), p(f, t, t), m), // z = hi, −Z
        quad(p(f, f, f), p(f, f, t), p(f, t, t), p(f, t, f), m), // x = lo, +X
        quad(p(t, f, f), p(t, t, f), p(t, t, t), p(t, f, t), m), // x = hi, −X
        quad(p(f, f, f), p(t, f, f), p(t, f, t), p(f, f, t), m), // y = lo, +Y
        quad(p(f, t, f), p(f, t, t), p(t, t, t), p(t, t, f), m), // y = hi, −Y
    ]
    .concat()
}

#[test]
fn tenth_of_a_millimetre_scene_matches_lambert_without_leaks_or_self_shadowing() {
    // The 1 m box below, scaled to 1e-4 m: a ceiling light inside, and a bright two-sided
    // emitter 1e-3 of the box outside the x = hi wall. Receivers sit 1e-2 of the box from the
    // walls, closer than the absolute 2^-16 m ray offset once used near the origin.
    let build = |s: f32| {
        let mut tris = closed_box(Vec3::ZERO, Vec3::ONE, 0);
        tris.extend(square(Vec3::new(0.5, 0.5, 0.95), 0.1, false, 1));
        tris.extend(quad(
            Vec3::new(1.001, -0.5, -0.5),
            Vec3::new(1.001, 1.5, -0.5),
            Vec3::new(1.001, 1.5, 1.5),
            Vec3::new(1.001, -0.5, 1.5),
            2,
        ));
        let scene = Scene::new(
            tris,
            vec![
                lambert_receiver(),
                Material::emitter(Vec3::splat(5.0), false),
                Material::emitter(Vec3::splat(1e4), true),
            ],
            None,
        )
        .unwrap();
        scaled(&scene, s)
    };
    for s in [1.0f32, 1e-4] {
        let scene = build(s);
        let inside_only = {
            let mut sub = scene.clone();
            sub.triangles.retain(|t| t.material != 2);
            sub
        };
        // Off the floor quads' shared diagonal x = y: a ray that meets a shared edge exactly can
        // miss both triangles (the intersector is not watertight).
        for (x, y) in [(0.5, 0.4), (0.99, 0.5), (0.99, 0.97), (0.01, 0.3)] {
            let target = Vec3::new(x, y, 0.0) * s;
            let expected = lambert_radiance(&inside_only, target, Vec3::Z);
            let eye = target + Vec3::new(0.5 - x, 0.5 - y, 0.5) * 0.3 * s;
            for strategy in [Strategy::LightArea, Strategy::Mis] {
                // Uniform selection: `power` would spend nearly every sample on the bright
                // outside emitter, leaving the inside light's share unsampled.
                let (px, stats) =
                    probe(&scene, SelectorKind::Uniform, strategy, eye, target, 20_000);
                assert_matches(
                    &format!("scale {s} at ({x}, {y}) {strategy:?}"),
                    &px,
                    &stats,
                    expected,
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Power

/// Σ_l pmf(l), in f64, and the smallest pmf of a light with a positive oracle weight.
fn pmf_sum_and_min_contributing(
    selector: &LightSelector,
    lights: &Lights,
    ctx: &ShadingContext,
) -> (f64, f64) {
    let mut sum = 0.0;
    let mut min = f64::INFINITY;
    for l in 0..lights.len() {
        let p = selector.pmf(lights, ctx, l);
        assert!(p.is_finite() && p >= 0.0, "pmf({l}) = {p}");
        sum += p;
        if oracle::weight(&lights.lights[l], ctx) > 0.0 {
            min = min.min(p);
        }
    }
    (sum, min)
}

/// For the power, bvh and oracle selectors at `ctx`: Σ pmf = 1 within 1e-9 (f64) and every
/// light the oracle says contributes has pmf > 0.
fn assert_power_bvh_oracle_pmfs(scene: &Scene, ctx: &ShadingContext) {
    for kind in [SelectorKind::Power, SelectorKind::Bvh, SelectorKind::Oracle] {
        let mut lights = Lights::from_scene(scene);
        let selector = LightSelector::build(kind, &mut lights).unwrap();
        let (sum, min) = pmf_sum_and_min_contributing(&selector, &lights, ctx);
        assert!((sum - 1.0).abs() < 1e-9, "{kind:?}: Σ pmf = {sum}");
        assert!(min > 0.0, "{kind:?}: a contributing light has pmf 0");
    }
}

#[test]
fn radiance_from_1e_minus_20_to_1e20_in_one_scene() {
    let radiances = [1e-20f32, 1e-10, 1.0, 1e10, 1e20];
    let mut tris = square(Vec3::ZERO, 3.0, true, 0).to_vec();
    let mut materials = vec![lambert_receiver()];
    for (i, &l) in radiances.iter().enumerate() {
        materials.push(Material::emitter(Vec3::splat(l), false));
        let c = Vec3::new(-1.0 + 0.5 * i as f32, 0.3, 1.0);
        tris.extend(square(c, 0.1, false, i as u32 + 1));
    }
    let scene = Scene::new(tris, materials, None).unwrap();
    let ctx = ShadingContext {
        p: Vec3::new(0.1, 0.0, 0.0),
        n: Vec3::Z,
    };
    assert_power_bvh_oracle_pmfs(&scene, &ctx);
    let target = ctx.p;
    let expected = lambert_radiance(&scene, target, Vec3::Z);
    for selector in [
        SelectorKind::Uniform,
        SelectorKind::Power,
        SelectorKind::Bvh,
    ] {
        let eye = target + Vec3::new(0.0, -0.2, 0.5);
        let (px, stats) = probe(&scene, selector, Strategy::LightArea, eye, target, 20_000);
        assert_matches(&format!("{selector:?}"), &px, &stats, expected);
    }
}

#[test]
fn overflowing_powers_stay_finite_in_every_selector() {
    // Φ = π·A·L ≈ 3e46 overflows f32 (the light BVH's Φ) but not f64 (the alias table's).
    let mut tris = square(Vec3::ZERO, 3.0, true, 0).to_vec();
    tris.extend(square(Vec3::new(0.0, 0.0, 1.0), 1e4, false, 1));
    tris.extend(square(Vec3::new(0.5, 0.0, 0.5), 0.1, false, 2));
    let scene = Scene::new(
        tris,
        vec![
            lambert_receiver(),
            Material::emitter(Vec3::splat(3e38), false),
            Material::emitter(Vec3::splat(1e-30), false),
        ],
        None,
    )
    .unwrap();
    let ctx = ShadingContext {
        p: Vec3::new(0.1, 0.0, 0.0),
        n: Vec3::Z,
    };
    assert_power_bvh_oracle_pmfs(&scene, &ctx);
}

#[test]
fn a_million_lights_where_one_holds_99_99_percent_of_the_power() {
    // 999,999 lights of 1e-3 m side in a 1 m grid well above the receiver, and one bright one.
    let count = 1_000_000u32;
    let side = 1000u32;
    let mut tris = square(Vec3::ZERO, 3.0, true, 0).to_vec();
    for i in 1..count {
        let c = Vec3::new(
            (i % side) as f32 / side as f32 - 0.5,
            (i / side) as f32 / side as f32 - 0.5,
            2.0,
        );
        tris.extend_from_slice(&[Triangle::flat(
            [
                c,
                c + Vec3::new(0.0, 1e-3, 0.0),
                c + Vec3::new(1e-3, 0.0, 0.0),
            ],
            1,
        )]);
    }
    // Φ_dim total = 999,999 · π · 5e-7 · 1 ; the bright light holds 99.99%.
    let dim_total = (count - 1) as f64 * std::f64::consts::PI * 5e-7;
    let bright_area = 0.5f64;
    let bright_l = (dim_total * 9999.0 / (std::f64::consts::PI * bright_area)) as f32;
    tris.push(Triangle::flat(
        [
            Vec3::new(-0.5, 0.5, 1.0),
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(-0.5, -0.5, 1.0),
        ],
        2,
    ));
    let scene = Scene::new(
        tris,
        vec![
            lambert_receiver(),
            Material::emitter(Vec3::ONE, false),
            Material::emitter(Vec3::splat(bright_l), false),
        ],
        None,
    )
    .unwrap();
    let mut lights = Lights::from_scene(&scene);
    assert_eq!(lights.len(), count as usize);
    let powers = lights.powers();
    let share = powers[count as usize - 1] / powers.iter().sum::<f64>();
    assert!((share - 0.9999).abs() < 1e-6, "premise: share {share}");
    let selector = LightSelector::build(SelectorKind::Power, &mut lights).unwrap();
    let ctx = ShadingContext {
        p: Vec3::ZERO,
        n: Vec3::Z,
    };
    let (sum, min) = pmf_sum_and_min_contributing(&selector, &lights, &ctx);
    assert!((sum - 1.0).abs() < 1e-9, "Σ pmf = {sum}");
    assert!(min > 0.0);
    let p_bright = selector.pmf(&lights, &ctx, count as usize - 1);
    assert!(
        (p_bright - share).abs() < 1e-9,
        "pmf {p_bright} vs share {share}"
    );
    // The render: Lambert summed over all million lights.
    let target = Vec3::new(0.01, 0.02, 0.0);
    let expected = lambert_radiance(&scene, target, Vec3::Z);
    let eye = target + Vec3::new(0.0, 0.1, 0.5);
    let (px, stats) = probe(
        &scene,
        SelectorKind::Power,
        Strategy::LightSolidAngle,
        eye,
        target,
        20_000,
    );
    assert_matches("1M lights", &px, &stats, expected);
}

#[test]
fn lights_that_all_have_zero_power_render_black_without_nan() {
    // Radiance (1e-45, 0, 0): a light (non-zero emission) whose f32 luminance rounds to 0.
    let mut tris = square(Vec3::ZERO, 3.0, true, 0).to_vec();
    tris.extend(square(Vec3::new(0.0, 0.0, 1.0), 0.5, false, 1));
    tris.extend(square(Vec3::new(1.0, 0.0, 1.0), 0.5, false, 1));
    let scene = Scene::new(
        tris,
        vec![
            lambert_receiver(),
            Material::emitter(Vec3::new(1e-45, 0.0, 0.0), true),
        ],
        None,
    )
    .unwrap();
    let mut lights = Lights::from_scene(&scene);
    assert_eq!(lights.len(), 4);
    assert!(lights.powers().iter().all(|&p| p == 0.0), "premise");
    let ctx = ShadingContext {
        p: Vec3::ZERO,
        n: Vec3::Z,
    };
    // The power selector falls back to uniform; the BVH and the oracle see nothing to choose.
    let power = LightSelector::build(SelectorKind::Power, &mut lights).unwrap();
    for l in 0..4 {
        assert_eq!(power.pmf(&lights, &ctx, l), 0.25);
    }
    let bvh = LightSelector::build(SelectorKind::Bvh, &mut lights).unwrap();
    assert!(bvh.sample(&lights, &ctx, 0.5).is_none());
    for selector in [SelectorKind::Power, SelectorKind::Bvh, SelectorKind::Oracle] {
        for strategy in [Strategy::LightArea, Strategy::Mis] {
            let (px, stats) = probe(
                &scene,
                selector,
                strategy,
                Vec3::new(0.0, 0.3, 0.5),
                Vec3::ZERO,
                1000,
            );
            assert_eq!(stats.nan_samples + stats.inf_samples, 0);
            assert!(px.mean.max_element() < 1e-40, "{selector:?}: {}", px.mean);
        }
    }
}

/// Random scenes of 12 triangle lights with powers over 1e-20..1e20, sizes over 1e-4..1e3 m,
/// any orientation, one- or two-sided.
fn extreme_light_scene(seed: u64) -> Scene {
    let mut rng = PixelRng::new(seed, 0);
    let mut uniform = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let mut tris = Vec::new();
    let mut materials = vec![lambert_receiver()];
    for i in 0..12 {
        let centre = Vec3::new(uniform(-5.0, 5.0), uniform(-5.0, 5.0), uniform(-5.0, 5.0));
        let size = 10f32.powf(uniform(-4.0, 3.0));
        let mut corner = || {
            Vec3::new(uniform(-1.0, 1.0), uniform(-1.0, 1.0), uniform(-1.0, 1.0)) * size + centre
        };
        let t = [corner(), corner(), corner()];
        let radiance = 10f32.powf(uniform(-20.0, 20.0));
        let two_sided = uniform(0.0, 1.0) < 0.5;
        materials.push(Material::emitter(Vec3::splat(radiance), two_sided));
        tris.push(Triangle::flat(t, i + 1));
    }
    Scene::new(tris, materials, None).unwrap()
}

#[test]
fn light_bvh_gives_every_contributing_light_a_finite_positive_pmf_exhaustively() {
    let mut contributing = 0;
    for seed in 0..40 {
        let scene = extreme_light_scene(seed);
        let mut lights = Lights::from_scene(&scene);
        let bvh = LightSelector::build(SelectorKind::Bvh, &mut lights).unwrap();
        let mut rng = PixelRng::new(seed, 1);
        for _ in 0..200 {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 12.0 - 6.0;
            let [a, b] = rng.next_2d();
            let z = 1.0 - 2.0 * a;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * b;
            let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let ctx = ShadingContext { p, n };
            let mut sum = 0.0;
            for l in 0..lights.len() {
                let pmf = bvh.pmf(&lights, &ctx, l);
                assert!(pmf.is_finite() && pmf >= 0.0, "seed {seed}: pmf {pmf}");
                sum += pmf;
                if oracle::weight(&lights.lights[l], &ctx) > 0.0 {
                    contributing += 1;
                    assert!(
                        pmf > 0.0,
                        "seed {seed}: light {l} ({:?}) contributes at {p} (n {n}) but has pmf 0",
                        lights.lights[l]
                    );
                }
            }
            // Traversal may stop without a light (wasted, never biased): Σ ≤ 1.
            assert!(sum <= 1.0 + 1e-9, "seed {seed}: Σ pmf = {sum}");
        }
    }
    assert!(
        contributing > 10_000,
        "premise: {contributing} pairs checked"
    );
}

// ---------------------------------------------------------------------------------------------
// 3. Samples

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
        let scene = Scene::new(
            tris,
            vec![
                lambert_receiver(),
                Material::emitter(Vec3::splat(1.0), false),
            ],
            None,
        )
        .unwrap();
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
    let scene = Scene::new(
        tris,
        vec![
            lambert_receiver(),
            Material::emitter(Vec3::ONE, false),
            Material::emitter(Vec3::splat(l_bright), false),
        ],
        None,
    )
    .unwrap();
    let prepared = PreparedScene::new(scene, SelectorKind::Uniform);
    let estimator = prepared.estimator(Strategy::LightArea, 1, 1);
    let camera = look_at(Vec3::new(0.0, 0.0, 0.5), Vec3::ZERO, 0.01);
    let opts = RenderOptions {
        width: 4,
        height: 4,
        spp: 1024,
        seed: 5,
        clamp: None,
        sampler: SamplerKind::Independent,
        first_sample: 0,
    };
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

// ---------------------------------------------------------------------------------------------
// 4. Accumulation

#[test]
fn a_million_samples_of_a_constant_accumulate_to_the_exact_value() {
    // The camera looks straight at a black emitter: every sample is exactly Le, so the f64 mean
    // over 10^6 samples is exactly Le and the variance exactly 0.
    let le = Vec3::new(0.1, 1e-7, 12345.678);
    let scene = Scene::new(
        square(Vec3::ZERO, 1.0, true, 0).to_vec(),
        vec![Material::emitter(le, false)],
        None,
    )
    .unwrap();
    let (px, stats) = probe(
        &scene,
        SelectorKind::Power,
        Strategy::LightArea,
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::ZERO,
        1_000_000,
    );
    assert_eq!(px.count, 1_000_000);
    assert_eq!(stats.nan_samples + stats.inf_samples, 0);
    assert_eq!(px.mean, le.as_dvec3());
    assert_eq!(px.m2, DVec3::ZERO);
}

#[test]
fn a_million_samples_of_two_values_give_the_exact_mean_and_variance() {
    // Alternating a and b: mean (a + b)/2, M2 = n·((b − a)/2)². Welford's rounding error grows
    // like √n·ε per update, so 1e-10 relative bounds it with room to spare.
    let (a, b) = (1e-3f64, 1e3f64);
    let n = 1_000_000u64;
    let mut px = PixelStats::default();
    for i in 0..n {
        px.add(DVec3::splat(if i % 2 == 0 { a } else { b }));
    }
    let mean = 0.5 * (a + b);
    let m2 = n as f64 * (0.5 * (b - a)).powi(2);
    assert!(
        (px.mean.x - mean).abs() <= 1e-10 * mean,
        "mean {}",
        px.mean.x
    );
    assert!((px.m2.x - m2).abs() <= 1e-10 * m2, "M2 {} vs {m2}", px.m2.x);
    let var = m2 / (n - 1) as f64;
    assert!((px.sample_variance().x - var).abs() <= 1e-10 * var);
    // Merging two halves (Chan et al.) gives the same.
    let (mut lo, mut hi) = (PixelStats::default(), PixelStats::default());
    for i in 0..n {
        let target = if i < n / 2 { &mut lo } else { &mut hi };
        target.add(DVec3::splat(if i % 2 == 0 { a } else { b }));
    }
    lo.merge(&hi);
    assert!((lo.mean.x - mean).abs() <= 1e-10 * mean);
    assert!((lo.m2.x - m2).abs() <= 1e-10 * m2);
}
