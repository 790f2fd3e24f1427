//! Light selection: choose one light for a shading point with a known probability p_l, and
//! evaluate that probability for any light (MIS needs it for lights hit by BSDF rays).
//!
//! `uniform`: p_l = 1/L. `power`: p_l = Φ_l / ΣΦ through an alias table (O(1)); zero-power lights
//! are never chosen, and all-zero powers fall back to uniform. `bvh`: a light BVH traversed by
//! importance (Conty Estevez & Kulla 2018), directional lights chosen outside the tree by power.
//! `oracle`: p_l ∝ each light's exact unshadowed contribution to a diffuse receiver (O(L)).

pub mod light_tree;
pub mod oracle;
mod tree_selector;

use glam::Vec3;

use crate::lights::Lights;
use crate::sampling::alias::AliasTable;

pub use light_tree::{Lobe, DEFAULT_FAR_SIN};
pub use tree_selector::BvhSelector;

/// Which selector to build.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum SelectorKind {
    Uniform,
    Power,
    Bvh,
    Oracle,
}

/// The receiver a light is chosen for: position, unit (shading) normal and its specular lobe
/// (`Lobe::NONE` for a diffuse receiver; only `bvh` reads it).
#[derive(Clone, Copy, Debug)]
pub struct ShadingContext {
    pub p: Vec3,
    pub n: Vec3,
    pub lobe: Lobe,
}

/// A built selector over a fixed set of lights.
#[derive(Clone, Debug)]
pub enum LightSelector {
    Uniform { count: usize },
    Power(AliasTable),
    Bvh(BvhSelector),
    Oracle,
}

impl LightSelector {
    /// None when there are no lights. `bvh` reorders `lights` (its leaves want contiguous ids).
    pub fn build(kind: SelectorKind, lights: &mut Lights) -> Option<LightSelector> {
        Self::build_with(kind, lights, DEFAULT_FAR_SIN)
    }

    /// [`build`](Self::build), the light tree's far lanes below `far_sin` (`bvh` only; see
    /// [`DEFAULT_FAR_SIN`]; 0: the walk always descends).
    pub fn build_with(
        kind: SelectorKind,
        lights: &mut Lights,
        far_sin: f32,
    ) -> Option<LightSelector> {
        if lights.is_empty() {
            return None;
        }
        let uniform = LightSelector::Uniform {
            count: lights.len(),
        };
        Some(match kind {
            SelectorKind::Uniform => uniform,
            SelectorKind::Power => AliasTable::new(&lights.powers())
                .map(LightSelector::Power)
                .unwrap_or(uniform),
            SelectorKind::Bvh => {
                LightSelector::Bvh(BvhSelector::build(lights).with_far_sin(far_sin))
            }
            SelectorKind::Oracle => LightSelector::Oracle,
        })
    }

    /// Chooses a light from u ∈ [0,1) (53 bits): (index, p_l); None when no light can contribute.
    #[inline]
    pub fn sample(&self, lights: &Lights, ctx: &ShadingContext, u: f64) -> Option<(usize, f64)> {
        match self {
            LightSelector::Uniform { count } => {
                let i = ((u * *count as f64) as usize).min(count - 1);
                Some((i, 1.0 / *count as f64))
            }
            LightSelector::Power(table) => Some(table.sample_with_pmf(u)),
            LightSelector::Bvh(bvh) => bvh.sample(ctx, u),
            LightSelector::Oracle => oracle::sample(lights, ctx, u),
        }
    }

    /// The probability that `sample` returns `light` at this shading point.
    #[inline]
    pub fn pmf(&self, lights: &Lights, ctx: &ShadingContext, light: usize) -> f64 {
        match self {
            LightSelector::Uniform { count } => 1.0 / *count as f64,
            LightSelector::Power(table) => table.pmf(light),
            LightSelector::Bvh(bvh) => bvh.pmf(ctx, light),
            LightSelector::Oracle => oracle::pmf(lights, ctx, light),
        }
    }

    /// Heap bytes of the selection structure.
    pub fn bytes(&self) -> usize {
        match self {
            LightSelector::Uniform { .. } | LightSelector::Oracle => 0,
            LightSelector::Power(table) => table.len() * AliasTable::BYTES_PER_ENTRY,
            LightSelector::Bvh(bvh) => bvh.bytes(),
        }
    }
}
