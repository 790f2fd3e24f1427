//! The program's memory allocator: glibc's malloc for every block below 1 MiB, and for larger
//! blocks an anonymous mapping of our own on a 2 MiB boundary, a whole number of 2 MiB long,
//! advised to use transparent huge pages (`madvise(MADV_HUGEPAGE)`) where it is one of the arrays
//! that rendering reads at random or 16 MiB or longer. The kernel then backs it with 2 MiB pages
//! where it can: one TLB entry and one page fault for 512 small pages.
//!
//! Rendering reads the scene's arrays at random (the AVX2 walk's nodes, the test triangles and
//! their ids, the scene's triangles, the lights and each triangle's light, the alias table, the
//! light tree's nodes, power prefix and powers), and every small page it touches is a TLB entry; in
//! a virtual machine each TLB miss walks two page tables. Those arrays are made inside
//! [`on_huge_pages`], which marks the blocks the thread maps meanwhile (the film too: filled tile
//! by tile, and made anew by every render of a process). A very large block (`LARGE`) would take
//! thousands of small-page faults, so it gets huge pages wherever it is made.
//! The other blocks, the builds' temporaries and the file's bytes, stay on small pages: a free huge
//! page may just have been handed back to the hypervisor (a guest with free page reporting, as this
//! machine's), and faulting it in again took about 2 ms. With every block of the 50k city on huge
//! pages (94 MB), a render started after 8 idle seconds spent 0.13–0.18 s of CPU besides its
//! render; with the render's arrays alone (22 MB) 0.09–0.12 s. Back to back, where the freed pages
//! are still the guest's, the small-page faults cost a little more: 0.063–0.080 s with every block
//! on huge pages, 0.072–0.081 s with the arrays alone (`render --spp 1 --width 320`, power + mis,
//! the peers' Lambert copy of the 50k city, four runs each). The peers' harness as its README runs
//! it (power_mis then bvh_mis, five runs each, alternating) gave power_mis 0.321–0.334 →
//! 0.314–0.321 µs per camera sample (1.27–1.32 → 1.21–1.25× Mitsuba's), bvh_mis unchanged; on the
//! 1M-light city (`render --spp 1 --width 64 --selector bvh`, back to back) CPU 2.04–2.11 →
//! 2.07–2.08 s, peak RSS 431–441 → 440–442 MB. Mapping the large blocks ourselves also lets growth
//! (`realloc`) move a block's pages with `mremap`, without copying (or copy them where the kernel
//! refuses the move). The advice is only advice: where the kernel gives no huge pages (THP
//! disabled, or none free), the blocks are plain mappings, as glibc's would be.

use std::alloc::{GlobalAlloc, Layout, System};
#[cfg(target_os = "linux")]
use std::ptr::null_mut;

std::thread_local! {
    /// Whether this thread is inside [`on_huge_pages`].
    static HUGE_PAGES: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `build` with the blocks of 1 MiB and more that this thread maps or grows meanwhile
/// advised to use huge pages (a grown block whole, the pages it had included): for the arrays
/// that rendering reads at random (see the module header). Blocks that other threads map
/// meanwhile (the workers of a parallel `collect`, whose final vector the calling thread
/// allocates) are not marked; a block grown later, outside, keeps the advice of the pages it had.
pub fn on_huge_pages<R>(build: impl FnOnce() -> R) -> R {
    /// Puts the thread's flag back as it was, also when `build` panics.
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            HUGE_PAGES.set(self.0);
        }
    }
    let _restore = Restore(HUGE_PAGES.replace(true));
    build()
}

/// One huge page: mappings start on a multiple of it and are a whole number of it long.
#[cfg(target_os = "linux")]
const HUGE_MIN: usize = 2 << 20;
/// Blocks of at least this many bytes are mapped by us.
const MAP_MIN: usize = 1 << 20;
/// Blocks of at least this many bytes are put on huge pages wherever they are made: thousands
/// of small-page faults each (see the module header).
#[cfg(target_os = "linux")]
const LARGE: usize = 16 << 20;
/// The size and alignment of a mapping's (small) pages.
const PAGE: usize = 4096;

