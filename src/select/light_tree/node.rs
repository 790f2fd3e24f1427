//! One 32-byte node of the binary build tree (quantised bounds, leaf bit, link
//! to the right child), from which [`super::wide::collapse`] makes wide nodes.

use super::*;

/// A compact tree node: 32 bytes, decoded on the fly.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Node {
    /// Box corners on the tree's [`Grid`].
    pub(super) lo: [u16; 3],
    pub(super) hi: [u16; 3],
    /// Octahedral code of the cone axis.
    pub(super) axis: u32,
    pub(super) phi: f32,
    /// Bits 0–14 cos θo, 15–29 cos θe, 30 two-sided, 31 leaf.
    pub(super) cones: u32,
    /// Right child (interior node) or the light id (leaf). The first light id
    /// of a right child's range is its parent's plus half the distance from
    /// parent to right child (the left subtree's 2k − 1 nodes hold k lights).
    pub(super) link: u32,
    /// [`bounding_radius`] of the decoded box.
    pub(super) radius: f32,
}

impl Node {
    /// A node with its place in the tree only; bounds come later.
    pub(super) fn topology(link: u32, leaf: bool) -> Node {
        Node {
            link,
            cones: if leaf { LEAF_BIT } else { 0 },
            ..Node::default()
        }
    }

    /// `self`'s topology with the quantised `bounds`.
    pub(super) fn with_bounds(self, b: &LightBounds, grid: &Grid) -> Node {
        let (axis, cos_o) = encode_cone(b.w, b.cos_theta_o);
        let cos_e = encode_cos(f64::from(b.cos_theta_e));
        let two_sided = if b.two_sided { TWO_SIDED_BIT } else { 0 };
        let node = Node {
            lo: grid.encode(b.lo, false),
            hi: grid.encode(b.hi, true),
            axis,
            phi: b.phi,
            cones: cos_o | cos_e << 15 | two_sided | (self.cones & LEAF_BIT),
            ..self
        };
        let (centre, half_diagonal_sq) = node.bounds(grid).centre_and_half_diagonal_sq();
        Node {
            radius: bounding_radius(centre, half_diagonal_sq),
            ..node
        }
    }

    pub(super) fn is_leaf(&self) -> bool {
        self.cones & LEAF_BIT != 0
    }

    #[inline(always)]
    pub(super) fn bounds(&self, grid: &Grid) -> LightBounds {
        LightBounds {
            lo: grid.decode(self.lo),
            hi: grid.decode(self.hi),
            phi: self.phi,
            w: decode_octahedral(self.axis),
            cos_theta_o: decode_cos(self.cones & COS_MAX),
            cos_theta_e: decode_cos((self.cones >> 15) & COS_MAX),
            two_sided: self.cones & TWO_SIDED_BIT != 0,
        }
    }

    /// First light id of the right child's range, `first` being this
    /// interior node's, at `index`.
    pub(super) fn right_first(&self, index: usize, first: usize) -> usize {
        first + (self.link as usize - index) / 2
    }
}
