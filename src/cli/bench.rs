//! `manylights bench SCENE …`: render every configuration R times, measure it against a
//! reference, and report error, variance, time and efficiency (table, JSON, CSV, Markdown).

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::options::{check_resolution, RenderOptionsArgs, TEXTBOOK_DEFAULTS};
use super::output::{check_output_folder, check_output_path};
use super::reference::obtain_reference;
use super::UsageError;
use crate::measure::bench::{
    apply_baseline, estimator_label, run, split_baseline, target_answers, BenchPlan,
};
use crate::measure::plot::{plot_relmse_vs_seconds, write_error_image};
use crate::measure::report::{csv, markdown, table, write_json, write_text};
use crate::measure::{EstimatorChoice, SceneSetup};

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
    /// The configuration ratios compare against, selector:strategy:KxN[:sampler][:spp]
    /// (default: the first; without :spp, at each row's own spp; without :sampler,
    /// independent).
    #[arg(long)]
    pub baseline: Option<String>,
    /// Equal time: each configuration renders 1-spp passes until this many seconds are spent
    /// (instead of --spp).
    #[arg(long, conflicts_with = "spp")]
    pub time_budget: Option<f64>,
    /// Print the seconds each configuration needs to reach this relMSE, and the cheapest.
    #[arg(long)]
    pub target_relmse: Option<f64>,
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

/// Every (selector, strategy, K, N, sampler) the options ask for, in the order given.
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
                for sampler in or(&o.sampler, d.sampler) {
                    out.push(EstimatorChoice {
                        selector,
                        strategy,
                        k,
                        n,
                        sampler,
                    });
                }
            }
        }
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
    let setup = SceneSetup::load(&o.scene, o.camera.as_ref(), o.width, o.height)?
        .with_punctual_units(o.punctual_units)
        .with_environment(o.environment()?);
    check_resolution(setup.width, setup.height)?;
    let pool = o.thread_pool()?;
    let reference =
        pool.install(|| obtain_reference(&setup, args.reference.as_deref(), args.reference_spp))?;
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
            .map_or(String::new(), |b| format!(", equal time {b} s each"))
    );
    let mut done = 0;
    let mut rows = pool.install(|| {
        run(&setup, &reference.mean, &plan, |row| {
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

    print!("{}", table(&rows));
    if let Some(ref_rel) = reference.relmse_estimate() {
        let smallest = rows.iter().map(|r| r.relmse).fold(f64::INFINITY, f64::min);
        if ref_rel > smallest / 100.0 {
            eprintln!(
                "warning: the reference's own relMSE ({ref_rel:.3e}) exceeds 1/100 of the \
                 smallest relMSE measured ({smallest:.3e}); the errors include the reference's \
                 noise — render a reference with more samples (--reference-spp)"
            );
        }
    } else {
        eprintln!("note: the reference has no variance layer; its own error is unknown");
    }
    if rows.iter().any(|r| r.biased) {
        println!(
            "biased: samples clamped to {} (--clamp)",
            o.clamp.unwrap_or_default()
        );
    }
    if let Some(target) = args.target_relmse {
        println!(
            "\ntime to reach relMSE {target:e} (relMSE ∝ spp^slope, fitted per configuration):"
        );
        let answers = target_answers(&rows, target);
        for a in &answers {
            match a.cost {
                Some(c) => println!(
                    "  {:<32} {:>12.3} s  ({:.0} spp, slope {:.2})",
                    a.config, c.seconds, c.spp, c.slope
                ),
                None => println!("  {:<32}  never (relMSE does not fall with spp)", a.config),
            }
        }
        if let Some(best) = answers.first().filter(|a| a.cost.is_some()) {
            println!("cheapest: {}", best.config);
        }
    }
    if let Some(p) = &args.json {
        write_json(p, &rows)?;
    }
    if let Some(p) = &args.csv {
        write_text(p, &csv(&rows))?;
    }
    if let Some(p) = &args.markdown {
        write_text(p, &markdown(&rows))?;
    }
    if let Some(p) = &args.plot {
        let name = setup.path.file_name().unwrap_or_default().to_string_lossy();
        let title = format!(
            "{name} {}x{}: relMSE against time",
            setup.width, setup.height
        );
        plot_relmse_vs_seconds(p, &rows, &title)?;
    }
    if let Some(dir) = &args.error_images {
        for row in &rows {
            let file = dir.join(format!("{}.png", row.label().replace(':', "_")));
            write_error_image(&file, &row.image, &reference.mean)?;
        }
    }
    Ok(())
}
