//! Direct lighting: the K×N estimator and its baselines, and the parallel tile loop.

mod estimator;
mod tiles;

pub use estimator::{Estimator, SampleCounts};
pub use tiles::{render, RenderOptions, RenderStats};

/// How the reflected part of direct lighting is estimated at the first hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Strategy {
    /// K lights from the selector, N uniform points on each (area measure), one shadow ray each.
    LightArea,
    /// K·N directions uniform on the hemisphere; one ray each, adding the emission it hits.
    HemisphereUniform,
    /// K·N cosine-distributed directions; one ray each, adding the emission it hits.
    HemisphereCosine,
}
