//! Ray queries over the scene's triangles with obvhs's compressed 8-wide BVH (CWBVH):
//! closest hit for camera and hemisphere rays, any hit (first hit ends the walk) for shadow
//! rays, with our own triangle test, which returns the barycentrics with the distance. On CPUs
//! with AVX2 + FMA (chosen at run time; the binary still runs on any x86-64) a ray walks the
//! tree nearest child first with an eight-children-at-once node test (`walk_avx2`,
//! `node_avx2`), a pixel's camera rays in one packet (`packet_avx2`); elsewhere the walk is
//! obvhs's `traverse!` loop. All find the same hits, but where a ray grazes a box corner within
//! a few ulps (the AVX2 node test reads the boxes as f32 planes, `planes`, and rounds a plane's
//! distance otherwise than obvhs: `node_avx2`).
//!
//! The triangles are stored eight to a block, field by field (`triangles`), and tested there.
//! A shadow ray first asks the eight triangles that blocked the thread's latest ones, held as
//! one such block (`occluders`), and walks the tree only when none of them blocks it.

use glam::{UVec2, Vec3};
use obvhs::cwbvh::{node::CwBvhNode, CwBvh};
use obvhs::ray::Ray;

use crate::alloc::on_huge_pages;
use crate::cpu::has_avx2_fma;
use crate::sampling::prefetch::prefetch;
use crate::scene::memory::BVH_PART_MAX_TRIANGLES;
use crate::scene::Scene;
use build::build_bvh;
pub use offset::offset_ray_origin;
use triangles::Triangles;
#[cfg(target_arch = "x86_64")]
use triangles_avx2::{nearest_triangle, RayLanes};

mod build;
mod collapse;
mod cut;
#[cfg(target_arch = "x86_64")]
mod masked_avx2;
#[cfg(target_arch = "x86_64")]
mod node_avx2;
mod occluders;
mod offset;
#[cfg(target_arch = "x86_64")]
mod packet_avx2;
#[cfg(target_arch = "x86_64")]
mod planes;
mod triangles;
#[cfg(target_arch = "x86_64")]
mod triangles_avx2;
#[cfg(target_arch = "x86_64")]
mod walk_avx2;

/// The most rays `Accel::closest_hits` traces in one walk.
pub const PACKET: usize = 8;

/// How many triangles ahead a gather of scene triangles in tree order (a part's boxes, the test
/// triangles) asks for the one it will read then: the reads are random, and the hint lets their
/// cache misses overlap (1M city: the test triangles' gather 73 → 46 ms, medians of 5 runs).
const GATHER_AHEAD: usize = 16;

/// The corners of scene triangle `ids[k]`, for a gather that reads `ids` in order: the triangle
/// `GATHER_AHEAD` further on is asked for meanwhile.
#[inline(always)]
fn gathered_positions(scene: &Scene, ids: &[u32], k: usize) -> [Vec3; 3] {
    if let Some(&ahead) = ids.get(k + GATHER_AHEAD) {
        prefetch(&scene.triangles[ahead as usize]);
    }
    scene.triangles[ids[k] as usize].positions
}

/// A ray–triangle intersection: the scene triangle, the distance, and the barycentric weights
/// (b1, b2) of its vertices 1 and 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub triangle: u32,
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
}

pub struct Accel {
    /// This tree's number among the process's (`occluders::new_owner`): it tags the occluders a
    /// thread remembers.
    id: u64,
    /// obvhs's tree: its leaf order, and its nodes where obvhs's walk reads them (no AVX2).
    bvh: CwBvh,
    /// Triangles in BVH leaf order, so that a leaf's primitive id indexes them directly.
    triangles: Triangles,
    /// Whether the CPU has what the AVX2 walk is compiled for (`has_simd_walk`).
    avx2: bool,
    /// The nodes as the AVX2 walk reads them (empty without it).
    #[cfg(target_arch = "x86_64")]
    walk_nodes: Vec<planes::WalkNode>,
}

impl Accel {
    pub fn build(scene: &Scene) -> Accel {
        Accel::build_in_parts(scene, BVH_PART_MAX_TRIANGLES as usize)
    }

