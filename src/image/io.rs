//! Image output: atomic file replacement, OpenEXR (float32 mean and optional
//! per-pixel variance) and 8-bit sRGB PNG previews.
//!
//! Every file is first written to a temporary file next to its target and
//! renamed over it only when complete, so a reader never sees a half-written
//! image and a failed write leaves the previous file untouched.

use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::{Context, bail, ensure};
use exr::prelude::{
    AnyChannel, AnyChannels, Compression, Encoding, FlatSamples, Image, Layer, LayerAttributes,
    LineOrder, ReadChannels, ReadLayers, SmallVec, WritableImage, read,
};

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

/// EXR encoding: ZIP over 1 scan line per block (OpenEXR's "ZIPS").
///
/// Lossless and measured the best trade-off for float32 render output with
/// Monte Carlo noise (see the report accompanying this file): RLE and
/// uncompressed are about as fast to write but barely shrink noisy floats,
/// while ZIP16 and PIZ cost more time for little further gain. Increasing line
/// order makes the chunk order, and thus the bytes, deterministic.
const EXR_ENCODING: Encoding = Encoding {
    compression: Compression::ZIP1,
    blocks: exr::image::Blocks::ScanLines,
    line_order: LineOrder::Increasing,
};

/// Channel names of the mean, in R, G, B order.
const MEAN_CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Channel names of the variance, in R, G, B order. The `layer.channel`
/// naming is the single-part convention that OpenEXR tools, Blender and tev
/// all show as a separate "variance" layer next to the RGB default layer.
const VARIANCE_CHANNELS: [&str; 3] = ["variance.R", "variance.G", "variance.B"];

/// Distinguishes temporary files of concurrent writes within one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: `write` fills a temporary file
/// `.{file_name}.tmp-{pid}-{counter}` in the same folder, which is then
/// flushed, fsynced and renamed over `path`.
///
/// On any error (or a panic in `write`) the temporary file is removed and
/// `path` is untouched. The folder must exist. If `path` is a symbolic link,
/// the link itself is replaced by the new file.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let file_name = path
        .file_name()
        .with_context(|| format!("{} does not name a file", path.display()))?;
    let folder = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    check_folder(folder)?;
    let temp_path = folder.join(format!(
        ".{}.tmp-{}-{}",
        file_name.to_string_lossy(),
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp_path)
        .with_context(|| format!("cannot create {}", temp_path.display()))?;
    let mut temp = TempFile {
        path: temp_path,
        keep: false,
    };
    let temp_path = temp.path.clone();

    let mut writer = BufWriter::new(file);
    write(&mut writer).with_context(|| format!("cannot write {}", path.display()))?;
    let file = writer
        .into_inner()
        .map_err(|e| e.into_error())
        .with_context(|| format!("cannot write {}", temp_path.display()))?;
    file.sync_all()
        .with_context(|| format!("cannot sync {}", temp_path.display()))?;
    drop(file);
    fs::rename(&temp_path, path).with_context(|| {
        format!(
            "cannot rename {} to {}",
            temp_path.display(),
            path.display()
        )
    })?;
    temp.keep = true;
    sync_folder(folder);
    Ok(())
}

/// Fails with a clear message unless `folder` is an existing directory.
fn check_folder(folder: &Path) -> anyhow::Result<()> {
    match fs::metadata(folder) {
        Ok(meta) if meta.is_dir() => Ok(()),
        Ok(_) => bail!("{} is not a folder", folder.display()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("folder {} does not exist", folder.display())
        }
        Err(e) => Err(e).with_context(|| format!("cannot access folder {}", folder.display())),
    }
}

/// Makes the rename durable by fsyncing the folder (Unix). Best effort: the
/// new file is already complete and in place, and some file systems refuse to
/// sync a directory, so a failure here is not reported.
fn sync_folder(folder: &Path) {
    #[cfg(unix)]
    if let Ok(dir) = File::open(folder) {
        let _ = dir.sync_all();
    }
    #[cfg(not(unix))]
    let _ = folder;
}

/// A temporary file that is removed when dropped, unless `keep` was set
/// because it has been renamed to its target.
struct TempFile {
    path: PathBuf,
    keep: bool,
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if !self.keep {
            // Nothing better to do if removal fails while handling an error.
            let _ = fs::remove_file(&self.path);
        }
    }
}

