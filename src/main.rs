use clap::Parser;

/// Large blocks on transparent huge pages (`manylights::alloc`).
#[global_allocator]
static ALLOCATOR: manylights::alloc::HugePageAllocator = manylights::alloc::HugePageAllocator;

fn main() {
    restore_broken_pipe_termination();
    tune_malloc();
    let cli = manylights::cli::Cli::parse();
    std::process::exit(manylights::cli::run(cli));
}

/// Output piped into a reader that stops early (`manylights info SCENE | head`) ends the program
/// quietly, as it ends `cat`: SIGPIPE terminates it instead of a failed write panicking (Rust
/// ignores SIGPIPE, and `println!` panics on the broken pipe).
fn restore_broken_pipe_termination() {
    #[cfg(unix)]
    {
        use std::sync::{atomic::AtomicBool, Arc};
        let always = Arc::new(AtomicBool::new(true));
        // Registration fails only for signals that cannot be handled; SIGPIPE can.
        let _ =
            signal_hook::flag::register_conditional_default(signal_hook::consts::SIGPIPE, always);
    }
}

/// glibc's malloc (which serves blocks below 1 MiB: larger ones are mapped by
/// `manylights::alloc`), told to use one arena and a fixed threshold of 1 MB above which blocks
/// get their own mapping (no block it sees is that large, but a set threshold never grows). By
/// default each thread gets an arena, and the size above which blocks are mapped grows to 32 MB
/// once a large block is freed; the BVH build's parts, built in parallel, then
/// leave their freed temporaries scattered through heaps that cannot shrink. On the 1M-emitter
/// city (`/usr/bin/time -f %M`, render 64×48, 1 spp, power) the peak was 473–553 MB and varied
/// between runs; with these settings it is 421–425 MB, for a BVH build of 0.79–0.84 s instead
/// of 0.6 s (fresh mappings are faulted in again). A camera sample allocates nothing, so the
/// render never contends for the one arena.
fn tune_malloc() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets tuning parameters; called before any thread is spawned.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 1);
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
}
