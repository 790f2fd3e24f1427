//! Seed inputs for the fuzzers that reach the loader paths the shipped scenes leave cold:
//! textures (data-URI PNG, samplers with every wrap mode, KHR_texture_transform, emissive
//! textures), cameras (perspective with and without aspect ratio, orthographic, on transformed
//! nodes), punctual lights on a camera node, KHR material extensions, and images whose URIs the
//! file policy must refuse (absolute, `..`, percent-encoded, `file:`), left unreferenced so that
//! the seed loads and a mutated texture `source` reaches them.

use base64::Engine;
use serde_json::{json, Value};

/// A base64 data URI of `bytes` with media type `mime`.
fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// A 2×2 RGB PNG, written through the renderer's own PNG writer.
fn tiny_png() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.png");
    let texels = [255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255];
    manylights::image::write_rgb8(&path, 2, 2, &texels).unwrap();
    std::fs::read(&path).unwrap()
}

/// One textured quad (POSITION, NORMAL, TEXCOORD_0, u16 indices) seen by three cameras, with
/// two textured materials, punctual lights and hostile image URIs (unreferenced).
pub fn textured_quad_with_cameras() -> Vec<u8> {
    let positions = [
        -1.0f32, 0.0, -1.0, 1.0, 0.0, -1.0, 1.0, 0.0, 1.0, -1.0, 0.0, 1.0,
    ];
    let normals = [0.0f32, 1.0, 0.0].repeat(4);
    let uvs = [0.0f32, 0.0, 2.0, 0.0, 2.0, 2.0, 0.0, 2.0];
    let indices = [0u16, 2, 1, 0, 3, 2];
    let mut bin: Vec<u8> = Vec::new();
    for f in positions.iter().chain(&normals).chain(&uvs) {
        bin.extend(f.to_le_bytes());
    }
    for i in indices {
        bin.extend(i.to_le_bytes());
    }
    let png = data_uri("image/png", &tiny_png());
    let transform = json!({"KHR_texture_transform": {
        "offset": [0.25, 0.5], "rotation": 0.3, "scale": [2.0, 0.5], "texCoord": 0
    }});
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": [
            "KHR_lights_punctual", "KHR_texture_transform",
            "KHR_materials_emissive_strength", "KHR_materials_specular"
        ],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "color": [1, 1, 1], "intensity": 10, "range": 5,
             "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.7}},
            {"type": "point", "intensity": 3}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"mesh": 0, "name": "quad", "scale": [2, 1, 2]},
            {"mesh": 1, "name": "lamp", "translation": [0, 1.5, 0],
             "rotation": [1, 0, 0, 0]},
            {"camera": 0, "name": "front", "translation": [0, 1, 4],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"camera": 1, "name": "above",
             "matrix": [1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 5, 0, 1]},
            {"camera": 2, "name": "ortho", "translation": [0, 1, 6],
             "children": [5]},
            {"name": "bulb", "translation": [0, 0.5, 0],
             "extensions": {"KHR_lights_punctual": {"light": 1}}}
        ],
        "cameras": [
            {"type": "perspective", "name": "wide",
             "perspective": {"yfov": 1.2, "znear": 0.01, "aspectRatio": 1.5}},
            {"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1, "zfar": 100}},
            {"type": "orthographic",
             "orthographic": {"xmag": 2, "ymag": 2, "znear": 0.01, "zfar": 50}}
        ],
        "meshes": [
            {"name": "floor", "primitives": [{
                "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                "indices": 3, "material": 0}]},
            {"name": "lamp", "primitives": [{
                "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                "indices": 3, "material": 1, "mode": 4}]}
        ],
        "materials": [
            {"name": "checker",
             "pbrMetallicRoughness": {
                 "baseColorTexture": {"index": 0, "texCoord": 0, "extensions": transform},
                 "metallicFactor": 0.2, "roughnessFactor": 0.6},
             "extensions": {"KHR_materials_specular": {"specularFactor": 0.5}}},
            {"name": "glow", "doubleSided": true, "emissiveFactor": [1, 0.8, 0.6],
             "emissiveTexture": {"index": 1},
             "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}}
        ],
        "samplers": [
            {"wrapS": 33071, "wrapT": 33648, "magFilter": 9728, "minFilter": 9987},
            {"wrapS": 10497, "wrapT": 33071}
        ],
        "textures": [{"source": 0, "sampler": 0}, {"source": 0, "sampler": 1}],
        "images": [
            {"uri": png},
            {"uri": "/etc/passwd"},
            {"uri": "../outside.png"},
            {"uri": "%2e%2e%2Foutside.png"},
            {"uri": "file:///etc/hostname"},
            {"uri": "missing.png", "mimeType": "image/png"}
        ],
        "buffers": [{"uri": data_uri("application/octet-stream", &bin), "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 32},
            {"buffer": 0, "byteOffset": 128, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-1, 0, -1], "max": [1, 0, 1]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]
    });
    serde_json::to_vec(&doc).unwrap()
}

/// Keys of textures, cameras and lights a JSON mutation sets (besides the accessor keys).
pub const SCENE_KEYS: [&str; 16] = [
    "source",
    "sampler",
    "index",
    "texCoord",
    "wrapS",
    "wrapT",
    "yfov",
    "aspectRatio",
    "znear",
    "zfar",
    "xmag",
    "innerConeAngle",
    "outerConeAngle",
    "intensity",
    "emissiveStrength",
    "rotation",
];

/// A hostile value for one of [`SCENE_KEYS`] (or anything else): wrap modes and texture
/// coordinates from their enums and past them, angles and lengths at their edges.
pub fn scene_value(key: &str, pick: u32) -> Value {
    let pick = pick as usize;
    match key {
        "wrapS" | "wrapT" => json!([33071, 33648, 10497, 0, 9728][pick % 5]),
        "texCoord" | "index" | "source" | "sampler" => [
            json!(0),
            json!(1),
            json!(5),
            json!(-1),
            json!(4294967295u64),
        ][pick % 5]
            .clone(),
        "rotation" => [
            json!([0, 0, 0, 0]),
            json!([0, 0, 0, 2]),
            json!(1e30),
            json!(-0.0),
        ][pick % 4]
            .clone(),
        _ => {
            let edges = [
                0.0,
                -1.0,
                1e-30,
                1e30,
                std::f64::consts::PI,
                std::f64::consts::FRAC_PI_2 + 1e-6,
                -0.0,
            ];
            json!(edges[pick % 7])
        }
    }
}
