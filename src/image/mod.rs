//! Image output: atomic file replacement, OpenEXR (float32 mean and optional per-pixel
//! variance) and 8-bit sRGB PNG previews.
//!
//! Every file is first written to a temporary file next to its target and renamed over it only
//! when complete, so a reader never sees a half-written image and a failed write leaves the
//! previous file untouched.

mod atomic;
mod exr;
mod png;

pub use self::atomic::write_atomically;
pub use self::exr::{read_exr_layers, read_exr_rgb, write_exr, write_exr_with_surface, ExrLayers};
pub use self::png::{write_png_preview, write_rgb8};

use std::path::Path;

use anyhow::{bail, ensure};

/// Linear RGB image, row-major with row 0 at the top:
/// pixel (x, y) is `pixels[y * width + x]`.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    /// Pixels per row.
    pub width: usize,
    /// Number of rows.
    pub height: usize,
    /// `width · height` pixels, `[R, G, B]` each.
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// A one-row image of `pixels` (test fixtures).
    #[cfg(test)]
    pub(crate) fn row(pixels: Vec<[f32; 3]>) -> RgbImage {
        RgbImage {
            width: pixels.len(),
            height: 1,
            pixels,
        }
    }
}

/// Checks `pixels.len() == width · height` and a non-empty size.
pub(crate) fn check_image(image: &RgbImage, what: &str) -> anyhow::Result<()> {
    ensure!(
        image.width > 0 && image.height > 0,
        "{what} image is empty ({}×{})",
        image.width,
        image.height
    );
    let expected = image.width.checked_mul(image.height);
    ensure!(
        expected == Some(image.pixels.len()),
        "{what} image is {}×{} but has {} pixels",
        image.width,
        image.height,
        image.pixels.len()
    );
    Ok(())
}

/// Fails, naming the file, the layer, the pixel (x, y from the top left), the channel and the
/// value, at the first sample of `image` that is not `valid`; `rule` says what valid means.
pub fn check_samples(
    image: &RgbImage,
    path: &Path,
    layer: &str,
    rule: &str,
    valid: impl Fn(f32) -> bool,
) -> anyhow::Result<()> {
    let bad = image.pixels.iter().enumerate().find_map(|(i, p)| {
        let c = p.iter().position(|&v| !valid(v))?;
        Some((i % image.width.max(1), i / image.width.max(1), c, p[c]))
    });
    if let Some((x, y, c, value)) = bad {
        bail!(
            "{}: {layer} pixel ({x}, {y}) channel {} is {value}, expected {rule}",
            path.display(),
            ["R", "G", "B"][c]
        );
    }
    Ok(())
}

#[cfg(test)]
mod test_util {
    use super::RgbImage;
    use rand_core::{Rng, SeedableRng};
    use rand_pcg::Pcg64;
    use std::path::Path;

    /// Image of noisy positive floats (all 32 bits vary), as a render has.
    pub fn noisy_image(width: usize, height: usize, seed: u64) -> RgbImage {
        let mut rng = Pcg64::seed_from_u64(seed);
        let mut value = || (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32 * 4.0;
        let pixels = (0..width * height)
            .map(|_| [value(), value(), value()])
            .collect();
        RgbImage {
            width,
            height,
            pixels,
        }
    }

    /// Names of all entries of `folder`, sorted.
    pub fn entries(folder: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(folder)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}
