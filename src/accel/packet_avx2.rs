//! Closest hits of up to eight rays that start close together and point the same way (the
//! camera samples of one pixel), in one walk of the BVH (`walk_avx2`, nearest child first): a
//! child is entered when any ray of the packet hits it, ordered and culled by the least entry
//! distance among those rays against the largest tmax among all, and each triangle is tested
//! against all eight rays at once, one AVX2 lane per ray. The rays share the walk's latency
//! (one chain of node fetches instead of eight), which is what a single-ray walk waits on.
//!
//! Each ray keeps its own closest distance, and the node and triangle tests are the single-ray
//! ones (`node_avx2`, `TestTriangle::intersect`) with the same arithmetic in the same order, so a
//! ray finds the same nearest triangle with the same (t, b1, b2) as when traced alone. Only a
//! tie — two triangles at exactly the same distance — may resolve the other way, since the
//! packet may reach them in another order.

use std::arch::x86_64::*;

use obvhs::ray::Ray;

use super::{node_avx2, walk_avx2, Accel, Hit, TestTriangle, PACKET};

/// The rays of a packet as a walk's query: their lanes, their obvhs rays (whose tmax the node
/// test reads) and the largest tmax among them.
struct Packet<'a> {
    lanes: Lanes,
    rays: &'a mut [Ray],
    reach: f32,
}

/// Eight rays, one lane each: origin, direction, and the nearest hit so far.
struct Lanes {
    ox: __m256,
    oy: __m256,
    oz: __m256,
    dx: __m256,
    dy: __m256,
    dz: __m256,
    tmin: __m256,
    /// Distance of the nearest hit so far (the ray's tmax).
    t: __m256,
    b1: __m256,
    b2: __m256,
    /// Leaf-order slot of the nearest triangle so far (−1: none).
    slot: __m256i,
}

impl Accel {
    /// Closest hits of `rays` (guarded, at most `PACKET`), written to `hits`.
    ///
    /// # Safety
    /// The CPU must support the features of `has_simd_walk`.
    #[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
    pub(super) unsafe fn closest_hits_avx2(&self, rays: &mut [Ray], hits: &mut [Option<Hit>]) {
        debug_assert!(rays.len() <= PACKET && hits.len() == rays.len());
        let node_rays: [_; PACKET] =
            std::array::from_fn(|i| node_avx2::NodeRay::new(&rays[i.min(rays.len() - 1)]));
        let reach = rays.iter().fold(0.0f32, |m, r| m.max(r.tmax));
        let mut packet = Packet {
            lanes: Lanes::new(rays),
            rays,
            reach,
        };
        walk_avx2::walk(
            &self.bvh.nodes,
            &mut packet,
            |packet, node| {
                // The children any ray hits, at the least entry among those rays; the boxes
                // are widened once for all the rays.
                let boxes = node_avx2::child_boxes(node);
                let mut hit = _mm256_setzero_ps();
                let mut entry = _mm256_set1_ps(f32::INFINITY);
                for (ray, node_ray) in packet.rays.iter().zip(&node_rays) {
                    let planes = |axis| node_avx2::box_planes(&boxes, node_ray, axis);
                    let (lanes, t) = node_avx2::hit_and_entry(node, node_ray, ray.tmax, planes);
                    hit = _mm256_or_ps(hit, lanes);
                    entry = _mm256_min_ps(_mm256_blendv_ps(entry, t, lanes), entry);
                }
                (hit, entry)
            },
            |packet| packet.reach,
            |packet, slot| {
                let closer = packet.lanes.intersect(&self.triangles[slot as usize], slot);
                if closer != 0 {
                    // The rays that found a nearer triangle now cull boxes beyond it.
                    let mut t = [0.0f32; PACKET];
                    _mm256_storeu_ps(t.as_mut_ptr(), packet.lanes.t);
                    for (ray, t) in packet.rays.iter_mut().zip(t) {
                        ray.tmax = t;
                    }
                    packet.reach = packet.rays.iter().fold(0.0f32, |m, r| m.max(r.tmax));
                }
                false
            },
        );
        let Packet { lanes, rays, .. } = packet;
        let mut slot = [0i32; PACKET];
        let (mut b1, mut b2) = ([0.0f32; PACKET], [0.0f32; PACKET]);
        _mm256_storeu_si256(slot.as_mut_ptr().cast(), lanes.slot);
        _mm256_storeu_ps(b1.as_mut_ptr(), lanes.b1);
        _mm256_storeu_ps(b2.as_mut_ptr(), lanes.b2);
        for (i, (hit, ray)) in hits.iter_mut().zip(rays.iter()).enumerate() {
            *hit = (slot[i] >= 0).then(|| self.hit(slot[i] as u32, ray.tmax, b1[i], b2[i]));
        }
    }
}

