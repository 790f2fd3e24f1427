//! `manylights diff A.exr B.exr`: error of image A against reference B.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;

use super::output::check_output_path;
use super::BadInput;
use crate::image::{check_samples, read_exr_rgb, write_exr, RgbImage};
use crate::measure::metrics::compare;

#[derive(Args, Debug)]
pub struct DiffArgs {
    /// The image to measure.
    pub image: PathBuf,
    /// The reference.
    pub reference: PathBuf,
    /// Also write |A − B| per pixel and channel as an EXR.
    #[arg(long = "image", value_name = "OUT")]
    pub error_image: Option<PathBuf>,
}

pub fn run(args: &DiffArgs) -> anyhow::Result<()> {
    if let Some(out) = &args.error_image {
        check_output_path(out, "exr")?;
    }
    let a = read_finite(&args.image)?;
    let b = read_finite(&args.reference)?;
    let Some(e) = compare(&a, &b) else {
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
    println!("mse      {:.6e}", e.mse);
    println!("relmse   {:.6e}", e.relmse);
    println!("max abs  {:.6e}", e.max_abs);
    println!("psnr     {:.3} dB (peak 1)", e.psnr);
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

/// The mean layer of an EXR, refused (bad input, exit 3) when it cannot be read or holds a NaN
/// or infinite pixel: the renderer never writes one, and an error measured over it is NaN.
fn read_finite(path: &Path) -> anyhow::Result<RgbImage> {
    let (image, _) = read_exr_rgb(path).map_err(BadInput::from_error)?;
    check_samples(&image, path, "mean", "a finite value", f32::is_finite)
        .map_err(BadInput::from_error)?;
    Ok(image)
}