    /// [`build`](Self::build) with parts of at most `part_max` triangles (see `build.rs`).
    fn build_in_parts(scene: &Scene, part_max: usize) -> Accel {
        let avx2 = has_simd_walk();
        let bvh = build_bvh(scene, part_max, !avx2);
        let prims = &bvh.primitive_indices;
        // The walks read these at random: on huge pages.
        let triangles =
            on_huge_pages(|| Triangles::new(prims.len(), |k| gathered_positions(scene, prims, k)));
        #[cfg(target_arch = "x86_64")]
        let walk_nodes = if avx2 {
            on_huge_pages(|| planes::walk_nodes(&bvh.nodes))
        } else {
            Vec::new()
        };
        // obvhs's nodes are read by its own walk alone, which runs beside the AVX2 walk only in
        // unit tests, which compare the two on one tree.
        #[cfg(target_arch = "x86_64")]
        let bvh = if avx2 && !cfg!(test) {
            CwBvh {
                nodes: Vec::new(),
                ..bvh
            }
        } else {
            bvh
        };
        Accel {
            id: occluders::new_owner(),
            bvh,
            triangles,
            avx2,
            #[cfg(target_arch = "x86_64")]
            walk_nodes,
        }
    }

    /// Bytes held by the BVH nodes, index map and reordered triangles.
    pub fn bytes(&self) -> usize {
        #[cfg(target_arch = "x86_64")]
        let walk_nodes = std::mem::size_of_val(self.walk_nodes.as_slice());
        #[cfg(not(target_arch = "x86_64"))]
        let walk_nodes = 0;
        std::mem::size_of_val(self.bvh.nodes.as_slice())
            + walk_nodes
            + std::mem::size_of_val(self.bvh.primitive_indices.as_slice())
            + self.triangles.bytes()
    }

