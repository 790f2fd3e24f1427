//! Light BVH: chooses one emitter among very many with probability roughly
//! proportional to its contribution at a shading point, after Conty Estevez &
//! Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree
//! Splitting" (the scheme of pbrt-v4's BVH light sampler), with 8-wide nodes
//! evaluated in SIMD lanes (as in sergcpp/Ray's light tree).
//!
//! Each node bounds a set of emitters by a box, their total power Φ, a cone of
//! normals (axis w, half-angle θo) and the spread θe of emission beyond those
//! normals. The importance (`lanes`) turns these into an estimate of what the
//! set sends to a receiver (pbrt-v4's bound, its cosines sharpened), 0 only
//! where the bound says nothing can arrive; [`LightBvh::sample`] walks down from the
//! root choosing one of a node's (up to) eight children with probability
//! proportional to its importance, until a light or a far child (small in the receiver's view,
//! its normals within 90°, the receiver not glossy), among whose lights it chooses ∝ Φ; and
//! [`LightBvh::pmf`] recomputes the probability of any given light by the same products.
//!
//! Two trees, one after the other:
//! - The build tree is binary (top-down, binned cost over all three axes: Φ
//!   times the orientation measure M_Ω times the surface area, scaled by how
//!   thin the node is along the split axis; subtrees in parallel with rayon).
//!   Its 32-byte nodes store bounds quantised so that every rounding enlarges
//!   them: the box as 16-bit codes on a grid over the root box (rounded
//!   outwards), the cone axis as an octahedral code with θo widened by its
//!   coding error, cosines rounded down. Lights are renumbered into leaf order,
//!   so every subtree covers a contiguous range of light ids.
//! - The traversed tree is 8-wide (`wide`): the binary tree collapsed by
//!   opening the child of largest r·Φ² until eight are gathered (near the
//!   leaves, subtrees of ≤ 16 lights by the cut with the fewest nodes), each child's bounds
//!   coded again in 16-bit fields relative to its node (bounding sphere on the
//!   node's grid, cone axis, cosines; Φ as a bfloat16; the power centre as 8-bit
//!   offsets within the sphere and the lights' spread about it in 4 bits), 256
//!   bytes a node, decoded to
//!   f32 lanes as a node is evaluated. Two lights whose bounds hardly differ
//!   (the triangles of a quad) share a lane, which chooses between them in
//!   proportion to power: the ratio of their importances where their boxes and
//!   cones are the same. A lane keeps
//!   the first light id of its range, so `pmf` finds the lane holding a light
//!   without parent links or per-light bit trails. Quantisation can cost
//!   efficiency but never gives 0 to a child that holds a light able to reach
//!   the receiver.
//!
//! Files: `bounds` (LightBounds, cone algebra), `quantise` (grid, cosine and
//! octahedral codes), `node` (the 32-byte build node), `split` (binned split
//! choice), `cost` (the split cost's orientation term in SIMD lanes), `build`
//! (parallel subtree construction), `wide` (8-wide nodes and the collapse),
//! `small_cut` (the collapse of small subtrees), `lanes` (the SIMD importance and far lanes),
//! `power_prefix` (the choice ∝ Φ inside a far lane),
//! `near_field` (the distance and direction terms of the root's and its children's lanes from
//! tables),
//! `traverse` (LightBvh: build entry, sample, pmf), `tests`.

mod bounds;
mod build;
mod cost;
mod lanes;
mod near_field;
mod node;
mod power_prefix;
mod quantise;
mod small_cut;
mod split;
#[cfg(test)]
mod tests;
mod traverse;
mod wide;

use build::*;
use cost::*;
use lanes::*;
use near_field::*;
use node::*;
use power_prefix::*;
use quantise::*;
use small_cut::*;
use split::*;
use wide::*;

pub use bounds::LightBounds;
use bounds::*;
pub use lanes::{Lobe, DEFAULT_FAR_SIN};
pub use traverse::{BinaryTree, LightBvh, RootImportances};

/// The least value of the importance's weighted cosines (`lanes::weighted`): E · R stays
/// above 4e-12 where the zero test keeps a lane (the lane's value is then held at least at
/// `f32::MIN_POSITIVE`).
const COS_FLOOR: f32 = 2e-6;
/// Margin of the zero test (`lanes::lane`), as an angle (radians): a lane is rejected only
/// where the bound's angle lies this far beyond its threshold. The emitter's θe is widened by it
/// when a lane is coded (`WideNode::new`), the receiver's test rejects only where cos θr ≤ −this
/// (below −sin of it). A sine or cosine the lanes take as a leg, √(d² − a²)/d, loses up to
/// √(10ε) ≈ 1.1e-3 (ε = 2⁻²³) where it is near 0, d², the dot product a and p − c each rounded,
/// for a unit normal n (the callers' receivers are normalised); the emitter's test combines two
/// such (sin θw, cos θb) and the receiver's two (sin θi, cos θb), so the f32 angle may overstate
/// the exact one by about 2.2e-3 at a threshold. (The coded axis's length, up to 1.5e-5 off 1,
/// would cost sin θw up to 5.5e-3: θo is widened for it when it is coded, `encode_axis`.) A
/// receiver that f32 puts just outside a sphere it lies inside is still outside the lane's
/// lights, which lie within r/(1 + 4ε) of its centre (`bounding_radius` enlarges the box's half
/// diagonal by 8ε and the codes round the radius up; `wide_lanes_hold_their_lights` checks the
/// margin, as the centre's move to the node's grid eats into it), where the bound holds.
const REJECT_ANGLE: f32 = 4e-3;
/// Angle (radians) added to every cone that is merged or quantised here, larger
/// than the rounding of the f64 computation and of the f32 axis it yields.
const ANGLE_SLACK: f64 = 1e-6;
/// Buckets per axis in the binned build.
const BUCKETS: usize = 12;
/// Subtrees with at least this many lights are built in parallel.
const PARALLEL_MIN: usize = 4096;
/// Nodes of at least twice this many lights bin an even sample of this many of their lights
/// (2¹⁵, about 2,700 to a bucket), which saves a pass over memory at each of a large tree's top
/// levels (the 1M city's per-pixel variance moved by < 0.2%).
const BINNED_SAMPLE: usize = 1 << 15;
/// Smaller nodes of at least this many lights bin an even sample of half as many (2¹², about 340
/// to a bucket; [`split::sample_step`]): at 1M lights that spares about three of the dozen
/// levels that bin every light. The 1M city's 64-spp per-pixel variance stayed within 0.05%
/// (median relative and mean, seeds 3 to 5); samples of n/8 (2¹² to 2¹⁵) for every node from
/// 2¹³ lights on raised the median relative variance by 0.9%.
const SAMPLED_MIN: usize = 1 << 13;
/// The largest f64 below 1.
const LARGEST_BELOW_ONE: f64 = 1.0 - f64::EPSILON / 2.0;
/// Largest 16-bit box coordinate.
const BOX_MAX: u32 = u16::MAX as u32;
/// Largest 15-bit cosine code.
const COS_MAX: u32 = (1 << 15) - 1;
const TWO_SIDED_BIT: u32 = 1 << 30;
const LEAF_BIT: u32 = 1 << 31;
