//! `manylights converge SCENE …`: check that a configuration converges at the expected rate to
//! the reference, without bias or non-finite samples; exit code 4 when a check fails.

use std::path::PathBuf;

use clap::Args;

use super::options::{check_resolution, RenderOptionsArgs, TEXTBOOK_DEFAULTS};
use super::output::check_output_path;
use super::reference::{lit_mask_for, obtain_reference};
use super::UsageError;
use crate::measure::converge::{run, ConvergeOptions, ConvergeReport};
use crate::measure::report::write_json;

#[derive(Args, Debug, Clone)]
pub struct ConvergeArgs {
    #[command(flatten)]
    pub options: RenderOptionsArgs,
    /// Renders per spp, each with its own seed.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub seeds: u32,
    /// Allowed deviation of the fitted log-log slope from −1 (with a sampler other than
    /// independent: how much shallower than −1 it may be).
    #[arg(long, default_value_t = 0.15)]
    pub tolerance: f64,
    /// The reference EXR (default: render one with bvh + mis, or reuse the cached one).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Samples per pixel of a reference converge renders itself (default: 64 × the largest
    /// --spp).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    pub reference_spp: Option<u32>,
    /// Also write the report (slope, slope_interval, checks) as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs converge; Ok(false) when a check failed (the caller exits with code 4).
pub fn run_converge(args: &ConvergeArgs) -> anyhow::Result<bool> {
    if let Some(p) = &args.json {
        check_output_path(p, "json")?;
    }
    if !(args.tolerance.is_finite() && args.tolerance >= 0.0) {
        return Err(UsageError(format!("--tolerance must be ≥ 0, got {}", args.tolerance)).into());
    }
    let o = &args.options;
    let spp = if o.spp.is_empty() {
        vec![4, 8, 16, 32, 64]
    } else {
        o.spp.clone()
    };
    let mut distinct = spp.clone();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() < 2 {
        return Err(UsageError("converge needs at least two distinct --spp values".into()).into());
    }
    let opts = ConvergeOptions {
        estimator: o.estimator(&TEXTBOOK_DEFAULTS)?,
        spp,
        seeds: args.seeds,
        seed: o.seed,
        clamp: o.clamp,
        tolerance: args.tolerance,
    };
    let setup = o.scene_setup()?;
    check_resolution(setup.width, setup.height)?;
    let pool = o.thread_pool()?;
    let max_spp = distinct.last().copied().unwrap_or(1);
    let reference_spp = args
        .reference_spp
        .unwrap_or_else(|| max_spp.saturating_mul(64));
    let reference =
        pool.install(|| obtain_reference(&setup, args.reference.as_deref(), reference_spp))?;
    let lit = pool.install(|| lit_mask_for(&setup, &reference));
    let report = pool.install(|| run(&setup, &reference, Some(&lit), &opts));
    print_report(&report);
    if let Some(p) = &args.json {
        write_json(p, &report)?;
    }
    Ok(report.passed)
}

fn print_report(r: &ConvergeReport) {
    let e = r.estimator;
    println!(
        "converge  {:?} {:?} K x N = {} x {}, {:?} sampler, {} seeds{}",
        e.selector,
        e.strategy,
        e.k,
        e.n,
        e.sampler,
        r.seeds,
        r.clamp
            .map_or(String::new(), |c| format!(", clamp {c} (biased)"))
    );
    let opt = |x: Option<f64>| x.map_or("-".to_owned(), |v| format!("{v:.4e}"));
    for l in &r.levels {
        let lit = l.errors.lit.as_ref();
        println!(
            "  spp {:>6}  MSE {:.4e}  MSE-Var[ref] {}  lit MSE {}  lit MSE-Var[ref] {}",
            l.spp,
            l.mse_mean,
            opt(l.errors.all.mse_corrected),
            opt(lit.map(|l| l.mse)),
            opt(lit.and_then(|l| l.mse_corrected))
        );
    }
    println!(
        "slope     {:.3}, 95% interval [{:.3}, {:.3}]",
        r.slope, r.slope_interval[0], r.slope_interval[1]
    );
    if let (Some(s), Some([lo, hi])) = (r.lit_slope, r.lit_slope_interval) {
        println!("lit slope {s:.3}, 95% interval [{lo:.3}, {hi:.3}] (lit-surface pixels)");
    }
    if let Some(why) = &r.heavy_tail {
        eprintln!("warning: heavy-tailed: {why}");
        println!("heavy tail: {why}");
    }
    for c in &r.checks {
        println!(
            "{:<9} {}  {}",
            c.name,
            if c.passed { "PASS" } else { "FAIL" },
            c.detail
        );
    }
    println!(
        "{}",
        if r.passed {
            "all checks passed"
        } else {
            "a check FAILED"
        }
    );
}