    /// The nearest intersection with t in [0, tmax) along a unit direction.
    #[inline]
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let ray = guarded_ray(origin, dir, tmax);
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is true only when the CPU reported the features (`has_simd_walk`).
            return unsafe { self.closest_hit_avx2(&ray) };
        }
        self.closest_hit_walk(&ray, CwBvhNode::intersect_ray)
    }

    /// The nearest intersections (t in [0, ∞)) of up to `PACKET` rays (origin, unit direction),
    /// written to `hits`: each equals what `closest_hit` returns for that ray, up to a tie
    /// between two triangles at exactly the same distance. Rays that start close together and
    /// point the same way (the samples of one pixel) share one walk of the BVH on AVX2 CPUs.
    pub fn closest_hits(&self, rays: &[(Vec3, Vec3)], hits: &mut [Option<Hit>]) {
        assert!(rays.len() <= PACKET && hits.len() == rays.len());
        #[cfg(target_arch = "x86_64")]
        if self.avx2 && rays.len() > 1 {
            let mut guarded = [guarded_ray(Vec3::ZERO, Vec3::Z, 0.0); PACKET];
            for (g, &(origin, dir)) in guarded.iter_mut().zip(rays) {
                *g = guarded_ray(origin, dir, f32::INFINITY);
            }
            // SAFETY: `avx2` is true only when the CPU reported the features (`has_simd_walk`).
            unsafe { self.closest_hits_avx2(&mut guarded[..rays.len()], hits) };
            return;
        }
        for (hit, &(origin, dir)) in hits.iter_mut().zip(rays) {
            *hit = self.closest_hit(origin, dir, f32::INFINITY);
        }
    }

    /// Whether anything lies on the segment origin + t·dir, t ∈ [0, tmax). The triangles that
    /// blocked this thread's latest queries are asked first (`occluders`); the walk runs when
    /// none of them blocks the segment, and the answer is the walk's.
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let ray = guarded_ray(origin, dir, tmax);
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is true only when the CPU reported the features (`has_simd_walk`).
            return unsafe { self.occluded_avx2(&ray) };
        }
        if let Some(block) = occluders::remembered(self.id) {
            if (0..triangles::BLOCK).any(|lane| block.lane(lane).intersect(&ray).is_some()) {
                return true;
            }
        }
        self.blocker_after_walk(self.occluded_walk(&ray, CwBvhNode::intersect_ray))
    }

    /// [`occluded`](Self::occluded) by the walk alone, neither asking nor remembering the
    /// latest occluders: what the BVH itself costs (the ray benchmark's figure beside Embree's).
    pub fn occluded_by_walk(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let ray = guarded_ray(origin, dir, tmax);
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is true only when the CPU reported the features (`has_simd_walk`).
            return unsafe { self.blocker_avx2(&ray, &RayLanes::new(&ray)) }.is_some();
        }
        self.occluded_walk(&ray, CwBvhNode::intersect_ray).is_some()
    }

    /// Whether a walk found `blocker` (a leaf-order slot), which is then remembered.
    #[inline(always)]
    fn blocker_after_walk(&self, blocker: Option<u32>) -> bool {
        if let Some(slot) = blocker {
            occluders::remember(self.id, &self.triangles.get(slot));
        }
        blocker.is_some()
    }

    /// Whether the segment from surface point `a` (unit normal `na` on the segment's side) to
    /// surface point `b` (unit normal `nb` on the segment's side) is blocked. Both ends are moved
    /// off their surfaces, so neither the receiver nor the emitter occludes itself.
    #[inline]
    pub fn segment_occluded(&self, a: Vec3, na: Vec3, b: Vec3, nb: Vec3) -> bool {
        self.segment_occluded_from(offset_ray_origin(a, na), b, nb)
    }

    /// [`segment_occluded`](Self::segment_occluded) with the first end already moved off its
    /// surface (`from` = `offset_ray_origin(a, na)`), for a caller that traces several rays
    /// from one point.
    #[inline]
    pub fn segment_occluded_from(&self, from: Vec3, b: Vec3, nb: Vec3) -> bool {
        let to = offset_ray_origin(b, nb);
        let d = to - from;
        let len = d.length();
        len > 0.0 && self.occluded(from, d / len, len)
    }

    /// The nearest-first walk of one ray: `leaf(ray, base, mask)` is called for the triangles of
    /// each node's leaves it reaches (slots `base + i` for the set bits i of `mask`; it may
    /// shorten `ray.tmax`; true ends the walk); returns the ray as the walk left it.
    ///
    /// # Safety
    /// The CPU must support the features of `has_simd_walk`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    #[inline]
    unsafe fn walk_one_avx2(&self, ray: &Ray, leaf: impl FnMut(&mut Ray, u32, u32) -> bool) -> Ray {
        let node_ray = node_avx2::NodeRay::new(ray);
        let mut walk_ray = *ray;
        walk_avx2::walk(
            &self.walk_nodes,
            0,
            &mut walk_ray,
            |ray, planes, _| node_avx2::test_children(planes, &node_ray, ray.tmax),
            |ray| ray.tmax,
            leaf,
        );
        walk_ray
    }

    /// # Safety
    /// The CPU must support the features of `has_simd_walk`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    unsafe fn closest_hit_avx2(&self, ray: &Ray) -> Option<Hit> {
        let lanes = RayLanes::new(ray);
        let mut best: Option<(u32, f32, f32)> = None;
        let walked = self.walk_one_avx2(ray, |ray, base, mask| {
            let blocks = &self.triangles.blocks;
            let found = nearest_triangle(blocks, &lanes, base, mask, &mut ray.tmax, false);
            best = found.or(best);
            false
        });
        best.map(|(slot, b1, b2)| self.hit(slot, walked.tmax, b1, b2))
    }

    /// # Safety
    /// The CPU must support the features of `has_simd_walk`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    unsafe fn occluded_avx2(&self, ray: &Ray) -> bool {
        let lanes = RayLanes::new(ray);
        if let Some(block) = occluders::remembered(self.id) {
            let (all, mut tmax) = ((1 << triangles::BLOCK) - 1, ray.tmax);
            if nearest_triangle(&[block], &lanes, 0, all, &mut tmax, true).is_some() {
                return true;
            }
        }
        self.blocker_after_walk(self.blocker_avx2(ray, &lanes))
    }

    /// The leaf-order slot of the first triangle the walk finds blocking a guarded ray (`lanes`
    /// its lanes), if any.
    ///
    /// # Safety
    /// The CPU must support the features of `has_simd_walk`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    #[inline]
    unsafe fn blocker_avx2(&self, ray: &Ray, lanes: &RayLanes) -> Option<u32> {
        let mut blocker = None;
        self.walk_one_avx2(ray, |ray, base, mask| {
            let blocks = &self.triangles.blocks;
            blocker = nearest_triangle(blocks, lanes, base, mask, &mut ray.tmax, true)
                .map(|(slot, _, _)| slot);
            blocker.is_some()
        });
        blocker
    }

    /// Closest hit of a guarded ray, its distance measured from the unguarded origin, the
    /// children of a node the ray hits (with its current tmax) given as obvhs's traversal mask
    /// by `node_hits` (obvhs's own test, or `node_avx2`'s inside the AVX2 walks).
    #[inline(always)]
    fn closest_hit_walk(
        &self,
        ray: &Ray,
        node_hits: impl Fn(&CwBvhNode, &Ray, u32) -> u32,
    ) -> Option<Hit> {
        let mut walk_ray = *ray;
        let mut best: Option<(u32, f32, f32)> = None;
        let mut state = self.bvh.new_traversal(ray.direction);
        let mut node;
        obvhs::traverse!(
            self.bvh,
            node,
            state,
            node_hits(node, &walk_ray, state.oct_inv4),
            {
                let slot = state.primitive_id;
                if let Some((t, b1, b2)) = self.triangles.get(slot).intersect(&walk_ray) {
                    walk_ray.tmax = t;
                    best = Some((slot, b1, b2));
                }
            }
        );
        best.map(|(slot, b1, b2)| self.hit(slot, walk_ray.tmax, b1, b2))
    }

    /// The hit on the triangle in leaf-order `slot` at guarded distance `t_guarded`, with its
    /// distance measured from the unguarded origin.
    #[inline(always)]
    fn hit(&self, slot: u32, t_guarded: f32, b1: f32, b2: f32) -> Hit {
        Hit {
            triangle: self.bvh.primitive_indices[slot as usize],
            t: t_guarded - NODE_CULL_GUARD,
            b1,
            b2,
        }
    }

    /// The leaf-order slot of the first triangle found blocking a guarded ray, if any; the walk
    /// ends there (`node_hits` as in `closest_hit_walk`).
    #[inline(always)]
    fn occluded_walk(
        &self,
        ray: &Ray,
        node_hits: impl Fn(&CwBvhNode, &Ray, u32) -> u32,
    ) -> Option<u32> {
        let mut blocker = None;
        let mut state = self.bvh.new_traversal(ray.direction);
        let mut node;
        // The label ends the whole walk: a plain `break` would only leave the macro's inner
        // loop over the leaf's primitives.
        'walk: {
            obvhs::traverse!(
                self.bvh,
                node,
                state,
                node_hits(node, ray, state.oct_inv4),
                {
                    let slot = state.primitive_id;
                    if self.triangles.get(slot).intersect(ray).is_some() {
                        blocker = Some(slot);
                        break 'walk;
                    }
                }
            );
        }
        blocker
    }
}

