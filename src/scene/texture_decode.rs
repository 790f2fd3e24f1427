//! Decoding PNG and JPEG images into linear RGB texels, once, at load.
//!
//! glTF stores base colour and emission sRGB-encoded, so every channel is decoded with the sRGB
//! transfer function (IEC 61966-2-1); a PNG's own gAMA/iCCP chunks are ignored, as glTF
//! specifies. Alpha is dropped (alpha modes are not modelled); grey images give grey RGB. The
//! format is recognised by its signature bytes, not by the file name or MIME type.

use glam::Vec3;

use crate::color::srgb_to_linear;

/// Images with more texels than this (8192², 768 MiB as linear f32 RGB) are refused before
/// anything is allocated.
pub const MAX_TEXELS: u64 = 1 << 26;

/// Deflate cannot expand data by more than 1032:1 (RFC 1951: a 258-byte match costs at least
/// 2 bits), so a PNG whose declared pixels need more than this many bytes per file byte is lying
/// about its size and is refused before its buffer is allocated.
const PNG_MAX_EXPANSION: u64 = 1032;

/// Width, height and row-major linear RGB texels of a PNG or JPEG image.
#[derive(Debug)]
pub struct DecodedImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec3>,
}

/// Decodes a PNG or JPEG image; the error says what is wrong with it.
pub fn decode_image(bytes: &[u8]) -> Result<DecodedImage, String> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        decode_png(bytes)
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        decode_jpeg(bytes)
    } else {
        let head: Vec<String> = bytes.iter().take(8).map(|b| format!("{b:02x}")).collect();
        Err(format!(
            "is neither PNG nor JPEG (first bytes: {})",
            if head.is_empty() {
                "none, it is empty".into()
            } else {
                head.join(" ")
            }
        ))
    }
}

fn check_size(width: u64, height: u64) -> Result<(), String> {
    if width == 0 || height == 0 || width * height > MAX_TEXELS {
        return Err(format!(
            "is {width}×{height} texels (at most {MAX_TEXELS} texels and no empty side)"
        ));
    }
    Ok(())
}

fn decode_png(bytes: &[u8]) -> Result<DecodedImage, String> {
    let bad = |e: png::DecodingError| format!("is not a valid PNG: {e}");
    let mut decoder = png::Decoder::new_with_limits(
        std::io::Cursor::new(bytes),
        png::Limits {
            // 16-bit RGBA is the largest decoded form: 8 bytes per texel.
            bytes: (MAX_TEXELS * 8) as usize,
        },
    );
    // Palette and sub-byte grey images become 8-bit; 16-bit samples stay 16-bit.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(bad)?;
    let (width, height) = reader.info().size();
    check_size(width as u64, height as u64)?;
    let size = reader
        .output_buffer_size()
        .ok_or("is too large to decode")?;
    if size as u64 > PNG_MAX_EXPANSION * bytes.len() as u64 + 4096 {
        return Err(format!(
            "declares {width}×{height} texels ({size} bytes decoded) but holds only {} bytes, \
             more than deflate can expand",
            bytes.len()
        ));
    }
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(bad)?;
    let channels = frame.color_type.samples();
    let texels = match frame.bit_depth {
        png::BitDepth::Eight => {
            let table: Vec<f32> = (0..=255u8)
                .map(|v| srgb_to_linear(v as f32 / 255.0))
                .collect();
            texels_from(&buf[..frame.buffer_size()], channels, 1, |s| {
                table[s[0] as usize]
            })
        }
        png::BitDepth::Sixteen => texels_from(&buf[..frame.buffer_size()], channels, 2, |s| {
            srgb_to_linear(u16::from_be_bytes([s[0], s[1]]) as f32 / 65535.0)
        }),
        depth => {
            return Err(format!(
                "has an unexpected bit depth {depth:?} after expansion"
            ))
        }
    };
    Ok(DecodedImage {
        width,
        height,
        texels,
    })
}

