//! Benchmark grids: every configuration (selector × strategy × K×N × sampler × spp) rendered R
//! times with
//! different seeds, at equal spp or at an equal time budget, and measured against a reference:
//!     MSE, relMSE                 (see `metrics`), mean over repeats, with a 95% interval of
//!                                 the MSE across seeds: mean ± 1.96·sd/√R (R ≥ 2)
//!     variance                    mean over pixels and channels of s²/n (no reference needed)
//!     efficiency                  1 / (relMSE × seconds), and 1 / (variance × seconds)
//! with seconds the median render time over repeats.

use std::time::Instant;

use serde::Serialize;

use super::fit::{cost_to_target, TargetCost};
use super::metrics::compare;
use super::progressive::{render_progressive, Budget};
use super::{mean_image, mean_variance, EstimatorChoice, SceneSetup};
use crate::image::RgbImage;
use crate::integrator::{render, PreparedScene, RenderOptions, Strategy};
use crate::sampling::rng::derive_seed;
use crate::sampling::sampler::SamplerKind;
use crate::select::SelectorKind;

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchPlan {
    pub estimators: Vec<EstimatorChoice>,
    /// Equal-spp mode: each value is one configuration. Ignored with a time budget.
    pub spp: Vec<u32>,
    pub repeat: u32,
    pub seed: u64,
    pub clamp: Option<f32>,
    /// Equal-time mode: passes of 1 spp until this many seconds are spent.
    pub time_budget: Option<f64>,
}

/// One configuration's results, aggregated over its repeats.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub selector: SelectorKind,
    pub strategy: Strategy,
    pub k: u32,
    pub n: u32,
    pub sampler: SamplerKind,
    /// RIS candidates per K×N slot (1 for strategies that do not resample).
    pub m: u32,
    /// Samples per pixel (with a time budget: the median reached over repeats).
    pub spp: u32,
    /// Median render seconds over repeats.
    pub seconds: f64,
    pub seconds_min: f64,
    pub seconds_max: f64,
    /// Rays traced per render (mean over repeats).
    pub rays: u64,
    pub mse: f64,
    /// 95% interval of the MSE across seeds (None when R = 1).
    pub mse_interval: Option<[f64; 2]>,
    pub relmse: f64,
    /// Mean over pixels and channels of the estimated variance of the pixel mean (None at
    /// 1 spp: one sample has no sample variance).
    pub variance: Option<f64>,
    /// 1 / (relMSE × seconds).
    pub efficiency: f64,
    /// 1 / (variance × seconds).
    pub efficiency_variance: Option<f64>,
    /// Baseline MSE / this MSE (> 1: less error than the baseline).
    pub mse_ratio: f64,
    /// This efficiency / the baseline's (> 1: more accuracy per second).
    pub efficiency_ratio: f64,
    /// The label of the configuration the ratios compare against.
    pub baseline: String,
    /// Clamped samples: the estimate is biased.
    pub biased: bool,
    pub clamp: Option<f32>,
    pub repeats: u32,
    pub time_budget: Option<f64>,
    pub nan_samples: u64,
    pub inf_samples: u64,
    /// Camera samples above `FIREFLY_FACTOR` × their pixel's mean luminance, over all repeats.
    pub fireflies: u64,
    /// The largest luminance of one camera sample over all repeats.
    pub max_sample_luminance: f64,
    /// The last repeat's image (for error images).
    #[serde(skip)]
    pub image: RgbImage,
}

impl BenchRow {
    /// `selector:strategy:KxN[:mM][:sampler]:spp`, the form `--baseline` accepts.
    pub fn label(&self) -> String {
        format!("{}:{}", estimator_label(&self.estimator()), self.spp)
    }

    pub fn estimator(&self) -> EstimatorChoice {
        EstimatorChoice {
            selector: self.selector,
            strategy: self.strategy,
            k: self.k,
            n: self.n,
            sampler: self.sampler,
            m: self.m,
        }
    }
}

/// `selector:strategy:KxN[:mM][:sampler]` with the CLI's spellings; M is named for the
/// resampling strategies, the sampler unless it is the default, independent.
pub fn estimator_label(e: &EstimatorChoice) -> String {
    use clap::ValueEnum;
    let name =
        |v: Option<clap::builder::PossibleValue>| v.map_or("?".into(), |v| v.get_name().to_owned());
    let sampler = match e.sampler {
        SamplerKind::Independent => String::new(),
        s => format!(":{}", name(s.to_possible_value())),
    };
    let m = if e.strategy.resamples() {
        format!(":m{}", e.m)
    } else {
        String::new()
    };
    format!(
        "{}:{}:{}x{}{m}{sampler}",
        name(e.selector.to_possible_value()),
        name(e.strategy.to_possible_value()),
        e.k,
        e.n
    )
}

