//! References: high-spp renders with the lowest-variance estimator, rendered progressively,
//! written as EXR (mean, variance of the mean, and the `surface` channel: per pixel, the
//! fraction of primary rays that hit a surface without emission, see `mask`) with a JSON sidecar `<file>.json` recording the
//! scene's content hash, the options, spp, seconds and the reference's own estimated relMSE,
//!     relMSE_ref ≈ mean over pixels and channels of Var\[ref] / (ref² + 1e-2),
//! and found again in a cache folder next to the scene when hash and options match.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::{Deserialize, Serialize};

use super::metrics::REL_MSE_EPSILON;
use super::progressive::{resume_progressive, Budget, Flow, PassCount, Progressive};
use super::{fnv1a64, mean_image, EstimatorChoice, SceneSetup};
use crate::image::{
    check_samples, read_exr_layers, write_atomically, write_exr_with_surface, RgbImage,
};
use crate::integrator::{PreparedScene, RenderOptions, Strategy};
use crate::sampling::sampler::SamplerKind;
use crate::select::{SelectorKind, DEFAULT_FAR_SIN};

/// The estimator references use by default: MIS of solid-angle light sampling and BSDF
/// sampling over the light BVH, the lowest-variance combination the renderer has.
pub const DEFAULT_ESTIMATOR: EstimatorChoice = EstimatorChoice {
    selector: SelectorKind::Bvh,
    strategy: Strategy::Mis,
    k: 1,
    n: 1,
    sampler: SamplerKind::Independent,
    m: 1,
    far_sin: DEFAULT_FAR_SIN,
};

/// Samples per pixel of each progressive pass of a reference.
pub const PASS_SPP: u32 = 8;

/// Everything a reference's pixels depend on besides the scene bytes; the cache key.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceOptions {
    pub width: u32,
    pub height: u32,
    pub camera: Option<String>,
    pub estimator: EstimatorChoice,
    pub seed: u64,
    /// Requested total spp (None for a time budget).
    pub spp: Option<u32>,
    /// Requested seconds (None for an spp budget).
    pub time: Option<f64>,
}

impl ReferenceOptions {
    pub fn budget(&self) -> Budget {
        match (self.spp, self.time) {
            (Some(spp), _) => Budget::Spp(spp),
            (None, Some(t)) => Budget::Seconds(t),
            (None, None) => Budget::Spp(1),
        }
    }
}

/// The JSON sidecar of a reference.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReferenceMeta {
    pub scene: PathBuf,
    /// FNV-1a of the scene file's bytes, 16 hex digits.
    pub scene_hash: String,
    pub options: ReferenceOptions,
    /// Samples per pixel rendered.
    pub spp: u32,
    pub passes: u32,
    pub seconds: f64,
    /// Mean over pixels and channels of the variance of the mean / (ref² + 1e-2).
    pub relmse_estimate: f64,
    pub nan_samples: u64,
    pub inf_samples: u64,
}

/// A reference image with its variance layer (when the file has one) and sidecar (when found).
pub struct Reference {
    pub path: PathBuf,
    pub mean: RgbImage,
    pub variance: Option<RgbImage>,
    /// Per pixel, the fraction of primary rays that hit a surface without emission (None for
    /// a file written before references carried it, or by another program).
    pub surface: Option<Vec<f32>>,
    pub meta: Option<ReferenceMeta>,
}

impl Reference {
    /// The reference's own estimated relMSE; None without a variance layer.
    pub fn relmse_estimate(&self) -> Option<f64> {
        self.variance
            .as_ref()
            .map(|v| estimated_relmse(&self.mean, v))
    }
}

/// relMSE a reference with per-pixel variance of the mean `variance` has against the truth:
/// mean over pixels and channels of variance / (mean² + 1e-2).
pub fn estimated_relmse(mean: &RgbImage, variance: &RgbImage) -> f64 {
    let sum: f64 = mean
        .pixels
        .iter()
        .zip(&variance.pixels)
        .map(|(m, v)| {
            (0..3)
                .map(|c| v[c] as f64 / ((m[c] as f64).powi(2) + REL_MSE_EPSILON))
                .sum::<f64>()
        })
        .sum();
    sum / (3 * mean.pixels.len()).max(1) as f64
}