/// Whether the CPU has AVX2 and FMA, and the bit instructions that come with them on every
/// CPU that has them (POPCNT, LZCNT, BMI1/2): the walk's child indexing counts bits, which
/// without POPCNT is a dozen instructions per node (6% of a walk's samples on the town).
#[cfg(target_arch = "x86_64")]
fn has_simd_walk() -> bool {
    has_avx2_fma()
        && is_x86_feature_detected!("popcnt")
        && is_x86_feature_detected!("lzcnt")
        && is_x86_feature_detected!("bmi1")
        && is_x86_feature_detected!("bmi2")
}

/// Never, off x86-64.
#[cfg(not(target_arch = "x86_64"))]
fn has_simd_walk() -> bool {
    false
}

/// obvhs's node test clamps a child box's entry distance to a fixed 1e-4 (ignoring
/// `ray.tmin`), so a box the ray leaves within 1e-4 of its origin is culled: a wall 5e-5 m
/// from a shading point near a corner would not block its shadow rays. Every ray therefore
/// starts this far behind its true origin, with the triangle test's tmin set to the same
/// distance, so nothing before the true origin is hit and nothing after it is culled.
const NODE_CULL_GUARD: f32 = 1e-3;

/// The obvhs ray for the segment origin + t·dir, t ∈ [0, tmax), shifted back by the guard.
///
/// Direction components of −0.0 become +0.0: obvhs picks a child order from `dir < 0.0` (false
/// for −0.0) but inverts −0.0 to a large negative number, and the two disagree, so an
/// axis-aligned ray such as −Z would miss every box.
#[inline]
fn guarded_ray(origin: Vec3, dir: Vec3, tmax: f32) -> Ray {
    let dir = dir + Vec3::ZERO;
    let start = origin - NODE_CULL_GUARD * dir;
    Ray::new(
        start.into(),
        dir.into(),
        NODE_CULL_GUARD,
        tmax + NODE_CULL_GUARD,
    )
}

#[cfg(test)]
mod tests;