/// A `--baseline` value split into its configuration label and the spp it pins, if any: a
/// final `:number` after the `KxN` part.
pub fn split_baseline(b: &str) -> (&str, Option<u32>) {
    match b.rsplit_once(':') {
        Some((config, spp)) if config.matches(':').count() >= 2 => match spp.parse() {
            Ok(spp) => (config, Some(spp)),
            Err(_) => (b, None),
        },
        _ => (b, None),
    }
}

/// One render's measurements.
struct Run {
    seconds: f64,
    spp: u32,
    rays: u64,
    mse: f64,
    relmse: f64,
    variance: f64,
    nan: u64,
    inf: u64,
    fireflies: u64,
    max_sample_luminance: f64,
    image: RgbImage,
}

/// Runs the plan against `reference` (same size as the setup's image); `on_row` sees each
/// configuration as it finishes. Ratios are filled in by [`apply_baseline`].
pub fn run(
    setup: &SceneSetup,
    reference: &RgbImage,
    plan: &BenchPlan,
    mut on_row: impl FnMut(&BenchRow),
) -> Vec<BenchRow> {
    let mut rows = Vec::new();
    let mut selectors: Vec<SelectorKind> = Vec::new();
    for e in &plan.estimators {
        if !selectors.contains(&e.selector) {
            selectors.push(e.selector);
        }
    }
    let spps: Vec<Option<u32>> = match plan.time_budget {
        Some(_) => vec![None],
        None => plan.spp.iter().map(|&s| Some(s)).collect(),
    };
    for kind in selectors {
        let prepared = PreparedScene::new(setup.scene.clone(), kind);
        for e in plan.estimators.iter().filter(|e| e.selector == kind) {
            let estimator = prepared
                .estimator(e.strategy, e.k, e.n)
                .with_candidates(e.m);
            for &spp in &spps {
                let runs: Vec<Run> = (0..plan.repeat.max(1))
                    .map(|r| {
                        let opts = RenderOptions {
                            width: setup.width,
                            height: setup.height,
                            spp: spp.unwrap_or(1),
                            seed: derive_seed(plan.seed, r as u64),
                            sampler: e.sampler,
                            first_sample: 0,
                            clamp: plan.clamp,
                        };
                        let (film, stats, seconds, spp) = match plan.time_budget {
                            Some(b) => {
                                let p = render_progressive(
                                    &estimator,
                                    &setup.camera,
                                    &opts,
                                    Budget::Seconds(b),
                                    1,
                                    |_, _| {},
                                );
                                (p.film, p.stats, p.seconds, p.count.spp)
                            }
                            None => {
                                let t = Instant::now();
                                let (film, stats) = render(&estimator, &setup.camera, &opts);
                                (film, stats, t.elapsed().as_secs_f64(), opts.spp)
                            }
                        };
                        let image = mean_image(&film);
                        let err =
                            compare(&image, reference).expect("reference has the image's size");
                        Run {
                            seconds,
                            spp,
                            rays: stats.rays.total_rays(),
                            mse: err.mse,
                            relmse: err.relmse,
                            variance: mean_variance(&film),
                            nan: stats.nan_samples,
                            inf: stats.inf_samples,
                            fireflies: stats.fireflies,
                            max_sample_luminance: stats.max_sample_luminance,
                            image,
                        }
                    })
                    .collect();
                let row = aggregate(*e, plan, runs);
                on_row(&row);
                rows.push(row);
            }
        }
    }
    rows
}

