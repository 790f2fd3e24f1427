//! The render options every rendering subcommand shares (render, reference, bench, converge),
//! with the same names everywhere. Options a sweep can vary (`--spp`, `--selector`,
//! `--strategy`, `--k`, `--n`, `--m`, `--sampler`) take comma-separated lists; commands that render one
//! configuration accept exactly one value and fall back to their own default when none is given.

use std::path::PathBuf;
use std::sync::Arc;

use clap::Args;

use super::UsageError;
use crate::integrator::Strategy;
use crate::measure::EstimatorChoice;
use crate::sampling::sampler::SamplerKind;
use crate::scene::memory::{available_memory, parse_size, MemoryBudget};
use crate::scene::{CameraChoice, EnvironmentError, EnvironmentImage, LoadPolicy, PunctualUnits};
use crate::select::{SelectorKind, DEFAULT_FAR_SIN};

#[derive(Args, Debug, Clone)]
pub struct RenderOptionsArgs {
    /// The scene, .gltf or .glb.
    pub scene: PathBuf,
    /// Camera samples per pixel (bench and converge: a comma-separated list).
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub spp: Vec<u32>,
    /// Lights chosen per camera sample, K (bench: a list, crossed with --n unless --kn is given).
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub k: Vec<u32>,
    /// Points sampled on each chosen light, N (bench: a list).
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub n: Vec<u32>,
    /// RIS candidates per K×N slot, M, for --strategy ris and ris-mis [default: 1] (bench: a
    /// list, swept for those strategies only).
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub m: Vec<u32>,
    /// Light selector [default: bvh; bench, converge: power] (bench: a list, also as --selectors).
    #[arg(long, value_enum, value_delimiter = ',', alias = "selectors")]
    pub selector: Vec<SelectorKind>,
    /// Estimation strategy [default: mis; bench, converge: light-area] (bench: a list, also as
    /// --strategies).
    #[arg(long, value_enum, value_delimiter = ',', alias = "strategies")]
    pub strategy: Vec<Strategy>,
    /// Sample sequence for every number a camera sample consumes [default: sobol; bench,
    /// converge: independent] (bench: a list, also as --samplers).
    #[arg(long, value_enum, value_delimiter = ',', alias = "samplers")]
    pub sampler: Vec<SamplerKind>,
    /// `--selector bvh`: the light tree's walk stops at a lane whose bounding sphere it sees under
    /// a half-angle whose sine is below this (and whose lights face within 90° of one way), and
    /// chooses among its lights in proportion to power; 0 always descends to one light
    /// [default: 0.3] (bench: a list, swept for bvh only).
    #[arg(long, value_delimiter = ',', value_parser = unit_interval)]
    pub far_sin: Vec<f32>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: u32,
    /// Image height in pixels (default: from the camera's aspect ratio, else square).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: Option<u32>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Camera node index (in scene order) or name; default the first perspective camera.
    #[arg(long)]
    pub camera: Option<CameraChoice>,
    /// Units of KHR_lights_punctual intensities: photometric (cd, lx; the glTF specification,
    /// divided by 683 lm/W) or radiometric (W/sr, W/m²; files written for manylights before it
    /// followed the specification).
    #[arg(long, value_enum, default_value_t = PunctualUnits::Photometric)]
    pub punctual_units: PunctualUnits,
    /// Clamp each camera sample's radiance per channel to this value (biased: removes
    /// fireflies at the price of energy; reports mark the configuration biased).
    #[arg(long, value_parser = positive_finite)]
    pub clamp: Option<f32>,
    /// Light the scene with an equirectangular RGB OpenEXR environment map (+Y up, row 0 at the
    /// zenith, the image centre toward −Z); it is one more light for selection.
    #[arg(long)]
    pub env: Option<PathBuf>,
    /// Multiply the environment map's radiance by this factor.
    #[arg(long, default_value_t = 1.0, value_parser = positive_finite, requires = "env")]
    pub env_scale: f32,
    /// Turn the environment map by this many degrees about +Y (counter-clockwise from above).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = finite, requires = "env")]
    pub env_rotate: f32,
    /// Also read the scene's external files (buffers, images) from inside this folder; without
    /// it only files inside the scene's own folder are read (repeatable).
    #[arg(long, value_name = "DIR", value_parser = existing_folder)]
    pub allow_external_files: Vec<PathBuf>,
    /// Refuse, before reading its buffers, a scene whose estimated memory (geometry and BVH,
    /// lights, film, from the sizes the file declares) exceeds SIZE, e.g. 512M, 8G, 1.5GiB
    /// [default: the memory the system has available]
    #[arg(long, value_name = "SIZE", value_parser = memory_size)]
    pub max_memory: Option<u64>,
}

