//! A stable-Rust mutation fuzzer for the OpenEXR readers: `--env` environment maps
//! (`EnvironmentImage::load`, then the light built from it, `EnvironmentMap::new`) and references
//! (`read_exr_rgb`, which `diff`, `bench --reference` and `converge --reference` use). Whatever
//! the bytes, each must return a value or an error naming the file — never panic, hang, or make
//! an allocation larger than the file could need.
//!
//! Corpus: EXRs written by the renderer (mean only; mean and variance; 1×1; a 16×8 map) and
//! their f16 variants. Mutations (deterministic from a PCG seed): bit flips, byte overwrites,
//! interesting 32-bit words (header sizes, data-window corners, chunk offsets), truncation,
//! chunk duplication and deletion, and header-aware edits of the data window.
//!
//! `fuzz_exr_briefly` runs a fixed number of mutations on every `cargo test`;
//! `FUZZ_SECONDS=600 cargo test --release --test fuzz_exr -- --ignored --nocapture` runs longer.

#[path = "common/byte_mutations.rs"]
mod byte_mutations;
#[path = "common/corpus.rs"]
mod corpus;

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use manylights::image::{read_exr_rgb, write_exr, RgbImage};
use manylights::lights::EnvironmentMap;
use manylights::scene::EnvironmentImage;
use rand_core::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use byte_mutations::{below, insert_byte, ByteMutations};

/// One allocation above this while reading a fuzzed input (the corpus files are < 4 kB) means a
/// size from the file was trusted; the allocator saves the input and aborts.
const MAX_ALLOCATION: usize = 256 << 20;
const SLOW: Duration = Duration::from_secs(2);

struct Guard;
static FUZZING: AtomicBool = AtomicBool::new(false);