fn decode_jpeg(bytes: &[u8]) -> Result<DecodedImage, String> {
    use zune_core::bytestream::ZCursor;
    use zune_core::colorspace::ColorSpace;
    use zune_core::options::DecoderOptions;
    let bad = |e: zune_jpeg::errors::DecodeErrors| format!("is not a valid JPEG: {e}");
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
        .set_max_width(1 << 16)
        .set_max_height(1 << 16);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder.decode_headers().map_err(bad)?;
    let (width, height) = decoder.dimensions().ok_or("has no frame header")?;
    check_size(width as u64, height as u64)?;
    let pixels = decoder.decode().map_err(bad)?;
    let table: Vec<f32> = (0..=255u8)
        .map(|v| srgb_to_linear(v as f32 / 255.0))
        .collect();
    let texels = texels_from(&pixels, 3, 1, |s| table[s[0] as usize]);
    if texels.len() != width * height {
        return Err(format!(
            "decoded to {} texels instead of {width}×{height}",
            texels.len()
        ));
    }
    Ok(DecodedImage {
        width: width as u32,
        height: height as u32,
        texels,
    })
}

/// Texels from interleaved samples of `channels` channels (1–2: grey, 3–4: RGB; a trailing
/// alpha is skipped), each `bytes` wide and decoded by `linear`.
fn texels_from(
    data: &[u8],
    channels: usize,
    bytes: usize,
    linear: impl Fn(&[u8]) -> f32,
) -> Vec<Vec3> {
    data.chunks_exact(channels * bytes)
        .map(|px| {
            let c = |k: usize| linear(&px[k * bytes..(k + 1) * bytes]);
            if channels >= 3 {
                Vec3::new(c(0), c(1), c(2))
            } else {
                Vec3::splat(c(0))
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png_bytes(
        width: u32,
        height: u32,
        color: png::ColorType,
        depth: png::BitDepth,
        data: &[u8],
    ) -> Vec<u8> {
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, width, height);
        encoder.set_color(color);
        encoder.set_depth(depth);
        encoder
            .write_header()
            .unwrap()
            .write_image_data(data)
            .unwrap();
        out
    }

    /// IEC 61966-2-1 written out in f64, independently of `srgb_to_linear`.
    fn srgb_reference(code: f64, max: f64) -> f64 {
        let c = code / max;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    }

    #[test]
    fn srgb_decode_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        for code in 0..=255 {
            let got = srgb_to_linear(code as f32 / 255.0) as f64;
            assert!(
                (got - srgb_reference(code as f64, 255.0)).abs() < 1e-6,
                "code {code}"
            );
        }
        // Continuous at the junction of the linear and power segments.
        let (a, b) = (srgb_to_linear(0.04045), srgb_to_linear(0.04046));
        assert!(b > a && b - a < 1e-5);
    }

    #[test]
    fn png_rgb8_grey_alpha8_and_rgba16_decode_to_linear_rgb() {
        let rgb = png_bytes(
            2,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            &[0, 10, 128, 255, 200, 1],
        );
        let img = decode_image(&rgb).unwrap();
        assert_eq!((img.width, img.height), (2, 1));
        let codes = [0.0, 10.0, 128.0, 255.0, 200.0, 1.0];
        for (k, code) in codes.iter().enumerate() {
            let got = img.texels[k / 3][k % 3] as f64;
            assert!((got - srgb_reference(*code, 255.0)).abs() < 1e-6);
        }

        let grey_alpha = png_bytes(
            1,
            2,
            png::ColorType::GrayscaleAlpha,
            png::BitDepth::Eight,
            &[64, 0, 255, 7],
        );
        let img = decode_image(&grey_alpha).unwrap();
        assert_eq!(img.texels.len(), 2);
        assert!((img.texels[0].y as f64 - srgb_reference(64.0, 255.0)).abs() < 1e-6);
        assert_eq!(img.texels[0].x, img.texels[0].z);
        assert!((img.texels[1].x - 1.0).abs() < 1e-6);

        let codes16 = [0u16, 1000, 30000, 65535];
        let data: Vec<u8> = codes16.iter().flat_map(|c| c.to_be_bytes()).collect();
        let img = decode_image(&png_bytes(
            1,
            1,
            png::ColorType::Rgba,
            png::BitDepth::Sixteen,
            &data,
        ))
        .unwrap();
        for (k, code) in codes16.iter().take(3).enumerate() {
            let expected = srgb_reference(*code as f64, 65535.0);
            assert!(
                (img.texels[0][k] as f64 - expected).abs() < 1e-6,
                "channel {k}"
            );
        }
    }

    #[test]
    fn png_palette_is_expanded() {
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, 2, 1);
        encoder.set_color(png::ColorType::Indexed);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_palette(vec![255, 0, 0, 0, 0, 255]);
        encoder
            .write_header()
            .unwrap()
            .write_image_data(&[1, 0])
            .unwrap();
        let img = decode_image(&out).unwrap();
        assert!((img.texels[0] - Vec3::Z).abs().max_element() < 1e-6);
        assert!((img.texels[1] - Vec3::X).abs().max_element() < 1e-6);
    }

    #[test]
    fn jpeg_of_a_constant_colour_decodes_to_it() {
        // Quality 100 keeps a flat 16×16 block within a code value or two.
        let (w, h) = (16u16, 16u16);
        let colour = [200u8, 120, 40];
        let data: Vec<u8> = (0..w as usize * h as usize).flat_map(|_| colour).collect();
        let mut bytes = Vec::new();
        jpeg_encoder::Encoder::new(&mut bytes, 100)
            .encode(&data, w, h, jpeg_encoder::ColorType::Rgb)
            .unwrap();
        let img = decode_image(&bytes).unwrap();
        assert_eq!((img.width, img.height), (16, 16));
        for t in &img.texels {
            for k in 0..3 {
                let lo = srgb_reference(colour[k] as f64 - 2.5, 255.0);
                let hi = srgb_reference(colour[k] as f64 + 2.5, 255.0);
                assert!((lo..=hi).contains(&(t[k] as f64)), "channel {k}: {}", t[k]);
            }
        }
    }

    #[test]
    fn bad_images_are_errors_not_panics_or_huge_allocations() {
        assert!(decode_image(b"")
            .unwrap_err()
            .contains("neither PNG nor JPEG"));
        assert!(decode_image(b"GIF89a....")
            .unwrap_err()
            .contains("47 49 46"));
        let good = png_bytes(2, 2, png::ColorType::Rgb, png::BitDepth::Eight, &[9; 12]);
        for cut in [8, 20, 33, good.len() - 13] {
            let err = decode_image(&good[..cut]).unwrap_err();
            assert!(err.contains("PNG"), "{cut}: {err}");
        }
        assert!(decode_image(&[0xFF, 0xD8, 0xFF, 0xE0, 0, 16])
            .unwrap_err()
            .contains("JPEG"));
        // A valid IHDR and a 2-byte IDAT: all a decoder reads before allocating its output.
        let header_only = |side: u32| {
            let mut ihdr = b"IHDR".to_vec();
            ihdr.extend(side.to_be_bytes());
            ihdr.extend(side.to_be_bytes());
            ihdr.extend([8, 2, 0, 0, 0]);
            let idat = b"IDAT\x78\x9c".to_vec();
            let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
            for (length, chunk) in [(13u32, &ihdr), (2, &idat)] {
                png.extend(length.to_be_bytes());
                png.extend(chunk);
                png.extend(crc32fast::hash(chunk).to_be_bytes());
            }
            png
        };
        // 65536 × 65536 texels (2^32): refused from the header alone.
        let err = decode_image(&header_only(65536)).unwrap_err();
        assert!(err.contains("65536×65536"), "{err}");
        // 8192 × 8192 (allowed by MAX_TEXELS, 192 MiB decoded) in a 47-byte file: refused
        // before the output buffer is allocated.
        let err = decode_image(&header_only(8192)).unwrap_err();
        assert!(err.contains("more than deflate can expand"), "{err}");
    }
}
