//! `manylights reference SCENE -o REF.exr [--spp N | --time SECONDS] [--resume]`: a
//! progressive high-spp reference with its variance layer and JSON sidecar, checkpointed to
//! `REF.exr.checkpoint` every `--checkpoint-every` seconds and when interrupted (SIGINT,
//! SIGTERM), and resumed from it bit-identically with `--resume`.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use super::options::{check_resolution, Defaults, RenderOptionsArgs};
use super::output::check_output_path;
use super::{BadInput, UsageError};
use crate::measure::checkpoint::{checkpoint_path, differences, read_checkpoint, write_checkpoint};
use crate::measure::mask::{lit_mask, primary_surface_fractions, RECOMPUTE_GRID};
use crate::measure::progressive::{Budget, Flow, PassCount, Progressive};
use crate::measure::reference::{
    cache_path, cached_or_render, finish_reference, read_reference, render_reference_passes,
    sidecar_path, write_reference, Obtained, Reference, ReferenceOptions, DEFAULT_ESTIMATOR,
    PASS_SPP,
};
use crate::measure::SceneSetup;

/// A reference's defaults: 1024 spp with MIS over the light BVH.
pub const REFERENCE_DEFAULTS: Defaults = Defaults {
    spp: 1024,
    estimator: DEFAULT_ESTIMATOR,
};

#[derive(Args, Debug, Clone)]
pub struct ReferenceArgs {
    #[command(flatten)]
    pub options: RenderOptionsArgs,
    /// Output OpenEXR file: the mean and its variance layer; the sidecar is FILE.json.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Render passes until this many seconds have elapsed, instead of a fixed --spp.
    #[arg(long, conflicts_with = "spp", value_parser = positive_seconds)]
    pub time: Option<f64>,
    /// Continue the interrupted run whose checkpoint is FILE.checkpoint (same scene and
    /// options); the result is bit-identical to an uninterrupted run.
    #[arg(long)]
    pub resume: bool,
    /// Write the checkpoint FILE.checkpoint after the first pass that ends this many seconds
    /// after the last one (0: after every pass); always when interrupted.
    #[arg(long, default_value_t = 60.0, value_parser = non_negative_seconds)]
    pub checkpoint_every: f64,
}

/// A reference interrupted by a signal after its checkpoint was written (exit code 130).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Interrupted(pub String);

/// Signals that stop a reference: SIGINT and SIGTERM.
const STOP_SIGNALS: [(i32, &str); 2] = [
    (signal_hook::consts::SIGINT, "SIGINT"),
    (signal_hook::consts::SIGTERM, "SIGTERM"),
];

/// Records SIGINT and SIGTERM in a flag (and which one came in `which`) instead of dying, so
/// that the pass loop can checkpoint and stop; a second signal while the flag is set exits at
/// once (status 128 + signal), the last checkpoint staying intact.
fn catch_stop_signals() -> anyhow::Result<(Arc<AtomicBool>, Arc<AtomicUsize>)> {
    use signal_hook::flag;
    let stop = Arc::new(AtomicBool::new(false));
    let which = Arc::new(AtomicUsize::new(0));
    for (signal, _) in STOP_SIGNALS {
        // Registered first, so it sees the flag as the previous signal left it.
        flag::register_conditional_shutdown(signal, 128 + signal, Arc::clone(&stop))?;
        flag::register_usize(signal, Arc::clone(&which), signal as usize)?;
        flag::register(signal, Arc::clone(&stop))?;
    }
    Ok((stop, which))
}

