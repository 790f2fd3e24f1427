//! The child boxes of each CWBVH node as plain f32 planes, beside obvhs's 8-bit codes, for the
//! AVX2 node test (`node_avx2`): a plane is one load, a difference and a product from a ray's
//! distance to it, (x − o) · (1/d), where the codes need a widening, an int → float conversion
//! and the node's grid first, all on the walk's chain of dependent instructions (node load →
//! node test → next node). 192 bytes a node, about 20 a triangle.
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

/// The planes of every node of `nodes`, in the same order, made in parallel (on one thread they
/// were about 0.8% of a 1M-emitter city render's CPU samples in perf; in parallel the render's
/// `bvh build` line fell from a median 0.985 to 0.963 s, 12 alternating runs).
pub(super) fn child_planes(nodes: &[CwBvhNode]) -> Vec<ChildPlanes> {
    nodes.par_iter().map(ChildPlanes::of).collect()
}
