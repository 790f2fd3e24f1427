//! The CWBVH as the AVX2 walk reads it: each node's child boxes as plain f32 planes, beside
//! obvhs's 8-bit codes, with the few fields of obvhs's node that the walk needs (`WalkNode`).
//! For the node test (`node_avx2`) a plane is one load, a difference and a product from a ray's
//! distance to it, (x − o) · (1/d), where the codes need a widening, an int → float conversion
//! and the node's grid first, all on the walk's chain of dependent instructions (node load →
//! node test → next node). 256 bytes a node, 28 a triangle on the 1M city (213,958 nodes for
//! 1,949,154 triangles, from `Accel::bytes`): a visit reads four cache lines of one list, where
//! the planes alone beside obvhs's 80-byte node made five of two.
//!
//! A code q on an axis with the node's origin p and grid step 2^e stands for the plane
//! p + 2^e · q. That sum is formed exactly (two-sum in f64: 2^e · q is exact, p is an f32) and
//! rounded outward to f32, lower planes down and upper planes up, so no child box shrinks: a
//! ray that enters the box obvhs decodes enters this one. Empty slots keep whatever their codes
//! give: the walk reads a slot's triangles or node only through its meta and inner mask, which
//! an empty slot has neither of.

use obvhs::cwbvh::node::CwBvhNode;
use rayon::prelude::*;

/// One node's eight child boxes, plane by plane (lower x, upper x, lower y, upper y, lower z,
/// upper z), eight children per plane so one 32-byte load gives a plane for all of them. 192
/// bytes, aligned to a cache line so a node's planes span exactly three.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct ChildPlanes(pub(super) [[f32; 8]; 6]);

impl ChildPlanes {
    /// The planes of `node`'s children, rounded outward.
    pub(super) fn of(node: &CwBvhNode) -> ChildPlanes {
        let extent = node.compute_extent();
        let codes = [
            &node.child_min_x,
            &node.child_max_x,
            &node.child_min_y,
            &node.child_max_y,
            &node.child_min_z,
            &node.child_max_z,
        ];
        let mut planes = [[0.0f32; 8]; 6];
        for (plane, (row, q)) in planes.iter_mut().zip(codes).enumerate() {
            let axis = plane / 2;
            let upper = plane % 2 == 1;
            for (x, &q) in row.iter_mut().zip(q) {
                *x = outward(node.p[axis], extent[axis], q, upper);
            }
        }
        ChildPlanes(planes)
    }
}

/// p + step · q rounded to the f32 at or below it (`upper` false) or at or above it (`upper`
/// true). In f64, a = step · q is exact (8 bits times a power of two) and s + err = p + a
/// exactly (Knuth's two-sum); the f32 nearest s is then moved one step out if it lies on the
/// wrong side of s + err (its difference from s is exact, the two being within an f32 ulp).
fn outward(p: f32, step: f32, q: u8, upper: bool) -> f32 {
    let (p, a) = (f64::from(p), f64::from(step) * f64::from(q));
    let s = p + a;
    let a_part = s - p;
    let err = (p - (s - a_part)) + (a - a_part);
    let nearest = s as f32;
    let above = f64::from(nearest) - s;
    if upper && above < err {
        nearest.next_up()
    } else if !upper && above > err {
        nearest.next_down()
    } else {
        nearest
    }
}

/// One CWBVH node as the AVX2 walk reads it: its children's planes, and obvhs's indices, leaf
/// metadata and inner-child mask (`CwBvhNode` says what they mean). 256 bytes, four cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct WalkNode {
    pub(super) planes: ChildPlanes,
    /// The node index of its first inner child; the others follow in slot order.
    pub(super) child_base: u32,
    /// The leaf-order slot its leaf children's triangles are counted from.
    pub(super) primitive_base: u32,
    /// Per child slot: a leaf's first triangle (low five bits) and count (high three, unary).
    pub(super) child_meta: [u8; 8],
    /// Bit k set: slot k is an inner node.
    pub(super) imask: u8,
}

impl WalkNode {
    pub(super) fn of(node: &CwBvhNode) -> WalkNode {
        WalkNode {
            planes: ChildPlanes::of(node),
            child_base: node.child_base_idx,
            primitive_base: node.primitive_base_idx,
            child_meta: node.child_meta,
            imask: node.imask,
        }
    }

    /// The triangles of the leaf children among `hits` (bit k: slot k), as bits i of slots
    /// `primitive_base + i`: an empty slot has meta 0, no triangles; a leaf's meta holds its first
    /// triangle's offset from the base in its low five bits (below 24: obvhs gives a node's
    /// leaves at most 24 triangles, in slot order) and its count in unary in the high three.
    #[inline(always)]
    pub(super) fn leaf_triangles(&self, hits: u32) -> u32 {
        let mut leaves = hits & !u32::from(self.imask);
        let mut triangles = 0u32;
        while leaves != 0 {
            let slot = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            let meta = u32::from(self.child_meta[slot]);
            triangles |= ((1 << (meta >> 5).count_ones()) - 1) << (meta & 0b1_1111);
        }
        triangles
    }
}

/// The walk's node for every node of `nodes`, in the same order, made in parallel (on one thread
/// the planes were about 0.8% of a 1M-emitter city render's CPU samples in perf; in parallel the
/// render's `bvh build` line fell from a median 0.985 to 0.963 s, 12 alternating runs).
pub(super) fn walk_nodes(nodes: &[CwBvhNode]) -> Vec<WalkNode> {
    nodes.par_iter().map(WalkNode::of).collect()
}