/// glibc's malloc with blocks of 1 MiB and more mapped by us, on transparent huge pages where
/// the module header says; elsewhere than Linux, the system allocator alone.
pub struct HugePageAllocator;

/// Whether a block of `layout` is mapped by us: large, and aligned no more than a page.
#[inline]
fn is_mapped(layout: &Layout) -> bool {
    cfg!(target_os = "linux") && layout.size() >= MAP_MIN && layout.align() <= PAGE
}

/// The length of the mapping that holds `size` bytes: whole huge pages.
#[cfg(target_os = "linux")]
#[inline]
fn mapped_len(size: usize) -> usize {
    size.next_multiple_of(HUGE_MIN)
}

/// A fresh zero-filled mapping of at least `size` bytes starting on a huge-page boundary,
/// advised to use huge pages where `wants_huge`, or null. The kernel does not align mappings to
/// huge pages: so `size` rounded up to whole huge pages, plus 2 MiB less a page, is mapped, and
/// the slack before the boundary and after the block is unmapped again. Every 2 MiB of the
/// block, the last one included, can then be one huge page.
#[cfg(target_os = "linux")]
unsafe fn map(size: usize) -> *mut u8 {
    let len = mapped_len(size);
    let Some(reserve) = len.checked_add(HUGE_MIN - PAGE) else {
        return null_mut();
    };
    // SAFETY: an anonymous private mapping at an address of the kernel's choice touches no
    // existing memory.
    let p = unsafe {
        libc::mmap(
            null_mut(),
            reserve,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        )
    };
    if p == libc::MAP_FAILED {
        return null_mut();
    }
    let base = p as usize;
    // `base` is page-aligned, so the boundary lies at most 2 MiB − 4 KiB on, and the block ends
    // within the reservation.
    let start = base.next_multiple_of(HUGE_MIN);
    let (head, tail) = (start - base, base + reserve - (start + len));
    // SAFETY: both ranges are page-aligned parts of the reservation just made, outside the block.
    unsafe {
        if head > 0 {
            libc::munmap(p, head);
        }
        if tail > 0 {
            libc::munmap((start + len) as *mut libc::c_void, tail);
        }
    }
    if wants_huge(size) {
        advise_huge(start as *mut libc::c_void, len);
    }
    start as *mut u8
}

/// Whether a block of `size` bytes mapped or grown now is to be on huge pages: inside
/// [`on_huge_pages`], or `LARGE` or longer.
#[cfg(target_os = "linux")]
fn wants_huge(size: usize) -> bool {
    HUGE_PAGES.get() || size >= LARGE
}

/// Asks for huge pages on `len` bytes at `p` (a mapping of ours); refused advice changes nothing.
#[cfg(target_os = "linux")]
fn advise_huge(p: *mut libc::c_void, len: usize) {
    // SAFETY: madvise only sets a flag on pages of a mapping we own; its result is ignored on
    // purpose (the mapping works either way).
    unsafe { libc::madvise(p, len, libc::MADV_HUGEPAGE) };
}

#[cfg(not(target_os = "linux"))]
unsafe fn map(_size: usize) -> *mut u8 {
    unreachable!("blocks are mapped on Linux only")
}

