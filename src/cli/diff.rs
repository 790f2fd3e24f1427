//! `manylights diff A.exr B.exr`: error of image A against reference B.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;

use crate::image::{read_exr_rgb, write_exr, RgbImage};
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
    let (a, _) = read_exr_rgb(&args.image)?;
    let (b, _) = read_exr_rgb(&args.reference)?;
    let Some(e) = compare(&a, &b) else {
        bail!(
            "{} is {}x{} but the reference {} is {}x{}",
            args.image.display(),
            a.width,
            a.height,
            args.reference.display(),
            b.width,
            b.height
        );
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
