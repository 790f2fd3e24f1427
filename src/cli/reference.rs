//! `manylights reference SCENE -o REF.exr [--spp N | --time SECONDS]`: a progressive high-spp
//! reference with its variance layer and JSON sidecar.

use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use super::options::{check_resolution, Defaults, RenderOptionsArgs};
use super::output::check_output_path;
use super::{BadInput, UsageError};
use crate::measure::progressive::PassCount;
use crate::measure::reference::{
    cache_path, cached_or_render, read_reference, render_reference, sidecar_path, write_reference,
    Obtained, Reference, ReferenceOptions, DEFAULT_ESTIMATOR,
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
    let setup = SceneSetup::load(&o.scene, o.camera.as_ref(), o.width, o.height)?
        .with_punctual_units(o.punctual_units)
        .with_environment(o.environment()?);
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
    let pool = o.thread_pool()?;
    let bar = progress_bar(&options);
    let reference = pool.install(|| {
        render_reference(&setup, &options, &args.output, |count, seconds| {
            update(&bar, &options, count, seconds)
        })
    });
    bar.finish_and_clear();
    write_reference(&reference)?;
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