unsafe impl GlobalAlloc for HugePageAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if is_mapped(&layout) {
            // SAFETY: a new mapping.
            unsafe { map(layout.size()) }
        } else {
            // SAFETY: the caller's contract, passed on.
            unsafe { System.alloc(layout) }
        }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if is_mapped(&layout) {
            // SAFETY: a new anonymous mapping reads as zeros.
            unsafe { map(layout.size()) }
        } else {
            // SAFETY: the caller's contract, passed on.
            unsafe { System.alloc_zeroed(layout) }
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if is_mapped(&layout) {
            #[cfg(target_os = "linux")]
            // SAFETY: `ptr` was mapped by `map` or `realloc` with this length (the layout is the
            // one it was allocated with).
            unsafe {
                libc::munmap(ptr.cast(), mapped_len(layout.size()));
            }
        } else {
            // SAFETY: the caller's contract, passed on.
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller guarantees that `new_size`, rounded up to the alignment, does not
        // overflow isize.
        let new_layout = unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) };
        match (is_mapped(&layout), is_mapped(&new_layout)) {
            // SAFETY: the caller's contract, passed on.
            (false, false) => unsafe { System.realloc(ptr, layout, new_size) },
            #[cfg(target_os = "linux")]
            (true, true) => {
                let (old_len, new_len) = (mapped_len(layout.size()), mapped_len(new_size));
                if old_len == new_len {
                    return ptr;
                }
                if new_len < old_len {
                    // A shrink unmaps the tail, whatever mappings the block is made of.
                    // SAFETY: the tail is part of our mapping of `old_len` bytes at `ptr`.
                    unsafe { libc::munmap(ptr.add(new_len).cast(), old_len - new_len) };
                    return ptr;
                }
                // A growth stays in place when the pages after the block are free (the start, on
                // its huge-page boundary, stays).
                // SAFETY: `ptr` is a mapping of ours of `old_len` bytes; on failure it stays as
                // it was.
                let p = unsafe { libc::mremap(ptr.cast(), old_len, new_len, 0) };
                if p != libc::MAP_FAILED {
                    if wants_huge(new_size) {
                        advise_huge(p, new_len);
                    }
                    return p.cast();
                }
                // Else a new aligned mapping, with the old pages moved to its start (not copied),
                // or copied where the kernel refuses the move (a block grown before by a move is
                // two mappings, which mremap may not take as one).
                // SAFETY: a new mapping.
                let new = unsafe { map(new_size) };
                if new.is_null() {
                    return null_mut();
                }
                // SAFETY: moves or copies the old block (ours, `old_len` bytes) over the start of
                // the new mapping, which is ours and longer; the old block is gone afterwards
                // either way.
                unsafe {
                    let flags = libc::MREMAP_MAYMOVE | libc::MREMAP_FIXED;
                    let moved = libc::mremap(ptr.cast(), old_len, old_len, flags, new);
                    if moved == libc::MAP_FAILED {
                        std::ptr::copy_nonoverlapping(ptr, new, layout.size());
                        libc::munmap(ptr.cast(), old_len);
                    }
                }
                // The moved pages keep their old advice: the whole block is advised anew.
                if wants_huge(new_size) {
                    advise_huge(new.cast(), new_len);
                }
                new
            }
            _ => {
                // Across the threshold: a new block, the contents copied, the old one freed.
                // SAFETY: `new_size` is non-zero (`realloc`'s contract).
                let new = unsafe { self.alloc(new_layout) };
                if !new.is_null() {
                    // SAFETY: both blocks hold at least the smaller size and do not overlap.
                    unsafe {
                        std::ptr::copy_nonoverlapping(ptr, new, layout.size().min(new_size));
                        self.dealloc(ptr, layout);
                    }
                }
                new
            }
        }
    }
}