/// Checks `pixels.len() == width · height` and a non-empty size.
fn check_image(image: &RgbImage, what: &str) -> anyhow::Result<()> {
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

/// The three channels of `image` under `names` (R, G, B order).
fn rgb_channels(image: &RgbImage, names: [&str; 3]) -> [AnyChannel<FlatSamples>; 3] {
    [0, 1, 2].map(|c| {
        let samples = image.pixels.iter().map(|p| p[c]).collect();
        AnyChannel::new(names[c], FlatSamples::F32(samples))
    })
}

/// Writes an OpenEXR file with float32 channels `R`, `G`, `B` from `mean` and,
/// if given, `variance.R`, `variance.G`, `variance.B` from `variance`, all in
/// one single-part layer, ZIP-compressed per scan line. Equal inputs give
/// byte-identical files. Written through [`write_atomically`].
pub fn write_exr(
    path: &Path,
    mean: &RgbImage,
    variance: Option<&RgbImage>,
) -> anyhow::Result<()> {
    check_image(mean, "mean")?;
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> =
        rgb_channels(mean, MEAN_CHANNELS).into_iter().collect();
    if let Some(variance) = variance {
        check_image(variance, "variance")?;
        ensure!(
            (variance.width, variance.height) == (mean.width, mean.height),
            "variance image is {}×{} but mean image is {}×{}",
            variance.width,
            variance.height,
            mean.width,
            mean.height
        );
        channels.extend(rgb_channels(variance, VARIANCE_CHANNELS));
    }
    let layer = Layer::new(
        (mean.width, mean.height),
        LayerAttributes::default(),
        EXR_ENCODING,
        AnyChannels::sort(channels),
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |out| {
        image
            .write()
            .to_buffered(out)
            .context("OpenEXR encoding failed")
    })
}

/// Reads the first layer of an OpenEXR file: the `R`, `G`, `B` channels as the
/// mean and, if all three are present, `variance.R`, `variance.G`,
/// `variance.B` as the variance. Samples stored as f16 or u32 are converted to
/// f32. Fails, naming the file, if it is not OpenEXR or lacks R, G or B.
pub fn read_exr_rgb(path: &Path) -> anyhow::Result<(RgbImage, Option<RgbImage>)> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .with_context(|| format!("cannot read {} as OpenEXR", path.display()))?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let channels = &layer.channel_data.list;
    let find = |name: &str| channels.iter().find(|c| c.name == *name);
    let gather = |names: [&str; 3]| -> anyhow::Result<RgbImage> {
        let mut pixels = vec![[0.0f32; 3]; width * height];
        for (c, name) in names.into_iter().enumerate() {
            let channel = find(name)
                .with_context(|| format!("{} has no channel {name}", path.display()))?;
            ensure!(
                channel.sample_data.len() == pixels.len(),
                "{}: channel {name} has {} samples for {width}×{height} pixels",
                path.display(),
                channel.sample_data.len()
            );
            for (pixel, value) in pixels.iter_mut().zip(channel.sample_data.values_as_f32()) {
                pixel[c] = value;
            }
        }
        Ok(RgbImage {
            width,
            height,
            pixels,
        })
    };
    let mean = gather(MEAN_CHANNELS)?;
    let has_variance = VARIANCE_CHANNELS.iter().any(|name| find(name).is_some());
    let variance = if has_variance {
        Some(gather(VARIANCE_CHANNELS)?)
    } else {
        None
    };
    Ok((mean, variance))
}

