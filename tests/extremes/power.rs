//! Power at the edges: radiance from 1e-20 to 1e20, overflowing powers, a million lights with
//! one dominant, zero power; every selector's pmf checked against a brute-force sum.

use super::*;

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
        lobe: Lobe::NONE,
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
    let scene = receiver_under(
        tris,
        vec![
            Material::emitter(Vec3::splat(3e38), false),
            Material::emitter(Vec3::splat(1e-30), false),
        ],
    );
    let ctx = ShadingContext {
        p: Vec3::new(0.1, 0.0, 0.0),
        n: Vec3::Z,
        lobe: Lobe::NONE,
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
    let scene = receiver_under(
        tris,
        vec![
            Material::emitter(Vec3::ONE, false),
            Material::emitter(Vec3::splat(bright_l), false),
        ],
    );
    let mut lights = Lights::from_scene(&scene);
    assert_eq!(lights.len(), count as usize);
    let powers = lights.powers();
    let share = powers[count as usize - 1] / powers.iter().sum::<f64>();
    assert!((share - 0.9999).abs() < 1e-6, "premise: share {share}");
    let selector = LightSelector::build(SelectorKind::Power, &mut lights).unwrap();
    let ctx = ShadingContext {
        p: Vec3::ZERO,
        n: Vec3::Z,
        lobe: Lobe::NONE,
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
    let scene = receiver_under(
        tris,
        vec![Material::emitter(Vec3::new(1e-45, 0.0, 0.0), true)],
    );
    let mut lights = Lights::from_scene(&scene);
    assert_eq!(lights.len(), 4);
    assert!(lights.powers().iter().all(|&p| p == 0.0), "premise");
    let ctx = ShadingContext {
        p: Vec3::ZERO,
        n: Vec3::Z,
        lobe: Lobe::NONE,
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
            let ctx = ShadingContext {
                p,
                n,
                lobe: Lobe::NONE,
            };
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
