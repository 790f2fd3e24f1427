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

#[path = "common/corpus.rs"]
mod corpus;

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, Once};
use std::time::{Duration, Instant};

use manylights::gen::generate;
use manylights::scene::{load_gltf_bytes, CameraChoice};
use rand_core::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use serde_json::Value;

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
// Mutations

fn below(rng: &mut Pcg32, n: usize) -> usize {
    if n == 0 {
        0
    } else {
        (rng.next_u32() as usize) % n
    }
}

const INTERESTING_U32: [u32; 12] = [
    0,
    1,
    2,
    3,
    4,
    12,
    0x7f,
    0xffff,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_fffe,
    0xffff_ffff,
];

const INTERESTING_NUMBERS: [&str; 22] = [
    "0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "-0",
    "0.5",
    "1e999",
    "-1e999",
    "1e38",
    "3.5e38",
    "255",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9007199254740993",
    "18446744073709551615",
    "18446744073709551616",
];

const COMPONENT_TYPES: [u64; 8] = [5120, 5121, 5122, 5123, 5124, 5125, 5126, 0];
const TYPES: [&str; 8] = [
    "SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4", "BOGUS",
];
const KEYS: [&str; 16] = [
    "componentType",
    "type",
    "count",
    "byteOffset",
    "byteLength",
    "byteStride",
    "indices",
    "bufferView",
    "buffer",
    "mesh",
    "material",
    "camera",
    "children",
    "scene",
    "light",
    "sparse",
];

fn mutate_bytes(rng: &mut Pcg32, data: &mut Vec<u8>) {
    let len = data.len();
    match below(rng, 8) {
        0 if len > 0 => {
            let i = below(rng, len);
            data[i] ^= 1 << below(rng, 8);
        }
        1 if len > 0 => {
            let i = below(rng, len);
            data[i] = rng.next_u32() as u8;
        }
        2 if len >= 4 => {
            // An interesting little-endian word, usually at an aligned offset (GLB lengths).
            let mut i = below(rng, len - 3);
            if !rng.next_u32().is_multiple_of(4) {
                i &= !3;
            }
            let w = INTERESTING_U32[below(rng, INTERESTING_U32.len())];
            data[i..i + 4].copy_from_slice(&w.to_le_bytes());
        }
        3 => data.truncate(below(rng, len + 1)),
        4 if len > 0 => {
            // Duplicate a chunk somewhere.
            let start = below(rng, len);
            let n = 1 + below(rng, (len - start).min(256));
            let chunk = data[start..start + n].to_vec();
            let at = below(rng, len + 1);
            data.splice(at..at, chunk);
        }
        5 if len > 0 => {
            let start = below(rng, len);
            let n = 1 + below(rng, (len - start).min(64));
            data.drain(start..start + n);
        }
        6 if len > 0 => {
            // Add or subtract a small amount to a byte.
            let i = below(rng, len);
            data[i] = data[i].wrapping_add((below(rng, 33) as u8).wrapping_sub(16));
        }
        _ => {
            let at = below(rng, len + 1);
            let b = rng.next_u32() as u8;
            data.insert(at, b);
        }
    }
}

