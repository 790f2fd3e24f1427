//! Measuring renders: error against a reference, references themselves, progressive rendering
//! to a budget, benchmark grids, convergence checks, and their reports and plots.

pub mod bench;
pub mod checkpoint;
pub mod converge;
pub mod cpu_time;
pub mod errors;
pub mod fit;
pub mod mask;
pub mod metrics;
pub mod plot;
pub mod progressive;
pub mod reference;
pub mod report;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::film::Film;
use crate::image::RgbImage;
use crate::integrator::Strategy;
use crate::sampling::sampler::SamplerKind;
use crate::scene::{
    load_gltf_bytes_allowing, read_scene_file, scene_folder, Camera, CameraChoice,
    EnvironmentImage, LoadPolicy, PunctualUnits, Scene,
};
use crate::select::{SelectorKind, DEFAULT_FAR_SIN};

/// One estimator configuration: the selector, the strategy, K × N and the sample sequence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EstimatorChoice {
    pub selector: SelectorKind,
    pub strategy: Strategy,
    pub k: u32,
    pub n: u32,
    /// Absent from files written before samplers existed: those used independent numbers.
    #[serde(default)]
    pub sampler: SamplerKind,
    /// RIS candidates per K×N slot (`ris`, `ris-mis`; 1 for every other strategy). Absent from
    /// files written before RIS existed.
    #[serde(default = "one_candidate")]
    pub m: u32,
    /// `bvh`: the sine of the half-angle under which a lane's bounding sphere makes the walk
    /// stop there and choose ∝ power ([`DEFAULT_FAR_SIN`]; 0: it always descends). Absent from
    /// files written before it could be chosen, which used the default.
    #[serde(default = "default_far_sin")]
    pub far_sin: f32,
}

fn one_candidate() -> u32 {
    1
}

fn default_far_sin() -> f32 {
    DEFAULT_FAR_SIN
}

/// A scene loaded for measurement, with the content hash that identifies its references.
pub struct SceneSetup {
    pub path: PathBuf,
    /// FNV-1a of the scene file's bytes (and, with an environment map, of its texels and
    /// rotation after them).
    pub hash: u64,
    pub scene: Scene,
    pub camera: Camera,
    /// The `--camera` choice as given (None: the first perspective camera).
    pub camera_choice: Option<String>,
    pub width: u32,
    pub height: u32,
}

impl SceneSetup {
    /// Loads `path` with the chosen camera (or one framing the scene) at the requested size.
    pub fn load(
        path: &Path,
        camera: Option<&CameraChoice>,
        width: u32,
        height: Option<u32>,
    ) -> anyhow::Result<SceneSetup> {
        Self::load_allowing(path, camera, width, height, &LoadPolicy::default())
    }

    /// [`SceneSetup::load`] under `policy` (external folders, memory budget).
    pub fn load_allowing(
        path: &Path,
        camera: Option<&CameraChoice>,
        width: u32,
        height: Option<u32>,
        policy: &LoadPolicy,
    ) -> anyhow::Result<SceneSetup> {
        // One read: the bytes the loader accepts are the bytes hashed.
        let bytes = read_scene_file(path)?;
        let choice = camera.cloned().unwrap_or_default();
        let scene = load_gltf_bytes_allowing(&bytes, path, scene_folder(path), &choice, policy)?;
        let cam = camera_or_framing(&scene, path, width, height);
        let (width, height) = cam.resolution(width, height);
        Ok(SceneSetup {
            path: path.into(),
            hash: fnv1a64(&bytes),
            scene,
            camera: cam,
            camera_choice: camera.map(|c| match c {
                CameraChoice::First => "first".into(),
                CameraChoice::Index(i) => i.to_string(),
                CameraChoice::Name(n) => n.clone(),
            }),
            width,
            height,
        })
    }

    /// Reads the scene's punctual lights in `units`. The hash changes when photometric units
    /// meet punctual lights, so that references rendered when their values were read as W/sr
    /// and W/m² (the meaning of the file's hash before units existed) do not match.
    pub fn with_punctual_units(mut self, units: PunctualUnits) -> SceneSetup {
        if units == PunctualUnits::Photometric && !self.scene.punctual.is_empty() {
            let mut bytes = self.hash.to_le_bytes().to_vec();
            bytes.extend(b"photometric");
            self.hash = fnv1a64(&bytes);
        }
        self.scene = self.scene.with_punctual_units(units);
        self
    }

    /// Lights the scene with `environment`; the hash then covers the map's size, scaled texels
    /// and rotation too, so that references rendered without it (or with another) do not match.
    pub fn with_environment(mut self, environment: Option<Arc<EnvironmentImage>>) -> SceneSetup {
        if let Some(env) = &environment {
            let mut bytes = self.hash.to_le_bytes().to_vec();
            bytes.extend((env.width() as u64).to_le_bytes());
            bytes.extend(env.rotation_degrees().to_le_bytes());
            bytes.extend(
                env.texels()
                    .iter()
                    .flat_map(|t| t.to_array())
                    .flat_map(f32::to_le_bytes),
            );
            self.hash = fnv1a64(&bytes);
        }
        self.scene = self.scene.with_environment(environment);
        self
    }
}

/// The scene's camera, or one framing its bounds for a `width × height` image (square without
/// `height`) when it has none, with a note naming where it looks from.
pub fn camera_or_framing(scene: &Scene, path: &Path, width: u32, height: Option<u32>) -> Camera {
    scene.camera.clone().unwrap_or_else(|| {
        let (lo, hi) = scene.bounds();
        let aspect = height.map_or(1.0, |h| width as f32 / h as f32);
        let camera = Camera::framing(lo, hi, aspect);
        eprintln!(
            "note: {} has no camera; framing its bounds {}: {}",
            path.display(),
            Camera::FRAMING_DIRECTION_TEXT,
            camera.describe()
        );
        camera
    })
}

/// 64-bit FNV-1a (Fowler, Noll & Vo): h = (h ⊕ byte) · 0x100000001b3 from 0xcbf29ce484222325.
/// Stable across Rust versions and platforms, unlike std's DefaultHasher.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The per-pixel mean of a film as an f32 image.
pub fn mean_image(film: &Film) -> RgbImage {
    RgbImage {
        width: film.width as usize,
        height: film.height as usize,
        pixels: film.mean_rgb(),
    }
}

/// Mean over pixels and channels of the estimated variance of the pixel mean, s²/n.
pub fn mean_variance(film: &Film) -> f64 {
    let sum: f64 = film
        .pixels
        .iter()
        .map(|p| p.variance_of_mean().element_sum())
        .sum();
    sum / (3 * film.pixels.len()).max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_published_test_vectors() {
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