impl Lanes {
    /// The rays in lanes 0..rays.len(); spare lanes repeat the first ray (their hits are
    /// never read).
    #[target_feature(enable = "avx2,fma")]
    unsafe fn new(rays: &[Ray]) -> Lanes {
        fn lane(rays: &[Ray], f: impl Fn(&Ray) -> f32) -> [f32; PACKET] {
            let mut v = [f(&rays[0]); PACKET];
            for (x, ray) in v.iter_mut().zip(rays) {
                *x = f(ray);
            }
            v
        }
        let load = |v: [f32; PACKET]| _mm256_loadu_ps(v.as_ptr());
        Lanes {
            ox: load(lane(rays, |r| r.origin.x)),
            oy: load(lane(rays, |r| r.origin.y)),
            oz: load(lane(rays, |r| r.origin.z)),
            dx: load(lane(rays, |r| r.direction.x)),
            dy: load(lane(rays, |r| r.direction.y)),
            dz: load(lane(rays, |r| r.direction.z)),
            tmin: load(lane(rays, |r| r.tmin)),
            t: load(lane(rays, |r| r.tmax)),
            b1: _mm256_setzero_ps(),
            b2: _mm256_setzero_ps(),
            slot: _mm256_set1_epi32(-1),
        }
    }

    /// Tests one triangle against the eight rays (Möller–Trumbore as in
    /// `TestTriangle::intersect`, operation for operation) and keeps it where it is nearer;
    /// returns the mask of lanes it became the nearest hit of.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn intersect(&mut self, tri: &TestTriangle, slot: u32) -> i32 {
        let s = |x: f32| _mm256_set1_ps(x);
        let (mul, add, sub) = (
            |a, b| _mm256_mul_ps(a, b),
            |a, b| _mm256_add_ps(a, b),
            |a, b| _mm256_sub_ps(a, b),
        );
        // dot(a, b) = (a.x·b.x + a.y·b.y) + a.z·b.z, glam's order.
        let dot = |a: [__m256; 3], b: [__m256; 3]| {
            add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
        };
        let n = tri.normal();
        let n = [s(n.x), s(n.y), s(n.z)];
        let e1 = [s(tri.e1.x), s(tri.e1.y), s(tri.e1.z)];
        let e2 = [s(tri.e2.x), s(tri.e2.y), s(tri.e2.z)];
        let c = [
            sub(s(tri.v0.x), self.ox),
            sub(s(tri.v0.y), self.oy),
            sub(s(tri.v0.z), self.oz),
        ];
        let d = [self.dx, self.dy, self.dz];
        // r = d × c.
        let r = [
            sub(mul(d[1], c[2]), mul(c[1], d[2])),
            sub(mul(d[2], c[0]), mul(c[2], d[0])),
            sub(mul(d[0], c[1]), mul(c[0], d[1])),
        ];
        let inv_det = _mm256_div_ps(s(1.0), dot(n, d));
        let neg = |a| _mm256_xor_ps(a, s(-0.0));
        let b1 = mul(neg(dot(r, e2)), inv_det);
        let b2 = mul(dot(r, e1), inv_det);
        let t = mul(dot(c, n), inv_det);
        let zero = _mm256_setzero_ps();
        let inside = _mm256_and_ps(
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(b1, zero),
                _mm256_cmp_ps::<_CMP_GE_OQ>(b2, zero),
            ),
            _mm256_cmp_ps::<_CMP_LE_OQ>(add(b1, b2), s(1.0)),
        );
        let in_range = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(t, self.tmin),
            _mm256_cmp_ps::<_CMP_LT_OQ>(t, self.t),
        );
        let closer = _mm256_and_ps(inside, in_range);
        let mask = _mm256_movemask_ps(closer);
        if mask != 0 {
            self.t = _mm256_blendv_ps(self.t, t, closer);
            self.b1 = _mm256_blendv_ps(self.b1, b1, closer);
            self.b2 = _mm256_blendv_ps(self.b2, b2, closer);
            self.slot = _mm256_blendv_epi8(
                self.slot,
                _mm256_set1_epi32(slot as i32),
                _mm256_castps_si256(closer),
            );
        }
        mask
    }
}
