//! `manylights bench SCENE …`: render every configuration R times, measure it (and any
//! external image) against a reference over all pixels and over lit-surface pixels, and report
//! error, variance, time and efficiency (table, JSON, CSV, Markdown, plot), heavy-tail flags,
//! convergence rates with 95% intervals and, with --target-relmse, the time to a target as an
//! interval.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::options::{check_resolution, RenderOptionsArgs, TEXTBOOK_DEFAULTS};
use super::output::{check_output_folder, check_output_path};
use super::reference::{lit_mask_for, obtain_reference};
use super::{BadInput, UsageError};
use crate::image::{check_samples, read_exr_rgb};
use crate::measure::bench::{
    apply_baseline, estimator_label, external_row, flag_heavy_tails, report_rows, run,
    selector_label, split_baseline, target_answers, BenchPlan, BenchRow, ExternalRow, TargetAnswer,
};
use crate::measure::cpu_time::process_cpu_seconds;
use crate::measure::errors::Against;
use crate::measure::fit::{fit_loglog, EXTRAPOLATION_FACTOR, MAX_INTERVAL_RATIO};
use crate::measure::plot::{plot_relmse_vs_seconds, write_error_image};
use crate::measure::progressive::Clock;
use crate::measure::report::{csv, markdown, short, table, write_json, write_text};
use crate::measure::EstimatorChoice;
use crate::select::SelectorKind;

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    #[command(flatten)]
    pub options: RenderOptionsArgs,
    /// K×N pairs to sweep, e.g. 1x1,4x1,1x4,16x1 (default: every --k with every --n).
    #[arg(long, value_delimiter = ',', value_parser = parse_kn)]
    pub kn: Vec<(u32, u32)>,
    /// Renders per configuration, each with its own seed.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeat: u32,
    /// The reference EXR (default: render one with bvh + mis, or reuse the cached one in
    /// SCENE.ref/).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of a reference bench renders itself.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub reference_spp: u32,
    /// The configuration ratios compare against,
    /// selector:strategy:KxN[:mM][:farS][:sampler][:spp] (default: the first; without :spp, at
    /// each row's own spp; without :sampler, independent).
    // The brackets are the help text's option syntax, not intra-doc links.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(long)]
    pub baseline: Option<String>,
    /// Equal time: each configuration renders 1-spp passes until this many seconds are spent
    /// (instead of --spp).
    #[arg(long, conflicts_with = "spp")]
    pub time_budget: Option<f64>,
    /// The clock --time-budget counts on: wall seconds, or the process's CPU seconds (all
    /// threads), which other jobs on the machine do not move.
    #[arg(long, value_enum, default_value_t = Clock::Wall, requires = "time_budget")]
    pub budget_clock: Clock,
    /// Print the seconds each configuration needs to reach this relMSE (a 95% interval, with a
    /// point estimate only when it is trustworthy), and the cheapest.
    #[arg(long)]
    pub target_relmse: Option<f64>,
    /// Which pixels' relMSE --target-relmse extrapolates (lit: lit-surface pixels, when the
    /// reference has any).
    #[arg(long, value_enum, default_value_t = TargetPixels::Lit)]
    pub target_pixels: TargetPixels,
    /// An image rendered elsewhere, measured against the same reference and listed as an
    /// external row: NAME=IMAGE.exr[:SECONDS[:SPP]] (seconds and spp are your claim; repeatable).
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(long, value_parser = parse_external)]
    pub external: Vec<ExternalSpec>,
    /// Draw relMSE against seconds (log-log, one line per configuration) as SVG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write a false-colour PNG of each configuration's per-pixel relative error here
    /// (the last repeat; log scale from 1e-4, dark, to 10, pale yellow).
    #[arg(long)]
    pub error_images: Option<PathBuf>,
    #[arg(long)]
    pub json: Option<PathBuf>,
    #[arg(long)]
    pub csv: Option<PathBuf>,
    #[arg(long)]
    pub markdown: Option<PathBuf>,
}

/// The pixels `--target-relmse` extrapolates over.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TargetPixels {
    Lit,
    All,
}

/// A parsed `--external NAME=IMAGE.exr[:SECONDS[:SPP]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExternalSpec {
    pub name: String,
    pub path: PathBuf,
    pub seconds: Option<f64>,
    pub spp: Option<u32>,
}