/// The sidecar path of a reference EXR: the same name with `.json` appended.
pub fn sidecar_path(exr: &Path) -> PathBuf {
    let mut s = exr.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

/// Renders a reference of `setup` progressively; `on_pass` sees each pass (progress display).
pub fn render_reference(
    setup: &SceneSetup,
    options: &ReferenceOptions,
    path: &Path,
    mut on_pass: impl FnMut(PassCount, f64),
) -> Reference {
    let p = render_reference_passes(setup, options, None, |p| {
        on_pass(p.count, p.seconds);
        Flow::Continue
    });
    finish_reference(setup, options, path, &p)
}

/// The passes of a reference of `setup`, continued from `from` (a checkpoint's state, or None),
/// with `after_pass` seeing the merged state after each pass (progress, checkpoints) and
/// stopping the run early by returning [`Flow::Stop`].
pub fn render_reference_passes(
    setup: &SceneSetup,
    options: &ReferenceOptions,
    from: Option<Progressive>,
    after_pass: impl FnMut(&Progressive) -> Flow,
) -> Progressive {
    let e = options.estimator;
    let prepared = PreparedScene::new_with(setup.scene.clone(), e.selector, e.far_sin);
    let estimator = prepared
        .estimator(e.strategy, e.k, e.n)
        .with_candidates(e.m);
    let opts = RenderOptions {
        width: setup.width,
        height: setup.height,
        spp: PASS_SPP,
        seed: options.seed,
        sampler: e.sampler,
        first_sample: 0,
        clamp: None,
    };
    resume_progressive(
        &estimator,
        &setup.camera,
        &opts,
        options.budget(),
        PASS_SPP,
        from,
        after_pass,
    )
}

/// The reference (mean, variance of the mean, sidecar) of the finished passes `p`.
pub fn finish_reference(
    setup: &SceneSetup,
    options: &ReferenceOptions,
    path: &Path,
    p: &Progressive,
) -> Reference {
    let mean = mean_image(&p.film);
    let variance = RgbImage {
        width: mean.width,
        height: mean.height,
        pixels: p.film.variance_of_mean_rgb(),
    };
    let surface = p.film.surface_fractions();
    let meta = ReferenceMeta {
        scene: setup.path.clone(),
        scene_hash: format!("{:016x}", setup.hash),
        options: options.clone(),
        spp: p.count.spp,
        passes: p.count.passes,
        seconds: p.seconds,
        relmse_estimate: estimated_relmse(&mean, &variance),
        nan_samples: p.stats.nan_samples,
        inf_samples: p.stats.inf_samples,
    };
    Reference {
        path: path.into(),
        mean,
        variance: Some(variance),
        surface: Some(surface),
        meta: Some(meta),
    }
}

/// Writes the EXR (mean and variance layer) and then its sidecar, each atomically.
pub fn write_reference(reference: &Reference) -> anyhow::Result<()> {
    write_exr_with_surface(
        &reference.path,
        &reference.mean,
        reference.variance.as_ref(),
        reference.surface.as_deref(),
    )?;
    if let Some(meta) = &reference.meta {
        write_atomically(&sidecar_path(&reference.path), |w| {
            serde_json::to_writer_pretty(&mut *w, meta)?;
            writeln!(w)?;
            Ok(())
        })?;
    }
    Ok(())
}

/// Reads a reference EXR and, when present, its sidecar. Refuses a mean that is not finite
/// or a variance that is not finite and ≥ 0 (the renderer writes neither; an error measured
/// against one would be NaN), naming the pixel.
pub fn read_reference(path: &Path) -> anyhow::Result<Reference> {
    let mut reference = read_reference_layers(path)?;
    let sidecar = sidecar_path(path);
    if sidecar.exists() {
        let text = std::fs::read_to_string(&sidecar)
            .with_context(|| format!("cannot read {}", sidecar.display()))?;
        reference.meta = Some(
            serde_json::from_str(&text)
                .with_context(|| format!("{}: not a reference sidecar", sidecar.display()))?,
        );
    }
    Ok(reference)
}

/// As [`read_reference`], without looking for the sidecar (`meta` is None).
pub fn read_reference_layers(path: &Path) -> anyhow::Result<Reference> {
    let layers = read_exr_layers(path)?;
    let (mean, variance, surface) = (layers.mean, layers.variance, layers.surface);
    check_samples(&mean, path, "mean", "a finite value", f32::is_finite)?;
    if let Some(v) = &variance {
        check_samples(v, path, "variance", "a finite value ≥ 0", |x| {
            x.is_finite() && x >= 0.0
        })?;
    }
    if let Some(bad) = surface
        .as_ref()
        .and_then(|s| s.iter().position(|f| !(0.0..=1.0).contains(f)))
    {
        anyhow::bail!(
            "{}: surface channel at pixel ({}, {}) is {}, not a fraction in [0, 1]",
            path.display(),
            bad % mean.width.max(1),
            bad / mean.width.max(1),
            surface.as_ref().map_or(0.0, |s| s[bad])
        );
    }
    Ok(Reference {
        path: path.into(),
        mean,
        variance,
        surface,
        meta: None,
    })
}

/// Where the cached reference for (scene, options) lives: `<scene>.ref/<key>.exr`, the key an
/// FNV-1a of the scene hash and the options' JSON.
pub fn cache_path(setup: &SceneSetup, options: &ReferenceOptions) -> PathBuf {
    let mut folder = setup.path.as_os_str().to_owned();
    folder.push(".ref");
    let key = format!(
        "{:016x}{}",
        setup.hash,
        serde_json::to_string(options).expect("options serialise")
    );
    PathBuf::from(folder).join(format!("{:016x}.exr", fnv1a64(key.as_bytes())))
}

/// Whether a reference was found in the cache or rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Obtained {
    Cached,
    Rendered,
}

/// The cached reference for (scene, options) when its sidecar's hash and options match, else a
/// newly rendered one, written to the cache (the folder is created).
pub fn cached_or_render(
    setup: &SceneSetup,
    options: &ReferenceOptions,
    on_pass: impl FnMut(PassCount, f64),
) -> anyhow::Result<(Reference, Obtained)> {
    let path = cache_path(setup, options);
    if path.exists() {
        if let Ok(r) = read_reference(&path) {
            let hash = format!("{:016x}", setup.hash);
            let matches = r
                .meta
                .as_ref()
                .is_some_and(|m| m.scene_hash == hash && m.options == *options);
            if matches && r.mean.width == setup.width as usize {
                return Ok((r, Obtained::Cached));
            }
        }
    }
    let folder = path.parent().expect("cache path has a folder");
    std::fs::create_dir_all(folder)
        .with_context(|| format!("cannot create the cache folder {}", folder.display()))?;
    let reference = render_reference(setup, options, &path, on_pass);
    write_reference(&reference)?;
    Ok((reference, Obtained::Rendered))
}
