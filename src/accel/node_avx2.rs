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
//!
//! Packets (`test_packet`): one interval test for all the rays of a packet whose rays, along
//! each axis, all take the same plane as near and have finite inverse directions s of one
//! strict sign, with o ∈ [o_lo, o_hi] and s ∈ [a, b] over its rays (o spreads a little even
//! for a pinhole camera: `guarded_ray` moves each origin back along its own direction). A
//! ray's distance to a plane x is fl(fl(x − o)·s); rounding is monotone, so fl(x − o) falls
//! as o grows, and fl(D·s) rises with D for s > 0, falls for s < 0, and over
//! s ∈ [a, b] lies between fl(D·a) and fl(D·b) (D·s is linear in s). Hence, for s > 0 with
//! D_near = fl(x − o_hi), every ray's near distance is at least
//! near_lo = min(fl(D_near·a), fl(D_near·b)), and with D_far = fl(x − o_lo) every far distance
//! is at most far_hi = max(fl(D_far·a), fl(D_far·b)); for s < 0, o_lo and o_hi trade places.
//! With entry_lo = max(near_lo over the axes, 1e-4) and exit_hi = min(far_hi over the axes,
//! the largest tmax), each ray's own entry ≥ entry_lo and exit ≤ exit_hi, so a child any ray
//! hits (entry ≤ exit) has entry_lo ≤ exit_hi: the test keeps it, and entry_lo is at most the
//! entry of every ray that hits it. No NaN arises: the planes are finite, and the conditions
//! make o finite (x − o is never ∞ − ∞) and s finite and non-zero (fl(x − o)·s is never 0·∞,
//! even where x − o overflows); a packet that fails them is tested ray by ray. Of the leaf
//! children the interval test keeps, `test_packet` keeps exactly those some ray hits: one pass
//! a child, the rays in lanes, with `hit_and_entry`'s arithmetic for each.

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
            (near[axis], far[axis]) = near_and_far(axis, negative[axis]);
        }
        NodeRay {
            origin: o.into(),
            inv_direction: inv.into(),
            near,
            far,
        }
    }
}

/// The indices in `ChildPlanes` of a child's near and far planes along `axis` for rays that run
/// toward −axis (`negative`) or not: the lower plane is near unless they run toward −axis.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn near_and_far(axis: usize, negative: bool) -> (usize, usize) {
    let (lower, upper) = (2 * axis, 2 * axis + 1);
    if negative {
        (upper, lower)
    } else {
        (lower, upper)
    }
}

/// What `test_packet` needs of a packet whose rays all run the same way along each axis
/// (module header), per axis: the origin bound that gives the least near distance and the one
/// that gives the greatest far distance, the least and greatest inverse direction (each in
/// every lane), the rays' origins and inverse directions (one ray a lane), and the indices in
/// `ChildPlanes` of the near and far planes, which all the rays share.
#[cfg(target_arch = "x86_64")]
pub(super) struct NodePacket {
    origin_near: [__m256; 3],
    origin_far: [__m256; 3],
    inv_lo: [__m256; 3],
    inv_hi: [__m256; 3],
    origins: [__m256; 3],
    inverses: [__m256; 3],
    near: [usize; 3],
    far: [usize; 3],
}

#[cfg(target_arch = "x86_64")]
impl NodePacket {
    /// The interval bounds of the rays in lanes (`origin`, `direction` and `inverse` direction
    /// per axis; spare lanes repeat a ray), or `None` unless, along each axis, they all take the
    /// same plane as near (`NodeRay`: the upper one where d < 0), their inverse directions are
    /// finite and of one strict sign, and their origins are finite.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) unsafe fn new(
        origin: [__m256; 3],
        direction: [__m256; 3],
        inverse: [__m256; 3],
    ) -> Option<NodePacket> {
        let (zero, infinity) = (_mm256_setzero_ps(), _mm256_set1_ps(f32::INFINITY));
        let finite = |v| {
            let magnitude = _mm256_andnot_ps(_mm256_set1_ps(-0.0), v);
            _mm256_cmp_ps::<_CMP_LT_OQ>(magnitude, infinity)
        };
        let negative = |v| _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(v, zero));
        let mut packet = NodePacket {
            origin_near: [zero; 3],
            origin_far: [zero; 3],
            inv_lo: [zero; 3],
            inv_hi: [zero; 3],
            origins: origin,
            inverses: inverse,
            near: [0; 3],
            far: [0; 3],
        };
        for axis in 0..3 {
            let (o, s) = (origin[axis], inverse[axis]);
            let usable = _mm256_and_ps(
                _mm256_and_ps(finite(s), finite(o)),
                _mm256_cmp_ps::<_CMP_NEQ_OQ>(s, zero),
            );
            let (d_negative, s_negative) = (negative(direction[axis]), negative(s));
            let one_way = |mask| mask == 0 || mask == 0xff;
            if _mm256_movemask_ps(usable) != 0xff || !one_way(d_negative) || !one_way(s_negative) {
                return None;
            }
            (packet.near[axis], packet.far[axis]) = near_and_far(axis, d_negative != 0);
            let (o_lo, o_hi) = (least(o), greatest(o));
            (packet.origin_near[axis], packet.origin_far[axis]) = if s_negative != 0 {
                (o_lo, o_hi)
            } else {
                (o_hi, o_lo)
            };
            (packet.inv_lo[axis], packet.inv_hi[axis]) = (least(s), greatest(s));
        }
        Some(packet)
    }
}

