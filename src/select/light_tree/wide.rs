//! The 8-wide tree that is traversed: each [`WideNode`] holds up to eight
//! children ("lanes") laid out field by field, so one node's importances are
//! computed together in SIMD lanes ([`super::lanes`]) and a choice descends
//! about three binary levels at once.
//!
//! [`collapse`] turns the binary build tree into wide nodes: starting from a
//! binary node it repeatedly opens the interior lane with the largest bounding
//! sphere (replacing it, in place, by its two children) until eight lanes are
//! filled or only leaves remain. Lanes keep light-id order, so each lane
//! covers a contiguous id range starting at `first`, and `pmf` can find the
//! lane holding a light without parent links.

use rayon::prelude::*;

use super::*;

/// Children per wide node.
pub(super) const LANES: usize = 8;
/// Set in `child` when the lane is a single light (the other bits its id).
pub(super) const LIGHT_LANE: u32 = 1 << 31;
/// `first` of an unused lane: larger than every light id.
pub(super) const EMPTY_LANE: u32 = u32::MAX;

/// Up to eight children's bounds in f32, one array per field (structure of
/// arrays): 384 bytes, six cache lines, aligned to a cache line.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub(super) struct WideNode {
    /// Centre of each child's bounding sphere.
    pub(super) centre: [[f32; LANES]; 3],
    /// Radius of that sphere ([`bounding_radius`] of the quantised box).
    pub(super) radius: [f32; LANES],
    /// Power Φ, negated for two-sided children; 0 in unused lanes.
    pub(super) signed_phi: [f32; LANES],
    /// Normal cone axis w.
    pub(super) axis: [[f32; LANES]; 3],
    /// cos θo of the normal cone.
    pub(super) cos_o: [f32; LANES],
    /// cos θe of the emission spread.
    pub(super) cos_e: [f32; LANES],
    /// Index of the child wide node, or `LIGHT_LANE | light id`.
    pub(super) child: [u32; LANES],
    /// First light id of the lane's range ([`EMPTY_LANE`] if unused).
    pub(super) first: [u32; LANES],
}

impl WideNode {
    /// A node with every lane unused (Φ = 0: importance 0).
    pub(super) fn empty() -> WideNode {
        WideNode {
            centre: [[0.0; LANES]; 3],
            radius: [0.0; LANES],
            signed_phi: [0.0; LANES],
            axis: [[0.0; LANES], [0.0; LANES], [1.0; LANES]],
            cos_o: [1.0; LANES],
            cos_e: [1.0; LANES],
            child: [0; LANES],
            first: [EMPTY_LANE; LANES],
        }
    }

    /// Stores the decoded bounds of binary `node` in lane `k`.
    fn set_lane(&mut self, k: usize, node: &Node, grid: &Grid) {
        let b = node.bounds(grid);
        let (centre, _) = b.centre_and_half_diagonal_sq();
        for axis in 0..3 {
            self.centre[axis][k] = centre[axis];
            self.axis[axis][k] = b.w[axis];
        }
        self.radius[k] = node.radius;
        self.signed_phi[k] = if b.two_sided { -b.phi } else { b.phi };
        self.cos_o[k] = b.cos_theta_o;
        self.cos_e[k] = b.cos_theta_e;
    }

    /// The lane whose id range holds `light`: the last used lane starting at
    /// or before it.
    pub(super) fn lane_of(&self, light: u32) -> Option<usize> {
        self.first
            .iter()
            .rposition(|&first| first != EMPTY_LANE && first <= light)
    }
}

/// A binary node as a candidate lane: its index, the first id of its range and how many
/// lights the range holds.
#[derive(Clone, Copy, Debug)]
struct Lane {
    index: usize,
    first: usize,
    count: usize,
}

/// Below lanes of fewer lights the subtrees are collapsed by one rayon task each.
const PARALLEL_COLLAPSE_MIN: usize = 1 << 14;

