//! OpenEXR output and input: float32 R, G, B of the mean, optional variance.R/G/B channels and
//! an optional single `surface` channel (a reference's lit-surface fraction per pixel).

use std::path::Path;

use anyhow::{anyhow, ensure, Context};
use exr::prelude::{
    read, AnyChannel, AnyChannels, Compression, Encoding, FlatSamples, Image, Layer,
    LayerAttributes, LineOrder, ReadChannels, ReadLayers, SmallVec, WritableImage,
};

use super::{atomic::write_atomically, check_image, RgbImage};

/// EXR encoding: RLE, one scan line per block, increasing line order.
///
/// Lossless. Measured on 6 float32 channels of render-like data (noisy
/// mantissas, 20 % black), encoding on one thread: at 1920×1080, RLE 117 ms /
/// 81 % of raw size, ZIP1 965 ms / 80 %, ZIP16 1343 ms / 78 %, PIZ 818 ms /
/// 72 %, uncompressed 39 ms / 100 %. Deflate barely shrinks noisy floats, so
/// RLE keeps almost all of ZIP's gain (black backgrounds, zero-variance
/// regions) at a tenth of its cost.
const EXR_ENCODING: Encoding = Encoding {
    compression: Compression::RLE,
    blocks: exr::image::Blocks::ScanLines,
    line_order: LineOrder::Increasing,
};

/// Channel names of the mean, in R, G, B order.
const MEAN_CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Channel names of the variance, in R, G, B order. One single-part file
/// with `layer.channel` names (the OpenEXR naming convention for layers): any
/// viewer shows the unprefixed R, G, B as the image, and layer-aware viewers
/// (tev, exrheader's listing, Blender's multilayer reader) group the
/// `variance.*` channels as a second layer. Multi-part files are skipped or
/// shown part by part by older readers.
const VARIANCE_CHANNELS: [&str; 3] = ["variance.R", "variance.G", "variance.B"];

/// Name of the optional single channel holding, per pixel, the fraction of samples whose
/// primary ray hit a surface without emission (written with references).
const SURFACE_CHANNEL: &str = "surface";

/// The three channels of `image` under `names` (R, G, B order). All are
/// marked not perceptually linear ("pLinear" off), as the exr crate does for
/// plain R, G, B; it would otherwise guess "on" from the `variance.` names.
fn rgb_channels(image: &RgbImage, names: [&str; 3]) -> [AnyChannel<FlatSamples>; 3] {
    [0, 1, 2].map(|c| {
        let samples = image.pixels.iter().map(|p| p[c]).collect();
        AnyChannel {
            quantize_linearly: false,
            ..AnyChannel::new(names[c], FlatSamples::F32(samples))
        }
    })
}

/// Writes an OpenEXR file with float32 channels `R`, `G`, `B` from `mean` and,
/// if given, `variance.R`, `variance.G`, `variance.B` from `variance`, all in
/// one single-part layer, RLE-compressed per scan line. Equal inputs give
/// byte-identical files. Written through [`write_atomically`].
pub fn write_exr(path: &Path, mean: &RgbImage, variance: Option<&RgbImage>) -> anyhow::Result<()> {
    write_exr_with_surface(path, mean, variance, None)
}

/// As [`write_exr`], with a `surface` channel from `surface` (one value per pixel) when given.
pub fn write_exr_with_surface(
    path: &Path,
    mean: &RgbImage,
    variance: Option<&RgbImage>,
    surface: Option<&[f32]>,
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
    if let Some(surface) = surface {
        ensure!(
            surface.len() == mean.pixels.len(),
            "surface channel has {} values for {}×{} pixels",
            surface.len(),
            mean.width,
            mean.height
        );
        channels.push(AnyChannel {
            quantize_linearly: false,
            ..AnyChannel::new(SURFACE_CHANNEL, FlatSamples::F32(surface.to_vec()))
        });
    }
    let layer = Layer::new(
        (mean.width, mean.height),
        LayerAttributes::default(),
        EXR_ENCODING,
        AnyChannels::sort(channels),
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |out| {
        // One thread: RLE is cheap, the bytes do not depend on thread timing,
        // and a write during rendering does not start a second thread pool
        // that competes with the render threads being measured.
        image
            .write()
            .non_parallel()
            .to_buffered(out)
            .context("OpenEXR encoding failed")
    })
}

/// Decoded samples may exceed the file's size at most this many times (deflate's limit is about
/// 1032:1, RLE's 64:1) — or [`MIN_DECODED_LIMIT`], whichever is larger.
const MAX_EXPANSION: u64 = 4096;
/// Decoded bytes any file may declare, however small.
const MIN_DECODED_LIMIT: u64 = 64 << 20;

