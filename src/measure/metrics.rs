//! Image error metrics against a reference, accumulated in f64 over all pixels and channels:
//!     MSE    = mean (x − r)²
//!     relMSE = mean (x − r)² / (r² + 1e-2)   (the 1e-2 keeps dark pixels from dominating)
//!     max abs error, and PSNR = 10·log10(1 / MSE) for a peak of 1 (display-referred white).

use serde::Serialize;

use crate::image::RgbImage;

/// Offset in the relative MSE's denominator.
pub const REL_MSE_EPSILON: f64 = 1e-2;

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImageError {
    pub mse: f64,
    pub relmse: f64,
    pub max_abs: f64,
    pub psnr: f64,
}

/// Errors of `image` against `reference`; None when their sizes differ.
pub fn compare(image: &RgbImage, reference: &RgbImage) -> Option<ImageError> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return None;
    }
    let (mut se, mut rel, mut max_abs) = (0.0f64, 0.0f64, 0.0f64);
    for (x, r) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (x, r) = (x[c] as f64, r[c] as f64);
            let d2 = (x - r) * (x - r);
            se += d2;
            rel += d2 / (r * r + REL_MSE_EPSILON);
            max_abs = max_abs.max((x - r).abs());
        }
    }
    let count = (3 * image.pixels.len()).max(1) as f64;
    let mse = se / count;
    Some(ImageError {
        mse,
        relmse: rel / count,
        max_abs,
        psnr: -10.0 * mse.log10(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_match_hand_computed_values() {
        let reference = RgbImage::row(vec![[1.0, 0.0, 0.5], [0.0, 0.0, 0.0]]);
        let test = RgbImage::row(vec![[1.5, 0.0, 0.5], [0.0, 0.1, 0.0]]);
        let e = compare(&test, &reference).unwrap();
        // Squared errors 0.25 and 0.01 over 6 values.
        assert!((e.mse - 0.26 / 6.0).abs() < 1e-7);
        // relMSE: 0.25/(1 + 0.01) + 0.01/(0 + 0.01) over 6.
        assert!((e.relmse - (0.25 / 1.01 + 1.0) / 6.0).abs() < 1e-7);
        assert!((e.max_abs - 0.5).abs() < 1e-7);
        assert!((e.psnr - (-10.0 * (0.26f64 / 6.0).log10())).abs() < 1e-5);
        assert!(compare(&test, &RgbImage::row(vec![[0.0; 3]])).is_none());
        assert_eq!(compare(&reference, &reference).unwrap().mse, 0.0);
    }
}
