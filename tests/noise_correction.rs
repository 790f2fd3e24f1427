//! Reference-noise correction on synthetic images with known variance. Per value i: truth μᵢ,
//! render xᵢ = μᵢ + bᵢ + N(0, σx²) (bias bᵢ), reference rᵢ = μᵢ + N(0, σr²) with its variance
//! layer holding σr². The render's true MSE against the truth is mean(bᵢ² + σx²); the raw MSE
//! against the reference exceeds it by mean σr², and MSE − mean Var[ref] estimates it without
//! bias, with a 95% interval that should cover it in about 95% of seeds.

use manylights::image::RgbImage;
use manylights::measure::errors::{Against, ErrorAccumulator};
use manylights::sampling::rng::PixelRng;

const W: usize = 48;
const H: usize = 32;

fn normal(rng: &mut PixelRng) -> f64 {
    let u1 = (1.0 - rng.next_f64()).max(1e-300);
    let u2 = rng.next_f64();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn image(f: impl FnMut(usize) -> f32) -> RgbImage {
    let mut f = f;
    RgbImage {
        width: W,
        height: H,
        pixels: (0..W * H)
            .map(|p| [0, 1, 2].map(|c| f(3 * p + c)))
            .collect(),
    }
}

/// Per value: truth, bias, render sd, reference sd (a fixed, varied pattern).
fn value(i: usize) -> (f64, f64, f64, f64) {
    let t = i as f64;
    let mu = 0.5 + 0.4 * (0.37 * t).sin();
    let bias = 0.01 * (0.11 * t).cos();
    let sx = 0.05 + 0.03 * (0.05 * t).sin().abs();
    let sr = 0.04 + 0.02 * (0.07 * t).cos().abs();
    (mu, bias, sx, sr)
}

#[test]
fn corrected_mse_covers_the_true_mse_and_raw_mse_is_biased_by_the_reference_variance() {
    let n = 3 * W * H;
    let true_mse = (0..n)
        .map(|i| value(i).1.powi(2) + value(i).2.powi(2))
        .sum::<f64>()
        / n as f64;
    let ref_var = (0..n).map(|i| value(i).3.powi(2)).sum::<f64>() / n as f64;
    let variance = image(|i| value(i).3.powi(2) as f32);
    let seeds = 200;
    let (mut covered, mut raw_sum, mut corrected_sum) = (0, 0.0, 0.0);
    for seed in 0..seeds {
        let mut rng = PixelRng::new(seed, 0);
        let reference = image(|i| (value(i).0 + value(i).3 * normal(&mut rng)) as f32);
        let render = image(|i| {
            let (mu, b, sx, _) = value(i);
            (mu + b + sx * normal(&mut rng)) as f32
        });
        let against = Against {
            mean: &reference,
            variance: Some(&variance),
            lit: None,
        };
        let mut acc = ErrorAccumulator::new(W * H);
        acc.add(&render, &against);
        let all = acc.finish(&against).all;
        let [lo, hi] = all.mse_corrected_interval.unwrap();
        if lo <= true_mse && true_mse <= hi {
            covered += 1;
        }
        raw_sum += all.mse;
        corrected_sum += all.mse_corrected.unwrap();
        assert!((all.reference_variance.unwrap() - ref_var).abs() < 1e-6 * ref_var);
    }
    // Binomial: 95% of 200 is 190 ± 3; 180 is more than 3σ below.
    assert!(covered >= 180, "covered {covered} of {seeds}");
    let (raw, corrected) = (raw_sum / seeds as f64, corrected_sum / seeds as f64);
    // Over 200 seeds of 4608 values the mean's sd is ~ 0.2% of the MSE: 1% is 5σ.
    assert!(
        ((raw - true_mse) - ref_var).abs() < 0.01 * true_mse,
        "raw {raw} true {true_mse} ref var {ref_var}"
    );
    assert!(
        (corrected - true_mse).abs() < 0.01 * true_mse,
        "corrected {corrected} true {true_mse}"
    );
}