unsafe impl GlobalAlloc for Guard {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        check_size(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        check_size(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        check_size(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Guard = Guard;

/// The file under test of the fuzzer `tag` is at a fixed place, so after an abort it is still
/// there to keep.
fn input_path(tag: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("target/fuzz-exr-{tag}.exr"))
}

fn check_size(size: usize) {
    if size > MAX_ALLOCATION && FUZZING.swap(false, Ordering::SeqCst) {
        eprintln!(
            "FUZZ: an EXR reader asked for {size} bytes; the input is {}",
            input_path("*").display()
        );
        std::process::abort();
    }
}

fn noisy(width: usize, height: usize, seed: u64) -> RgbImage {
    let mut rng = Pcg32::seed_from_u64(seed);
    let pixels = (0..width * height)
        .map(|_| [0, 1, 2].map(|_| (rng.next_u32() % 1000) as f32 / 100.0))
        .collect();
    RgbImage {
        width,
        height,
        pixels,
    }
}

fn corpus() -> Vec<Vec<u8>> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.exr");
    let mut out = Vec::new();
    for (w, h, variance) in [(4, 2, false), (3, 3, true), (1, 1, false), (16, 8, false)] {
        let mean = noisy(w, h, w as u64);
        let var = variance.then(|| noisy(w, h, 99));
        write_exr(&path, &mean, var.as_ref()).unwrap();
        out.push(std::fs::read(&path).unwrap());
    }
    out
}

const INTERESTING: [u32; 10] = [
    0,
    1,
    0x7f,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_fffe,
    0xffff_ffff,
    0x10000,
    0x4000_0000,
];

/// The shared byte mutations, tuned for EXR.
const MUTATIONS: ByteMutations = ByteMutations {
    interesting: &INTERESTING,
    aligned: false,
    max_duplicate: 128,
    max_delete: 32,
};

fn mutate(rng: &mut Pcg32, input: &[u8]) -> Vec<u8> {
    let mut data = input.to_vec();
    for _ in 0..1 + below(rng, 4) {
        let kind = below(rng, 8);
        if MUTATIONS.apply(kind, rng, &mut data) {
            continue;
        }
        let len = data.len();
        match kind {
            6 => {
                // The data window (box2i: four i32 after its name, type and size): corners far
                // apart or reversed, the size every reader allocates from.
                if let Some(at) = find(&data, b"dataWindow\0box2i\0") {
                    let corner = at + 17 + 4 + 4 * below(rng, 4);
                    if corner + 4 <= len {
                        let w = INTERESTING[below(rng, INTERESTING.len())];
                        data[corner..corner + 4].copy_from_slice(&w.to_le_bytes());
                    }
                }
            }
            _ => insert_byte(rng, &mut data),
        }
    }
    data
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

#[derive(Default)]
struct Report {
    executions: u64,
    read: u64,
    elapsed: Duration,
    slowest: Duration,
    /// Distinct panic message → first iteration.
    panics: BTreeMap<String, u64>,
    slow: Vec<u64>,
}

/// Reads the file at `path` as a reference and as an environment map.
fn read_both(path: &Path, report: &mut Report) -> Result<(), String> {
    let start = Instant::now();
    FUZZING.store(true, Ordering::SeqCst);
    let result = catch_unwind(AssertUnwindSafe(|| {
        let reference = read_exr_rgb(path).map(|_| ()).map_err(|e| format!("{e:#}"));
        let env = EnvironmentImage::load(path, 1.0, 30.0)
            .map(|image| drop(EnvironmentMap::new(Arc::new(image))))
            .map_err(|e| e.to_string());
        (reference, env)
    }));
    FUZZING.store(false, Ordering::SeqCst);
    let took = start.elapsed();
    report.executions += 1;
    report.slowest = report.slowest.max(took);
    let (reference, env) = result.map_err(|p| {
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "unknown panic".into())
    })?;
    let name = path.display().to_string();
    for e in [&reference, &env]
        .into_iter()
        .flat_map(|r| r.as_ref().err())
    {
        assert!(
            e.contains(&name),
            "an error that does not name the file: {e}"
        );
    }
    if took > SLOW {
        report.slow.push(report.executions);
    }
    if reference.is_ok() && env.is_ok() {
        report.read += 1;
    }
    Ok(())
}

fn fuzz(tag: &str, seed: u64, budget: impl Fn(u64, Duration) -> bool) -> Report {
    let path = input_path(tag);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    // Panics are expected and collected; keep their messages off stderr.
    std::panic::set_hook(Box::new(|_| {}));
    let corpus = corpus();
    let mut report = Report::default();
    for (i, input) in corpus.iter().enumerate() {
        std::fs::write(&path, input).unwrap();
        read_both(&path, &mut report).unwrap();
        assert_eq!(report.read, i as u64 + 1, "corpus input {i} does not read");
    }
    let mut rng = Pcg32::seed_from_u64(seed);
    let start = Instant::now();
    let mut iteration = 0;
    while budget(iteration, start.elapsed()) {
        let input = &corpus[below(&mut rng, corpus.len())];
        let mutated = mutate(&mut rng, input);
        std::fs::write(&path, &mutated).unwrap();
        if let Err(message) = read_both(&path, &mut report) {
            if let std::collections::btree_map::Entry::Vacant(slot) = report.panics.entry(message) {
                let keep = path.with_file_name(format!("fuzz-exr-panic-{seed}-{iteration}.exr"));
                std::fs::write(&keep, &mutated).unwrap();
                eprintln!(
                    "FUZZ PANIC seed {seed} iteration {iteration}: {} ({})",
                    slot.key(),
                    keep.display()
                );
                slot.insert(iteration);
            }
        }
        iteration += 1;
    }
    let _ = std::panic::take_hook();
    report.elapsed = start.elapsed();
    eprintln!(
        "fuzz exr: {} executions in {:.1} s, {} read cleanly, slowest {:?}, {} distinct panic(s), \
         {} slow input(s)",
        report.executions,
        report.elapsed.as_secs_f64(),
        report.read,
        report.slowest,
        report.panics.len(),
        report.slow.len()
    );
    report
}

/// Inputs the long run found, each refused now with an error naming the file (and the test fails
/// by aborting if a reader allocates from their headers again).
#[test]
fn found_inputs_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("found.exr");
    // Seed 16002, within its first second: 65,537 one-line chunks declared in 376 bytes; the exr crate
    // asked for 120 GB for its chunk offsets.
    let found: [(&[u8], &str); 1] = [(
        include_bytes!("fuzz_inputs/chunks-65537-in-376-bytes.exr"),
        "declare 65537 chunks, more than its 376 bytes hold",
    )];
    for (bytes, says) in found {
        std::fs::write(&path, bytes).unwrap();
        FUZZING.store(true, Ordering::SeqCst);
        let reference = read_exr_rgb(&path)
            .map(|_| ())
            .map_err(|e| format!("{e:#}"));
        let env = EnvironmentImage::load(&path, 1.0, 0.0)
            .map(|_| ())
            .map_err(|e| e.to_string());
        FUZZING.store(false, Ordering::SeqCst);
        for result in [reference, env] {
            let e = result.expect_err("refused");
            assert!(
                e.contains(&path.display().to_string()) && e.contains(says),
                "{e}"
            );
        }
    }
    // The same defect made on purpose: a valid 4×2 file whose data window claims 2^20 rows.
    write_exr(&path, &noisy(4, 2, 1), None).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let at = find(&bytes, b"dataWindow\0box2i\0").unwrap() + 17 + 4 + 12;
    bytes[at..at + 4].copy_from_slice(&(1u32 << 20).to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    FUZZING.store(true, Ordering::SeqCst);
    let e = read_exr_rgb(&path)
        .map(|_| ())
        .map_err(|e| format!("{e:#}"));
    FUZZING.store(false, Ordering::SeqCst);
    let e = e.expect_err("refused");
    assert!(e.contains("chunks, more than its"), "{e}");
}

#[test]
fn fuzz_exr_briefly() {
    let report = fuzz("brief", 1, |i, _| i < 1_000);
    assert!(report.panics.is_empty(), "panics: {:?}", report.panics);
    assert!(report.slow.is_empty(), "slow inputs at {:?}", report.slow);
}

#[test]
#[ignore = "long-running; set FUZZ_SECONDS (default 60) and FUZZ_SEED"]
fn fuzz_exr_for_a_while() {
    let env = |name: &str, default: u64| {
        std::env::var(name)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(default)
    };
    let limit = Duration::from_secs(env("FUZZ_SECONDS", 60));
    let report = fuzz("long", env("FUZZ_SEED", 0x5eed), |_, elapsed| {
        elapsed < limit
    });
    assert!(report.panics.is_empty(), "panics: {:?}", report.panics);
    assert!(report.slow.is_empty(), "slow inputs at {:?}", report.slow);
}

#[test]
#[ignore = "writes the seed corpus of the coverage-guided fuzzer to FUZZ_CORPUS_DIR"]
fn write_seed_corpus() {
    corpus::write_seed_corpus(&corpus(), ".exr");
}
