//! The mutations: byte flips and overwrites, interesting words, truncation, chunk duplication
//! and deletion, and JSON-aware edits, applied to the JSON chunk of a GLB too (its lengths
//! rewritten to match). Deterministic from the PCG state.

use rand_core::Rng;
use rand_pcg::Pcg32;
use serde_json::Value;

pub(crate) use crate::byte_mutations::below;
use crate::byte_mutations::{insert_byte, ByteMutations};
use crate::fuzz_inputs;

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

/// The shared byte mutations, tuned for glTF and GLB.
const BYTE_MUTATIONS: ByteMutations = ByteMutations {
    interesting: &INTERESTING_U32,
    // GLB lengths and chunk headers sit at aligned offsets.
    aligned: true,
    max_duplicate: 256,
    max_delete: 64,
};

fn mutate_bytes(rng: &mut Pcg32, data: &mut Vec<u8>) {
    let kind = below(rng, 8);
    if BYTE_MUTATIONS.apply(kind, rng, data) {
        return;
    }
    let len = data.len();
    match kind {
        6 if len > 0 => {
            // Add or subtract a small amount to a byte.
            let i = below(rng, len);
            data[i] = data[i].wrapping_add((below(rng, 33) as u8).wrapping_sub(16));
        }
        _ => insert_byte(rng, data),
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

pub(crate) fn mutate(rng: &mut Pcg32, input: &[u8]) -> Vec<u8> {
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