/// The defaults of a command that renders one configuration.
#[derive(Clone, Copy, Debug)]
pub struct Defaults {
    pub spp: u32,
    pub estimator: EstimatorChoice,
}

/// `render`'s defaults, the best configuration measured: 16 spp, light BVH
/// selection, MIS of light and BSDF samples, K = N = 1, Owen-scrambled Sobol numbers, M = 1. On
/// town.glb (128², 16 spp, 3 repeats, `bench --selectors power,bvh --strategies light-area,mis
/// --samplers independent,sobol`) its MSE is 11.3× lower than the textbook baseline's below,
/// and its efficiency 1/(relMSE·s) 3.0× higher.
pub const RENDER_DEFAULTS: Defaults = Defaults {
    spp: 16,
    estimator: EstimatorChoice {
        selector: SelectorKind::Bvh,
        strategy: Strategy::Mis,
        k: 1,
        n: 1,
        sampler: SamplerKind::Sobol,
        m: 1,
        far_sin: DEFAULT_FAR_SIN,
    },
};

/// The textbook estimator: power selection, light-area sampling, K = N = 1, independent numbers.
/// `bench` takes it for any list not given, so that a sweep's first row (its default baseline)
/// is this estimator; `converge` defaults to it because it checks plain Monte Carlo's MSE ∝ 1/spp
/// (a Sobol sequence converges faster: slope −1.70 on cornell).
pub const TEXTBOOK_DEFAULTS: Defaults = Defaults {
    spp: 16,
    estimator: EstimatorChoice {
        selector: SelectorKind::Power,
        strategy: Strategy::LightArea,
        k: 1,
        n: 1,
        sampler: SamplerKind::Independent,
        m: 1,
        far_sin: DEFAULT_FAR_SIN,
    },
};

impl RenderOptionsArgs {
    /// The single estimator configuration of a one-configuration command.
    pub fn estimator(&self, defaults: &Defaults) -> Result<EstimatorChoice, UsageError> {
        let d = defaults.estimator;
        let choice = EstimatorChoice {
            selector: single("--selector", &self.selector, d.selector)?,
            strategy: single("--strategy", &self.strategy, d.strategy)?,
            k: single("--k", &self.k, d.k)?,
            n: single("--n", &self.n, d.n)?,
            sampler: single("--sampler", &self.sampler, d.sampler)?,
            m: single("--m", &self.m, d.m)?,
            far_sin: single("--far-sin", &self.far_sin, d.far_sin)?,
        };
        if choice.m != 1 && !choice.strategy.resamples() {
            return Err(UsageError(format!(
                "--m {} applies to --strategy ris and ris-mis only",
                choice.m
            )));
        }
        if !self.far_sin.is_empty() && choice.selector != SelectorKind::Bvh {
            return Err(UsageError(
                "--far-sin applies to --selector bvh only".into(),
            ));
        }
        Ok(choice)
    }

    /// The single spp of a one-configuration command.
    pub fn single_spp(&self, defaults: &Defaults) -> Result<u32, UsageError> {
        single("--spp", &self.spp, defaults.spp)
    }

    /// The scene with its camera, resolution, punctual-light units, external-file policy and
    /// `--env` map, as every command that renders sets it up.
    pub fn scene_setup(&self) -> anyhow::Result<crate::measure::SceneSetup> {
        self.check_given_resolution()?;
        Ok(crate::measure::SceneSetup::load_allowing(
            &self.scene,
            self.camera.as_ref(),
            self.width,
            self.height,
            &self.load_policy(),
        )?
        .with_punctual_units(self.punctual_units)
        .with_environment(self.environment()?))
    }

