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

/// A binary node as a candidate lane: its index and the first id of its range.
#[derive(Clone, Copy, Debug)]
struct Lane {
    index: usize,
    first: usize,
}

/// The wide tree of the binary depth-first tree `binary` (root at 0): wide
/// node 0 is the root, children come after their parent.
pub(super) fn collapse(binary: &[Node], grid: &Grid) -> Vec<WideNode> {
    if binary.is_empty() {
        return Vec::new();
    }
    // Sized exactly: the nodes are over-aligned, so growing or shrinking the list copies it
    // (the system allocator's realloc does not keep a 64-byte alignment), which for a million
    // lights held 132 MB twice.
    let mut wide = Vec::with_capacity(count_wide(binary));
    wide.push(WideNode::empty());
    let mut pending = vec![(Lane { index: 0, first: 0 }, 0)];
    while let Some((start, slot)) = pending.pop() {
        let mut node = WideNode::empty();
        for (k, lane) in open(binary, start).into_iter().flatten().enumerate() {
            let b = &binary[lane.index];
            node.set_lane(k, b, grid);
            node.first[k] = lane.first as u32;
            node.child[k] = if b.is_leaf() {
                LIGHT_LANE | b.link
            } else {
                wide.push(WideNode::empty());
                pending.push((lane, wide.len() - 1));
                (wide.len() - 1) as u32
            };
        }
        wide[slot] = node;
    }
    debug_assert_eq!(wide.len(), wide.capacity());
    wide
}

/// How many wide nodes [`collapse`] makes: one for the root and one per interior lane.
fn count_wide(binary: &[Node]) -> usize {
    let mut count = 1;
    let mut pending = vec![Lane { index: 0, first: 0 }];
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
        };
        let right = Lane {
            index: node.link as usize,
            first: node.right_first(lane.index, lane.first),
        };
        lanes.copy_within(k + 1..used, k + 2);
        lanes[k] = Some(left);
        lanes[k + 1] = Some(right);
        used += 1;
    }
    lanes
}