/// The wide tree of the binary depth-first tree `binary` (root at 0): wide node 0 is the root,
/// and a node's children come after it. The top is collapsed first, down to lanes of fewer than
/// [`PARALLEL_COLLAPSE_MIN`] lights; the subtrees below those lanes are counted, given their
/// ranges of the list, and collapsed into them in parallel.
pub(super) fn collapse(binary: &[Node], grid: &Grid) -> Vec<WideNode> {
    if binary.is_empty() {
        return Vec::new();
    }
    let root = Lane {
        index: 0,
        first: 0,
        count: binary.len().div_ceil(2),
    };
    // (lane, node, lane slot) of each subtree left for later.
    let mut deferred = Vec::new();
    let mut wide = vec![WideNode::empty()];
    let mut pending = vec![(root, 0)];
    while let Some((start, slot)) = pending.pop() {
        wide[slot] = wide_node(binary, grid, start, |k, lane| {
            if lane.count < PARALLEL_COLLAPSE_MIN {
                deferred.push((lane, slot, k));
                return 0;
            }
            wide.push(WideNode::empty());
            pending.push((lane, wide.len() - 1));
            (wide.len() - 1) as u32
        });
    }
    let counts: Vec<usize> = deferred
        .par_iter()
        .map(|&(lane, _, _)| count_wide(binary, lane))
        .collect();
    // Sized once: the nodes are over-aligned, so growing or shrinking the list would copy it
    // (the system allocator's realloc does not keep a 64-byte alignment).
    let (top, below): (usize, usize) = (wide.len(), counts.iter().sum());
    wide.reserve_exact(below);
    wide.resize(top + below, WideNode::empty());
    let mut blocks = Vec::with_capacity(deferred.len());
    let mut rest = &mut wide[top..];
    let mut base = top;
    for (&(lane, slot, k), &count) in deferred.iter().zip(&counts) {
        let (block, after) = rest.split_at_mut(count);
        blocks.push((lane, block, base as u32, slot, k));
        rest = after;
        base += count;
    }
    let roots: Vec<(usize, usize, u32)> = blocks
        .into_par_iter()
        .map(|(lane, block, base, slot, k)| {
            collapse_block(binary, grid, lane, block, base);
            (slot, k, base)
        })
        .collect();
    for (slot, k, base) in roots {
        wide[slot].child[k] = base;
    }
    wide
}

/// The wide node of lanes `open(start)`: their bounds, first ids and children, an interior
/// lane's child index being `child(lane slot, lane)`.
fn wide_node(
    binary: &[Node],
    grid: &Grid,
    start: Lane,
    mut child: impl FnMut(usize, Lane) -> u32,
) -> WideNode {
    let mut node = WideNode::empty();
    for (k, lane) in open(binary, start).into_iter().flatten().enumerate() {
        let b = &binary[lane.index];
        node.set_lane(k, b, grid);
        node.first[k] = lane.first as u32;
        node.child[k] = if b.is_leaf() {
            LIGHT_LANE | b.link
        } else {
            child(k, lane)
        };
    }
    node
}

/// Collapses the subtree of lane `start` into `block` (exactly its size, from
/// [`count_wide`]), whose first node has index `base` in the whole list.
fn collapse_block(binary: &[Node], grid: &Grid, start: Lane, block: &mut [WideNode], base: u32) {
    let mut used = 1;
    let mut pending = vec![(start, 0)];
    while let Some((start, slot)) = pending.pop() {
        block[slot] = wide_node(binary, grid, start, |_, lane| {
            pending.push((lane, used));
            used += 1;
            base + used as u32 - 1
        });
    }
    debug_assert_eq!(used, block.len());
}

/// How many wide nodes the subtree of lane `start` makes: one for its root and one per
/// interior lane below.
fn count_wide(binary: &[Node], start: Lane) -> usize {
    let mut count = 1;
    let mut pending = vec![start];
    while let Some(start) = pending.pop() {
        for lane in open(binary, start).into_iter().flatten() {
            if !binary[lane.index].is_leaf() {
                count += 1;
                pending.push(lane);
            }
        }
    }
    count
}

/// The lanes of the wide node rooted at binary node `start`: `start` itself
/// if it is a leaf, else its children, with the interior lane of largest
/// radius opened while fewer than eight lanes are used.
fn open(binary: &[Node], start: Lane) -> [Option<Lane>; LANES] {
    let mut lanes = [None; LANES];
    lanes[0] = Some(start);
    let mut used = 1;
    while used < LANES {
        let widest = lanes[..used]
            .iter()
            .enumerate()
            .filter_map(|(k, lane)| lane.map(|l| (k, l)))
            .filter(|(_, l)| !binary[l.index].is_leaf())
            .max_by(|a, b| {
                binary[a.1.index]
                    .radius
                    .total_cmp(&binary[b.1.index].radius)
            });
        let Some((k, lane)) = widest else { break };
        let node = &binary[lane.index];
        let left = Lane {
            index: lane.index + 1,
            first: lane.first,
            count: (node.link as usize - lane.index) / 2,
        };
        let right = Lane {
            index: node.link as usize,
            first: node.right_first(lane.index, lane.first),
            count: lane.count - left.count,
        };
        lanes.copy_within(k + 1..used, k + 2);
        lanes[k] = Some(left);
        lanes[k + 1] = Some(right);
        used += 1;
    }
    lanes
}