/// Parses `NAME=IMAGE.exr[:SECONDS[:SPP]]`; the image's name must end in `.exr` (so that a
/// path holding `:` stays whole).
pub fn parse_external(s: &str) -> Result<ExternalSpec, String> {
    let form = "expected NAME=IMAGE.exr[:SECONDS[:SPP]]";
    let (name, rest) = s
        .split_once('=')
        .filter(|(n, _)| !n.is_empty() && !n.contains(':'))
        .ok_or_else(|| format!("{form}, got {s}"))?;
    let is_exr = |p: &str| p.to_ascii_lowercase().ends_with(".exr") && p.len() > 4;
    let parts: Vec<&str> = rest.rsplitn(3, ':').collect();
    let seconds = |t: &str| {
        t.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v > 0.0)
            .ok_or_else(|| format!("{s}: seconds must be a positive number, got {t}"))
    };
    let spp = |t: &str| {
        t.parse::<u32>()
            .ok()
            .filter(|v| *v > 0)
            .ok_or_else(|| format!("{s}: spp must be a positive integer, got {t}"))
    };
    let (path, seconds, spp) = if is_exr(rest) {
        (rest.to_owned(), None, None)
    } else if parts.len() >= 2 && is_exr(&rest[..rest.len() - parts[0].len() - 1]) {
        (
            rest[..rest.len() - parts[0].len() - 1].to_owned(),
            Some(seconds(parts[0])?),
            None,
        )
    } else if parts.len() == 3 && is_exr(parts[2]) {
        (
            parts[2].to_owned(),
            Some(seconds(parts[1])?),
            Some(spp(parts[0])?),
        )
    } else {
        return Err(format!("{form} (the image must be .exr), got {s}"));
    };
    Ok(ExternalSpec {
        name: name.to_owned(),
        path: path.into(),
        seconds,
        spp,
    })
}

/// Parses `KxN`.
fn parse_kn(s: &str) -> Result<(u32, u32), String> {
    let (k, n) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected KxN like 4x1, got {s}"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|v| (1..=4096).contains(v))
            .ok_or_else(|| format!("K and N must be 1..=4096, got {s}"))
    };
    Ok((parse(k)?, parse(n)?))
}

/// A positive finite number.
fn check_positive(name: &str, x: Option<f64>) -> Result<(), UsageError> {
    match x {
        Some(v) if !(v.is_finite() && v > 0.0) => Err(UsageError(format!(
            "{name} must be a positive number, got {v}"
        ))),
        _ => Ok(()),
    }
}

/// The values given, or the default alone.
fn or<T: Clone>(values: &[T], default: T) -> Vec<T> {
    if values.is_empty() {
        vec![default]
    } else {
        values.to_vec()
    }
}

/// Every (selector, strategy, K, N, M, sampler) the options ask for, in the order given; M is
/// swept for the resampling strategies only (the others take M = 1).
pub fn estimators(args: &BenchArgs) -> Result<Vec<EstimatorChoice>, UsageError> {
    let o = &args.options;
    let d = TEXTBOOK_DEFAULTS.estimator;
    let kn = if args.kn.is_empty() {
        let mut kn = Vec::new();
        for k in or(&o.k, d.k) {
            for n in or(&o.n, d.n) {
                kn.push((k, n));
            }
        }
        kn
    } else if !o.k.is_empty() || !o.n.is_empty() {
        return Err(UsageError("give either --kn or --k/--n, not both".into()));
    } else {
        args.kn.clone()
    };
    let mut out = Vec::new();
    for selector in or(&o.selector, d.selector) {
        for strategy in or(&o.strategy, d.strategy) {
            for &(k, n) in &kn {
                let ms = if strategy.resamples() {
                    or(&o.m, d.m)
                } else {
                    vec![1]
                };
                // The far-lane sine is swept for the light tree only.
                let far = if selector == SelectorKind::Bvh {
                    or(&o.far_sin, d.far_sin)
                } else {
                    vec![d.far_sin]
                };
                for m in ms {
                    for &far_sin in &far {
                        for sampler in or(&o.sampler, d.sampler) {
                            out.push(EstimatorChoice {
                                selector,
                                strategy,
                                k,
                                n,
                                sampler,
                                m,
                                far_sin,
                            });
                        }
                    }
                }
            }
        }
    }
    if !o.m.is_empty() && !out.iter().any(|e| e.strategy.resamples()) {
        return Err(UsageError(
            "--m applies to --strategy ris and ris-mis only".into(),
        ));
    }
    if !o.far_sin.is_empty() && !out.iter().any(|e| e.selector == SelectorKind::Bvh) {
        return Err(UsageError(
            "--far-sin applies to --selector bvh only".into(),
        ));
    }
    Ok(out)
}

