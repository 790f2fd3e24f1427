//! Every selector's choices follow its own pmf, and the light BVH never rules out a light that
//! contributes. Lights: a 2,000-light town plus a point, a spot and a directional light and a
//! sun-and-sky environment map.

use std::sync::Arc;

use glam::Vec3;
use manylights::gen::{generate, sky};
use manylights::lights::Lights;
use manylights::sampling::rng::PixelRng;
use manylights::scene::{
    load_gltf, CameraChoice, EnvironmentImage, PunctualKind, PunctualLight, Scene,
};
use manylights::select::{
    oracle, LightSelector, Lobe, SelectorKind, ShadingContext, DEFAULT_FAR_SIN,
};

fn town_with_punctual_lights() -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("town.glb");
    generate::many_lights(9, 2000).write(&path).unwrap();
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    scene
        .with_punctual(vec![
            PunctualLight {
                kind: PunctualKind::Point,
                position: Vec3::new(1.0, 3.0, 2.0),
                direction: -Vec3::Z,
                intensity: Vec3::splat(50.0),
            },
            PunctualLight {
                kind: PunctualKind::Spot {
                    cos_inner: 0.9,
                    cos_outer: 0.7,
                },
                position: Vec3::new(-4.0, 6.0, 1.0),
                direction: -Vec3::Y,
                intensity: Vec3::new(300.0, 200.0, 100.0),
            },
            PunctualLight {
                kind: PunctualKind::Directional,
                position: Vec3::ZERO,
                direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
                intensity: Vec3::splat(0.05),
            },
        ])
        .unwrap()
        .with_environment(Some(Arc::new(
            EnvironmentImage::from_rgb(&sky::sun_and_sky(32, 16), 0.2, 20.0).unwrap(),
        )))
}

/// Shading points spread over the town's bounds with random normals (some on the ground).
fn random_contexts(scene: &Scene, count: usize, seed: u64) -> Vec<ShadingContext> {
    let (lo, hi) = scene.bounds();
    let mut rng = PixelRng::new(seed, 0);
    (0..count)
        .map(|i| {
            let t = Vec3::new(rng.next_f32(), rng.next_f32() * 0.3, rng.next_f32());
            let p = lo + t * (hi - lo);
            let n = if i % 3 == 0 {
                Vec3::Y
            } else {
                let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
                v.normalize_or(Vec3::Y)
            };
            ShadingContext {
                p,
                n,
                lobe: Lobe::NONE,
            }
        })
        .collect()
}

/// For random shading points and M = 10,000 stratified u: every sample's pmf equals `pmf`, each
/// light's hits match its pmf, and the pmfs sum to 1 (for bvh: to 1 − the share of dead ends).
fn frequencies_match_the_pmf(kind: SelectorKind) {
    frequencies_match_the_pmf_with(kind, DEFAULT_FAR_SIN);
}

/// [`frequencies_match_the_pmf`] with the light tree's far lanes below `far_sin`.
fn frequencies_match_the_pmf_with(kind: SelectorKind, far_sin: f32) {
    let scene = town_with_punctual_lights();
    const M: usize = 10_000;
    let mut lights = Lights::from_scene(&scene);
    let selector = LightSelector::build_with(kind, &mut lights, far_sin).unwrap();
    for ctx in random_contexts(&scene, 4, kind as u64) {
        let mut rng = PixelRng::new(77, kind as u64);
        // Σ over the hits of light l of 1/(p_l · M) estimates 1 for every light with p_l > 0.
        let mut inverse_sum = vec![0.0f64; lights.len()];
        let pmf: Vec<f64> = (0..lights.len())
            .map(|l| selector.pmf(&lights, &ctx, l))
            .collect();
        let mut misses = 0;
        for i in 0..M {
            let u = (i as f64 + rng.next_f64()) / M as f64;
            let Some((l, p)) = selector.sample(&lights, &ctx, u) else {
                // Allowed where no light can contribute, or at a light BVH node whose children
                // both bound to 0 (a "dead end"): the missing mass is 1 − Σ pmf.
                misses += 1;
                continue;
            };
            assert!(p > 0.0, "{kind:?}: sampled light {l} with pmf 0");
            assert_eq!(p, pmf[l], "{kind:?}: sample vs pmf of light {l}");
            inverse_sum[l] += 1.0 / (p * M as f64);
        }
        for (l, (s, &p)) in inverse_sum.iter().zip(&pmf).enumerate() {
            // Stratified u: a light expected ≥ 1000 times is hit within ±2%.
            if p * M as f64 >= 1000.0 {
                assert!(
                    (0.98..=1.02).contains(s),
                    "{kind:?} light {l}: Σ1/(pM) = {s} (p {p})"
                );
            }
        }
        let total: f64 = pmf.iter().sum();
        let missed = misses as f64 / M as f64;
        if kind == SelectorKind::Bvh {
            assert!(
                (total + missed - 1.0).abs() < 1e-2,
                "{kind:?}: Σpmf {total}, missed {missed}"
            );
        } else {
            assert!(
                (total - 1.0).abs() < 1e-6 && misses == 0,
                "{kind:?}: Σpmf {total}, {misses} misses"
            );
        }
    }
}

#[test]
fn uniform_frequencies_match_the_pmf() {
    frequencies_match_the_pmf(SelectorKind::Uniform);
}

#[test]
fn power_frequencies_match_the_pmf() {
    frequencies_match_the_pmf(SelectorKind::Power);
}

#[test]
fn bvh_frequencies_match_the_pmf() {
    frequencies_match_the_pmf(SelectorKind::Bvh);
}

/// The far-lane sine changes where the walk stops, never the agreement of `sample` with `pmf`:
/// none (0) and most lanes (0.9).
#[test]
fn bvh_frequencies_match_the_pmf_at_other_far_sines() {
    for far_sin in [0.0, 0.9] {
        frequencies_match_the_pmf_with(SelectorKind::Bvh, far_sin);
    }
}

#[test]
fn oracle_frequencies_match_the_pmf() {
    frequencies_match_the_pmf(SelectorKind::Oracle);
}

#[test]
fn bvh_never_rules_out_a_light_that_contributes() {
    let scene = town_with_punctual_lights();
    let mut lights = Lights::from_scene(&scene);
    let selector = LightSelector::build(SelectorKind::Bvh, &mut lights).unwrap();
    let mut checked = 0;
    for ctx in random_contexts(&scene, 300, 5) {
        for (l, light) in lights.lights.iter().enumerate() {
            if oracle::weight(light, &ctx) > 0.0 {
                checked += 1;
                assert!(
                    selector.pmf(&lights, &ctx, l) > 0.0,
                    "light {l} contributes {} at {ctx:?} but the BVH gives it pmf 0",
                    oracle::weight(light, &ctx)
                );
            }
        }
    }
    assert!(
        checked > 10_000,
        "only {checked} contributing (point, light) pairs were checked"
    );
}
