//! Benchmark grids: every configuration (selector × strategy × K×N × sampler × spp) rendered R
//! times with
//! different seeds, at equal spp or at an equal time budget, and measured against a reference:
//!     MSE, relMSE                 (see `metrics`), mean over repeats, with a 95% interval
//!                                 across seeds: mean ± t₀.₉₇₅,R−1·sd/√R (R ≥ 2); over all
//!                                 pixels and over lit-surface pixels, raw and corrected for
//!                                 the reference's noise (see `errors`)
//!     variance                    mean over pixels and channels of s²/n (no reference needed)
//!     efficiency                  1 / (relMSE × seconds), and 1 / (variance × seconds); and
//!                                 1 / (relMSE × CPU seconds), which does not move while
//!                                 other jobs hold the cores
//! with seconds the median render time over repeats (CPU seconds: the median of the renders'
//! CPU time, all threads). A configuration is flagged heavy-tailed
//! when its MSE (all or lit pixels) does not fall from one spp to the next, or one pixel holds
//! more than `WORST_PIXEL_SHARE_FLAG` of the squared error (lit pixels when known). Images
//! rendered elsewhere enter as external rows measured the same way.

use std::path::PathBuf;
use std::time::Instant;

use serde::Serialize;

use super::cpu_time::{cpu_seconds_between, process_cpu_seconds};
use super::errors::{not_falling, Against, ErrorAccumulator, Errors, WORST_PIXEL_SHARE_FLAG};
use super::fit::{cost_to_target, TargetCost, TargetPoint};
use super::metrics::compare;
use super::progressive::{render_progressive, Budget, Clock};
use super::{mean_image, mean_variance, EstimatorChoice, SceneSetup};
use crate::image::RgbImage;
use crate::integrator::{render, PreparedScene, RenderOptions, Strategy};
use crate::sampling::rng::derive_seed;
use crate::sampling::sampler::SamplerKind;
use crate::select::{SelectorKind, DEFAULT_FAR_SIN};

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchPlan {
    pub estimators: Vec<EstimatorChoice>,
    /// Equal-spp mode: each value is one configuration. Ignored with a time budget.
    pub spp: Vec<u32>,
    pub repeat: u32,
    pub seed: u64,
    pub clamp: Option<f32>,
    /// Equal-time mode: passes of 1 spp until this many seconds are spent...
    pub time_budget: Option<f64>,
    /// ...on this clock.
    pub budget_clock: Clock,
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
    /// `bvh`'s far-lane sine (`EstimatorChoice::far_sin`).
    pub far_sin: f32,
    /// Samples per pixel (with a time budget: the median reached over repeats).
    pub spp: u32,
    /// Median render seconds over repeats.
    pub seconds: f64,
    pub seconds_min: f64,
    pub seconds_max: f64,
    /// Median CPU seconds of the renders over repeats, user and system, all threads (None where
    /// the system does not say): their cost in CPU time, which, unlike `seconds`, does not grow
    /// while other jobs hold the cores.
    pub cpu_seconds: Option<f64>,
    /// The one-off build of this configuration's light selector (the light tree, the alias
    /// table), wall seconds: made once before its renders, for every configuration with the
    /// same selector, and not counted in `seconds` or `cpu_seconds`.
    pub selector_build_seconds: f64,
    /// The same build's CPU seconds, all threads (None where the system does not say).
    pub selector_build_cpu_seconds: Option<f64>,
    /// Rays traced per render (mean over repeats).
    pub rays: u64,
    pub mse: f64,
    /// 95% interval of the MSE across seeds (None when R = 1).
    pub mse_interval: Option<[f64; 2]>,
    pub relmse: f64,
    /// 95% interval of the relMSE across seeds (None when R = 1).
    pub relmse_interval: Option<[f64; 2]>,
    /// Over all pixels and over lit-surface pixels, raw and corrected for the reference's noise.
    pub errors: Errors,
    /// Why the configuration looks heavy-tailed (None: no sign of it).
    pub heavy_tail: Option<String>,
    /// Mean over pixels and channels of the estimated variance of the pixel mean (None at
    /// 1 spp: one sample has no sample variance).
    pub variance: Option<f64>,
    /// 1 / (relMSE × seconds).
    pub efficiency: f64,
    /// 1 / (variance × seconds).
    pub efficiency_variance: Option<f64>,
    /// 1 / (relMSE × CPU seconds) (None where the system does not give CPU time).
    pub efficiency_cpu: Option<f64>,
    /// Baseline MSE / this MSE (> 1: less error than the baseline).
    pub mse_ratio: f64,
    /// This efficiency / the baseline's (> 1: more accuracy per second).
    pub efficiency_ratio: f64,
    /// This CPU-time efficiency / the baseline's (> 1: more accuracy per CPU second).
    pub efficiency_cpu_ratio: Option<f64>,
    /// The label of the configuration the ratios compare against.
    pub baseline: String,
    /// Clamped samples: the estimate is biased.
    pub biased: bool,
    pub clamp: Option<f32>,
    pub repeats: u32,
    pub time_budget: Option<f64>,
    /// The clock the time budget was counted on (None without one).
    pub budget_clock: Option<Clock>,
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
    /// `selector:strategy:KxN[:mM][:farS][:sampler]:spp`, the form `--baseline` accepts.
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
            far_sin: self.far_sin,
        }
    }
}