pub fn run_bench(args: &BenchArgs) -> anyhow::Result<()> {
    if let Some(dir) = &args.error_images {
        check_output_folder(dir).with_context(|| format!("--error-images {}", dir.display()))?;
    }
    for (path, ext) in [
        (&args.json, "json"),
        (&args.csv, "csv"),
        (&args.markdown, "md"),
        (&args.plot, "svg"),
    ] {
        if let Some(p) = path {
            check_output_path(p, ext)?;
        }
    }
    check_positive("--time-budget", args.time_budget)?;
    if args.budget_clock == Clock::Cpu && process_cpu_seconds().is_none() {
        return Err(UsageError("--budget-clock cpu: this system gives no CPU time".into()).into());
    }
    check_positive("--target-relmse", args.target_relmse)?;
    let o = &args.options;
    let plan = BenchPlan {
        estimators: estimators(args)?,
        spp: if o.spp.is_empty() {
            vec![1, 4, 16]
        } else {
            o.spp.clone()
        },
        repeat: args.repeat,
        seed: o.seed,
        clamp: o.clamp,
        time_budget: args.time_budget,
        budget_clock: args.budget_clock,
    };
    if let Some(b) = &args.baseline {
        let (config, _) = split_baseline(b);
        if !plan.estimators.iter().any(|e| estimator_label(e) == config) {
            let known: Vec<String> = plan.estimators.iter().map(estimator_label).collect();
            return Err(UsageError(format!(
                "--baseline {b} is not among the configurations: {}",
                known.join(", ")
            ))
            .into());
        }
    }
    let setup = o.scene_setup()?;
    check_resolution(setup.width, setup.height)?;
    let externals = read_externals(&args.external, setup.width, setup.height)?;
    let pool = o.thread_pool()?;
    let reference =
        pool.install(|| obtain_reference(&setup, args.reference.as_deref(), args.reference_spp))?;
    let lit = pool.install(|| lit_mask_for(&setup, &reference));
    let against = Against {
        mean: &reference.mean,
        variance: reference.variance.as_ref(),
        lit: Some(&lit),
    };
    let total = plan.estimators.len()
        * if plan.time_budget.is_some() {
            1
        } else {
            plan.spp.len()
        };
    eprintln!(
        "bench     {} configurations x {} repeats on {} at {}x{}{}",
        total,
        plan.repeat,
        setup.path.display(),
        setup.width,
        setup.height,
        plan.time_budget
            .map_or(String::new(), |b| match plan.budget_clock {
                Clock::Wall => format!(", equal time {b} s each"),
                Clock::Cpu => format!(", equal CPU time {b} s each (all threads)"),
            })
    );
    let mut done = 0;
    let mut rows = pool.install(|| {
        run(&setup, &against, &plan, |row| {
            done += 1;
            eprintln!(
                "  [{done}/{total}] {} relMSE {:.3e} in {:.3} s",
                row.label(),
                row.relmse,
                row.seconds
            );
        })
    });
    apply_baseline(&mut rows, args.baseline.as_deref()).map_err(UsageError)?;
    flag_heavy_tails(&mut rows);
    let external: Vec<ExternalRow> = externals
        .into_iter()
        .map(|(spec, image)| {
            external_row(
                &spec.name,
                spec.path,
                image,
                spec.seconds,
                spec.spp,
                &against,
            )
        })
        .collect();
    let report = report_rows(&rows, &external);

    print!("{}", table(&report));
    print_selector_builds(&rows);
    print_reference_notes(&rows, &reference);
    print_heavy_tails(&rows, &external);
    print_rates(&rows);
    if rows.iter().any(|r| r.biased) {
        println!(
            "biased: samples clamped to {} (--clamp)",
            o.clamp.unwrap_or_default()
        );
    }
    if let Some(target) = args.target_relmse {
        let on_lit = args.target_pixels == TargetPixels::Lit && lit.iter().any(|&l| l);
        print_target(&target_answers(&rows, target, on_lit), target, on_lit);
    }
    if let Some(p) = &args.json {
        write_json(p, &report)?;
    }
    if let Some(p) = &args.csv {
        write_text(p, &csv(&report))?;
    }
    if let Some(p) = &args.markdown {
        write_text(p, &markdown(&report))?;
    }
    if let Some(p) = &args.plot {
        let name = setup.path.file_name().unwrap_or_default().to_string_lossy();
        let title = format!(
            "{name} {}x{}: relMSE against time (bars: 95% interval across repeats)",
            setup.width, setup.height
        );
        plot_relmse_vs_seconds(p, &report, &title)?;
    }
    if let Some(dir) = &args.error_images {
        for x in &external {
            let file = dir.join(format!("external_{}.png", x.name.replace([':', '/'], "_")));
            write_error_image(&file, &x.image, &reference.mean)?;
        }
        for row in &rows {
            let file = dir.join(format!("{}.png", row.label().replace(':', "_")));
            write_error_image(&file, &row.image, &reference.mean)?;
        }
    }
    Ok(())
}

