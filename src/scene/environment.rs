//! The environment map as the scene holds it: the radiance texels of an equirectangular
//! (latitude-longitude) RGB image, scaled, and its rotation about +Y. Plain data: the light
//! built from it, with its sampling distribution, is `lights::EnvironmentMap`.
//!
//! Convention (glTF's +Y up): texel (i, j) of a W×H map covers u = φ/2π ∈ [i/W, (i+1)/W) and
//! v = θ/π ∈ [j/H, (j+1)/H), with θ the angle from +Y (row 0 is the zenith) and the map's
//! direction d(θ, φ) = (−sinθ·sinφ, cosθ, sinθ·cosφ): u = 0 looks along +Z, u = 1/4 along −X,
//! the image centre u = 1/2 along −Z (where a default glTF camera looks), u = 3/4 along +X, so
//! the image reads left to right as a viewer inside the sphere turns right. `--env-rotate α`
//! turns the map by α about +Y (counter-clockwise seen from above): world = R_y(α)·d.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::image::{read_exr_rgb, RgbImage};

/// An environment map that cannot be used, naming its file.
#[derive(Debug, thiserror::Error)]
#[error("environment map {}: {message}", path.display())]
pub struct EnvironmentError {
    pub path: PathBuf,
    pub message: String,
}

/// A validated environment image: at least one texel, every texel finite and non-negative,
/// the rotation finite.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentImage {
    width: usize,
    height: usize,
    /// Radiance × scale, row-major, row 0 at the zenith.
    texels: Vec<Vec3>,
    /// The turn about +Y, in degrees.
    rotation_degrees: f32,
}

impl EnvironmentImage {
    /// Reads an RGB OpenEXR file (channels R, G, B; f16, f32 or u32 samples), multiplies its
    /// radiance by `scale` and turns it by `rotate_degrees` about +Y.
    pub fn load(
        path: &Path,
        scale: f32,
        rotate_degrees: f32,
    ) -> Result<EnvironmentImage, EnvironmentError> {
        let error = |message: String| EnvironmentError {
            path: path.into(),
            message,
        };
        let (image, _) = read_exr_rgb(path).map_err(|e| error(format!("{e:#}")))?;
        EnvironmentImage::from_rgb(&image, scale, rotate_degrees).map_err(error)
    }

    /// From an image of radiance: every texel finite and non-negative, scale finite and
    /// non-negative, the rotation finite.
    pub fn from_rgb(
        image: &RgbImage,
        scale: f32,
        rotate_degrees: f32,
    ) -> Result<EnvironmentImage, String> {
        let (width, height) = (image.width, image.height);
        if width == 0 || height == 0 || image.pixels.len() != width * height {
            return Err(format!(
                "image is {width}×{height} with {} texels",
                image.pixels.len()
            ));
        }
        if !(scale.is_finite() && scale >= 0.0 && rotate_degrees.is_finite()) {
            return Err(format!(
                "scale {scale} and rotation {rotate_degrees}° must be finite, the scale ≥ 0"
            ));
        }
        let mut texels = Vec::with_capacity(image.pixels.len());
        for (k, p) in image.pixels.iter().enumerate() {
            let l = Vec3::from_array(*p);
            if !l.is_finite() || l.min_element() < 0.0 {
                return Err(format!(
                    "texel ({}, {}) is {p:?}: radiance must be finite and non-negative",
                    k % width,
                    k / width
                ));
            }
            texels.push(l * scale);
        }
        Ok(EnvironmentImage {
            width,
            height,
            texels,
            rotation_degrees: rotate_degrees,
        })
    }

    /// Texels per row (W, along φ).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows (H, along θ).
    pub fn height(&self) -> usize {
        self.height
    }

    /// The scaled radiance of every texel, row-major, row 0 at the zenith.
    pub fn texels(&self) -> &[Vec3] {
        &self.texels
    }

    /// The turn α about +Y, in degrees (world = R_y(α)·d).
    pub fn rotation_degrees(&self) -> f32 {
        self.rotation_degrees
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_maps_are_refused_with_the_texel_named() {
        let image = |pixels: Vec<[f32; 3]>| RgbImage {
            width: 2,
            height: 1,
            pixels,
        };
        let e = EnvironmentImage::from_rgb(&image(vec![[1.0; 3], [f32::NAN, 0.0, 0.0]]), 1.0, 0.0)
            .unwrap_err();
        assert!(e.contains("texel (1, 0)"), "{e}");
        let e = EnvironmentImage::from_rgb(&image(vec![[-1.0, 0.0, 0.0], [1.0; 3]]), 1.0, 0.0)
            .unwrap_err();
        assert!(e.contains("texel (0, 0)"), "{e}");
        let empty = RgbImage {
            width: 0,
            height: 0,
            pixels: vec![],
        };
        assert!(EnvironmentImage::from_rgb(&empty, 1.0, 0.0).is_err());
        let one = image(vec![[1.0; 3], [2.0; 3]]);
        assert!(EnvironmentImage::from_rgb(&one, -1.0, 0.0).is_err());
        assert!(EnvironmentImage::from_rgb(&one, 1.0, f32::INFINITY).is_err());
        let scaled = EnvironmentImage::from_rgb(&one, 0.5, 10.0).unwrap();
        assert_eq!(scaled.texels(), &[Vec3::splat(0.5), Vec3::ONE]);
        assert_eq!(scaled.rotation_degrees(), 10.0);
    }
}
