//! Geometry at the edges: shading points on or a micrometre from an emitter, grazing emission
//! and reception, degenerate and non-finite geometry, megametre and tenth-of-a-millimetre scenes.

use super::*;

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
        let scene = receiver_under(tris, vec![Material::emitter(Vec3::splat(1.0), false)]);
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
    let scene = receiver_under(tris, vec![Material::emitter(Vec3::splat(4.0), false)]);
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
        let opts = RenderOptions::new(16, 16, 16, 1);
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
    receiver_under(tris, vec![Material::emitter(Vec3::splat(radiance), false)])
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
        let scene = receiver_under(
            tris,
            vec![
                Material::emitter(Vec3::splat(5.0), false),
                Material::emitter(Vec3::splat(1e4), true),
            ],
        );
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