/// Reads every external image, refusing (bad input) an unreadable file, a non-finite pixel or
/// a size other than the renders'.
fn read_externals(
    specs: &[ExternalSpec],
    width: u32,
    height: u32,
) -> anyhow::Result<Vec<(ExternalSpec, crate::image::RgbImage)>> {
    specs
        .iter()
        .map(|spec| {
            let (image, _) = read_exr_rgb(&spec.path).map_err(BadInput::from_error)?;
            check_samples(&image, &spec.path, "mean", "a finite value", f32::is_finite)
                .map_err(BadInput::from_error)?;
            if (image.width, image.height) != (width as usize, height as usize) {
                return Err(BadInput(format!(
                    "--external {}: {} is {}x{} but the renders are {width}x{height}",
                    spec.name,
                    spec.path.display(),
                    image.width,
                    image.height
                ))
                .into());
            }
            Ok((spec.clone(), image))
        })
        .collect()
}

/// How much of the measured error is the reference's own noise, and the lit-surface count.
fn print_reference_notes(rows: &[BenchRow], reference: &crate::measure::reference::Reference) {
    let Some(first) = rows.first() else {
        return;
    };
    let all = &first.errors.all;
    match all.reference_variance {
        Some(v) => {
            let smallest = rows.iter().map(|r| r.mse).fold(f64::INFINITY, f64::min);
            println!(
                "reference noise: mean Var[ref] {v:.3e} over all pixels{}; the -Var[ref] \
                 columns subtract it ({:.1}% of the smallest MSE measured)",
                first.errors.lit.as_ref().map_or(String::new(), |l| format!(
                    ", {:.3e} over lit-surface pixels",
                    l.reference_variance.unwrap_or(f64::NAN)
                )),
                100.0 * v / smallest
            );
            // A correction larger than the raw figure's own interval changes the comparison.
            let beyond: Vec<String> = rows
                .iter()
                .filter(|r| r.mse_interval.is_some_and(|[lo, hi]| v > 0.5 * (hi - lo)))
                .map(BenchRow::label)
                .collect();
            if !beyond.is_empty() {
                eprintln!(
                    "warning: the reference's noise exceeds the half-width of the MSE's 95% \
                     interval for {}: read the MSE-Var[ref] columns, or render a reference with \
                     more samples (--reference-spp)",
                    beyond.join(", ")
                );
            }
        }
        None => eprintln!("note: the reference has no variance layer; its own error is unknown"),
    }
    match &first.errors.lit {
        Some(l) => println!(
            "lit surface: {} of {} pixels (every primary ray of the reference hit a surface \
             without emission)",
            l.pixels, all.pixels
        ),
        None if reference.surface.is_some() => {
            println!("lit surface: no pixel is lit surface; lit columns are empty")
        }
        None => {}
    }
}

/// A warning per heavy-tailed configuration, naming it.
fn print_heavy_tails(rows: &[BenchRow], external: &[ExternalRow]) {
    let flagged = rows
        .iter()
        .filter_map(|r| r.heavy_tail.as_ref().map(|h| (r.label(), h)))
        .chain(external.iter().filter_map(|x| {
            x.heavy_tail
                .as_ref()
                .map(|h| (format!("external:{}", x.name), h))
        }));
    for (label, why) in flagged {
        eprintln!("warning: heavy-tailed: {label}: {why}");
    }
}

/// Each selector's one-off build, which the renders' seconds leave out: it is paid once per
/// image, so at low spp it can weigh as much as the render (the light tree on 50,000 lights).
fn print_selector_builds(rows: &[BenchRow]) {
    let mut builds: Vec<String> = Vec::new();
    for r in rows {
        let cpu = r
            .selector_build_cpu_seconds
            .map_or(String::new(), |c| format!(", {} CPU s", short(c)));
        let build = format!(
            "{} {} s{cpu}",
            selector_label(r.selector, r.far_sin),
            short(r.selector_build_seconds)
        );
        if !builds.contains(&build) {
            builds.push(build);
        }
    }
    if !builds.is_empty() {
        println!(
            "selector builds (once before a selector's renders, not in the seconds above): {}",
            builds.join("; ")
        );
    }
}