    /// Refuses a --width × --height over [`MAX_PIXELS`] before the scene is read, when both are
    /// given (a derived height is checked once the camera is known), so that such a request is a
    /// usage error whatever memory the machine has, not a memory-budget refusal of its film.
    pub fn check_given_resolution(&self) -> Result<(), UsageError> {
        self.height
            .map_or(Ok(()), |height| check_resolution(self.width, height))
    }

    /// External folders and the memory budget: `--max-memory`, else the memory available
    /// (none when it cannot be read); the film is counted at width × height (width² when the
    /// height comes from the camera).
    pub fn load_policy(&self) -> LoadPolicy {
        let film_pixels = u64::from(self.width) * u64::from(self.height.unwrap_or(self.width));
        LoadPolicy {
            allowed: self.allow_external_files.clone(),
            memory: self
                .max_memory
                .or_else(available_memory)
                .map(|max_bytes| MemoryBudget {
                    max_bytes,
                    film_pixels,
                }),
        }
    }

    /// The `--env` map, scaled and rotated (None without `--env`).
    pub fn environment(&self) -> Result<Option<Arc<EnvironmentImage>>, EnvironmentError> {
        self.env
            .as_deref()
            .map(|path| EnvironmentImage::load(path, self.env_scale, self.env_rotate).map(Arc::new))
            .transpose()
    }

    /// A rayon pool with `--threads` workers (default: all cores).
    pub fn thread_pool(&self) -> anyhow::Result<rayon::ThreadPool> {
        use anyhow::Context;
        let mut builder = rayon::ThreadPoolBuilder::new();
        if let Some(t) = self.threads {
            builder = builder.num_threads(t as usize);
        }
        builder.build().context("cannot start the worker threads")
    }
}

/// The one value of a list option, or `default` when it was not given.
fn single<T: Copy + std::fmt::Debug>(
    name: &str,
    values: &[T],
    default: T,
) -> Result<T, UsageError> {
    match values {
        [] => Ok(default),
        [v] => Ok(*v),
        _ => Err(UsageError(format!(
            "{name} takes one value here, got {values:?} (lists are for bench and converge)"
        ))),
    }
}

/// Parses a finite f32 (clap value parser).
pub fn finite(s: &str) -> Result<f32, String> {
    let x: f32 = s.parse().map_err(|e| format!("{e}"))?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("must be a finite number, got {s}"))
    }
}

/// The most pixels an image may have: 2^25 (8K UHD, 7680 × 4320, fits). Each pixel's
/// statistics take 56 bytes, so the film alone stays under 2 GB; a larger request is refused
/// before anything is allocated.
pub const MAX_PIXELS: u64 = 1 << 25;

/// Refuses an image of more than [`MAX_PIXELS`] pixels (after the height has been derived from
/// the camera's aspect ratio), naming --width and --height.
pub fn check_resolution(width: u32, height: u32) -> Result<(), UsageError> {
    let pixels = u64::from(width) * u64::from(height);
    if pixels > MAX_PIXELS {
        return Err(UsageError(format!(
            "--width {width} --height {height} is {pixels} pixels, more than the {MAX_PIXELS} \
             allowed (8K UHD fits)"
        )));
    }
    Ok(())
}

/// A number in [0, 1] (clap value parser for `--far-sin`).
fn unit_interval(s: &str) -> Result<f32, String> {
    let x: f32 = s.parse().map_err(|e| format!("{e}"))?;
    if (0.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err(format!("must be a number from 0 to 1, got {s}"))
    }
}

fn positive_finite(s: &str) -> Result<f32, String> {
    let x: f32 = s.parse().map_err(|e| format!("{e}"))?;
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(format!("must be a positive finite number, got {s}"))
    }
}

/// Parses an existing folder into its canonical path (clap value parser for
/// `--allow-external-files`, whose paths are compared with canonical file paths).
/// A `--max-memory` size (see [`parse_size`]).
fn memory_size(s: &str) -> Result<u64, String> {
    parse_size(s)
}

pub fn existing_folder(s: &str) -> Result<PathBuf, String> {
    let path = std::path::Path::new(s)
        .canonicalize()
        .map_err(|e| format!("cannot resolve {s}: {e}"))?;
    if path.is_dir() {
        Ok(path)
    } else {
        Err(format!("{s} is not a folder"))
    }
}
