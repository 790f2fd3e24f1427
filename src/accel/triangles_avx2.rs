//! The triangle test in eight AVX2 lanes: eight triangles of a block against one ray (the AVX2
//! walk tests all the leaf triangles of a node it reaches at once), or one triangle against the
//! eight rays of a packet (`packet_avx2`). The same arithmetic as `TestTriangle::intersect`,
//! operation for operation (glam's order for dot and cross products, no fused multiply-adds),
//! so every lane gives the bits the one-at-a-time test gives.

use std::arch::x86_64::*;

use obvhs::ray::Ray;

use super::triangles::{Block, BLOCK};

/// A 3-vector with eight values per component.
pub(super) type Lanes3 = [__m256; 3];

/// The fields of eight tests of the module header, before the ray's range is checked.
pub(super) struct Tested {
    /// All-ones where b1 ≥ 0, b2 ≥ 0 and b1 + b2 ≤ 1.
    pub(super) inside: __m256,
    pub(super) t: __m256,
    pub(super) b1: __m256,
    pub(super) b2: __m256,
}

/// a × b, as glam computes it: (a.y·b.z − b.y·a.z, a.z·b.x − b.z·a.x, a.x·b.y − b.x·a.y).
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn cross(a: Lanes3, b: Lanes3) -> Lanes3 {
    let (mul, sub) = (|x, y| _mm256_mul_ps(x, y), |x, y| _mm256_sub_ps(x, y));
    [
        sub(mul(a[1], b[2]), mul(b[1], a[2])),
        sub(mul(a[2], b[0]), mul(b[2], a[0])),
        sub(mul(a[0], b[1]), mul(b[0], a[1])),
    ]
}

/// Möller–Trumbore (see `triangles`) in eight lanes, with the triangles' normals n = E1 × E2,
/// edges E1, E2, c = v0 − o and the rays' directions d.
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn moller_trumbore(
    n: Lanes3,
    e1: Lanes3,
    e2: Lanes3,
    c: Lanes3,
    d: Lanes3,
) -> Tested {
    let s = |x: f32| _mm256_set1_ps(x);
    let (mul, add) = (|a, b| _mm256_mul_ps(a, b), |a, b| _mm256_add_ps(a, b));
    // dot(a, b) = (a.x·b.x + a.y·b.y) + a.z·b.z, glam's order.
    let dot = |a: Lanes3, b: Lanes3| add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]));
    let r = cross(d, c);
    let inv_det = _mm256_div_ps(s(1.0), dot(n, d));
    let b1 = mul(_mm256_xor_ps(dot(r, e2), s(-0.0)), inv_det);
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
    Tested { inside, t, b1, b2 }
}

/// What the block test needs of one ray, in every lane.
#[derive(Clone, Copy)]
pub(super) struct RayLanes {
    origin: Lanes3,
    direction: Lanes3,
    tmin: __m256,
}

impl RayLanes {
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) unsafe fn new(ray: &Ray) -> RayLanes {
        let splat = |v: glam::Vec3A| [v.x, v.y, v.z].map(|x| _mm256_set1_ps(x));
        RayLanes {
            origin: splat(ray.origin),
            direction: splat(ray.direction),
            tmin: _mm256_set1_ps(ray.tmin),
        }
    }
}

/// Tests the triangles `base + i` for the set bits i of `mask` (leaf order) against `ray`, a
/// block of eight at a time: returns the nearest hit with t ∈ [tmin, `tmax`) as (slot, b1, b2)
/// and lowers `tmax` to its t (of two at the same t, the lower slot); with `any`, the first hit
/// found instead.
///
/// # Safety
/// The CPU must support AVX2 and FMA. Inlined into its callers, which are compiled for them:
/// a call would make the walk keep its vector registers in memory across it.
#[inline(always)]
pub(super) unsafe fn nearest_triangle(
    blocks: &[Block],
    ray: &RayLanes,
    base: u32,
    mask: u32,
    tmax: &mut f32,
    any: bool,
) -> Option<(u32, f32, f32)> {
    let first = base as usize / BLOCK;
    // Bit 8k + j: lane j of block first + k.
    let mut wide = u64::from(mask) << (base as usize % BLOCK);
    let mut nearest = None;
    while wide != 0 {
        let k = wide.trailing_zeros() as usize / BLOCK;
        let lanes = (wide >> (k * BLOCK)) as u32 & 0xFF;
        wide &= !(0xFF << (k * BLOCK));
        let block = &blocks[first + k];
        // The rows are 32-byte aligned (`Block`); a plain read needs no call to an intrinsic.
        let load =
            |f: &[[f32; BLOCK]; 3]| f.map(|row| std::ptr::read(row.as_ptr().cast::<__m256>()));
        let (v0, e1, e2) = (load(&block.v0), load(&block.e1), load(&block.e2));
        let c = [0, 1, 2].map(|a| _mm256_sub_ps(v0[a], ray.origin[a]));
        let tested = moller_trumbore(cross(e1, e2), e1, e2, c, ray.direction);
        let in_range = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(tested.t, ray.tmin),
            _mm256_cmp_ps::<_CMP_LT_OQ>(tested.t, _mm256_set1_ps(*tmax)),
        );
        let mut hits = _mm256_movemask_ps(_mm256_and_ps(tested.inside, in_range)) as u32 & lanes;
        if hits == 0 {
            continue;
        }
        let store = |v: __m256| {
            let mut out = [0.0f32; BLOCK];
            _mm256_storeu_ps(out.as_mut_ptr(), v);
            out
        };
        let (t, b1, b2) = (store(tested.t), store(tested.b1), store(tested.b2));
        while hits != 0 {
            let j = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            if t[j] < *tmax {
                *tmax = t[j];
                nearest = Some((((first + k) * BLOCK + j) as u32, b1[j], b2[j]));
                if any {
                    return nearest;
                }
            }
        }
    }
    nearest
}