/// The log-log slope of MSE against spp with its 95% interval, per configuration measured at
/// two or more spp, over all and over lit-surface pixels.
fn print_rates(rows: &[BenchRow]) {
    let mut configs = Vec::new();
    for r in rows {
        if !configs.contains(&r.estimator()) {
            configs.push(r.estimator());
        }
    }
    let mut header = false;
    for e in configs {
        let mine: Vec<&BenchRow> = rows.iter().filter(|r| r.estimator() == e).collect();
        let spp: Vec<f64> = mine.iter().map(|r| r.spp as f64).collect();
        let describe = |ys: Option<Vec<f64>>| {
            ys.and_then(|ys| fit_loglog(&spp, &ys))
                .map_or("-".into(), |f| {
                    if f.points > 2 {
                        format!(
                            "{:.2} [{:.2}, {:.2}]",
                            f.slope, f.slope_interval[0], f.slope_interval[1]
                        )
                    } else {
                        format!("{:.2} (two points: no interval)", f.slope)
                    }
                })
        };
        let all = describe(Some(mine.iter().map(|r| r.mse).collect()));
        if all == "-" {
            continue;
        }
        let lit = describe(
            mine.iter()
                .map(|r| r.errors.lit.as_ref().map(|l| l.mse))
                .collect(),
        );
        if !header {
            println!("\nrate: log-log slope of MSE against spp, 95% interval (-1: Monte Carlo):");
            header = true;
        }
        println!(
            "  {:<32} all pixels {all:<28} lit surface {lit}",
            estimator_label(&e)
        );
    }
}

/// The time each configuration needs to reach `target`, as intervals, with refusals explained.
fn print_target(answers: &[TargetAnswer], target: f64, on_lit: bool) {
    println!(
        "\ntime to reach relMSE {target:e} over {} (relMSE ∝ spp^slope per configuration; \
         95% intervals; no point estimate when heavy-tailed, wider than {MAX_INTERVAL_RATIO}x, \
         or beyond {EXTRAPOLATION_FACTOR}x the largest measured spp):",
        if on_lit {
            "lit-surface pixels"
        } else {
            "all pixels"
        }
    );
    for a in answers {
        let Some(c) = &a.cost else {
            println!("  {:<32} never (relMSE does not fall with spp)", a.config);
            continue;
        };
        let slope = match (c.assumed_slope, c.slope_interval) {
            (true, _) => "slope -1 assumed (the data cannot tell the rate)".to_owned(),
            (false, Some([lo, hi])) => format!("slope {:.2} [{lo:.2}, {hi:.2}]", c.slope),
            (false, None) => format!("slope {:.2}", c.slope),
        };
        let [lo, hi] = c.seconds_interval;
        let interval = if lo.is_nan() {
            "interval unknown".to_owned()
        } else {
            format!("[{lo:.3e}, {hi:.3e}] s")
        };
        match (c.seconds, &c.refused) {
            (Some(s), _) => println!(
                "  {:<32} {s:>10.3} s  {interval}  ({:.0} spp, {slope})",
                a.config,
                c.spp.unwrap_or(f64::NAN)
            ),
            (None, Some(why)) => println!(
                "  {:<32} {interval}  no point estimate: {why}  ({slope})",
                a.config
            ),
            (None, None) => {}
        }
    }
    match answers
        .first()
        .filter(|a| a.cost.as_ref().is_some_and(|c| c.seconds.is_some()))
    {
        Some(best) => println!("cheapest: {}", best.config),
        None => println!("cheapest: none can be named (no configuration has a point estimate)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn external_specs_split_from_the_right_and_keep_colons_in_paths() {
        let p = parse_external("cycles=/data/a:b/img.EXR:2.5:16").unwrap();
        assert_eq!(p.name, "cycles");
        assert_eq!(p.path, PathBuf::from("/data/a:b/img.EXR"));
        assert_eq!((p.seconds, p.spp), (Some(2.5), Some(16)));
        let p = parse_external("m=img.exr:3").unwrap();
        assert_eq!((p.seconds, p.spp), (Some(3.0), None));
        let p = parse_external("m=img.exr").unwrap();
        assert_eq!((p.seconds, p.spp), (None, None));
        for bad in [
            "img.exr",
            "=img.exr",
            "a:b=img.exr",
            "m=img.png",
            "m=img.exr:-1",
        ] {
            assert!(parse_external(bad).is_err(), "{bad}");
        }
    }
}