pub fn run(args: &ReferenceArgs) -> anyhow::Result<()> {
    check_output_path(&args.output, "exr")?;
    check_output_path(&sidecar_path(&args.output), "json")?;
    let o = &args.options;
    if o.clamp.is_some() {
        return Err(
            UsageError("a reference must be unbiased: --clamp is not allowed".into()).into(),
        );
    }
    let estimator = o.estimator(&REFERENCE_DEFAULTS)?;
    let spp = o.single_spp(&REFERENCE_DEFAULTS)?;
    let setup = o.scene_setup()?;
    check_resolution(setup.width, setup.height)?;
    let options = ReferenceOptions {
        width: setup.width,
        height: setup.height,
        camera: setup.camera_choice.clone(),
        estimator,
        seed: o.seed,
        spp: args.time.is_none().then_some(spp),
        time: args.time,
    };
    let checkpoint = checkpoint_path(&args.output);
    check_output_path(&checkpoint, "checkpoint")?;
    let from = if args.resume {
        Some(resume_state(&checkpoint, &setup, &options)?)
    } else {
        if checkpoint.exists() {
            return Err(UsageError(format!(
                "{} exists from an interrupted run: add --resume to continue it, or delete it \
                 to start over",
                checkpoint.display()
            ))
            .into());
        }
        None
    };
    let (stop, which) = catch_stop_signals()?;
    let pool = o.thread_pool()?;
    let bar = progress_bar(&options);
    let every = Duration::from_secs_f64(args.checkpoint_every);
    let mut last_checkpoint = Instant::now();
    let mut checkpoint_error = None;
    let p = pool.install(|| {
        render_reference_passes(&setup, &options, from, |p| {
            update(&bar, &options, p.count, p.seconds);
            let stopping = stop.load(Ordering::SeqCst);
            if (stopping || last_checkpoint.elapsed() >= every) && !budget_spent(&options, p) {
                if let Err(e) = write_checkpoint(&checkpoint, &setup, &options, PASS_SPP, p) {
                    checkpoint_error = Some(e);
                    return Flow::Stop;
                }
                last_checkpoint = Instant::now();
            }
            if stopping {
                Flow::Stop
            } else {
                Flow::Continue
            }
        })
    });
    bar.finish_and_clear();
    if let Some(e) = checkpoint_error {
        return Err(e);
    }
    if !budget_spent(&options, &p) {
        let signal = which.load(Ordering::SeqCst) as i32;
        let name = STOP_SIGNALS
            .iter()
            .find(|(s, _)| *s == signal)
            .map_or("a signal", |(_, n)| n);
        return Err(Interrupted(format!(
            "interrupted by {name} after pass {} ({} spp, {:.1} s); checkpoint written to {}; \
             resume with: {}",
            p.count.passes,
            p.count.spp,
            p.seconds,
            checkpoint.display(),
            resume_command()
        ))
        .into());
    }
    let reference = finish_reference(&setup, &options, &args.output, &p);
    write_reference(&reference)?;
    if checkpoint.exists() {
        std::fs::remove_file(&checkpoint)
            .with_context(|| format!("cannot remove {}", checkpoint.display()))?;
    }
    let meta = reference
        .meta
        .as_ref()
        .expect("a rendered reference has a sidecar");
    println!(
        "reference {}x{}, {} spp in {} passes, {:.2} s, selector {:?}, strategy {:?}, K x N = {} x {}, sampler {:?}",
        setup.width,
        setup.height,
        meta.spp,
        meta.passes,
        meta.seconds,
        estimator.selector,
        estimator.strategy,
        estimator.k,
        estimator.n,
        estimator.sampler
    );
    println!(
        "relmse    {:.3e} (the reference's own, estimated from its variance)",
        meta.relmse_estimate
    );
    if let Some(surface) = &reference.surface {
        let lit = lit_mask(surface).iter().filter(|&&l| l).count();
        println!(
            "lit       {lit} of {} pixels are lit surface (every primary ray hit a surface without emission)",
            surface.len()
        );
    }
    if meta.nan_samples + meta.inf_samples > 0 {
        println!(
            "nan/inf   {} NaN, {} Inf samples (left out)",
            meta.nan_samples, meta.inf_samples
        );
    }
    println!(
        "wrote     {} and {}",
        args.output.display(),
        sidecar_path(&args.output).display()
    );
    Ok(())
}

/// A progress bar over spp, or over milliseconds for a time budget (hidden when stderr is not
/// a terminal).
pub fn progress_bar(options: &ReferenceOptions) -> ProgressBar {
    let (len, template) = match options.time {
        Some(t) => (
            (t * 1000.0) as u64,
            "reference [{bar:40}] {elapsed_precise} / {msg}",
        ),
        None => (
            options.spp.unwrap_or(1) as u64,
            "reference [{bar:40}] {pos}/{len} spp, {elapsed_precise}, eta {eta}",
        ),
    };
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    if let Some(t) = options.time {
        bar.set_message(format!("{t} s"));
    }
    bar.enable_steady_tick(Duration::from_millis(250));
    bar
}

/// Moves the bar after a pass.
pub fn update(bar: &ProgressBar, options: &ReferenceOptions, count: PassCount, seconds: f64) {
    match options.time {
        Some(_) => bar.set_position((seconds * 1000.0) as u64),
        None => bar.set_position(count.spp as u64),
    }
}

/// The state saved in `checkpoint`, when it was made for this scene and these options.
fn resume_state(
    checkpoint: &Path,
    setup: &SceneSetup,
    options: &ReferenceOptions,
) -> anyhow::Result<Progressive> {
    let (header, state) = read_checkpoint(checkpoint).map_err(BadInput::from_error)?;
    let differ = differences(&header, setup, options, PASS_SPP);
    if !differ.is_empty() {
        return Err(BadInput(format!(
            "checkpoint {} belongs to another run; it differs in {}",
            checkpoint.display(),
            differ.join("; ")
        ))
        .into());
    }
    eprintln!(
        "resuming {} after pass {} ({} spp, {:.1} s)",
        checkpoint.display(),
        header.passes,
        header.spp,
        header.seconds
    );
    Ok(state)
}

