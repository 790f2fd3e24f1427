//! The walk of the CWBVH on AVX2 CPUs (one ray, or a packet's rays: `packet_avx2`), nearest
//! child first with the children's entry distances kept on the stack (as Embree's BVH8 walk
//! does), in place of obvhs's `traverse!`, which visits a node's children in the order of the
//! ray's octant and re-enters a child after a nearer hit has put it out of reach.
//!
//! At a node, one AVX2 pass gives the children the ray enters before its current tmax and their
//! entry distances (`node_avx2::test_children`, obvhs's slab test on the boxes as f32 planes).
//! The triangles of the leaf children are tested first, all at once (`triangles_avx2`, eight to
//! a pass for one ray), which may shorten tmax. Of the inner children hit, the nearest is
//! visited next and the others are pushed with their entry distances, nearest on top, their
//! nodes prefetched:
//! one child goes straight to the next visit, two need one compare and one push, more are
//! sorted into the stack by insertion and the nearest popped. A child whose entry lies beyond
//! the ray's tmax (a nearer hit was found since the node test) is dropped without reading its
//! node, when it would be visited or popped; that test is a branch, so the next node's load
//! need not wait for the leaf's triangle tests. The order is the one a push of all children
//! sorted by entry and a pop would give (two at the same entry: the higher slot first). The
//! walk finds the same nearest triangle as obvhs's: the same children are hit (but for a box
//! corner grazed within a few ulps, see `node_avx2`), and a dropped child holds nothing nearer
//! than tmax; only two triangles at exactly the same distance may be found in the other order.

use std::arch::x86_64::*;
use std::mem::MaybeUninit;

use super::planes::{ChildPlanes, WalkNode};

/// Stack entries: a node's visit pops one entry and pushes at most eight (its inner children),
/// so a walk through a tree d levels deep holds at most 7·d + 1; 512 (4 KiB, left
/// uninitialised) covers 73 levels, where obvhs's own walk keeps 32. A deeper tree drops the
/// newest entries rather than writing past the end, as obvhs's stack does.
pub(super) const STACK: usize = 512;

/// Walks the subtree of node `start` (0: the whole BVH) of `nodes` (obvhs's, with their child
/// boxes as f32 planes) for a query `state` (one ray, or the rays of a packet):
/// `children(state, planes, imask)` gives the hit lanes and entry distances of a node's children
/// from its planes and its mask of inner children (for a packet: at least the lanes any ray
/// hits, at no more than the least entry among the rays that hit them),
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
    nodes: &[WalkNode],
    start: u32,
    state: &mut S,
    children: impl Fn(&S, &ChildPlanes, u32) -> (__m256, __m256),
    reach: impl Fn(&S) -> f32,
    mut leaf: impl FnMut(&mut S, u32, u32) -> bool,
) {
    if nodes.is_empty() {
        return;
    }
    let mut stack: [MaybeUninit<(u32, f32)>; STACK] = [MaybeUninit::uninit(); STACK];
    let mut len = 0usize;
    let mut index = start;
    loop {
        let node = &nodes[index as usize];
        let imask = node.imask as u32;
        let (hit, entry) = children(state, &node.planes, imask);
        let hits = _mm256_movemask_ps(hit) as u32;
        let mut inner = hits & imask;
        // The triangles of the leaves hit are tested together (a hit lane's entry is at most the
        // tmax the node test was given, so no leaf is out of reach yet).
        let triangles = node.leaf_triangles(hits);
        if triangles != 0 && leaf(state, node.primitive_base, triangles) {
            return;
        }
        // A child's node follows the node's inner children in lower slots.
        let child = |slot: u32| node.child_base + _bzhi_u32(imask, slot).count_ones();
        let mut entries = [0.0f32; 8];
        _mm256_storeu_ps(entries.as_mut_ptr(), entry);
        // The next node is chosen from the node test alone and kept only if still within
        // reach (a nearer hit in the leaves may have moved it out) by a branch, which the CPU
        // predicts, so its load does not wait for the triangle tests.
        if inner != 0 {
            let first = inner.trailing_zeros();
            let rest = inner & (inner - 1);
            // One child: it is next, with no trip through the stack.
            if rest == 0 {
                if entries[first as usize] <= reach(state) {
                    index = child(first);
                    continue;
                }
            } else if rest & (rest - 1) == 0 {
                // Two children: the farther is pushed, the nearer is next (of two at the same
                // entry, the higher slot, as the insertion below orders them).
                let second = rest.trailing_zeros();
                let (t_first, t_second) = (entries[first as usize], entries[second as usize]);
                let (near, t_near, far, t_far) = if t_first >= t_second {
                    (second, t_second, first, t_first)
                } else {
                    (first, t_first, second, t_second)
                };
                let far = child(far);
                prefetch(nodes, far);
                // SAFETY: `len` stays below `STACK`.
                *stack.get_unchecked_mut(len) = MaybeUninit::new((far, t_far));
                len = (len + 1).min(STACK - 1);
                if t_near <= reach(state) {
                    index = child(near);
                    continue;
                }
            } else {
                // More: all are pushed, the nearest on top.
                let bottom = len;
                while inner != 0 {
                    let slot = inner.trailing_zeros();
                    inner &= inner - 1;
                    let node = child(slot);
                    let t = entries[slot as usize];
                    prefetch(nodes, node);
                    // SAFETY: bottom ≤ len < STACK, the entries below len written.
                    push_by_distance(&mut stack, bottom, &mut len, (node, t), |e| e.1);
                }
            }
        }
        loop {
            if len == 0 {
                return;
            }
            len -= 1;
            // SAFETY: `len` < `STACK`, and every entry below the old `len` was written.
            let (child, t) = stack.get_unchecked(len).assume_init();
            if t <= reach(state) {
                index = child;
                break;
            }
        }
    }
}

/// Pushes `entry` onto the entries of `stack` from `bottom` to `len`, kept by falling
/// `distance(entry)` (insertion: the nearest ends on top; of two at the same distance the later
/// one lies on top), and counts it in `len`, which stays below `STACK` (a full stack loses its
/// newest entry). Both walks order a node's children this way.
///
/// # Safety
/// `bottom ≤ *len < STACK`, and the entries from `bottom` to `*len` are written.
#[inline(always)]
pub(super) unsafe fn push_by_distance<E: Copy>(
    stack: &mut [MaybeUninit<E>; STACK],
    bottom: usize,
    len: &mut usize,
    entry: E,
    distance: impl Fn(&E) -> f32,
) {
    let t = distance(&entry);
    let mut k = *len;
    // SAFETY: bottom ≤ k ≤ len < STACK, and the entries from bottom to len are written.
    while k > bottom {
        if distance(&stack.get_unchecked(k - 1).assume_init()) >= t {
            break;
        }
        *stack.get_unchecked_mut(k) = *stack.get_unchecked(k - 1);
        k -= 1;
    }
    *stack.get_unchecked_mut(k) = MaybeUninit::new(entry);
    *len = (*len + 1).min(STACK - 1);
}

/// Starts loading the node at `index` (four cache lines).
#[target_feature(enable = "avx2,fma,popcnt,bmi1,bmi2,lzcnt")]
#[inline]
unsafe fn prefetch(nodes: &[WalkNode], index: u32) {
    let ahead = nodes.as_ptr().wrapping_add(index as usize).cast::<i8>();
    for line in 0..4 {
        _mm_prefetch::<_MM_HINT_T0>(ahead.wrapping_add(64 * line));
    }
}
