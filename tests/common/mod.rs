//! Shared test fixtures: hand-written glTF files whose every byte the test controls.

use std::path::Path;

/// glTF component types for indices.
pub const U8: u32 = 5121;
pub const U16: u32 = 5123;
pub const U32: u32 = 5125;

/// Writes `name`.gltf with one triangle-list mesh "plate" whose buffer is `name`.bin: f32 VEC3
/// positions, then the indices (if any) as `component` (U8, U16 or U32). `write_bin` false
/// leaves the buffer file missing. Returns the .gltf path.
pub fn write_gltf(
    dir: &Path,
    name: &str,
    positions: &[f32],
    indices: Option<(&[u32], u32)>,
    write_bin: bool,
) -> String {
    let mut bin: Vec<u8> = positions.iter().flat_map(|f| f.to_le_bytes()).collect();
    let pos_len = bin.len();
    let mut primitive = serde_json::json!({"attributes": {"POSITION": 0}});
    let mut views = vec![serde_json::json!({"buffer": 0, "byteOffset": 0, "byteLength": pos_len})];
    let mut accessors = vec![serde_json::json!({
        "bufferView": 0, "componentType": 5126, "count": positions.len() / 3, "type": "VEC3",
        "min": [0, 0, 0], "max": [1, 1, 0]
    })];
    if let Some((idx, component)) = indices {
        for &i in idx {
            match component {
                U8 => bin.push(i as u8),
                U16 => bin.extend((i as u16).to_le_bytes()),
                _ => bin.extend(i.to_le_bytes()),
            }
        }
        views.push(serde_json::json!({
            "buffer": 0, "byteOffset": pos_len, "byteLength": bin.len() - pos_len
        }));
        accessors.push(serde_json::json!({
            "bufferView": 1, "componentType": component, "count": idx.len(), "type": "SCALAR"
        }));
        primitive["indices"] = 1.into();
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"name": "plate", "primitives": [primitive]}],
        "buffers": [{"uri": format!("{name}.bin"), "byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors
    });
    if write_bin {
        std::fs::write(dir.join(format!("{name}.bin")), &bin).unwrap();
    }
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec_pretty(&json).unwrap()).unwrap();
    path.to_string_lossy().into_owned()
}
