//! A stable-Rust mutation fuzzer for the glTF/GLB loader: it must never panic, hang or make a
//! huge allocation, whatever the bytes. Corpus: the shipped Cornell box, a small generated town
//! (GLB), a JSON .gltf Cornell box, the same with KHR_lights_punctual lights, a triangle
//! with a sparse accessor, the shipped textured and extremes scenes, and a textured quad with
//! three cameras, samplers, KHR_texture_transform, material extensions, lights on camera nodes
//! and hostile image URIs (`fuzz_inputs`). Mutations are deterministic from a PCG seed: byte flips
//! and overwrites, interesting 32-bit words, truncation, chunk duplication and deletion, and
//! JSON-aware edits (numbers replaced by huge/negative/non-finite literals, keys dropped or
//! duplicated, componentType/type/count/byteOffset/byteLength and index references changed) —
//! applied to the JSON chunk of a GLB too, with the GLB lengths rewritten to match.
//!
//! `fuzz_loader_briefly` runs a fixed number of mutations on every `cargo test`;
//! `FUZZ_SECONDS=600 cargo test --test fuzz_loader -- --ignored --nocapture` fuzzes for longer
//! (without `--release`, so the test profile's overflow checks are on). Each panic prints the
//! seed and iteration and writes the input to `target/fuzz-crashes/`.

#[path = "../common/byte_mutations.rs"]
mod byte_mutations;
#[path = "../common/corpus.rs"]
mod corpus;
mod mutations;
use mutations::{below, mutate};

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

use manylights::gen::generate;
use manylights::scene::{load_gltf_bytes, CameraChoice};
use rand_core::SeedableRng;
use rand_pcg::Pcg32;
use serde_json::Value;

#[path = "../fuzz_inputs/mod.rs"]
mod fuzz_inputs;

/// Any single allocation above this while loading a fuzzed input (all are < 1 MiB) is a bug:
/// the loader trusted a count or length from the file. The allocator writes the input and aborts.
const MAX_ALLOCATION: usize = 256 << 20;
/// An input that takes longer than this to load is reported as a hang.
const SLOW: Duration = Duration::from_secs(2);

struct Guard;

static FUZZING: AtomicBool = AtomicBool::new(false);
static CURRENT: Mutex<Option<(String, Vec<u8>)>> = Mutex::new(None);

unsafe impl GlobalAlloc for Guard {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION && FUZZING.swap(false, Ordering::SeqCst) {
            huge_allocation(layout.size());
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION && FUZZING.swap(false, Ordering::SeqCst) {
            huge_allocation(layout.size());
        }
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > MAX_ALLOCATION && FUZZING.swap(false, Ordering::SeqCst) {
            huge_allocation(new_size);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Guard = Guard;

fn huge_allocation(size: usize) -> ! {
    if let Ok(current) = CURRENT.try_lock() {
        if let Some((name, bytes)) = current.as_ref() {
            let path = save_crash(&format!("{name}-alloc"), bytes);
            eprintln!(
                "FUZZ: {name}: the loader asked for {size} bytes; input written to {}",
                path.display()
            );
        }
    }
    std::process::abort();
}

fn crash_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("target/fuzz-crashes")
}

fn save_crash(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = crash_dir();
    let _ = std::fs::create_dir_all(&dir);
    let ext = if bytes.starts_with(b"glTF") {
        "glb"
    } else {
        "gltf"
    };
    let path = dir.join(format!("{name}.{ext}"));
    let _ = std::fs::write(&path, bytes);
    path
}

thread_local! {
    static LAST_PANIC: std::cell::RefCell<Option<(String, String)>> =
        const { std::cell::RefCell::new(None) };
}

/// A quiet panic hook that records (file:line, message); panics are grouped by location.
fn install_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if FUZZING.load(Ordering::SeqCst) {
                let location = info
                    .location()
                    .map(|l| format!("{}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                let message = info
                    .payload()
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| info.payload().downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                LAST_PANIC.with(|p| *p.borrow_mut() = Some((location, message)));
            } else {
                previous(info);
            }
        }));
    });
}