/// The least of the eight lanes of `v`, in every lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn least(v: __m256) -> __m256 {
    let v = _mm256_min_ps(v, _mm256_permute2f128_ps::<1>(v, v));
    let v = _mm256_min_ps(v, _mm256_permute_ps::<0b01_00_11_10>(v));
    _mm256_min_ps(v, _mm256_permute_ps::<0b10_11_00_01>(v))
}

/// The greatest of the eight lanes of `v`, in every lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn greatest(v: __m256) -> __m256 {
    let v = _mm256_max_ps(v, _mm256_permute2f128_ps::<1>(v, v));
    let v = _mm256_max_ps(v, _mm256_permute_ps::<0b01_00_11_10>(v));
    _mm256_max_ps(v, _mm256_permute_ps::<0b10_11_00_01>(v))
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
    // Axis by axis, each loaded where it is used.
    let x = slab(planes(0), ray, 0);
    let y = slab(planes(1), ray, 1);
    let z = slab(planes(2), ray, 2);
    overlap([x, y, z], _mm256_set1_ps(tmax))
}

/// obvhs's fixed lower clamp of a child's entry distance.
const ENTRY_EPSILON: f32 = 1e-4;

/// From the near and far plane distances along the three axes: all-ones where
/// entry = max(near, 1e-4) ≤ exit = min(far, `tmax`), and the entry.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn overlap(
    [(near_x, far_x), (near_y, far_y), (near_z, far_z)]: [(__m256, __m256); 3],
    tmax: __m256,
) -> (__m256, __m256) {
    let entry = _mm256_max_ps(
        _mm256_max_ps(near_x, _mm256_set1_ps(ENTRY_EPSILON)),
        _mm256_max_ps(near_y, near_z),
    );
    let exit = _mm256_min_ps(_mm256_min_ps(far_x, tmax), _mm256_min_ps(far_y, far_z));
    (_mm256_cmp_ps::<_CMP_LE_OS>(entry, exit), entry)
}

/// The children of a node with child `planes` that the rays of `packet` may hit (module
/// header), their current tmax in lanes `tmax`, the largest `reach`: all-ones in the lanes of
/// the inner children (set bits of `imask`) the interval test keeps, at least those any ray
/// hits (`test_children`), and of the leaf children some ray hits; and a lower bound of each
/// kept child's entry distance over the rays that hit it.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(super) unsafe fn test_packet(
    planes: &ChildPlanes,
    packet: &NodePacket,
    tmax: __m256,
    reach: f32,
    imask: u32,
) -> (__m256, __m256) {
    let p = &planes.0;
    // Per axis, near_lo = min(fl(x − o_near)·a, fl(x − o_near)·b) with the near planes x and
    // far_hi = max(fl(x − o_far)·a, fl(x − o_far)·b) with the far planes.
    // SAFETY: `near` and `far` hold plane indices below 6; the planes are 64-byte aligned.
    let bounds = |axis: usize| unsafe {
        let near = _mm256_load_ps(p.get_unchecked(packet.near[axis]).as_ptr());
        let far = _mm256_load_ps(p.get_unchecked(packet.far[axis]).as_ptr());
        let (a, b) = (packet.inv_lo[axis], packet.inv_hi[axis]);
        let near = _mm256_sub_ps(near, packet.origin_near[axis]);
        let far = _mm256_sub_ps(far, packet.origin_far[axis]);
        (
            _mm256_min_ps(_mm256_mul_ps(near, a), _mm256_mul_ps(near, b)),
            _mm256_max_ps(_mm256_mul_ps(far, a), _mm256_mul_ps(far, b)),
        )
    };
    let (hit, entry) = overlap([bounds(0), bounds(1), bounds(2)], _mm256_set1_ps(reach));
    let kept = _mm256_movemask_ps(hit) as u32;
    let mut hits = kept & imask;
    let mut leaves = kept & !imask;
    while leaves != 0 {
        let child = leaves.trailing_zeros();
        leaves &= leaves - 1;
        if rays_hit_child(planes, child as usize, packet, tmax) {
            hits |= 1 << child;
        }
    }
    // Bit i of `hits` to the sign of lane i, all the walk reads of a hit lane.
    let signs = _mm256_sllv_epi32(
        _mm256_set1_epi32(hits as i32),
        _mm256_setr_epi32(31, 30, 29, 28, 27, 26, 25, 24),
    );
    (_mm256_castsi256_ps(signs), entry)
}

/// Whether any ray of `packet` hits child `child` of a node with child `planes`, their tmax in
/// lanes `tmax`: `hit_and_entry`'s arithmetic for each ray, the rays in lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn rays_hit_child(
    planes: &ChildPlanes,
    child: usize,
    packet: &NodePacket,
    tmax: __m256,
) -> bool {
    let p = &planes.0;
    // SAFETY: `near` and `far` hold plane indices below 6, and `child` is below 8.
    let distances = |axis: usize| unsafe {
        let plane = |i: usize| _mm256_broadcast_ss(p.get_unchecked(i).get_unchecked(child));
        let (near, far) = (plane(packet.near[axis]), plane(packet.far[axis]));
        let (o, s) = (packet.origins[axis], packet.inverses[axis]);
        (
            _mm256_mul_ps(_mm256_sub_ps(near, o), s),
            _mm256_mul_ps(_mm256_sub_ps(far, o), s),
        )
    };
    let (hit, _) = overlap([distances(0), distances(1), distances(2)], tmax);
    _mm256_movemask_ps(hit) != 0
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