/// Refuses, from the headers alone and before anything is allocated from them, a file whose
/// headers declare more than it can hold: more chunks than its size has room for offsets
/// (8 bytes each), or more decoded sample bytes than [`MAX_EXPANSION`] × its size (a 376-byte
/// file declaring a 120 GB image was found by `tests/fuzz_exr.rs`). Returns the file's size.
fn check_declared_size(path: &Path) -> anyhow::Result<u64> {
    let size = std::fs::metadata(path)
        .with_context(|| format!("cannot read {}", path.display()))?
        .len();
    let Ok(meta) = exr::meta::MetaData::read_from_file(path, false) else {
        return Ok(size); // the full read reports what is wrong
    };
    let (mut chunks, mut decoded) = (0u64, 0u64);
    for h in &meta.headers {
        let pixels = (h.layer_size.0 as u64).saturating_mul(h.layer_size.1 as u64);
        let sample_bytes: u64 = (h.channels.list.iter())
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum();
        decoded = decoded.saturating_add(pixels.saturating_mul(sample_bytes));
        chunks = chunks.saturating_add(h.chunk_count as u64);
    }
    ensure!(
        chunks.saturating_mul(8) <= size,
        "{}: not a valid OpenEXR file, truncated or corrupt (its headers declare {chunks} \
         chunks, more than its {size} bytes hold)",
        path.display()
    );
    let limit = size.saturating_mul(MAX_EXPANSION).max(MIN_DECODED_LIMIT);
    ensure!(
        decoded <= limit,
        "{}: not a valid OpenEXR file, truncated or corrupt (its headers declare {decoded} \
         bytes of samples, more than {MAX_EXPANSION} times its {size} bytes)",
        path.display()
    );
    Ok(size)
}

/// Files below this size are decompressed on the calling thread: the exr crate's parallel
/// reader starts a thread pool of its own for every file, which costs more than a small file's
/// decompression (fuzzing 2 kB files ran at 380 reads/s in parallel, about 9,100 on the calling
/// thread).
const PARALLEL_READ_MIN_BYTES: u64 = 1 << 20;

/// Reads the first layer of an OpenEXR file: the `R`, `G`, `B` channels as the
/// mean and, if all three are present, `variance.R`, `variance.G`,
/// `variance.B` as the variance. Samples stored as f16 or u32 are converted to
/// f32. Fails, naming the file, if it is not OpenEXR or lacks R, G or B.
pub fn read_exr_rgb(path: &Path) -> anyhow::Result<(RgbImage, Option<RgbImage>)> {
    let layers = read_exr_layers(path)?;
    Ok((layers.mean, layers.variance))
}

/// Everything [`read_exr_layers`] finds in a file.
pub struct ExrLayers {
    pub mean: RgbImage,
    pub variance: Option<RgbImage>,
    /// The `surface` channel, one value per pixel, when the file has one.
    pub surface: Option<Vec<f32>>,
}

/// As [`read_exr_rgb`], with the `surface` channel too when the file has one.
pub fn read_exr_layers(path: &Path) -> anyhow::Result<ExrLayers> {
    let size = check_declared_size(path)?;
    let reader = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes();
    let reader = if size < PARALLEL_READ_MIN_BYTES {
        reader.non_parallel()
    } else {
        reader
    };
    let image = reader.from_file(path).map_err(|e| match e {
        exr::error::Error::Invalid(why) => anyhow!(
            "{}: not a valid OpenEXR file, truncated or corrupt ({why})",
            path.display()
        ),
        other => {
            anyhow::Error::new(other).context(format!("cannot read {} as OpenEXR", path.display()))
        }
    })?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let channels = &layer.channel_data.list;
    let find = |name: &str| channels.iter().find(|c| c.name == *name);
    let gather = |names: [&str; 3]| -> anyhow::Result<RgbImage> {
        let mut pixels = vec![[0.0f32; 3]; width * height];
        for (c, name) in names.into_iter().enumerate() {
            let channel =
                find(name).with_context(|| format!("{} has no channel {name}", path.display()))?;
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
    let surface = match find(SURFACE_CHANNEL) {
        Some(channel) => {
            ensure!(
                channel.sample_data.len() == width * height,
                "{}: channel {SURFACE_CHANNEL} has {} samples for {width}×{height} pixels",
                path.display(),
                channel.sample_data.len()
            );
            Some(channel.sample_data.values_as_f32().collect())
        }
        None => None,
    };
    Ok(ExrLayers {
        mean,
        variance,
        surface,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::test_util::*;
    use std::fs;

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
    fn surface_channel_round_trips_and_is_absent_from_plain_files() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ref.exr");
        let mean = noisy_image(5, 4, 8);
        let surface: Vec<f32> = (0..20).map(|i| i as f32 / 19.0).collect();
        write_exr_with_surface(&path, &mean, None, Some(&surface)).unwrap();
        let layers = read_exr_layers(&path).unwrap();
        assert_eq!(layers.mean, mean);
        assert!(layers.variance.is_none());
        assert_eq!(layers.surface.as_deref(), Some(&surface[..]));
        write_exr(&path, &mean, None).unwrap();
        assert!(read_exr_layers(&path).unwrap().surface.is_none());
        assert!(write_exr_with_surface(&path, &mean, None, Some(&surface[1..])).is_err());
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
        assert!(
            error.contains("luma.exr") && error.contains("channel R"),
            "{error}"
        );
    }
}
