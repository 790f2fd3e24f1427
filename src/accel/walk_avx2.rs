//! The walk of the CWBVH on AVX2 CPUs (one ray, or a packet's rays: `packet_avx2`), nearest
//! child first with the children's entry distances kept on the stack (as Embree's BVH8 walk
//! does), in place of obvhs's `traverse!`, which visits a node's children in the order of the
//! ray's octant and re-enters a child after a nearer hit has put it out of reach.
//!
//! At a node, one AVX2 pass gives the children the ray enters before its current tmax and their
//! entry distances (`node_avx2::test_children`, obvhs's slab test in fewer steps). The triangles
//! of the leaf children are tested first, all at once (`triangles_avx2`, eight to a pass for
//! one ray), which may shorten tmax; the inner children are pushed with their entry distances,
//! farthest first, so that the nearest is popped next, and their nodes are prefetched. A popped
//! child whose entry lies beyond the ray's tmax (a nearer hit was found since it was pushed) is
//! dropped without reading its node. The walk finds the same nearest triangle as obvhs's: the
//! same children are hit (but for a box corner grazed within a few ulps, see `node_avx2`), and a
//! dropped child holds nothing nearer than tmax; only two triangles at exactly the same distance
//! may be found in the other order.

use std::arch::x86_64::*;
use std::mem::MaybeUninit;

use obvhs::cwbvh::node::CwBvhNode;

/// Stack entries: a node's visit pops one entry and pushes at most eight (its inner children),
/// so a walk through a tree d levels deep holds at most 7·d + 1; 512 (4 KiB, left
/// uninitialised) covers 73 levels, where obvhs's own walk keeps 32. A deeper tree drops the
/// newest entries rather than writing past the end, as obvhs's stack does.
const STACK: usize = 512;

/// Walks the BVH of `nodes` for a query `state` (one ray, or the rays of a packet):
/// `children(state, node)` gives the hit lanes and entry distances of a node's children (for a
/// packet: the lanes any ray hits, at the least entry among the rays that hit them),
/// `reach(state)` the farthest distance any ray still looks at (its tmax), and
/// `leaf(state, base, mask)` tests the triangles in leaf-order slots `base + i` for the set
/// bits i of `mask` (the triangles of a node's leaf children that the query enters), possibly
/// shortening tmax (closest hit), and returns true to end the walk (any hit).
///
/// # Safety
/// The CPU must support AVX2, FMA, POPCNT, BMI1/2 and LZCNT.
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
#[inline]
pub(super) unsafe fn walk<S>(
    nodes: &[CwBvhNode],
    state: &mut S,
    children: impl Fn(&S, &CwBvhNode) -> (__m256, __m256),
    reach: impl Fn(&S) -> f32,
    mut leaf: impl FnMut(&mut S, u32, u32) -> bool,
) {
    if nodes.is_empty() {
        return;
    }
    let mut stack: [MaybeUninit<(u32, f32)>; STACK] = [MaybeUninit::uninit(); STACK];
    let mut len = 0usize;
    let mut index = 0u32;
    loop {
        let node = &nodes[index as usize];
        let (hit, entry) = children(state, node);
        let hits = _mm256_movemask_ps(hit) as u32;
        let imask = node.imask as u32;
        let mut entries = [0.0f32; 8];
        _mm256_storeu_ps(entries.as_mut_ptr(), entry);
        // Leaf children (an empty slot has meta 0: no triangles): the low five bits of a leaf's
        // meta are its first triangle's offset from the node's base (below 24: obvhs gives a
        // node's leaves at most 24 triangles, in slot order), the high three its count in unary.
        // The triangles of the leaves hit are tested together (a hit lane's entry is at most
        // the tmax the node test was given, so no leaf is out of reach yet).
        let mut leaves = hits & !imask;
        let mut triangles = 0u32;
        while leaves != 0 {
            let slot = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            let meta = node.child_meta[slot] as u32;
            triangles |= ((1 << (meta >> 5).count_ones()) - 1) << (meta & 0b1_1111);
        }
        if triangles != 0 && leaf(state, node.primitive_base_idx, triangles) {
            return;
        }
        let mut inner = hits & imask;
        if inner != 0 {
            let first = len;
            while inner != 0 {
                let slot = inner.trailing_zeros();
                inner &= inner - 1;
                let child = node.child_base_idx + (imask & ((1 << slot) - 1)).count_ones();
                let t = entries[slot as usize];
                let ahead = nodes.as_ptr().wrapping_add(child as usize).cast::<i8>();
                _mm_prefetch::<_MM_HINT_T0>(ahead);
                _mm_prefetch::<_MM_HINT_T0>(ahead.wrapping_add(64));
                // Insertion by falling distance: the nearest ends on top.
                let mut k = len;
                while k > first {
                    let (_, above) = stack[k - 1].assume_init();
                    if above >= t {
                        break;
                    }
                    stack[k] = stack[k - 1];
                    k -= 1;
                }
                stack[k] = MaybeUninit::new((child, t));
                len = (len + 1).min(STACK - 1);
            }
        }
        loop {
            if len == 0 {
                return;
            }
            len -= 1;
            let (child, t) = stack[len].assume_init();
            if t <= reach(state) {
                index = child;
                break;
            }
        }
    }
}
