//! Convergence checks: render one configuration at increasing spp over several seeds, fit the
//! log-log slope of MSE against spp (see `fit`), and check
//!   (a) rate:       |slope + 1| ≤ tolerance (independent samples give MSE ∝ 1/spp); with a
//!                   stratified or quasi-random sampler, slope ≤ −1 + tolerance (at least the
//!                   Monte Carlo rate: they may converge faster);
//!   (b) unbiased:   at the largest spp, per channel, the mean over S seeds of the image-mean
//!                   error ē = mean(render) − mean(reference) satisfies |ē| ≤ 5σ, with
//!                   σ² = (Σₚ Var\[renderₚ] / S + Σₚ Var\[refₚ]) / P² from the per-pixel
//!                   variances of the mean (pixels are independent streams; for correlated
//!                   samplers s²/n overestimates the variance of the mean, so the check is
//!                   conservative);
//!   (c) finite:     no NaN or Inf sample and finite errors.
//! Beside the checks: per spp the MSE over lit-surface pixels and both corrected for the
//! reference's noise (see `errors`), the lit-surface slope with its 95% interval, and a
//! heavy-tail flag when the mean MSE (all or lit) does not fall from one spp to the next.

use serde::Serialize;

use super::errors::{not_falling, Against, ErrorAccumulator, Errors};
use super::fit::fit_loglog;
use super::reference::Reference;
use super::{mean_image, EstimatorChoice, SceneSetup};
use crate::integrator::{render, PreparedScene, RenderOptions};
use crate::sampling::rng::derive_seed;
use crate::sampling::sampler::SamplerKind;

/// Confidence multiple of σ the unbiasedness check allows.
pub const BIAS_SIGMAS: f64 = 5.0;

#[derive(Clone, Debug)]
pub struct ConvergeOptions {
    pub estimator: EstimatorChoice,
    /// Samples per pixel to render at (sorted and deduplicated; two or more distinct values
    /// for a slope).
    pub spp: Vec<u32>,
    pub seeds: u32,
    pub seed: u64,
    pub clamp: Option<f32>,
    /// Allowed |slope + 1| (independent), or slope + 1 (other samplers).
    pub tolerance: f64,
}

/// MSE of each seed's render at one spp.
#[derive(Clone, Debug, Serialize)]
pub struct Level {
    pub spp: u32,
    pub mse: Vec<f64>,
    pub mse_mean: f64,
    /// Per seed, the MSE over lit-surface pixels (empty without a mask).
    pub lit_mse: Vec<f64>,
    /// All figures over the seeds: all and lit pixels, raw and corrected.
    pub errors: Errors,
}