/// Maps a linear value to an 8-bit sRGB code:
/// `x = clamp(linear, 0, 1)` (NaN → 0), then the sRGB OETF
/// `12.92·x` for `x ≤ 0.0031308`, else `1.055·x^(1/2.4) − 0.055`,
/// then `round(255·v)`.
fn srgb8(linear: f32) -> u8 {
    let x = if linear.is_nan() {
        0.0
    } else {
        f64::from(linear.clamp(0.0, 1.0))
    };
    let v = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    // v ∈ [0, 1], so the rounded value fits in u8.
    (v * 255.0).round() as u8
}

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
        .flat_map(|pixel| pixel.map(|c| srgb8(c * scale)))
        .collect();
    write_atomically(path, |out| {
        let mut encoder = png::Encoder::new(&mut *out, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().context("PNG header")?;
        writer.write_image_data(&bytes).context("PNG data")?;
        writer.finish().context("PNG end")?;
        out.flush().context("flush")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// Image of noisy positive floats (all 32 bits vary), as a render has.
    fn noisy_image(width: usize, height: usize, seed: u64) -> RgbImage {
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
    fn entries(folder: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(folder)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("render.exr");
        let mut mean = noisy_image(37, 23, 1);
        mean.pixels[0] = [f32::NAN, f32::INFINITY, -0.0];
        mean.pixels[1] = [f32::MIN_POSITIVE / 8.0, f32::MAX, -1e-30];
        let variance = noisy_image(37, 23, 2);
        write_exr(&path, &mean, Some(&variance)).unwrap();
        let (read_mean, read_variance) = read_exr_rgb(&path).unwrap();
        let bits = |img: &RgbImage| -> Vec<u32> {
            img.pixels.iter().flatten().map(|v| v.to_bits()).collect()
        };
        assert_eq!((read_mean.width, read_mean.height), (37, 23));
        assert_eq!(bits(&read_mean), bits(&mean));
        let read_variance = read_variance.expect("variance channels");
        assert_eq!((read_variance.width, read_variance.height), (37, 23));
        assert_eq!(bits(&read_variance), bits(&variance));
        assert_eq!(entries(dir.path()), ["render.exr"]);
    }

    #[test]
    fn exr_without_variance_reads_none() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mean.exr");
        let mean = noisy_image(8, 5, 3);
        write_exr(&path, &mean, None).unwrap();
        let (read_mean, variance) = read_exr_rgb(&path).unwrap();
        assert_eq!(read_mean, mean);
        assert!(variance.is_none());
    }

    #[test]
    fn exr_bytes_are_deterministic() {
        let dir = tempfile::tempdir().unwrap();
        let mean = noisy_image(300, 200, 4);
        let variance = noisy_image(300, 200, 5);
        let a = dir.path().join("a.exr");
        let b = dir.path().join("b.exr");
        write_exr(&a, &mean, Some(&variance)).unwrap();
        write_exr(&b, &mean, Some(&variance)).unwrap();
        assert!(fs::read(&a).unwrap() == fs::read(&b).unwrap());
    }

    #[test]
    fn exr_rejects_mismatched_sizes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.exr");
        let mean = noisy_image(4, 4, 6);
        let variance = noisy_image(4, 3, 7);
        let error = write_exr(&path, &mean, Some(&variance)).unwrap_err();
        assert!(format!("{error:#}").contains("4×3"), "{error:#}");
        let mut short = mean.clone();
        short.pixels.pop();
        assert!(write_exr(&path, &short, None).is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn reading_a_non_exr_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("not-an-image.exr");
        fs::write(&path, b"hello").unwrap();
        let error = format!("{:#}", read_exr_rgb(&path).unwrap_err());
        assert!(error.contains(&path.display().to_string()), "{error}");
        let missing = dir.path().join("missing.exr");
        let error = format!("{:#}", read_exr_rgb(&missing).unwrap_err());
        assert!(error.contains("missing.exr"), "{error}");
    }

    #[test]
    fn reading_an_exr_without_rgb_names_the_file_and_channel() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("luma.exr");
        let luma = AnyChannel::new("Y", FlatSamples::F32(vec![0.5; 6]));
        let layer = Layer::new(
            (3, 2),
            LayerAttributes::default(),
            EXR_ENCODING,
            AnyChannels::sort(std::iter::once(luma).collect()),
        );
        Image::from_layer(layer).write().to_file(&path).unwrap();
        let error = format!("{:#}", read_exr_rgb(&path).unwrap_err());
        assert!(error.contains("luma.exr") && error.contains("channel R"), "{error}");
    }

    #[test]
    fn missing_folder_is_an_error_naming_it_and_creates_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join("nope");
        let path = folder.join("out.exr");
        let image = noisy_image(4, 4, 8);
        let error = format!("{:#}", write_exr(&path, &image, None).unwrap_err());
        assert!(error.contains("does not exist"), "{error}");
        assert!(error.contains(&folder.display().to_string()), "{error}");
        let error = format!("{:#}", write_png_preview(&path, &image, 0.0).unwrap_err());
        assert!(error.contains(&folder.display().to_string()), "{error}");
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn failing_writer_keeps_old_target_and_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("result.txt");
        fs::write(&path, b"old").unwrap();
        let error = write_atomically(&path, |out| {
            out.write_all(&[b'x'; 100_000])?;
            bail!("simulated failure")
        })
        .unwrap_err();
        let message = format!("{error:#}");
        assert!(message.contains("simulated failure"), "{message}");
        assert!(message.contains("result.txt"), "{message}");
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(dir.path()), ["result.txt"]);

        let fresh = dir.path().join("fresh.txt");
        assert!(write_atomically(&fresh, |_| bail!("no")).is_err());
        assert_eq!(entries(dir.path()), ["result.txt"]);
    }

    #[test]
    fn panicking_writer_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("result.txt");
        let outcome = std::panic::catch_unwind(|| write_atomically(&path, |_| panic!("boom")));
        assert!(outcome.is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn successful_write_replaces_target() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("result.txt");
        fs::write(&path, b"old").unwrap();
        write_atomically(&path, |out| Ok(out.write_all(b"new")?)).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert_eq!(entries(dir.path()), ["result.txt"]);
    }

    #[test]
    fn path_without_file_name_is_an_error() {
        let error = write_atomically(Path::new("/"), |_| Ok(())).unwrap_err();
        assert!(format!("{error:#}").contains("does not name a file"));
    }

    /// The sRGB OETF in f64, written out independently of `srgb8`.
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
        let file = std::io::BufReader::new(File::open(path).unwrap());
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