/// Whether the passes `p` finished the reference's budget.
fn budget_spent(options: &ReferenceOptions, p: &Progressive) -> bool {
    match options.budget() {
        Budget::Spp(total) => p.count.spp >= total,
        Budget::Seconds(t) => p.seconds >= t,
    }
}

/// This process's command line with `--resume` (once), quoted for a POSIX shell where needed.
fn resume_command() -> String {
    let mut args: Vec<String> = std::env::args().collect();
    if !args.iter().any(|a| a == "--resume") {
        args.push("--resume".into());
    }
    let quote = |a: &String| {
        let plain = a
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=,:+@%".contains(c));
        if plain && !a.is_empty() {
            a.clone()
        } else {
            format!("'{}'", a.replace('\'', "'\\''"))
        }
    };
    args.iter().map(quote).collect::<Vec<_>>().join(" ")
}

fn non_negative_seconds(s: &str) -> Result<f64, String> {
    let x: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if x.is_finite() && x >= 0.0 {
        Ok(x)
    } else {
        Err(format!("must be a non-negative number of seconds, got {s}"))
    }
}

fn positive_seconds(s: &str) -> Result<f64, String> {
    let x: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("must be a positive number of seconds, got {s}"))
    }
}

/// The base seed of references bench and converge render themselves: fixed, so one cached
/// reference serves every `--seed` (the renders' seeds are mixed from theirs and never meet it
/// in practice).
pub const REFERENCE_SEED: u64 = 0x5eed_f0e5_7e11_ca5e;

/// The reference a measuring command compares against: the file given, or the cached one for
/// this scene and size (rendered with bvh + mis at `spp` when missing). Says which on stderr.
pub fn obtain_reference(
    setup: &SceneSetup,
    given: Option<&Path>,
    spp: u32,
) -> anyhow::Result<Reference> {
    if let Some(path) = given {
        let r = read_reference(path).map_err(BadInput::from_error)?;
        if (r.mean.width, r.mean.height) != (setup.width as usize, setup.height as usize) {
            return Err(BadInput(format!(
                "reference {} is {}x{} but the renders are {}x{} (set --width/--height)",
                path.display(),
                r.mean.width,
                r.mean.height,
                setup.width,
                setup.height
            ))
            .into());
        }
        if let Some(m) = &r.meta {
            if m.scene_hash != format!("{:016x}", setup.hash) {
                eprintln!(
                    "warning: reference {} was rendered from a different scene file (hash {}, \
                     this one {:016x})",
                    path.display(),
                    m.scene_hash,
                    setup.hash
                );
            }
        }
        eprintln!("reference {} (given)", path.display());
        return Ok(r);
    }
    let options = ReferenceOptions {
        width: setup.width,
        height: setup.height,
        camera: setup.camera_choice.clone(),
        estimator: DEFAULT_ESTIMATOR,
        seed: REFERENCE_SEED,
        spp: Some(spp),
        time: None,
    };
    let path = cache_path(setup, &options);
    if !path.exists() {
        eprintln!(
            "reference not given: rendering one ({} spp, bvh + mis) into {}",
            spp,
            path.display()
        );
    }
    let bar = progress_bar(&options);
    let (r, obtained) = cached_or_render(setup, &options, |count, secs| {
        update(&bar, &options, count, secs)
    })?;
    bar.finish_and_clear();
    let rel = r.relmse_estimate().unwrap_or(f64::NAN);
    match obtained {
        Obtained::Cached => eprintln!(
            "reference not given: reusing the cached reference {} ({} spp, own relMSE {:.3e})",
            path.display(),
            spp,
            rel
        ),
        Obtained::Rendered => eprintln!(
            "reference rendered and cached: {} ({} spp, own relMSE {:.3e})",
            path.display(),
            spp,
            rel
        ),
    }
    Ok(r)
}

/// The lit-surface mask of `reference` (see `measure::mask`): from its `surface` channel, or,
/// for a reference without one, recomputed by a primary-visibility pass over `setup` (with a
/// note on stderr).
pub fn lit_mask_for(setup: &SceneSetup, reference: &Reference) -> Vec<bool> {
    match &reference.surface {
        Some(surface) => lit_mask(surface),
        None => {
            eprintln!(
                "note: reference {} has no surface channel (written by an older version or \
                 another program); lit-surface mask recomputed from primary visibility, \
                 {RECOMPUTE_GRID}x{RECOMPUTE_GRID} rays per pixel",
                reference.path.display()
            );
            lit_mask(&primary_surface_fractions(setup, RECOMPUTE_GRID))
        }
    }
}
