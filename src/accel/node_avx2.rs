//! obvhs's CWBVH node test with all eight children in one AVX2 pass.
//!
//! A child box is stored as 8-bit offsets q on the node's grid: plane = p + 2^e · q per axis.
//! The ray is moved into that grid instead (slab test, Kay & Kajiya 1986): with
//! s = 2^e / d and o' = (p − o) / d per axis, a plane's distance is t = q·s + o'. A child is hit
//! when max(t_near) ≤ min(t_far) after clamping to [1e-4, ray.tmax], as in obvhs's own test
//! (`CwBvhNode::intersect_ray`), with two differences that shorten the chain of dependent
//! instructions: t is one FMA (obvhs rounds the product and then the sum), and the clamps join
//! the max/min tree as a fourth operand (two levels, not three). So the masks agree except for a
//! child whose entry and exit lie within a few ulps of each other (a grazed box corner: the
//! test in `tests.rs` checks every disagreement is one, and found none in 1,896 rays; the walk's
//! triangle tests decide the hit itself) or a NaN distance, which needs coordinates beyond about
//! 1e31. `cargo bench --bench rays` at dc1fd63, six alternating rounds against the exact form:
//! town camera / shadow / bounce 6.94 / 4.87 / 4.12 → 7.19 / 5.05 / 4.42 Mrays/s, 50k city
//! 8.81 / 5.95 / 5.92 → 9.09 / 6.13 / 6.32 (+3 to +7%). obvhs converts each child's bytes to
//! floats one at a time, four children per pass; here one widening conversion per axis bound
//! serves all eight (and all the rays of a packet), and the traversal mask is built in the
//! vector too.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use std::mem::offset_of;

use glam::Vec3A;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray;

/// What the node test needs of a ray, fixed for its whole walk: its origin, inverse direction,
/// and per axis which of a child's two planes is near (the lower one when the ray runs toward
/// +axis), as the byte offsets in a node of the near and far planes' offsets. Chosen once per
/// ray, so a node's test loads the near and far bytes directly instead of loading both and
/// picking by the direction's sign.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct NodeRay {
    origin: Vec3A,
    inv_direction: Vec3A,
    negative: [bool; 3],
    near: [usize; 3],
    far: [usize; 3],
}

#[cfg(target_arch = "x86_64")]
impl NodeRay {
    #[inline]
    pub(super) fn new(ray: &Ray) -> NodeRay {
        let lower = [
            offset_of!(CwBvhNode, child_min_x),
            offset_of!(CwBvhNode, child_min_y),
            offset_of!(CwBvhNode, child_min_z),
        ];
        let upper = [
            offset_of!(CwBvhNode, child_max_x),
            offset_of!(CwBvhNode, child_max_y),
            offset_of!(CwBvhNode, child_max_z),
        ];
        let d = ray.direction;
        let negative = [d.x < 0.0, d.y < 0.0, d.z < 0.0];
        let pick = |toward_negative: bool| {
            [0, 1, 2].map(|a| {
                if negative[a] == toward_negative {
                    lower[a]
                } else {
                    upper[a]
                }
            })
        };
        NodeRay {
            origin: ray.origin,
            inv_direction: ray.inv_direction,
            negative,
            near: pick(false),
            far: pick(true),
        }
    }
}

/// A node's child boxes as f32 lanes on its grid, per axis (x, y, z): the lower and upper
/// offsets, before the ray's direction picks which is near.
#[cfg(target_arch = "x86_64")]
pub(super) type ChildBoxes = [(__m256, __m256); 3];

/// The node's eight child boxes, widened once (the rays of a packet share them).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn child_boxes(node: &CwBvhNode) -> ChildBoxes {
    [0, 1, 2].map(|axis| axis_bounds(node, axis))
}

/// The lower and upper offsets of the eight children along `axis`, as f32 lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn axis_bounds(node: &CwBvhNode, axis: usize) -> (__m256, __m256) {
    let (lo, hi) = match axis {
        0 => (&node.child_min_x, &node.child_max_x),
        1 => (&node.child_min_y, &node.child_max_y),
        _ => (&node.child_min_z, &node.child_max_z),
    };
    (widen(lo), widen(hi))
}

/// All-ones in the lanes of the children `ray` hits (the slab test of the module header)
/// with the ray's current `tmax`, the near and far planes' offsets along each axis as f32
/// lanes from `planes(axis)`; and each child's entry distance max(t_near, 1e-4) (meaningful in
/// hit lanes).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn hit_and_entry(
    node: &CwBvhNode,
    ray: &NodeRay,
    tmax: f32,
    planes: impl Fn(usize) -> (__m256, __m256),
) -> (__m256, __m256) {
    /// obvhs's fixed lower clamp of a child's entry distance.
    const ENTRY_EPSILON: f32 = 1e-4;
    let scale = node.compute_extent() * ray.inv_direction;
    let shift = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // Axis by axis, each widened where it is used (faster than all six up front).
    let (near_x, far_x) = slab(planes(0), scale.x, shift.x);
    let (near_y, far_y) = slab(planes(1), scale.y, shift.y);
    let (near_z, far_z) = slab(planes(2), scale.z, shift.z);
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

/// The near and far planes of `axis` for `ray` from a node's `boxes` (widened once for the
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
    let (lo, hi) = boxes[axis];
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
    let lanes = |x: u64| bytes_to_lanes(_mm_cvtsi64_si128(x as i64));
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

/// The hit mask and entry distances (`hit_and_entry`) of the children of `node` for one ray,
/// the near and far planes read directly from the node's bytes.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn test_children(node: &CwBvhNode, ray: &NodeRay, tmax: f32) -> (__m256, __m256) {
    let bytes = (node as *const CwBvhNode).cast::<u8>();
    // SAFETY: `near` and `far` hold offsets of [u8; 8] fields of `CwBvhNode`.
    let planes = |axis| unsafe {
        (
            widen(&*bytes.add(ray.near[axis]).cast()),
            widen(&*bytes.add(ray.far[axis]).cast()),
        )
    };
    hit_and_entry(node, ray, tmax, planes)
}

/// The low eight bytes of `bytes` as eight u32 lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn bytes_to_lanes(bytes: __m128i) -> __m256i {
    _mm256_cvtepu8_epi32(bytes)
}

/// Eight u8 grid offsets as eight f32 lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn widen(q: &[u8; 8]) -> __m256 {
    _mm256_cvtepi32_ps(bytes_to_lanes(_mm_loadl_epi64(q.as_ptr().cast())))
}

/// Distances t = q·s + o to the near and far planes of one axis for the eight children.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn slab((near, far): (__m256, __m256), s: f32, o: f32) -> (__m256, __m256) {
    let (s, o) = (_mm256_set1_ps(s), _mm256_set1_ps(o));
    (_mm256_fmadd_ps(near, s, o), _mm256_fmadd_ps(far, s, o))
}
