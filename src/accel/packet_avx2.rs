//! Closest hits of up to eight rays that start close together and point the same way (the
//! camera samples of one pixel), in one walk of the BVH (`walk_avx2`, nearest child first),
//! each triangle tested against all eight rays at once, one AVX2 lane per ray. The rays share
//! the walk's latency (one chain of node fetches instead of eight), which is what a single-ray
//! walk waits on.
//!
//! When the rays all run the same way along each axis, a node's children take one interval
//! test for all of them (`node_avx2::test_packet`, from the bounds of their origins and inverse
//! directions): an inner child is entered unless no ray can hit it, ordered and culled by a
//! lower bound of the entry distance of the rays that hit it against the largest tmax among
//! all; a leaf child the interval test keeps is tested ray by ray (all the rays at once), and
//! its triangles only when a ray hits its box. The interval spans the whole region between the
//! rays (a pixel's footprint) and a leaf costs all eight rays' triangle tests: with leaves
//! taken by the interval test alone, the 1M-emitter city at 32 × 24 pixels tested 8.4 times
//! the triangles and saved nothing. Packets whose rays run different ways along some axis (the
//! bounce rays of a pixel's samples) take the walk of `masked_avx2`, which keeps the rays of
//! each subtree apart.
//!
//! Each ray keeps its own closest distance and the triangle tests are the single-ray ones
//! (`TestTriangle::intersect`) with the same arithmetic in the same order; every child a ray
//! hits is entered while within its reach, so a ray finds the same nearest triangle with the
//! same (t, b1, b2) as when traced alone. Only a tie — two triangles at exactly the same
//! distance — may resolve the other way, since the packet may reach them in another order.

use std::arch::x86_64::*;

use obvhs::ray::Ray;

use glam::Vec3;

use super::planes::ChildPlanes;
use super::triangles::TestTriangle;
use super::triangles_avx2::{moller_trumbore, Tested};
use super::{node_avx2, walk_avx2, Accel, Hit, PACKET};

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
    /// Inverse direction (obvhs's, as the node tests use it).
    ix: __m256,
    iy: __m256,
    iz: __m256,
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
        let lanes = Lanes::new(rays);
        let Some(bounds) = node_avx2::NodePacket::new(
            [lanes.ox, lanes.oy, lanes.oz],
            [lanes.dx, lanes.dy, lanes.dz],
            [lanes.ix, lanes.iy, lanes.iz],
        ) else {
            // Rays that run different ways along some axis: each subtree is walked by the rays
            // that enter it.
            return self.closest_hits_masked_avx2(rays, hits);
        };
        let reach = rays.iter().fold(0.0f32, |m, r| m.max(r.tmax));
        let mut packet = Packet { lanes, rays, reach };
        let leaf = |packet: &mut Packet, base, mask: u32| {
            let mut closer = 0;
            let mut triangles = mask;
            while triangles != 0 {
                let slot = base + triangles.trailing_zeros();
                triangles &= triangles - 1;
                closer |= packet.lanes.intersect(&self.triangles.get(slot), slot);
            }
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
        };
        let nodes = &self.walk_nodes;
        let reach = |packet: &Packet| packet.reach;
        // One interval test for all the rays; leaf children ray by ray.
        let children = |packet: &Packet, planes: &ChildPlanes, imask| {
            let (tmax, reach) = (packet.lanes.t, packet.reach);
            node_avx2::test_packet(planes, &bounds, tmax, reach, imask)
        };
        walk_avx2::walk(nodes, 0, &mut packet, children, reach, leaf);
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
        if let Ok(full) = <&[Ray; PACKET]>::try_from(rays) {
            return Lanes::transposed(full);
        }
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
            ix: load(lane(rays, |r| r.inv_direction.x)),
            iy: load(lane(rays, |r| r.inv_direction.y)),
            iz: load(lane(rays, |r| r.inv_direction.z)),
            tmin: load(lane(rays, |r| r.tmin)),
            t: load(lane(rays, |r| r.tmax)),
            b1: _mm256_setzero_ps(),
            b2: _mm256_setzero_ps(),
            slot: _mm256_set1_epi32(-1),
        }
    }

    /// A full packet's lanes, the same values as `new`'s lane-by-lane copies: each of the rays'
    /// origin, direction and inverse direction (x, y, z, unused) goes through an 8 × 4
    /// transpose, and (tmin, tmax) through one of 8 × 2, instead of 88 scalar stores read back as
    /// vectors.
    #[target_feature(enable = "avx2,fma")]
    unsafe fn transposed(rays: &[Ray; PACKET]) -> Lanes {
        const TMIN: usize = std::mem::offset_of!(Ray, tmin);
        const _: () = assert!(std::mem::offset_of!(Ray, tmax) == TMIN + 4);
        // The 8-byte read below is aligned: rays are, and tmin starts on 8 bytes.
        const _: () = assert!(TMIN.is_multiple_of(8) && std::mem::align_of::<Ray>() >= 8);
        let [ox, oy, oz] = columns(rows(rays, |r| r.origin.into()));
        let [dx, dy, dz] = columns(rows(rays, |r| r.direction.into()));
        let [ix, iy, iz] = columns(rows(rays, |r| r.inv_direction.into()));
        // (tmin, tmax) in the two low lanes, read as one 8-byte value through a pointer to the
        // whole ray (the padding after them is not read). SAFETY: bytes TMIN .. TMIN + 8 of a
        // ray are its tmin and tmax (the assertion above).
        let range = |r: &Ray| {
            let at = (r as *const Ray).cast::<u8>().add(TMIN).cast::<f64>();
            _mm_castpd_ps(_mm_load_sd(at))
        };
        let [tmin, t, _] = columns(rows(rays, range));
        Lanes {
            ox,
            oy,
            oz,
            dx,
            dy,
            dz,
            ix,
            iy,
            iz,
            tmin,
            t,
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
        let n = tri.normal();
        let splat = |v: Vec3| [s(v.x), s(v.y), s(v.z)];
        let c = [
            _mm256_sub_ps(s(tri.v0.x), self.ox),
            _mm256_sub_ps(s(tri.v0.y), self.oy),
            _mm256_sub_ps(s(tri.v0.z), self.oz),
        ];
        let d = [self.dx, self.dy, self.dz];
        let Tested { inside, t, b1, b2 } =
            moller_trumbore([s(n.x), s(n.y), s(n.z)], splat(tri.e1), splat(tri.e2), c, d);
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

/// `row` of rays i and i + 4 side by side in one register, for the four i < 4.
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn rows(rays: &[Ray; PACKET], row: impl Fn(&Ray) -> __m128) -> [__m256; 4] {
    [0, 1, 2, 3].map(|i| {
        _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(row(&rays[i])), row(&rays[i + 4]))
    })
}

/// The first three lanes of `rows`' four-lane rows as eight-lane columns, rays in order (an
/// 8 × 4 transpose, the two 128-bit halves holding rays 0..4 and 4..8).
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn columns([a, b, c, d]: [__m256; 4]) -> [__m256; 3] {
    let (ab_low, ab_high) = (_mm256_unpacklo_ps(a, b), _mm256_unpackhi_ps(a, b));
    let (cd_low, cd_high) = (_mm256_unpacklo_ps(c, d), _mm256_unpackhi_ps(c, d));
    [
        _mm256_shuffle_ps::<0b01_00_01_00>(ab_low, cd_low),
        _mm256_shuffle_ps::<0b11_10_11_10>(ab_low, cd_low),
        _mm256_shuffle_ps::<0b01_00_01_00>(ab_high, cd_high),
    ]
}
