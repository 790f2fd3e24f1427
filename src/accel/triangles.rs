//! The triangles as the ray tests read them, in BVH leaf order: v0, E1 = v1 − v0, E2 = v2 − v0,
//! stored eight triangles to a block, field by field (36 bytes a triangle, as one triangle after
//! another would take), so that the AVX2 walk tests a node's leaf triangles eight in one pass
//! (`triangles_avx2`) and the other tests read one triangle's fields from the lanes.
//!
//! Triangle test (Möller & Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection", 1997,
//! in the form with the triangle's normal and one cross product with the ray): with
//! n = E1 × E2, c = v0 − o, r = d × c and D = n·d, Cramer's rule on o + t·d = v0 + b1·E1 + b2·E2
//! gives t = (c·n)/D, b1 = −(r·E2)/D, b2 = (r·E1)/D; the ray hits when b1 ≥ 0, b2 ≥ 0,
//! b1 + b2 ≤ 1 and t lies in [tmin, tmax). D = 0 (a ray in the triangle's plane) gives an
//! infinite or NaN weight and fails the tests. The normal is formed in each test instead of
//! stored: 12 bytes less per triangle, neutral on the city and town in `cargo bench --bench
//! rays`, 4–10% slower on the 32-triangle Cornell box, where every ray is all triangle tests.

use glam::{Vec3, Vec3A};
use obvhs::ray::Ray;
use rayon::prelude::*;

/// Triangles in one block.
pub(super) const BLOCK: usize = 8;

/// One triangle's fields for the one-at-a-time tests.
#[derive(Clone, Copy, Debug)]
pub(super) struct TestTriangle {
    pub(super) v0: Vec3,
    pub(super) e1: Vec3,
    pub(super) e2: Vec3,
}

impl TestTriangle {
    /// n = E1 × E2, unnormalised.
    #[inline(always)]
    pub(super) fn normal(&self) -> Vec3A {
        Vec3A::from(self.e1).cross(Vec3A::from(self.e2))
    }

    /// (t, b1, b2) of the hit with t ∈ [ray.tmin, ray.tmax), or None (see the module header).
    #[inline(always)]
    pub(super) fn intersect(&self, ray: &Ray) -> Option<(f32, f32, f32)> {
        let n = self.normal();
        let c = Vec3A::from(self.v0) - ray.origin;
        let r = ray.direction.cross(c);
        let inv_det = 1.0 / n.dot(ray.direction);
        let b1 = -r.dot(Vec3A::from(self.e2)) * inv_det;
        let b2 = r.dot(Vec3A::from(self.e1)) * inv_det;
        if !(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0) {
            return None;
        }
        let t = c.dot(n) * inv_det;
        (t >= ray.tmin && t < ray.tmax).then_some((t, b1, b2))
    }
}

/// Eight triangles: for each of v0, E1 and E2, the x, y and z of all eight (unused lanes of
/// the last block are 0: a degenerate triangle, which no ray hits).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct Block {
    pub(super) v0: [[f32; BLOCK]; 3],
    pub(super) e1: [[f32; BLOCK]; 3],
    pub(super) e2: [[f32; BLOCK]; 3],
}

impl Block {
    /// No triangle in any lane.
    pub(super) const EMPTY: Block = Block {
        v0: [[0.0; BLOCK]; 3],
        e1: [[0.0; BLOCK]; 3],
        e2: [[0.0; BLOCK]; 3],
    };

    /// The triangle in lane `lane`.
    #[inline(always)]
    pub(super) fn lane(&self, lane: usize) -> TestTriangle {
        let field = |f: &[[f32; BLOCK]; 3]| Vec3::new(f[0][lane], f[1][lane], f[2][lane]);
        TestTriangle {
            v0: field(&self.v0),
            e1: field(&self.e1),
            e2: field(&self.e2),
        }
    }

    /// Puts `triangle` in lane `lane`.
    #[inline]
    pub(super) fn set(&mut self, lane: usize, triangle: &TestTriangle) {
        for axis in 0..3 {
            self.v0[axis][lane] = triangle.v0[axis];
            self.e1[axis][lane] = triangle.e1[axis];
            self.e2[axis][lane] = triangle.e2[axis];
        }
    }
}

/// The triangles in leaf order, in blocks of [`BLOCK`].
#[derive(Debug)]
pub(super) struct Triangles {
    pub(super) blocks: Vec<Block>,
}

impl Triangles {
    /// The triangles `corners(k)` for k in 0..count, in that order, a block per rayon task
    /// (the corners are gathered from the scene in leaf order: random reads, which the second
    /// core halves).
    pub(super) fn new(count: usize, corners: impl Fn(usize) -> [Vec3; 3] + Sync) -> Triangles {
        let blocks = (0..count.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut block = Block::EMPTY;
                for lane in 0..BLOCK.min(count - b * BLOCK) {
                    let [p0, p1, p2] = corners(b * BLOCK + lane);
                    for axis in 0..3 {
                        block.v0[axis][lane] = p0[axis];
                        block.e1[axis][lane] = p1[axis] - p0[axis];
                        block.e2[axis][lane] = p2[axis] - p0[axis];
                    }
                }
                block
            })
            .collect();
        Triangles { blocks }
    }

    /// Triangle `slot`'s fields.
    #[inline(always)]
    pub(super) fn get(&self, slot: u32) -> TestTriangle {
        self.blocks[slot as usize / BLOCK].lane(slot as usize % BLOCK)
    }

    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(self.blocks.as_slice())
    }
}