/// The mappings and their kernel flags are Linux's (elsewhere the allocator is the system's).
#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    /// Writes a pattern that tells every 8-byte word apart.
    fn fill(p: *mut u8, len: usize, seed: u64) {
        for i in 0..len / 8 {
            // SAFETY: `p` holds `len` bytes, 8-aligned.
            unsafe { p.cast::<u64>().add(i).write(seed ^ i as u64) };
        }
    }

    fn holds(p: *const u8, len: usize, seed: u64) -> bool {
        // SAFETY: `p` holds `len` bytes, 8-aligned.
        (0..len / 8).all(|i| unsafe { p.cast::<u64>().add(i).read() } == seed ^ i as u64)
    }

    #[test]
    fn blocks_keep_their_contents_through_growth_and_shrinking_across_the_threshold() {
        let a = HugePageAllocator;
        let small = Layout::from_size_align(MAP_MIN / 4, 64).unwrap();
        // SAFETY: non-zero sizes; every block is freed with the layout it has.
        unsafe {
            let p = a.alloc(small);
            assert!(!p.is_null());
            fill(p, small.size(), 7);
            // Small → mapped → larger mapped → smaller mapped → small.
            let sizes = [
                HUGE_MIN + 8,
                3 * HUGE_MIN + 4096 + 8,
                HUGE_MIN + 16,
                MAP_MIN / 8,
            ];
            let (mut p, mut layout) = (p, small);
            for &size in &sizes {
                let kept = layout.size().min(size);
                p = a.realloc(p, layout, size);
                assert!(!p.is_null());
                assert_eq!(p as usize % 64, 0, "alignment kept");
                if size >= MAP_MIN {
                    assert_eq!(
                        p as usize % HUGE_MIN,
                        0,
                        "a mapped block starts on a huge page"
                    );
                }
                assert!(holds(p, kept, 7), "contents kept at {size} bytes");
                layout = Layout::from_size_align(size, 64).unwrap();
                fill(p, size, 7);
            }
            a.dealloc(p, layout);
        }
    }

    /// The kernel's flags of the mapping that holds `p` (`VmFlags` in /proc/self/smaps).
    fn mapping_flags(p: *const u8) -> Option<String> {
        mapping_of(p).map(|(_, flags)| flags)
    }

    /// The end of the mapping that holds `p` and its kernel flags (`/proc/self/smaps`).
    fn mapping_of(p: *const u8) -> Option<(usize, String)> {
        let smaps = std::fs::read_to_string("/proc/self/smaps").ok()?;
        let at = p as usize;
        let mut inside = None;
        for line in smaps.lines() {
            let range = line
                .split_whitespace()
                .next()
                .and_then(|r| r.split_once('-'));
            if let Some((lo, hi)) = range.filter(|_| !line.starts_with("VmFlags")) {
                if let (Ok(lo), Ok(hi)) =
                    (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
                {
                    inside = (lo..hi).contains(&at).then_some(hi);
                    continue;
                }
            }
            if let Some(end) = inside {
                if let Some(flags) = line.strip_prefix("VmFlags:") {
                    return Some((end, flags.to_string()));
                }
            }
        }
        None
    }

    /// Blocks mapped inside `on_huge_pages` (also nested in another call, and moved there by
    /// growth) and blocks of `LARGE` bytes or more are advised to use huge pages; other mapped
    /// blocks, blocks mapped after the call returned, and glibc's small blocks are not.
    #[test]
    fn huge_pages_are_asked_for_inside_on_huge_pages_and_for_large_blocks_only() {
        // Where the kernel has no transparent huge pages, madvise refuses the advice.
        if !std::path::Path::new("/sys/kernel/mm/transparent_hugepage/enabled").exists() {
            return;
        }
        let a = HugePageAllocator;
        let layout = |size: usize| Layout::from_size_align(size, 8).unwrap();
        // SAFETY: non-zero sizes.
        let block = |size: usize| (unsafe { a.alloc(layout(size)) }, layout(size));
        let huge = |p: *const u8| {
            let flags = mapping_flags(p).expect("the block is in some mapping");
            (flags.split_whitespace().any(|f| f == "hg"), flags)
        };
        let (medium, grown) = (2 * HUGE_MIN, 5 * HUGE_MIN);
        // Made outside, grown inside: moved (a block made after it takes the pages behind it),
        // and in place (nothing behind it, where the kernel leaves room).
        let (to_move, blocker) = (block(medium), block(medium));
        let in_place = block(medium);
        let marked = on_huge_pages(|| {
            let outer = block(medium);
            let inner = on_huge_pages(|| block(medium));
            let after_inner = block(medium);
            // SAFETY: blocks of ours with their layouts.
            let (moved, grown_in_place) = unsafe {
                (
                    a.realloc(to_move.0, to_move.1, grown),
                    a.realloc(in_place.0, in_place.1, grown),
                )
            };
            [
                outer,
                inner,
                after_inner,
                (moved, layout(grown)),
                (grown_in_place, layout(grown)),
            ]
        });
        let others = [blocker, block(medium), block(LARGE), block(MAP_MIN / 2)];
        for (p, l) in &marked {
            // Both ends: a grown block's old pages and its new ones.
            for at in [*p, p.wrapping_add(l.size() - 1)] {
                let (hg, flags) = huge(at);
                assert!(hg, "a block made or grown inside on_huge_pages: {flags}");
            }
        }
        let expected = [false, false, true, false];
        for ((p, l), want) in others.iter().zip(expected) {
            let (hg, flags) = huge(*p);
            assert_eq!(
                hg,
                want,
                "a block of {} bytes made outside: {flags}",
                l.size()
            );
        }
        for (p, l) in marked.into_iter().chain(others) {
            // SAFETY: each block is ours, freed once with its layout.
            unsafe { a.dealloc(p, l) };
        }
    }

    /// A block's mapping runs to the end of its last huge page, so that page can be a huge page
    /// too (a block mapped to the end of its last small page would end 1 MiB + 4 KiB on, unless
    /// the kernel joined it to a neighbouring mapping).
    #[cfg(target_os = "linux")]
    #[test]
    fn a_block_is_mapped_to_the_end_of_its_last_huge_page() {
        let a = HugePageAllocator;
        let layout = Layout::from_size_align(MAP_MIN + 8, 8).unwrap();
        // SAFETY: a non-zero size, freed with its layout.
        unsafe {
            let p = a.alloc(layout);
            assert!(!p.is_null());
            let (end, _) = mapping_of(p).expect("the block is a mapping");
            assert!(
                end >= p as usize + HUGE_MIN,
                "the mapping of the block at {p:?} ends at {end:#x}"
            );
            a.dealloc(p, layout);
        }
    }

    /// Maps an inaccessible page at `at` unless something is mapped there already, and says
    /// whether it did. Other tests run in parallel and allocate, so the page after a block
    /// may be taken by the time the test asks for it.
    ///
    /// # Safety
    /// `at` is page-aligned; the caller unmaps the page when this returns true.
    unsafe fn guard_page(at: *mut u8) -> bool {
        let got = libc::mmap(
            at.cast(),
            PAGE,
            libc::PROT_NONE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS | libc::MAP_FIXED_NOREPLACE,
            -1,
            0,
        );
        if got == at.cast() {
            return true;
        }
        let error = std::io::Error::last_os_error();
        assert!(
            got == libc::MAP_FAILED && error.raw_os_error() == Some(libc::EEXIST),
            "MAP_FIXED_NOREPLACE at {at:?}: got {got:?}, {error}"
        );
        false
    }

    #[test]
    fn a_block_that_cannot_grow_in_place_moves_to_a_new_huge_page_boundary_with_its_contents() {
        let a = HugePageAllocator;
        let layout = Layout::from_size_align(HUGE_MIN + 3 * PAGE, 8).unwrap();
        let len = mapped_len(layout.size());
        // SAFETY: guard pages are mapped only where nothing is (NOREPLACE) and unmapped at the
        // end; every block is freed with its layout, the set-aside ones last.
        unsafe {
            // A block with a mapping of ours right after it: a guard page, or a block set aside
            // before (the kernel often places a new mapping right below the last one). Blocks
            // whose next page another test took meanwhile are set aside, as that mapping may go
            // away at any time.
            let mut set_aside: Vec<*mut u8> = Vec::new();
            let (p, guard) = loop {
                let p = a.alloc(layout);
                let after = p.add(len);
                if set_aside.contains(&after) {
                    break (p, None);
                }
                if guard_page(after) {
                    break (p, Some(after));
                }
                set_aside.push(p);
                assert!(set_aside.len() < 16, "no free page after 16 blocks");
            };
            fill(p, layout.size(), 5);
            let grown = a.realloc(p, layout, 4 * HUGE_MIN);
            assert!(!grown.is_null());
            assert_ne!(grown, p, "moved: the guard page is in the way");
            assert_eq!(grown as usize % HUGE_MIN, 0, "on a huge-page boundary");
            assert!(holds(grown, layout.size(), 5), "contents moved");
            let rest = std::slice::from_raw_parts(grown.add(len), 4 * HUGE_MIN - len);
            assert!(rest.iter().all(|&b| b == 0), "the new part is fresh");
            // The moved block is now two mappings (the moved pages and the fresh part): grown
            // again past a second guard page (or another test's mapping), it moves or is
            // copied, or grows in place if that mapping went away.
            fill(grown, 4 * HUGE_MIN, 6);
            let guard2 = grown.add(4 * HUGE_MIN);
            let guarded2 = guard_page(guard2);
            let layout = Layout::from_size_align(4 * HUGE_MIN, 8).unwrap();
            let again = a.realloc(grown, layout, 7 * HUGE_MIN);
            assert!(!again.is_null());
            assert_eq!(
                again as usize % HUGE_MIN,
                0,
                "on a huge-page boundary again"
            );
            assert!(holds(again, 4 * HUGE_MIN, 6), "contents moved again");
            // And shrunk across its two mappings.
            let layout = Layout::from_size_align(7 * HUGE_MIN, 8).unwrap();
            let small = a.realloc(again, layout, 3 * HUGE_MIN);
            assert_eq!(small, again, "a shrink stays in place");
            assert!(holds(small, 3 * HUGE_MIN, 6), "contents kept by the shrink");
            a.dealloc(small, Layout::from_size_align(3 * HUGE_MIN, 8).unwrap());
            if let Some(guard) = guard {
                libc::munmap(guard.cast(), PAGE);
            }
            if guarded2 {
                libc::munmap(guard2.cast(), PAGE);
            }
            for q in set_aside {
                a.dealloc(q, Layout::from_size_align(HUGE_MIN + 3 * PAGE, 8).unwrap());
            }
        }
    }

    #[test]
    fn zeroed_blocks_read_as_zero_on_both_sides_of_the_threshold() {
        let a = HugePageAllocator;
        for size in [4096, MAP_MIN - 8, MAP_MIN, HUGE_MIN, 5 * HUGE_MIN + 24] {
            let layout = Layout::from_size_align(size, 8).unwrap();
            // SAFETY: a non-zero size, freed with its layout.
            unsafe {
                let p = a.alloc_zeroed(layout);
                assert!(!p.is_null());
                assert!((0..size).all(|i| *p.add(i) == 0), "{size} bytes zeroed");
                a.dealloc(p, layout);
            }
        }
    }

    #[test]
    fn a_vec_grown_past_many_huge_pages_keeps_every_element() {
        // The test binary's global allocator is the system's: ours is driven directly, the way
        // a Vec grows (doubling its capacity), through 32 MiB.
        let a = HugePageAllocator;
        let mut cap = 1usize << 10;
        let mut layout = Layout::array::<u64>(cap).unwrap();
        // SAFETY: as above.
        unsafe {
            let mut p = a.alloc(layout);
            fill(p, layout.size(), 99);
            while cap < 1 << 22 {
                let new = Layout::array::<u64>(cap * 2).unwrap();
                p = a.realloc(p, layout, new.size());
                assert!(holds(p, layout.size(), 99), "{} elements kept", cap);
                fill(p, new.size(), 99);
                (cap, layout) = (cap * 2, new);
            }
            a.dealloc(p, layout);
        }
    }
}
