//! Light selection: choose one light index with a known probability p_l.
//!
//! `uniform`: p_l = 1/L. `power`: p_l = Φ_l / ΣΦ through an alias table (O(1) per choice);
//! lights of zero power are never chosen, and when every light has zero power it falls back to
//! uniform. Later selectors (light BVH, oracle) depend on the shading point.

use crate::lights::Lights;
use crate::sampling::alias::AliasTable;

/// Which selector to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SelectorKind {
    Uniform,
    Power,
}

/// A built selector over a fixed set of lights.
#[derive(Clone, Debug)]
pub enum LightSelector {
    Uniform { count: usize },
    Power(AliasTable),
}

impl LightSelector {
    /// None when there are no lights. `Power` over all-zero powers falls back to `Uniform`.
    pub fn new(kind: SelectorKind, lights: &Lights) -> Option<LightSelector> {
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
        })
    }

    /// Chooses a light from u ∈ [0,1) (53 bits): (index, p_l).
    #[inline]
    pub fn sample(&self, u: f64) -> (usize, f64) {
        match self {
            LightSelector::Uniform { count } => {
                let i = ((u * *count as f64) as usize).min(count - 1);
                (i, 1.0 / *count as f64)
            }
            LightSelector::Power(table) => table.sample_with_pmf(u),
        }
    }

    /// The probability that `sample` returns `light`.
    pub fn pmf(&self, light: usize) -> f64 {
        match self {
            LightSelector::Uniform { count } => 1.0 / *count as f64,
            LightSelector::Power(table) => table.pmf(light),
        }
    }
}
