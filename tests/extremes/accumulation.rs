//! Accumulation: a million samples of a constant and of two values give the exact statistics.

use super::*;

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
