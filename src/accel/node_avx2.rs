//! The CWBVH node test with all eight children in one AVX2 pass, on the children's boxes as
//! f32 planes (`planes`: obvhs's 8-bit codes decoded once after the build, rounded outward).
//!
//! Slab test (Kay & Kajiya 1986): with 1/d the ray's inverse direction and o its origin, a
//! plane x's distance is t = (x − o) · (1/d). The difference comes first: x · (1/d) − o · (1/d)
//! would be one FMA, but where a scene lies far from the origin (10 cm across at 1 km) the
//! rounding of o · (1/d) is a few percent of a small box, and rays aimed near a triangle's
//! vertex miss its leaf. A child is hit when max(t_near) ≤ min(t_far) after clamping
//! to [1e-4, ray.tmax], as in obvhs's own test (`CwBvhNode::intersect_ray`); the clamps join
//! the max/min tree as a fourth operand (two levels, not three). obvhs moves the ray into the
//! node's grid instead (t = q · 2^e/d + (p − o)/d), so the masks agree except
//! for a child whose entry and exit lie within a few ulps of each other (a grazed box corner:
//! the test in `tests.rs` checks every disagreement is one; the walk's triangle tests decide
//! the hit itself) or a NaN distance, which needs coordinates beyond about 1e31. The planes
//! take the widening and conversion of the codes (and the node's grid) off the walk's chain of
//! dependent instructions, node load → node test → next node.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

#[cfg(test)]
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray;

use super::planes::ChildPlanes;

/// What the node test needs of a ray, fixed for its whole walk: per axis its origin o and
/// inverse direction 1/d, and which of a child's two planes is near (the lower one when the ray
/// runs toward +axis), as the indices in `ChildPlanes` of the near and far planes. Chosen once
/// per ray, so a node's test loads the near and far planes directly instead of loading both
/// and picking by the direction's sign.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct NodeRay {
    origin: [f32; 3],
    inv_direction: [f32; 3],
    negative: [bool; 3],
    near: [usize; 3],
    far: [usize; 3],
}

#[cfg(target_arch = "x86_64")]
impl NodeRay {
    #[inline]
    pub(super) fn new(ray: &Ray) -> NodeRay {
        let (o, inv) = (ray.origin, ray.inv_direction);
        let d = ray.direction;
        let negative = [d.x < 0.0, d.y < 0.0, d.z < 0.0];
        let mut near = [0; 3];
        let mut far = [0; 3];
        for axis in 0..3 {
            let (lower, upper) = (2 * axis, 2 * axis + 1);
            (near[axis], far[axis]) = if negative[axis] {
                (upper, lower)
            } else {
                (lower, upper)
            };
        }
        NodeRay {
            origin: o.into(),
            inv_direction: inv.into(),
            negative,
            near,
            far,
        }
    }
}

/// A node's child planes as f32 lanes (the rays of a packet share one load).
#[cfg(target_arch = "x86_64")]
pub(super) type ChildBoxes = [__m256; 6];

/// The node's eight child boxes, loaded once.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn child_boxes(planes: &ChildPlanes) -> ChildBoxes {
    let p = &planes.0;
    [
        _mm256_load_ps(p[0].as_ptr()),
        _mm256_load_ps(p[1].as_ptr()),
        _mm256_load_ps(p[2].as_ptr()),
        _mm256_load_ps(p[3].as_ptr()),
        _mm256_load_ps(p[4].as_ptr()),
        _mm256_load_ps(p[5].as_ptr()),
    ]
}

/// All-ones in the lanes of the children `ray` hits (the slab test of the module header)
/// with the ray's current `tmax`, the near and far planes along each axis as f32 lanes from
/// `planes(axis)`; and each child's entry distance max(t_near, 1e-4) (meaningful in hit
/// lanes).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn hit_and_entry(
    ray: &NodeRay,
    tmax: f32,
    planes: impl Fn(usize) -> (__m256, __m256),
) -> (__m256, __m256) {
    /// obvhs's fixed lower clamp of a child's entry distance.
    const ENTRY_EPSILON: f32 = 1e-4;
    // Axis by axis, each loaded where it is used.
    let (near_x, far_x) = slab(planes(0), ray, 0);
    let (near_y, far_y) = slab(planes(1), ray, 1);
    let (near_z, far_z) = slab(planes(2), ray, 2);
    let entry = _mm256_max_ps(
        _mm256_max_ps(near_x, _mm256_set1_ps(ENTRY_EPSILON)),
        _mm256_max_ps(near_y, near_z),
    );
    let exit = _mm256_min_ps(
        _mm256_min_ps(far_x, _mm256_set1_ps(tmax)),
        _mm256_min_ps(far_y, far_z),
    );
    (_mm256_cmp_ps::<_CMP_LE_OS>(entry, exit), entry)
}

/// The near and far planes of `axis` for `ray` from a node's `boxes` (loaded once for the
/// rays of a packet).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn box_planes(
    boxes: &ChildBoxes,
    ray: &NodeRay,
    axis: usize,
) -> (__m256, __m256) {
    let (lo, hi) = (boxes[2 * axis], boxes[2 * axis + 1]);
    if ray.negative[axis] {
        (hi, lo)
    } else {
        (lo, hi)
    }
}

/// The hit mask of obvhs's traversal (`traverse!`) for the children in `hit` lanes: each
/// child's traversal bits shifted to its priority slot (inner children) or its primitive bits
/// (leaves), OR-ed (the children's bits never overlap).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(all(test, target_arch = "x86_64"))]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn traversal_mask(node: &CwBvhNode, oct_inv4: u32, hit: __m256) -> u32 {
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let lanes = |x: u64| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(x as i64));
    let bits = _mm256_and_si256(
        _mm256_sllv_epi32(lanes(child_bits8), lanes(bit_index8)),
        _mm256_castps_si256(hit),
    );
    let half = _mm_or_si128(
        _mm256_castsi256_si128(bits),
        _mm256_extracti128_si256::<1>(bits),
    );
    let pair = _mm_or_si128(half, _mm_shuffle_epi32::<0b01_00_11_10>(half));
    let one = _mm_or_si128(pair, _mm_shuffle_epi32::<0b10_11_00_01>(pair));
    _mm_cvtsi128_si32(one) as u32
}

/// The hit mask and entry distances (`hit_and_entry`) of the children of a node with child
/// `planes` for one ray, the near and far planes loaded directly.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn test_children(
    planes: &ChildPlanes,
    ray: &NodeRay,
    tmax: f32,
) -> (__m256, __m256) {
    let p = &planes.0;
    // SAFETY: `near` and `far` hold plane indices below 6; the planes are 64-byte aligned.
    let load = |axis: usize| unsafe {
        (
            _mm256_load_ps(p.get_unchecked(ray.near[axis]).as_ptr()),
            _mm256_load_ps(p.get_unchecked(ray.far[axis]).as_ptr()),
        )
    };
    hit_and_entry(ray, tmax, load)
}

/// Distances t = (x − o) · (1/d) to the near and far planes of `axis` for the eight children.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn slab((near, far): (__m256, __m256), ray: &NodeRay, axis: usize) -> (__m256, __m256) {
    let s = _mm256_set1_ps(ray.inv_direction[axis]);
    let o = _mm256_set1_ps(ray.origin[axis]);
    (
        _mm256_mul_ps(_mm256_sub_ps(near, o), s),
        _mm256_mul_ps(_mm256_sub_ps(far, o), s),
    )
}
