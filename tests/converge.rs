//! `measure::converge::run` on the Cornell box: an unbiased configuration passes every check,
//! and a deliberately biased one (samples clamped low) fails them — a check that cannot fail is
//! not a check. Fixed seeds; the checks' own thresholds come from the measured variances.

use std::path::Path;

use manylights::cli::options::TEXTBOOK_DEFAULTS;
use manylights::measure::converge::{run, ConvergeOptions};
use manylights::measure::reference::{render_reference, ReferenceOptions, DEFAULT_ESTIMATOR};
use manylights::measure::SceneSetup;

fn options(clamp: Option<f32>) -> ConvergeOptions {
    ConvergeOptions {
        // The textbook estimator (power + light-area, K = N = M = 1, independent numbers),
        // which `converge` defaults to: plain Monte Carlo, MSE ∝ 1/spp.
        estimator: TEXTBOOK_DEFAULTS.estimator,
        spp: vec![4, 8, 16, 32, 64],
        // 16 seeds over 32×32 pixels put the slope's standard error near 0.04, well inside
        // the ±0.15 tolerance.
        seeds: 16,
        seed: 0,
        clamp,
        tolerance: 0.15,
    }
}

#[test]
fn converge_passes_unbiased_and_fails_clamped() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.glb");
    let setup = SceneSetup::load(&scene, None, 32, None).unwrap();
    let reference_options = ReferenceOptions {
        width: setup.width,
        height: setup.height,
        camera: None,
        estimator: DEFAULT_ESTIMATOR,
        seed: 12345,
        spp: Some(4096),
        time: None,
    };
    let reference = render_reference(
        &setup,
        &reference_options,
        Path::new("unused.exr"),
        |_, _| {},
    );

    let good = run(&setup, &reference, None, &options(None));
    assert!(good.passed, "{:#?}", good.checks);
    assert!((good.slope + 1.0).abs() <= 0.15);
    assert!(good.slope_interval[0] < good.slope && good.slope < good.slope_interval[1]);
    assert_eq!(good.levels.len(), 5);
    assert!(!good.biased);

    let clamped = run(&setup, &reference, None, &options(Some(0.5)));
    assert!(!clamped.passed);
    assert!(clamped.biased);
    let verdict = |name| {
        clamped
            .checks
            .iter()
            .find(|c| c.name == name)
            .unwrap()
            .passed
    };
    assert!(!verdict("unbiased"), "{:#?}", clamped.checks);
    assert!(
        !verdict("rate"),
        "a bias floor flattens the slope: {}",
        clamped.slope
    );
    assert!(verdict("finite"));
}