fn corpus() -> Vec<Vec<u8>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cornell_glb = std::fs::read(root.join("scenes/cornell.glb")).expect("scenes/cornell.glb");
    // Embedded PNG emissive and base-colour textures with samplers and TEXCOORD_0.
    let textured_glb =
        std::fs::read(root.join("scenes/textured.glb")).expect("scenes/textured.glb");
    // KHR_materials_specular, one- and two-sided emitters, extreme radiances.
    let extremes_glb =
        std::fs::read(root.join("scenes/extremes.glb")).expect("scenes/extremes.glb");
    // scenes/town.glb is ~0.5 MB: too slow per execution. A 50-light town has the same structure.
    let town = generate::many_lights(1, 50).to_glb_bytes();
    let dir = tempfile::tempdir().unwrap();
    let gltf_path = dir.path().join("cornell.gltf");
    generate::cornell().write(&gltf_path).unwrap();
    let cornell_gltf = std::fs::read(&gltf_path).unwrap();
    // The same box with punctual lights (point, spot, directional) on three new root nodes.
    let mut lit: Value = serde_json::from_slice(&cornell_gltf).unwrap();
    lit["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
    lit["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1, 0.9, 0.8], "intensity": 5},
        {"type": "spot", "intensity": 20, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        {"type": "directional", "intensity": 2}
    ]}});
    let nodes = lit["nodes"].as_array_mut().unwrap();
    let first = nodes.len();
    for light in 0..3 {
        nodes.push(serde_json::json!({
            "translation": [0, 1.5, light as f64 * 0.1],
            "extensions": {"KHR_lights_punctual": {"light": light}}
        }));
    }
    let roots = lit["scenes"][0]["nodes"].as_array_mut().unwrap();
    roots.extend((first..first + 3).map(Value::from));
    vec![
        cornell_glb,
        town,
        cornell_gltf,
        serde_json::to_vec(&lit).unwrap(),
        sparse_triangle(),
        textured_glb,
        extremes_glb,
        fuzz_inputs::textured_quad_with_cameras(),
    ]
}

/// One triangle whose first vertex is replaced by a sparse value (u32 index 0 → (0, 0, -1)).
fn sparse_triangle() -> Vec<u8> {
    use base64::Engine;
    let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    bin.extend(0u32.to_le_bytes());
    bin.extend([0.0f32, 0.0, -1.0].iter().flat_map(|f| f.to_le_bytes()));
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"uri": uri, "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 4},
            {"buffer": 0, "byteOffset": 40, "byteLength": 12}
        ],
        "accessors": [{
            "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [0, 0, -1], "max": [1, 1, 0],
            "sparse": {
                "count": 1,
                "indices": {"bufferView": 1, "componentType": 5125},
                "values": {"bufferView": 2}
            }
        }]
    });
    serde_json::to_vec(&doc).unwrap()
}

// ---------------------------------------------------------------------------------------------
// The harness

#[derive(Default)]
struct Report {
    executions: u64,
    loaded: u64,
    elapsed: Duration,
    slowest: Duration,
    /// Distinct panic location → (first message, first input name).
    panics: BTreeMap<String, (String, String)>,
    hangs: Vec<String>,
}

