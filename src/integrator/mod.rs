//! Direct lighting: the K×N estimator and its baselines, and the parallel tile loop.

mod estimator;
mod prefetch;
mod prepared;
mod tiles;

pub use estimator::{power_heuristic, Estimator, SampleCounts};
pub use prepared::PreparedScene;
pub use tiles::{render, RenderOptions, RenderStats, FIREFLY_FACTOR};

/// How the reflected part of direct lighting is estimated at the first hit.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Strategy {
    /// K lights from the selector, N uniform points on each (area measure), one shadow ray each.
    LightArea,
    /// As light-area, but points uniform in the triangle's solid angle (Arvo 1995), with area
    /// sampling when Ω < 1e-2 sr (3e-4 sr where the receiver sees the triangle's points at
    /// distances differing by more than 1.5×; `lights::triangle`); from 6.22 sr on the triangle
    /// is split at the receiver's foot.
    LightSolidAngle,
    /// K·N directions from the BRDF (cosine diffuse lobe, GGX visible normals); one ray each.
    Bsdf,
    /// Each light-solid-angle sample plus one BSDF sample, power heuristic; two rays per slot.
    Mis,
    /// K·N directions uniform on the hemisphere; one ray each, adding the emission it hits.
    HemisphereUniform,
    /// K·N cosine-distributed directions; one ray each, adding the emission it hits.
    HemisphereCosine,
    /// Resampled importance sampling: M light-solid-angle candidates per K×N slot, one kept ∝
    /// the unshadowed luminance of f·Le·cosθ, one shadow ray (M = 1: light-solid-angle).
    Ris,
    /// As ris, with the slot's BSDF direction as one more candidate and balance-heuristic
    /// multiple-proposal weights; one BSDF ray and one shadow ray per slot.
    RisMis,
}

impl Strategy {
    /// Whether this strategy resamples M candidates per slot (M, `--m`, applies to it).
    pub fn resamples(self) -> bool {
        matches!(self, Strategy::Ris | Strategy::RisMis)
    }
}