/// One check's verdict.
#[derive(Clone, Debug, Serialize)]
pub struct Check {
    pub name: &'static str,
    pub passed: bool,
    pub detail: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct ConvergeReport {
    pub estimator: EstimatorChoice,
    pub seeds: u32,
    pub clamp: Option<f32>,
    pub biased: bool,
    pub levels: Vec<Level>,
    /// Least-squares slope of ln MSE against ln spp over every (spp, seed) render.
    pub slope: f64,
    /// Its 95% interval.
    pub slope_interval: [f64; 2],
    /// The same over lit-surface pixels (None without a mask).
    pub lit_slope: Option<f64>,
    pub lit_slope_interval: Option<[f64; 2]>,
    /// Why the series looks heavy-tailed (None: no sign of it).
    pub heavy_tail: Option<String>,
    /// Per channel at the largest spp: mean over seeds of mean(render) − mean(reference).
    pub mean_error: [f64; 3],
    /// Per channel: the standard deviation σ of that mean error.
    pub mean_error_sigma: [f64; 3],
    pub nan_samples: u64,
    pub inf_samples: u64,
    pub checks: Vec<Check>,
    pub passed: bool,
}

/// Runs the renders and the three checks against `reference` (same size as the setup).
pub fn run(
    setup: &SceneSetup,
    reference: &Reference,
    lit: Option<&[bool]>,
    opts: &ConvergeOptions,
) -> ConvergeReport {
    let against = Against {
        mean: &reference.mean,
        variance: reference.variance.as_ref(),
        lit,
    };
    let e = opts.estimator;
    let prepared = PreparedScene::new_with(setup.scene.clone(), e.selector, e.far_sin);
    let estimator = prepared
        .estimator(e.strategy, e.k, e.n)
        .with_candidates(e.m);
    let pixels = (setup.width * setup.height) as f64;
    let mut spps = opts.spp.clone();
    spps.sort_unstable();
    spps.dedup();
    let max_spp = spps.last().copied().unwrap_or(1);
    let (mut nan, mut inf) = (0, 0);
    let mut levels = Vec::new();
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    let mut lit_ys = Vec::new();
    // Sums over seeds at the largest spp: image-mean error and Σₚ Var\[renderₚ], per channel.
    let mut err_sum = [0.0f64; 3];
    let mut var_sum = [0.0f64; 3];
    for (level, &spp) in spps.iter().enumerate() {
        let mut mse = Vec::new();
        let mut lit_mse = Vec::new();
        let mut acc = ErrorAccumulator::new(reference.mean.pixels.len());
        for s in 0..opts.seeds.max(1) {
            let film_opts = RenderOptions {
                width: setup.width,
                height: setup.height,
                spp,
                seed: derive_seed(derive_seed(opts.seed, level as u64), s as u64),
                sampler: e.sampler,
                first_sample: 0,
                clamp: opts.clamp,
            };
            let (film, stats) = render(&estimator, &setup.camera, &film_opts);
            nan += stats.nan_samples;
            inf += stats.inf_samples;
            let image = mean_image(&film);
            let figures = acc.add(&image, &against);
            let m = figures.all.0;
            mse.push(m);
            xs.push(spp as f64);
            ys.push(m);
            if let Some((l, _)) = figures.lit {
                lit_mse.push(l);
                lit_ys.push(l);
            }
            if spp == max_spp {
                for (x, r) in film.pixels.iter().zip(&reference.mean.pixels) {
                    let v = x.variance_of_mean();
                    for c in 0..3 {
                        err_sum[c] += (x.mean[c] - r[c] as f64) / pixels;
                        var_sum[c] += v[c];
                    }
                }
            }
        }
        let mse_mean = mse.iter().sum::<f64>() / mse.len() as f64;
        levels.push(Level {
            spp,
            mse,
            mse_mean,
            lit_mse,
            errors: acc.finish(&against),
        });
    }

    let seeds = opts.seeds.max(1) as f64;
    let mut mean_error = [0.0; 3];
    let mut sigma = [0.0; 3];
    for c in 0..3 {
        let ref_var: f64 = reference
            .variance
            .as_ref()
            .map_or(0.0, |v| v.pixels.iter().map(|p| p[c] as f64).sum());
        mean_error[c] = err_sum[c] / seeds;
        sigma[c] = ((var_sum[c] / seeds / seeds + ref_var) / (pixels * pixels)).sqrt();
    }

    let fit = fit_loglog(&xs, &ys);
    let lit_fit = (lit_ys.len() == xs.len())
        .then(|| fit_loglog(&xs, &lit_ys))
        .flatten();
    let heavy_tail = heavy_tail(&levels);
    let (slope, slope_interval) =
        fit.map_or((f64::NAN, [f64::NAN; 2]), |f| (f.slope, f.slope_interval));
    let independent = e.sampler == SamplerKind::Independent;
    let rate = Check {
        name: "rate",
        passed: if independent {
            (slope + 1.0).abs() <= opts.tolerance
        } else {
            slope + 1.0 <= opts.tolerance
        },
        detail: format!(
            "slope {slope:.3} (95% interval [{:.3}, {:.3}]); expected {} {}",
            slope_interval[0],
            slope_interval[1],
            if independent { "-1 ±" } else { "≤ -1 +" },
            opts.tolerance
        ),
    };
    let within = (0..3).all(|c| mean_error[c].abs() <= BIAS_SIGMAS * sigma[c]);
    let unbiased = Check {
        name: "unbiased",
        passed: within,
        detail: format!(
            "image-mean error at {max_spp} spp per channel {} (allowed ±{BIAS_SIGMAS}σ)",
            (0..3)
                .map(|c| format!(
                    "{:+.3e} (95% interval ±{:.2e}, {:.1}σ)",
                    mean_error[c],
                    1.96 * sigma[c],
                    mean_error[c].abs() / sigma[c]
                ))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let all_finite = ys.iter().all(|m| m.is_finite()) && mean_error.iter().all(|e| e.is_finite());
    let finite = Check {
        name: "finite",
        passed: nan + inf == 0 && all_finite,
        detail: format!("{nan} NaN and {inf} Inf samples; errors finite: {all_finite}"),
    };
    let checks = vec![rate, unbiased, finite];
    ConvergeReport {
        estimator: e,
        seeds: opts.seeds,
        clamp: opts.clamp,
        biased: opts.clamp.is_some(),
        levels,
        slope,
        slope_interval,
        lit_slope: lit_fit.map(|f| f.slope),
        lit_slope_interval: lit_fit.map(|f| f.slope_interval),
        heavy_tail,
        mean_error,
        mean_error_sigma: sigma,
        nan_samples: nan,
        inf_samples: inf,
        passed: checks.iter().all(|c| c.passed),
        checks,
    }
}

/// Why a series of levels (sorted by spp) looks heavy-tailed (see [`not_falling`]).
fn heavy_tail(levels: &[Level]) -> Option<String> {
    let series: Vec<(u32, f64, Option<f64>)> = levels
        .iter()
        .map(|l| (l.spp, l.mse_mean, l.errors.lit.as_ref().map(|e| e.mse)))
        .collect();
    let reasons = not_falling(&series);
    (!reasons.is_empty()).then(|| reasons.join("; "))
}