/// Every value in the document, by path (object keys and array positions).
fn paths(v: &Value, prefix: &mut Vec<PathStep>, out: &mut Vec<Vec<PathStep>>) {
    out.push(prefix.clone());
    match v {
        Value::Object(map) => {
            for (k, child) in map {
                prefix.push(PathStep::Key(k.clone()));
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        Value::Array(items) => {
            for (i, child) in items.iter().enumerate() {
                prefix.push(PathStep::Index(i));
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

#[derive(Clone, Debug)]
enum PathStep {
    Key(String),
    Index(usize),
}

fn at_path<'v>(v: &'v mut Value, path: &[PathStep]) -> &'v mut Value {
    path.iter().fold(v, |v, step| match step {
        PathStep::Key(k) => &mut v[k.as_str()],
        PathStep::Index(i) => &mut v[*i],
    })
}

fn random_small_number(rng: &mut Pcg32) -> Value {
    match below(rng, 4) {
        0 => Value::from(below(rng, 8) as u64),
        1 => Value::from(-(below(rng, 4) as i64) - 1),
        2 => Value::from(rng.next_u32() as u64),
        _ => Value::from(below(rng, 100_000) as u64),
    }
}

/// One structural edit of the JSON document; returns false if it did nothing.
fn mutate_json_value(rng: &mut Pcg32, doc: &mut Value) -> bool {
    let mut all = Vec::new();
    paths(doc, &mut Vec::new(), &mut all);
    let path = all[below(rng, all.len())].clone();
    let target = at_path(doc, &path);
    match below(rng, 9) {
        0 => match target {
            Value::Number(_) => *target = random_small_number(rng),
            _ => return false,
        },
        1 => match target {
            Value::Object(map) if !map.is_empty() => {
                let key = map.keys().nth(below(rng, map.len())).unwrap().clone();
                map.remove(&key);
            }
            _ => return false,
        },
        2 => match target {
            Value::Array(items) if !items.is_empty() => {
                let i = below(rng, items.len());
                let item = items[i].clone();
                let at = below(rng, items.len() + 1);
                items.insert(at, item);
            }
            _ => return false,
        },
        3 => match target {
            Value::Array(items) if !items.is_empty() => {
                items.remove(below(rng, items.len()));
            }
            _ => return false,
        },
        4 => match target {
            // Set a well-known key of an object to a plausible or hostile value.
            Value::Object(map) => {
                let scene_keys = &fuzz_inputs::SCENE_KEYS;
                let k = below(rng, KEYS.len() + scene_keys.len());
                let key = KEYS
                    .get(k)
                    .copied()
                    .unwrap_or_else(|| scene_keys[k - KEYS.len()]);
                let value = match key {
                    _ if k >= KEYS.len() => fuzz_inputs::scene_value(key, rng.next_u32()),
                    "componentType" => Value::from(COMPONENT_TYPES[below(rng, 8)]),
                    "type" => Value::from(TYPES[below(rng, TYPES.len())]),
                    "children" => Value::from(vec![random_small_number(rng)]),
                    "sparse" => {
                        let index_type = [5121, 5123, 5125][below(rng, 3)];
                        serde_json::json!({
                            "count": random_small_number(rng),
                            "indices": {
                                "bufferView": below(rng, 4),
                                "byteOffset": random_small_number(rng),
                                "componentType": index_type
                            },
                            "values": {"bufferView": below(rng, 4), "byteOffset": below(rng, 64)}
                        })
                    }
                    _ => random_small_number(rng),
                };
                map.insert(key.to_string(), value);
            }
            _ => return false,
        },
        5 => match target {
            Value::Object(map) if map.contains_key("componentType") => {
                map["componentType"] = Value::from(COMPONENT_TYPES[below(rng, 8)]);
            }
            Value::Object(map) if map.contains_key("type") => {
                map["type"] = Value::from(TYPES[below(rng, TYPES.len())]);
            }
            _ => return false,
        },
        6 => match target {
            Value::Number(n) => {
                // Nudge a number: off-by-one and doubling errors are the interesting ones.
                let x = n.as_f64().unwrap_or(0.0);
                let y = match below(rng, 4) {
                    0 => x + 1.0,
                    1 => x - 1.0,
                    2 => x * 2.0,
                    _ => x * 1000.0,
                };
                *target = if y.fract() == 0.0 && y.abs() < 9e15 {
                    Value::from(y as i64)
                } else {
                    Value::from(y)
                };
            }
            _ => return false,
        },
        7 => {
            // Replace any value with another from elsewhere in the document.
            let other = all[below(rng, all.len())].clone();
            let v = at_path(&mut doc.clone(), &other).clone();
            *at_path(doc, &path) = v;
        }
        _ => match target {
            Value::Array(items) if !items.is_empty() => {
                // Grow an array of objects (meshes, accessors, nodes): dangling-index heaven.
                let item = items[below(rng, items.len())].clone();
                items.push(item);
            }
            _ => return false,
        },
    }
    true
}

/// Replaces one number literal of the text with a hostile one (also ones serde cannot build,
/// such as 1e999 or integers past u64).
fn mutate_json_number_text(rng: &mut Pcg32, text: &mut Vec<u8>) -> bool {
    let mut starts = Vec::new();
    let mut i = 0;
    let mut in_string = false;
    while i < text.len() {
        let c = text[i];
        if in_string {
            if c == b'\\' {
                i += 1;
            } else if c == b'"' {
                in_string = false;
            }
        } else if c == b'"' {
            in_string = true;
        } else if (c == b'-' || c.is_ascii_digit())
            && (i == 0 || !(text[i - 1].is_ascii_alphanumeric() || text[i - 1] == b'.'))
        {
            let start = i;
            while i < text.len()
                && matches!(text[i], b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9')
            {
                i += 1;
            }
            starts.push((start, i));
            continue;
        }
        i += 1;
    }
    if starts.is_empty() {
        return false;
    }
    let (s, e) = starts[below(rng, starts.len())];
    let lit = INTERESTING_NUMBERS[below(rng, INTERESTING_NUMBERS.len())];
    text.splice(s..e, lit.bytes());
    true
}

fn mutate_json_text(rng: &mut Pcg32, json: &mut Vec<u8>) {
    match below(rng, 10) {
        0..=5 => {
            if let Ok(mut doc) = serde_json::from_slice::<Value>(json) {
                if mutate_json_value(rng, &mut doc) {
                    *json = serde_json::to_vec(&doc).unwrap();
                    return;
                }
            }
            mutate_bytes(rng, json);
        }
        6..=8 => {
            if !mutate_json_number_text(rng, json) {
                mutate_bytes(rng, json);
            }
        }
        _ => mutate_bytes(rng, json),
    }
}

/// Splits a well-formed GLB into its JSON and BIN chunk payloads.
fn split_glb(data: &[u8]) -> Option<(Vec<u8>, Option<Vec<u8>>)> {
    let word = |i: usize| -> Option<u32> {
        Some(u32::from_le_bytes(data.get(i..i + 4)?.try_into().ok()?))
    };
    if !data.starts_with(b"glTF") || word(4)? != 2 {
        return None;
    }
    let json_len = word(12)? as usize;
    let json = data.get(20..20 + json_len)?.to_vec();
    let bin_at = 20 + json_len;
    let bin = match word(bin_at) {
        Some(n) => Some(data.get(bin_at + 8..bin_at + 8 + n as usize)?.to_vec()),
        None => None,
    };
    Some((json, bin))
}

fn join_glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let mut json = json.to_vec();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut total = 12 + 8 + json.len();
    if let Some(b) = bin {
        total += 8 + b.len();
    }
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if let Some(b) = bin {
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(b);
    }
    out
}

fn mutate(rng: &mut Pcg32, input: &[u8]) -> Vec<u8> {
    let mut data = input.to_vec();
    let rounds = 1 + below(rng, 4);
    for _ in 0..rounds {
        if let Some((mut json, bin)) = split_glb(&data).filter(|_| below(rng, 4) != 0) {
            // Mostly edit the GLB's JSON (or its BIN chunk) and keep the container consistent.
            match (below(rng, 5), bin) {
                (0, Some(mut bin)) => {
                    mutate_bytes(rng, &mut bin);
                    data = join_glb(&json, Some(&bin));
                }
                (_, bin) => {
                    mutate_json_text(rng, &mut json);
                    data = join_glb(&json, bin.as_deref());
                }
            }
        } else if data.first() == Some(&b'{') && below(rng, 4) != 0 {
            mutate_json_text(rng, &mut data);
        } else {
            mutate_bytes(rng, &mut data);
        }
    }
    data
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
