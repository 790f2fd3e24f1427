//! A cache hint: start loading a value's cache lines ahead of its use, so that the misses of
//! several independent lookups (one per camera sample of a packet) overlap instead of stalling
//! one after another. A hint only: it never changes a result.

/// Bytes per cache line on the x86-64 processors this targets.
const LINE: usize = 64;

/// Asks for every cache line `value` spans to be loaded into all cache levels.
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = value as *const T as *const i8;
        let last = std::mem::size_of::<T>().saturating_sub(1);
        // The first byte's line, then each line up to and including the last byte's.
        let mut offset = 0;
        while offset < last + LINE {
            let at = start.wrapping_add(offset.min(last));
            // SAFETY: prefetching never faults, and `at` lies within `value`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(at) };
            offset += LINE;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
