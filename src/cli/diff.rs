//! `manylights diff A.exr B.exr`: error of image A against reference B, over all pixels and,
//! when B carries a `surface` channel (references written by `manylights reference`), over
//! lit-surface pixels; with B's variance layer, also corrected for B's own noise
//! (MSE − mean Var\[ref], see `measure::errors`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::output::check_output_path;
use super::BadInput;
use crate::image::{check_samples, read_exr_rgb, write_exr, RgbImage};
use crate::measure::errors::{Against, ErrorAccumulator, Errors, RegionErrors};
use crate::measure::mask::lit_mask;
use crate::measure::metrics::compare;
use crate::measure::reference::read_reference_layers;
use crate::measure::report::write_json;

#[derive(Args, Debug)]
pub struct DiffArgs {
    /// The image to measure.
    pub image: PathBuf,
    /// The reference.
    pub reference: PathBuf,
    /// Also write |A − B| per pixel and channel as an EXR.
    #[arg(long = "image", value_name = "OUT")]
    pub error_image: Option<PathBuf>,
    /// Also write the figures as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// What `diff --json` writes.
#[derive(Serialize)]
struct DiffReport {
    mse: f64,
    relmse: f64,
    max_abs: f64,
    psnr: f64,
    errors: Errors,
}

pub fn run(args: &DiffArgs) -> anyhow::Result<()> {
    if let Some(out) = &args.error_image {
        check_output_path(out, "exr")?;
    }
    if let Some(out) = &args.json {
        check_output_path(out, "json")?;
    }
    let a = read_finite(&args.image)?;
    let reference = read_reference_layers(&args.reference).map_err(BadInput::from_error)?;
    let b = &reference.mean;
    let Some(e) = compare(&a, b) else {
        return Err(BadInput(format!(
            "{} is {}x{} but the reference {} is {}x{}",
            args.image.display(),
            a.width,
            a.height,
            args.reference.display(),
            b.width,
            b.height
        ))
        .into());
    };
    let lit = reference.surface.as_deref().map(lit_mask);
    let against = Against {
        mean: b,
        variance: reference.variance.as_ref(),
        lit: lit.as_deref(),
    };
    let mut acc = ErrorAccumulator::new(a.pixels.len());
    acc.add(&a, &against);
    let errors = acc.finish(&against);
    println!("mse      {:.6e}", e.mse);
    println!("relmse   {:.6e}", e.relmse);
    println!("max abs  {:.6e}", e.max_abs);
    println!("psnr     {:.3} dB (peak 1)", e.psnr);
    print_corrected("all", &errors.all);
    match (&errors.lit, &lit) {
        (Some(l), _) => {
            println!(
                "lit surface: {} of {} pixels (every primary ray hit a surface without emission)",
                l.pixels, errors.all.pixels
            );
            println!("lit mse      {:.6e}", l.mse);
            println!("lit relmse   {:.6e}", l.relmse);
            print_corrected("lit", l);
        }
        (None, Some(_)) => println!("lit surface: no pixel of the reference is lit surface"),
        (None, None) => println!(
            "lit surface: unknown (the reference has no surface channel; references written by \
             `manylights reference` carry one)"
        ),
    }
    if reference.variance.is_none() {
        println!("corrected: unknown (the reference has no variance layer)");
    }
    if let Some(out) = &args.json {
        let report = DiffReport {
            mse: e.mse,
            relmse: e.relmse,
            max_abs: e.max_abs,
            psnr: e.psnr,
            errors,
        };
        write_json(out, &report)?;
    }
    if let Some(out) = &args.error_image {
        let pixels = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(x, r)| [0, 1, 2].map(|c| (x[c] - r[c]).abs()))
            .collect();
        let diff = RgbImage {
            width: a.width,
            height: a.height,
            pixels,
        };
        write_exr(out, &diff, None).context("writing the difference image")?;
    }
    Ok(())
}

/// The reference-noise-corrected figures of one region with their 95% intervals.
fn print_corrected(region: &str, e: &RegionErrors) {
    let (Some(m), Some([mlo, mhi]), Some(r), Some([rlo, rhi])) = (
        e.mse_corrected,
        e.mse_corrected_interval,
        e.relmse_corrected,
        e.relmse_corrected_interval,
    ) else {
        return;
    };
    println!(
        "{region} mse-var[ref]     {m:.6e}  95% interval [{mlo:.6e}, {mhi:.6e}]  (mean Var[ref] {:.3e})",
        e.reference_variance.unwrap_or(f64::NAN)
    );
    println!("{region} relmse-var[ref]  {r:.6e}  95% interval [{rlo:.6e}, {rhi:.6e}]");
}

/// The mean layer of an EXR, refused (bad input, exit 3) when it cannot be read or holds a NaN
/// or infinite pixel: the renderer never writes one, and an error measured over it is NaN.
fn read_finite(path: &Path) -> anyhow::Result<RgbImage> {
    let (image, _) = read_exr_rgb(path).map_err(BadInput::from_error)?;
    check_samples(&image, path, "mean", "a finite value", f32::is_finite)
        .map_err(BadInput::from_error)?;
    Ok(image)
}