fn aggregate(e: EstimatorChoice, plan: &BenchPlan, runs: Vec<Run>) -> BenchRow {
    let r = runs.len() as f64;
    let mean = |f: fn(&Run) -> f64| runs.iter().map(f).sum::<f64>() / r;
    let mut secs: Vec<f64> = runs.iter().map(|x| x.seconds).collect();
    let seconds = median(&mut secs);
    let mut spps: Vec<f64> = runs.iter().map(|x| x.spp as f64).collect();
    let spp = median(&mut spps).round() as u32;
    let mse = mean(|x| x.mse);
    let relmse = mean(|x| x.relmse);
    let variance = (spp >= 2).then(|| mean(|x| x.variance));
    let mse_interval = (runs.len() >= 2).then(|| {
        let sd = (runs.iter().map(|x| (x.mse - mse).powi(2)).sum::<f64>() / (r - 1.0)).sqrt();
        let half = 1.96 * sd / r.sqrt();
        [mse - half, mse + half]
    });
    BenchRow {
        selector: e.selector,
        strategy: e.strategy,
        k: e.k,
        n: e.n,
        sampler: e.sampler,
        m: e.m,
        spp,
        seconds,
        seconds_min: secs.iter().cloned().fold(f64::INFINITY, f64::min),
        seconds_max: secs.iter().cloned().fold(0.0, f64::max),
        rays: (mean(|x| x.rays as f64)).round() as u64,
        mse,
        mse_interval,
        relmse,
        variance,
        efficiency: 1.0 / (relmse * seconds),
        efficiency_variance: variance.map(|v| 1.0 / (v * seconds)),
        mse_ratio: 1.0,
        efficiency_ratio: 1.0,
        baseline: String::new(),
        biased: plan.clamp.is_some(),
        clamp: plan.clamp,
        repeats: runs.len() as u32,
        time_budget: plan.time_budget,
        nan_samples: runs.iter().map(|x| x.nan).sum(),
        inf_samples: runs.iter().map(|x| x.inf).sum(),
        fireflies: runs.iter().map(|x| x.fireflies).sum(),
        max_sample_luminance: runs
            .iter()
            .map(|x| x.max_sample_luminance)
            .fold(0.0, f64::max),
        image: runs.into_iter().last().expect("at least one repeat").image,
    }
}

/// Median of a non-empty list (sorts it; the mean of the middle two for an even count).
pub fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    let m = xs.len() / 2;
    if xs.len() % 2 == 1 {
        xs[m]
    } else {
        0.5 * (xs[m - 1] + xs[m])
    }
}

/// Fills each row's ratios against the baseline: `selector:strategy:KxN[:mM][:sampler][:spp]`. Without
/// `:spp` (and by default, with the first row's configuration), each row is compared with the
/// baseline configuration at its own spp (or the first baseline row when that spp is missing).
/// Errors when no row matches.
pub fn apply_baseline(rows: &mut [BenchRow], baseline: Option<&str>) -> Result<(), String> {
    let Some(first) = rows.first() else {
        return Ok(());
    };
    let wanted = baseline.map_or_else(|| estimator_label(&first.estimator()), str::to_owned);
    let matches =
        |row: &BenchRow| row.label() == wanted || estimator_label(&row.estimator()) == wanted;
    let candidates: Vec<(u32, f64, f64, String)> = rows
        .iter()
        .filter(|r| matches(r))
        .map(|r| (r.spp, r.mse, r.efficiency, r.label()))
        .collect();
    let Some(fallback) = candidates.first().cloned() else {
        let known: Vec<String> = rows.iter().map(BenchRow::label).collect();
        return Err(format!(
            "--baseline {wanted} matches no configuration; they are: {}",
            known.join(", ")
        ));
    };
    let pinned = split_baseline(&wanted).1.is_some();
    for row in rows.iter_mut() {
        let (_, mse, eff, label) = if pinned {
            fallback.clone()
        } else {
            candidates
                .iter()
                .find(|c| c.0 == row.spp)
                .cloned()
                .unwrap_or_else(|| fallback.clone())
        };
        row.mse_ratio = mse / row.mse;
        row.efficiency_ratio = row.efficiency / eff;
        row.baseline = label;
    }
    Ok(())
}

/// What one estimator configuration needs to reach a target relMSE.
#[derive(Clone, Debug, Serialize)]
pub struct TargetAnswer {
    /// `selector:strategy:KxN[:mM][:sampler]`.
    pub config: String,
    /// None when its measured relMSE does not fall with spp.
    pub cost: Option<TargetCost>,
}

/// For each estimator configuration, the spp and seconds to reach `target` relMSE, fitted
/// over its rows (see [`cost_to_target`]); sorted cheapest first, unreachable last.
pub fn target_answers(rows: &[BenchRow], target: f64) -> Vec<TargetAnswer> {
    let mut configs: Vec<EstimatorChoice> = Vec::new();
    for r in rows {
        if !configs.contains(&r.estimator()) {
            configs.push(r.estimator());
        }
    }
    let mut answers: Vec<TargetAnswer> = configs
        .iter()
        .map(|e| {
            let points: Vec<(f64, f64, f64)> = rows
                .iter()
                .filter(|r| r.estimator() == *e)
                .map(|r| (r.spp as f64, r.relmse, r.seconds))
                .collect();
            TargetAnswer {
                config: estimator_label(e),
                cost: cost_to_target(&points, target),
            }
        })
        .collect();
    answers.sort_by(|a, b| {
        let s = |t: &TargetAnswer| t.cost.map_or(f64::INFINITY, |c| c.seconds);
        s(a).total_cmp(&s(b))
    });
    answers
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
    }
}
