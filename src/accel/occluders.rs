//! The triangles that blocked this thread's latest shadow rays, asked before the next shadow
//! ray walks the BVH: the last-occluder cache of Haines & Greenberg's light buffer (1986), eight
//! triangles deep, tested in one block (one AVX2 pass).
//!
//! An occlusion query asks whether anything lies on a segment, so any one triangle that blocks
//! it answers the query. The shadow rays of one pixel's samples, and of its neighbours', tend to
//! be blocked by the same few triangles (the shares below), so the walk runs only when none of
//! the eight remembered ones blocks the ray; the triangle it then finds replaces the oldest.
//! The answer is the walk's: a remembered triangle blocks the ray exactly when the walk's leaf
//! test says it does (the same triangle test on the same guarded ray, t ∈ [tmin, tmax)), and
//! the walk would reach it, its leaf box holding it (up to a box corner grazed within a few
//! ulps: `node_avx2`). A remembered triangle cannot come back as a new occluder, since the
//! walk's test of it would fail as the block's did.
//!
//! Share of shadow rays the eight answered (render, 64 spp, 320 pixels wide, power + mis): 71% on
//! the Lambert copy of the 50k city (95% were blocked), 39% on the town (73% blocked); bvh + mis
//! on the city 49% (66% blocked). Each thread keeps its own, tagged with the `Accel` that filled
//! them (a number of its own, never reused), so a thread that moves to another scene starts
//! afresh.

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};

use super::triangles::{Block, TestTriangle, BLOCK};

/// Eight remembered occluders of the `Accel` numbered `owner` (0: none yet), as a triangle block
/// whose unused lanes are all zero (degenerate: no ray hits them); `next` is the lane the next
/// occluder takes (the oldest once all are filled).
struct Recent {
    owner: u64,
    block: Block,
    next: usize,
}

impl Recent {
    const EMPTY: Recent = Recent {
        owner: 0,
        block: Block::EMPTY,
        next: 0,
    };
}

thread_local! {
    static RECENT: RefCell<Recent> = const { RefCell::new(Recent::EMPTY) };
}

/// A number for a new `Accel`, never given before in this process (from 1).
pub(super) fn new_owner() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// A copy of the occluders this thread remembers of `owner`, if it remembers that tree's (a copy
/// rather than a closure over them: a closure with the caller's AVX2 code would not be inlined
/// into the thread-local access, which is compiled without it).
#[inline(always)]
pub(super) fn remembered(owner: u64) -> Option<Block> {
    RECENT.with_borrow(|recent| (recent.owner == owner).then_some(recent.block))
}

/// Remembers `triangle`, which blocked a shadow ray in the `Accel` numbered `owner`, in place of
/// the oldest remembered occluder (of all of them when they were another `Accel`'s).
#[inline]
pub(super) fn remember(owner: u64, triangle: &TestTriangle) {
    RECENT.with_borrow_mut(|recent| {
        if recent.owner != owner {
            *recent = Recent::EMPTY;
            recent.owner = owner;
        }
        recent.block.set(recent.next, triangle);
        recent.next = (recent.next + 1) % BLOCK;
    });
}
