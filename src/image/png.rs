//! 8-bit sRGB PNG previews of linear images.

use std::path::Path;

use anyhow::Context;

use super::{atomic::write_atomically, check_image, RgbImage};
use crate::color::linear_to_srgb8;

/// Writes an 8-bit sRGB PNG preview of a linear image: each channel is
/// multiplied by `2^exposure`, clamped to [0, 1] (NaN → 0; no other tone
/// curve, so values inside [0, 1] keep their exact meaning and exposure alone
/// brings highlights into range), encoded with the sRGB OETF and rounded.
/// The file is tagged sRGB. Written through [`write_atomically`].
pub fn write_png_preview(path: &Path, image: &RgbImage, exposure: f32) -> anyhow::Result<()> {
    check_image(image, "preview")?;
    let too_large = || format!("{}×{} is too large for PNG", image.width, image.height);
    let width = u32::try_from(image.width).with_context(too_large)?;
    let height = u32::try_from(image.height).with_context(too_large)?;
    let scale = exposure.exp2();
    let bytes: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|pixel| pixel.map(|c| linear_to_srgb8(c * scale)))
        .collect();
    write_rgb8(path, width, height, &bytes)
}

/// Writes 8-bit RGB bytes (row 0 at the top) as an sRGB-tagged PNG, atomically.
pub fn write_rgb8(path: &Path, width: u32, height: u32, bytes: &[u8]) -> anyhow::Result<()> {
    write_atomically(path, |out| {
        let mut encoder = png::Encoder::new(&mut *out, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().context("PNG header")?;
        writer.write_image_data(bytes).context("PNG data")?;
        writer.finish().context("PNG end")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::test_util::*;

    /// The sRGB OETF in f64, written out independently of `linear_to_srgb8`.
    fn expected_code(linear: f64) -> u8 {
        let x = linear.clamp(0.0, 1.0);
        let v = if x <= 0.0031308 {
            x * 12.92
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (255.0 * v + 0.5).floor() as u8
    }

    fn decode_png(path: &Path) -> (png::OutputInfo, Vec<u8>) {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buffer).unwrap();
        buffer.truncate(info.buffer_size());
        (info, buffer)
    }

    #[test]
    fn png_preview_has_known_codes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("preview.png");
        let image = RgbImage {
            width: 3,
            height: 2,
            pixels: vec![
                [0.0, 1.0, 0.5],
                [f32::NAN, -1.0, f32::INFINITY],
                [0.002, 0.0031308, 0.2],
                [2.0, 0.9, 1e-6],
                [0.25, 0.75, 0.1],
                [f32::NEG_INFINITY, 0.01, 0.4],
            ],
        };
        write_png_preview(&path, &image, 0.0).unwrap();
        let (info, bytes) = decode_png(&path);
        assert_eq!((info.width, info.height), (3, 2));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        assert_eq!(&bytes[..9], &[0, 255, 188, 0, 0, 255, 7, 10, 124]);
        let expected: Vec<u8> = image
            .pixels
            .iter()
            .flatten()
            .map(|&v| {
                if v.is_nan() {
                    0
                } else {
                    expected_code(f64::from(v))
                }
            })
            .collect();
        assert_eq!(bytes, expected);
        assert_eq!(entries(dir.path()), ["preview.png"]);
    }

    #[test]
    fn png_exposure_scales_by_power_of_two() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("exposed.png");
        let image = RgbImage {
            width: 1,
            height: 1,
            pixels: vec![[0.25, 0.125, 1.0]],
        };
        write_png_preview(&path, &image, 1.0).unwrap();
        let (_, bytes) = decode_png(&path);
        assert_eq!(bytes, [188, expected_code(0.25), 255]);
    }

    #[test]
    fn png_rejects_empty_image() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.png");
        let image = RgbImage {
            width: 0,
            height: 3,
            pixels: vec![],
        };
        assert!(write_png_preview(&path, &image, 0.0).is_err());
        assert!(entries(dir.path()).is_empty());
    }
}