/// `selector:strategy:KxN[:mM][:farS][:sampler]` with the CLI's spellings; M is named for the
/// resampling strategies, the far-lane sine S for `bvh` when it is not the default, the sampler
/// unless it is the default, independent.
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
        "{}:{}:{}x{}{m}{}{sampler}",
        name(e.selector.to_possible_value()),
        name(e.strategy.to_possible_value()),
        e.k,
        e.n,
        far_suffix(e.selector, e.far_sin)
    )
}

/// `:farS` for `bvh` with a far-lane sine S other than the default, else nothing.
fn far_suffix(selector: SelectorKind, far_sin: f32) -> String {
    if selector == SelectorKind::Bvh && far_sin != DEFAULT_FAR_SIN {
        format!(":far{far_sin}")
    } else {
        String::new()
    }
}

/// A selector as the configuration labels name it: `selector[:farS]`.
pub fn selector_label(selector: SelectorKind, far_sin: f32) -> String {
    use clap::ValueEnum;
    let name = selector
        .to_possible_value()
        .map_or("?".into(), |v| v.get_name().to_owned());
    format!("{name}{}", far_suffix(selector, far_sin))
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
    cpu_seconds: Option<f64>,
    spp: u32,
    rays: u64,
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
    against: &Against,
    plan: &BenchPlan,
    mut on_row: impl FnMut(&BenchRow),
) -> Vec<BenchRow> {
    let mut rows = Vec::new();
    // One prepared scene per selector (and far-lane sine), in the order first asked for.
    let mut selectors: Vec<(SelectorKind, f32)> = Vec::new();
    for e in &plan.estimators {
        if !selectors.contains(&(e.selector, e.far_sin)) {
            selectors.push((e.selector, e.far_sin));
        }
    }
    let spps: Vec<Option<u32>> = match plan.time_budget {
        Some(_) => vec![None],
        None => plan.spp.iter().map(|&s| Some(s)).collect(),
    };
    for (kind, far_sin) in selectors {
        let prepared = PreparedScene::new_with(setup.scene.clone(), kind, far_sin);
        let of_these = |e: &&EstimatorChoice| e.selector == kind && e.far_sin == far_sin;
        for e in plan.estimators.iter().filter(of_these) {
            let estimator = prepared
                .estimator(e.strategy, e.k, e.n)
                .with_candidates(e.m);
            for &spp in &spps {
                let mut errors = ErrorAccumulator::new(against.mean.pixels.len());
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
                        let cpu = process_cpu_seconds();
                        let (film, stats, seconds, spp) = match plan.time_budget {
                            Some(b) => {
                                let p = render_progressive(
                                    &estimator,
                                    &setup.camera,
                                    &opts,
                                    Budget::Seconds(b),
                                    plan.budget_clock,
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
                        let cpu_seconds = cpu_seconds_between(cpu, process_cpu_seconds());
                        let image = mean_image(&film);
                        errors.add(&image, against);
                        Run {
                            seconds,
                            cpu_seconds,
                            spp,
                            rays: stats.rays.total_rays(),
                            variance: mean_variance(&film),
                            nan: stats.nan_samples,
                            inf: stats.inf_samples,
                            fireflies: stats.fireflies,
                            max_sample_luminance: stats.max_sample_luminance,
                            image,
                        }
                    })
                    .collect();
                let build = (prepared.selector_seconds, prepared.selector_cpu_seconds);
                let row = aggregate(*e, plan, runs, errors.finish(against), build);
                on_row(&row);
                rows.push(row);
            }
        }
    }
    rows
}

/// One configuration's row from its renders, their errors and its selector's `build` (wall and
/// CPU seconds).
fn aggregate(
    e: EstimatorChoice,
    plan: &BenchPlan,
    runs: Vec<Run>,
    errors: Errors,
    build: (f64, Option<f64>),
) -> BenchRow {
    let r = runs.len() as f64;
    let mean = |f: fn(&Run) -> f64| runs.iter().map(f).sum::<f64>() / r;
    let mut secs: Vec<f64> = runs.iter().map(|x| x.seconds).collect();
    let seconds = median(&mut secs);
    let mut cpu: Vec<f64> = runs.iter().filter_map(|x| x.cpu_seconds).collect();
    let cpu_seconds = (cpu.len() == runs.len()).then(|| median(&mut cpu));
    let mut spps: Vec<f64> = runs.iter().map(|x| x.spp as f64).collect();
    let spp = median(&mut spps).round() as u32;
    let (mse, mse_interval) = (errors.all.mse, errors.all.mse_interval);
    let (relmse, relmse_interval) = (errors.all.relmse, errors.all.relmse_interval);
    let variance = (spp >= 2).then(|| mean(|x| x.variance));
    BenchRow {
        selector: e.selector,
        strategy: e.strategy,
        k: e.k,
        n: e.n,
        sampler: e.sampler,
        m: e.m,
        far_sin: e.far_sin,
        spp,
        seconds,
        seconds_min: secs.iter().cloned().fold(f64::INFINITY, f64::min),
        seconds_max: secs.iter().cloned().fold(0.0, f64::max),
        cpu_seconds,
        selector_build_seconds: build.0,
        selector_build_cpu_seconds: build.1,
        rays: (mean(|x| x.rays as f64)).round() as u64,
        mse,
        mse_interval,
        relmse,
        relmse_interval,
        errors,
        heavy_tail: None,
        variance,
        efficiency: 1.0 / (relmse * seconds),
        efficiency_variance: variance.map(|v| 1.0 / (v * seconds)),
        efficiency_cpu: cpu_seconds.map(|c| 1.0 / (relmse * c)),
        mse_ratio: 1.0,
        efficiency_ratio: 1.0,
        efficiency_cpu_ratio: cpu_seconds.map(|_| 1.0),
        baseline: String::new(),
        biased: plan.clamp.is_some(),
        clamp: plan.clamp,
        repeats: runs.len() as u32,
        time_budget: plan.time_budget,
        budget_clock: plan.time_budget.map(|_| plan.budget_clock),
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

/// Fills each row's ratios against the baseline:
/// `selector:strategy:KxN[:mM][:farS][:sampler][:spp]`. Without `:spp` (and by default, with the
/// first row's configuration), each row is compared with the
/// baseline configuration at its own spp (or the first baseline row when that spp is missing).
/// Errors when no row matches.
pub fn apply_baseline(rows: &mut [BenchRow], baseline: Option<&str>) -> Result<(), String> {
    let Some(first) = rows.first() else {
        return Ok(());
    };
    let wanted = baseline.map_or_else(|| estimator_label(&first.estimator()), str::to_owned);
    let matches =
        |row: &BenchRow| row.label() == wanted || estimator_label(&row.estimator()) == wanted;
    let candidates: Vec<(u32, f64, f64, Option<f64>, String)> = rows
        .iter()
        .filter(|r| matches(r))
        .map(|r| (r.spp, r.mse, r.efficiency, r.efficiency_cpu, r.label()))
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
        let (_, mse, eff, eff_cpu, label) = if pinned {
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
        row.efficiency_cpu_ratio = row.efficiency_cpu.zip(eff_cpu).map(|(e, b)| e / b);
        row.baseline = label;
    }
    Ok(())
}

/// Marks heavy-tailed configurations: MSE over all or over lit-surface pixels that does not
/// fall from one spp to the next larger, or one pixel holding more than
/// [`WORST_PIXEL_SHARE_FLAG`] of the squared error (over lit-surface pixels when known).
pub fn flag_heavy_tails(rows: &mut [BenchRow]) {
    for i in 0..rows.len() {
        let mut reasons = Vec::new();
        let e = &rows[i].errors;
        let region = e.lit.as_ref().unwrap_or(&e.all);
        if region.worst_pixel_share > WORST_PIXEL_SHARE_FLAG {
            reasons.push(format!(
                "one pixel holds {:.0}% of the {} squared error",
                100.0 * region.worst_pixel_share,
                if e.lit.is_some() {
                    "lit-surface"
                } else {
                    "image's"
                }
            ));
        }
        // This row and the same configuration at the next larger spp.
        let next = rows
            .iter()
            .filter(|r| r.estimator() == rows[i].estimator() && r.spp > rows[i].spp)
            .min_by_key(|r| r.spp);
        let point = |r: &BenchRow| (r.spp, r.mse, r.errors.lit.as_ref().map(|l| l.mse));
        if let Some(next) = next {
            reasons.extend(not_falling(&[point(&rows[i]), point(next)]));
        }
        if !reasons.is_empty() {
            rows[i].heavy_tail = Some(reasons.join("; "));
        }
    }
}

/// What one estimator configuration needs to reach a target relMSE.
#[derive(Clone, Debug, Serialize)]
pub struct TargetAnswer {
    /// `selector:strategy:KxN[:mM][:farS][:sampler]`.
    pub config: String,
    /// None when its measured relMSE does not fall with spp.
    pub cost: Option<TargetCost>,
}

/// For each estimator configuration, the spp and seconds to reach `target` relMSE, fitted
/// over its rows (see [`cost_to_target`]) on lit-surface relMSE when `lit` (and every row has
/// it), else over all pixels; sorted by point estimate, then refused ones by their interval's
/// upper end, unreachable last.
pub fn target_answers(rows: &[BenchRow], target: f64, lit: bool) -> Vec<TargetAnswer> {
    let mut configs: Vec<EstimatorChoice> = Vec::new();
    for r in rows {
        if !configs.contains(&r.estimator()) {
            configs.push(r.estimator());
        }
    }
    let mut answers: Vec<TargetAnswer> = configs
        .iter()
        .map(|e| {
            let mine: Vec<&BenchRow> = rows.iter().filter(|r| r.estimator() == *e).collect();
            let points: Vec<TargetPoint> = mine
                .iter()
                .map(|r| {
                    let region = r
                        .errors
                        .lit
                        .as_ref()
                        .filter(|_| lit)
                        .unwrap_or(&r.errors.all);
                    TargetPoint {
                        spp: r.spp as f64,
                        relmse: region.relmse,
                        relmse_interval: region.relmse_interval,
                        seconds: r.seconds,
                    }
                })
                .collect();
            let heavy = mine.iter().find_map(|r| r.heavy_tail.as_deref());
            TargetAnswer {
                config: estimator_label(e),
                cost: cost_to_target(&points, target, heavy),
            }
        })
        .collect();
    answers.sort_by(|a, b| {
        let key = |t: &TargetAnswer| match &t.cost {
            Some(c) => match c.seconds {
                Some(s) => (0, s),
                None if c.seconds_interval[1].is_finite() => (1, c.seconds_interval[1]),
                None => (2, 0.0),
            },
            None => (3, 0.0),
        };
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    answers
}

/// An image rendered elsewhere, measured against the same reference: `NAME=IMAGE.exr` with the
/// seconds and spp its author claims, when given.
#[derive(Clone, Debug, Serialize)]
pub struct ExternalRow {
    pub name: String,
    pub path: PathBuf,
    /// Always true: marks the row in JSON.
    pub external: bool,
    /// The user's claim, not measured here.
    pub seconds: Option<f64>,
    pub spp: Option<u32>,
    pub mse: f64,
    pub relmse: f64,
    pub max_abs: f64,
    pub psnr: f64,
    /// 1 / (relMSE × seconds) when seconds are given.
    pub efficiency: Option<f64>,
    pub errors: Errors,
    /// One pixel holding more than the flag's share of the squared error.
    pub heavy_tail: Option<String>,
    #[serde(skip)]
    pub image: RgbImage,
}

/// Measures an external image (of the reference's size) the way bench rows are measured.
pub fn external_row(
    name: &str,
    path: PathBuf,
    image: RgbImage,
    seconds: Option<f64>,
    spp: Option<u32>,
    against: &Against,
) -> ExternalRow {
    let mut acc = ErrorAccumulator::new(image.pixels.len());
    acc.add(&image, against);
    let errors = acc.finish(against);
    let raw = compare(&image, against.mean).expect("external image has the reference's size");
    let region = errors.lit.as_ref().unwrap_or(&errors.all);
    let heavy_tail = (region.worst_pixel_share > WORST_PIXEL_SHARE_FLAG).then(|| {
        format!(
            "one pixel holds {:.0}% of the squared error",
            100.0 * region.worst_pixel_share
        )
    });
    ExternalRow {
        name: name.into(),
        path,
        external: true,
        seconds,
        spp,
        mse: errors.all.mse,
        relmse: errors.all.relmse,
        max_abs: raw.max_abs,
        psnr: raw.psnr,
        efficiency: seconds.map(|s| 1.0 / (errors.all.relmse * s)),
        errors,
        heavy_tail,
        image,
    }
}

/// A row of a bench report: measured here or external.
#[derive(Clone, Copy, Debug, Serialize)]
#[serde(untagged)]
pub enum ReportRow<'a> {
    Bench(&'a BenchRow),
    External(&'a ExternalRow),
}

impl ReportRow<'_> {
    /// The configuration label, or `external:NAME`.
    pub fn label(&self) -> String {
        match self {
            ReportRow::Bench(r) => estimator_label(&r.estimator()),
            ReportRow::External(x) => format!("external:{}", x.name),
        }
    }

    pub fn errors(&self) -> &Errors {
        match self {
            ReportRow::Bench(r) => &r.errors,
            ReportRow::External(x) => &x.errors,
        }
    }

    pub fn seconds(&self) -> Option<f64> {
        match self {
            ReportRow::Bench(r) => Some(r.seconds),
            ReportRow::External(x) => x.seconds,
        }
    }
}

/// Every row for the reports: bench rows first, then external ones.
pub fn report_rows<'a>(rows: &'a [BenchRow], external: &'a [ExternalRow]) -> Vec<ReportRow<'a>> {
    rows.iter()
        .map(ReportRow::Bench)
        .chain(external.iter().map(ReportRow::External))
        .collect()
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
