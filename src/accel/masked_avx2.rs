//! Closest hits of up to eight rays that start close together but point any way (the bounce
//! rays of one pixel's samples), in one walk that keeps with each node the mask of the rays that
//! entered it. At a node the children are tested ray by ray for those rays only (`node_avx2`'s
//! single-ray test, the node's planes loaded once); each leaf child's triangles are tested by
//! the rays that hit it, eight triangles to a pass as for one ray; each inner child is entered
//! with the rays that hit it, nearest first by the least entry among them; and a subtree that
//! one ray alone enters is walked by that ray alone (`walk_avx2::walk` from that node). The
//! rays share the nodes near their origins, where most of a walk's node fetches and tests are,
//! and part ways below.
//!
//! Each ray tests exactly the triangles of the leaves it hits, with the single-ray arithmetic,
//! and enters every child it hits while within its reach, so it finds the same nearest triangle
//! with the same (t, b1, b2) as when traced alone; only a tie (two triangles at exactly the same
//! distance) may resolve the other way, the packet reaching them in another order.

use std::arch::x86_64::*;
use std::mem::MaybeUninit;

use obvhs::ray::Ray;

use super::node_avx2::{self, NodeRay};
use super::triangles_avx2::{nearest_triangle, RayLanes};
use super::walk_avx2::{self, push_by_distance, STACK};
use super::{Accel, Hit, PACKET};

impl Accel {
    /// Closest hits of `rays` (guarded, 2 ..= `PACKET` of them), written to `hits`.
    ///
    /// # Safety
    /// The CPU must support the features of `has_simd_walk`.
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    pub(super) unsafe fn closest_hits_masked_avx2(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        debug_assert!((2..=PACKET).contains(&rays.len()) && hits.len() == rays.len());
        let nodes = &self.walk_nodes;
        if nodes.is_empty() {
            hits.fill(None);
            return;
        }
        let mut node_rays = [NodeRay::new(&rays[0]); PACKET];
        let mut lanes = [RayLanes::new(&rays[0]); PACKET];
        let mut tmax = [0.0f32; PACKET];
        for (i, ray) in rays.iter().enumerate() {
            node_rays[i] = NodeRay::new(ray);
            lanes[i] = RayLanes::new(ray);
            tmax[i] = ray.tmax;
        }
        let mut best: [Option<(u32, f32, f32)>; PACKET] = [None; PACKET];
        // Entries (node, ray mask, least entry), as many as `walk_avx2`'s.
        let mut stack: [MaybeUninit<(u32, u32, f32)>; STACK] = [MaybeUninit::uninit(); STACK];
        let mut len = 0usize;
        let (mut index, mut mask) = (0u32, (1u32 << rays.len()) - 1);
        loop {
            if mask & (mask - 1) == 0 {
                // One ray: its own walk of the subtree.
                let r = mask.trailing_zeros() as usize;
                let mut walk_ray = rays[r];
                walk_ray.tmax = tmax[r];
                let (node_ray, ray_lanes) = (&node_rays[r], &lanes[r]);
                let found = &mut best[r];
                walk_avx2::walk(
                    nodes,
                    index,
                    &mut walk_ray,
                    |ray, planes, _| node_avx2::test_children(planes, node_ray, ray.tmax),
                    |ray| ray.tmax,
                    |ray, base, triangles| {
                        let hit = nearest_triangle(
                            &self.triangles.blocks,
                            ray_lanes,
                            base,
                            triangles,
                            &mut ray.tmax,
                            false,
                        );
                        *found = hit.or(*found);
                        false
                    },
                );
                tmax[r] = walk_ray.tmax;
            } else {
                let node = &nodes[index as usize];
                let imask = node.imask as u32;
                // Lane k: the mask of the rays that hit child k, and the least of their entries.
                let mut rays_of = _mm256_setzero_si256();
                let mut entry = _mm256_set1_ps(f32::INFINITY);
                let mut each = mask;
                while each != 0 {
                    let r = each.trailing_zeros() as usize;
                    each &= each - 1;
                    let (hit, t) = node_avx2::test_children(&node.planes, &node_rays[r], tmax[r]);
                    let bit = _mm256_set1_epi32(1 << r);
                    rays_of =
                        _mm256_or_si256(rays_of, _mm256_and_si256(_mm256_castps_si256(hit), bit));
                    entry = _mm256_min_ps(entry, _mm256_blendv_ps(entry, t, hit));
                    // The triangles of the leaf children it hits.
                    let triangles = node.leaf_triangles(_mm256_movemask_ps(hit) as u32);
                    if triangles != 0 {
                        let hit = nearest_triangle(
                            &self.triangles.blocks,
                            &lanes[r],
                            node.primitive_base,
                            triangles,
                            &mut tmax[r],
                            false,
                        );
                        best[r] = hit.or(best[r]);
                    }
                }
                let (mut masks, mut entries) = ([0u32; 8], [0.0f32; 8]);
                _mm256_storeu_si256(masks.as_mut_ptr().cast(), rays_of);
                _mm256_storeu_ps(entries.as_mut_ptr(), entry);
                let entered = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(
                    rays_of,
                    _mm256_setzero_si256(),
                ))) as u32;
                let mut inner = entered & imask;
                // The nearest inner child is next, without a trip through the stack; the others
                // are pushed, nearest on top.
                let next = if inner != 0 {
                    let mut nearest = inner.trailing_zeros();
                    let mut rest = inner & (inner - 1);
                    while rest != 0 {
                        let slot = rest.trailing_zeros();
                        rest &= rest - 1;
                        if entries[slot as usize] <= entries[nearest as usize] {
                            nearest = slot;
                        }
                    }
                    inner &= !(1 << nearest);
                    let child = node.child_base + _bzhi_u32(imask, nearest).count_ones();
                    Some((child, masks[nearest as usize], entries[nearest as usize]))
                } else {
                    None
                };
                let bottom = len;
                while inner != 0 {
                    let slot = inner.trailing_zeros();
                    inner &= inner - 1;
                    let child = node.child_base + _bzhi_u32(imask, slot).count_ones();
                    let (m, t) = (masks[slot as usize], entries[slot as usize]);
                    // SAFETY: bottom ≤ len < STACK, the entries below len written.
                    push_by_distance(&mut stack, bottom, &mut len, (child, m, t), |e| e.2);
                }
                if let Some((child, rays, t)) = next {
                    // Its rays that a nearer hit in the leaves has not put out of reach.
                    let within = within_reach(rays, t, &tmax);
                    if within != 0 {
                        (index, mask) = (child, within);
                        continue;
                    }
                }
            }
            // The next entry with a ray still within reach of it.
            loop {
                if len == 0 {
                    for (hit, (found, t)) in hits.iter_mut().zip(best.into_iter().zip(tmax)) {
                        *hit = found.map(|(slot, b1, b2)| self.hit(slot, t, b1, b2));
                    }
                    return;
                }
                len -= 1;
                // SAFETY: `len` < `STACK`, and every entry below the old `len` was written.
                let (child, m, t) = stack.get_unchecked(len).assume_init();
                let within = within_reach(m, t, &tmax);
                if within != 0 {
                    (index, mask) = (child, within);
                    break;
                }
            }
        }
    }
}

/// The rays of `mask` whose tmax is at least `entry` (a child's least entry among them).
#[inline(always)]
fn within_reach(mask: u32, entry: f32, tmax: &[f32; PACKET]) -> u32 {
    let mut within = 0;
    let mut each = mask;
    while each != 0 {
        let r = each.trailing_zeros();
        each &= each - 1;
        within |= u32::from(entry <= tmax[r as usize]) << r;
    }
    within
}