/// Loads one input, catching a panic. Returns Some((location, message)) on a panic.
fn run_one(name: &str, bytes: &[u8], report: &mut Report) -> Option<(String, String)> {
    *CURRENT.lock().unwrap() = Some((name.to_string(), bytes.to_vec()));
    let dir = std::env::temp_dir().join("manylights-fuzz-no-such-dir");
    let start = Instant::now();
    FUZZING.store(true, Ordering::SeqCst);
    let result = catch_unwind(AssertUnwindSafe(|| {
        load_gltf_bytes(bytes, Path::new("fuzz.glb"), &dir, &CameraChoice::First)
    }));
    FUZZING.store(false, Ordering::SeqCst);
    let took = start.elapsed();
    report.executions += 1;
    report.slowest = report.slowest.max(took);
    if took > SLOW {
        let path = save_crash(&format!("{name}-slow"), bytes);
        report
            .hangs
            .push(format!("{name}: {took:?} ({})", path.display()));
    }
    match result {
        Ok(Ok(_)) => {
            report.loaded += 1;
            None
        }
        Ok(Err(e)) => {
            // Every error names the file.
            assert!(e.to_string().contains("fuzz.glb"), "{e}");
            None
        }
        Err(_) => {
            let what = LAST_PANIC
                .with(|p| p.borrow_mut().take())
                .unwrap_or_else(|| ("unknown".into(), "unknown panic".into()));
            Some(what)
        }
    }
}

fn fuzz(seed: u64, budget: impl Fn(u64, Duration) -> bool) -> Report {
    install_hook();
    let corpus = corpus();
    let mut report = Report::default();
    let mut rng = Pcg32::seed_from_u64(seed);
    let start = Instant::now();
    // The unmutated corpus must load.
    for (i, input) in corpus.iter().enumerate() {
        assert!(run_one(&format!("corpus{i}"), input, &mut report).is_none());
        assert_eq!(
            report.loaded,
            i as u64 + 1,
            "corpus input {i} does not load"
        );
    }
    let mut iteration = 0u64;
    while budget(iteration, start.elapsed()) {
        let input = &corpus[below(&mut rng, corpus.len())];
        let mutated = mutate(&mut rng, input);
        let name = format!("seed{seed}-iter{iteration}");
        if let Some((location, message)) = run_one(&name, &mutated, &mut report) {
            if let std::collections::btree_map::Entry::Vacant(slot) = report.panics.entry(location)
            {
                let path = save_crash(&name, &mutated);
                eprintln!(
                    "FUZZ PANIC seed {seed} iteration {iteration}: {}: {message}\n  input: {}",
                    slot.key(),
                    path.display()
                );
                slot.insert((message, name));
            }
        }
        iteration += 1;
    }
    report.elapsed = start.elapsed();
    report
}

fn print(report: &Report) {
    let secs = report.elapsed.as_secs_f64();
    eprintln!(
        "fuzz: {} executions in {:.1} s ({:.0} exec/s), {} loaded cleanly, slowest {:?}, \
         {} distinct panic(s), {} slow input(s)",
        report.executions,
        secs,
        report.executions as f64 / secs.max(1e-9),
        report.loaded,
        report.slowest,
        report.panics.len(),
        report.hangs.len()
    );
    for (location, (message, first)) in &report.panics {
        eprintln!("  panic {location}: {message} (first: {first})");
    }
    for h in &report.hangs {
        eprintln!("  slow {h}");
    }
}

fn assert_clean(report: &Report) {
    assert!(
        report.panics.is_empty() && report.hangs.is_empty(),
        "the loader panicked or hung; inputs are in {}",
        crash_dir().display()
    );
}

#[test]
fn fuzz_loader_briefly() {
    let report = fuzz(1, |i, _| i < 2_000);
    print(&report);
    assert_clean(&report);
}

#[test]
#[ignore = "long-running; set FUZZ_SECONDS (default 60) and FUZZ_SEED"]
fn fuzz_loader_for_a_while() {
    let seconds: u64 = std::env::var("FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    let seed: u64 = std::env::var("FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed);
    let limit = Duration::from_secs(seconds);
    let report = fuzz(seed, |_, elapsed| elapsed < limit);
    print(&report);
    assert_clean(&report);
}

#[test]
#[ignore = "writes the seed corpus of the coverage-guided fuzzer to FUZZ_CORPUS_DIR"]
fn write_seed_corpus() {
    corpus::write_seed_corpus(&corpus(), "");
}
