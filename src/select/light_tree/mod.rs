//! Light BVH: chooses one emitter among very many with probability roughly
//! proportional to its contribution at a shading point, after Conty Estevez &
//! Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree
//! Splitting" (the same scheme as pbrt-v4's BVH light sampler).
//!
//! Each node bounds a set of emitters by a box, their total power Φ, a cone of
//! normals (axis w, half-angle θo) and the spread θe of emission beyond those
//! normals. [`LightBounds::importance`] turns these into an upper bound on what
//! the set can send to a receiver; [`LightBvh::sample`] walks down from the
//! root choosing a child with probability proportional to its importance, and
//! [`LightBvh::pmf`] recomputes the probability of any given light.
//!
//! What is stored, and why:
//! - Nodes are 32 bytes (two per cache line), in depth-first order: the left
//!   child of node i is i + 1 and the node keeps the index of its right child.
//! - The box is kept as 16-bit coordinates on a grid spanning the root's box,
//!   the cone axis as a 2×16-bit octahedral code, cos θo and cos θe as 15-bit
//!   numbers, plus a two-sided and a leaf bit, Φ as an f32 and the radius of
//!   a sphere holding the decoded box (so `importance` need not recompute it).
//!   Every rounding makes the bound larger (box rounded outwards, cosines
//!   rounded down, θo widened by the axis' coding error), so quantisation can
//!   cost efficiency but never gives 0 to a node that holds a light able to
//!   reach the receiver.
//! - The lights are renumbered into leaf order, so a subtree covers a
//!   contiguous range of light ids: a leaf keeps its light's id, and the first
//!   id of a right child's range is its parent's plus half the index distance
//!   between them. `pmf` then finds a light by descending towards its id,
//!   multiplying the very same per-node probabilities that `sample` does, at
//!   any depth and without per-light bit trails or parent links.
//!
//! The build is top-down with a binned cost over all three axes (Φ times the
//! orientation measure M_Ω times the surface area, scaled by how thin the node
//! is along the split axis), running subtrees in parallel with rayon.
//!
//! Files: `bounds` (LightBounds, importance, cone algebra), `quantise` (grid,
//! cosine and octahedral codes), `node` (the 32-byte node), `traverse`
//! (LightBvh: build entry, sample, pmf), `split` (binned split choice),
//! `build` (parallel subtree construction), `tests`.

mod bounds;
mod build;
mod node;
mod quantise;
mod split;
#[cfg(test)]
mod tests;
mod traverse;

use build::*;
use node::*;
use quantise::*;
use split::*;

pub use bounds::LightBounds;
use bounds::*;
pub use traverse::LightBvh;

/// Absolute tolerance on the cosines compared in `importance`, larger than the
/// f32 rounding of those cosines: a node is only rejected with this margin.
const COS_SLACK: f32 = 2e-6;
/// Angle (radians) added to every cone that is merged or quantised here, larger
/// than the rounding of the f64 computation and of the f32 axis it yields.
const ANGLE_SLACK: f64 = 1e-6;
/// Buckets per axis in the binned build.
const BUCKETS: usize = 12;
/// Subtrees with at least this many lights are built in parallel.
const PARALLEL_MIN: usize = 4096;
/// Nodes with at least this many lights are binned in parallel.
const PARALLEL_BINNING_MIN: usize = 1 << 16;
/// The largest f64 below 1.
const LARGEST_BELOW_ONE: f64 = 1.0 - f64::EPSILON / 2.0;
/// Largest 16-bit box coordinate.
const BOX_MAX: u32 = u16::MAX as u32;
/// Largest 15-bit cosine code.
const COS_MAX: u32 = (1 << 15) - 1;
const TWO_SIDED_BIT: u32 = 1 << 30;
const LEAF_BIT: u32 = 1 << 31;
