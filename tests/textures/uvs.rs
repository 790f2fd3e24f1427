//! Texture coordinates are kept per triangle, in triangle order, from the first textured
//! primitive on: an untextured primitive before it gets zeros (its material reads none), and an
//! untextured scene keeps none.

use super::*;

/// One triangle per mesh, each with TEXCOORD_0 = (k + 0.25, 0.5), (k + 0.5, 0.75), (k + 0.75,
/// 0.25) for mesh k; mesh k uses material `materials[k]` (true: a base-colour texture).
fn scene_of(textured: &[bool]) -> Scene {
    scene_laid_out(textured, false)
}

/// [`scene_of`], with each mesh's positions and texture coordinates interleaved in one buffer
/// view (a stride of 20 bytes) when `interleaved`, else each in a packed view of its own.
fn scene_laid_out(textured: &[bool], interleaved: bool) -> Scene {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut materials) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (k, &is_textured) in textured.iter().enumerate() {
        let x = k as f32 * 2.0;
        let positions = [x, 0.0, 0.0, x + 1.0, 0.0, 0.0, x, 1.0, 0.0];
        let uv = [
            k as f32 + 0.25,
            0.5,
            k as f32 + 0.5,
            0.75,
            k as f32 + 0.75,
            0.25,
        ];
        if interleaved {
            views.push(
                json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": 60,
                "byteStride": 20}),
            );
            for v in 0..3 {
                let vertex = positions[3 * v..3 * v + 3]
                    .iter()
                    .chain(&uv[2 * v..2 * v + 2]);
                bin.extend(vertex.flat_map(|x| x.to_le_bytes()));
            }
        }
        for (values, kind) in [(&positions[..], "VEC3"), (&uv[..], "VEC2")] {
            let (view, offset) = if interleaved {
                (views.len() - 1, if kind == "VEC3" { 0 } else { 12 })
            } else {
                views.push(
                    json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": values.len() * 4}),
                );
                bin.extend(values.iter().flat_map(|v| v.to_le_bytes()));
                (views.len() - 1, 0)
            };
            let mut accessor = json!({"bufferView": view, "byteOffset": offset,
                "componentType": 5126, "count": 3, "type": kind});
            if kind == "VEC3" {
                accessor["min"] = json!([x, 0.0, 0.0]);
                accessor["max"] = json!([x + 1.0, 1.0, 0.0]);
            }
            accessors.push(accessor);
        }
        let (pos, tex) = (accessors.len() - 2, accessors.len() - 1);
        meshes.push(
            json!({"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": tex},
            "material": k}]}),
        );
        materials.push(if is_textured {
            json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}})
        } else {
            json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}})
        });
    }
    let data_uri = |mime: &str, bytes: &[u8]| {
        let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
        format!("data:{mime};base64,{b64}")
    };
    let nodes: Vec<_> = (0..textured.len()).map(|k| json!({"mesh": k})).collect();
    let gltf = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..textured.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "textures": [{"source": 0}],
        "images": [{"uri": data_uri("image/png", &png(1, 1, &[[200, 100, 50]]))}],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri("application/octet-stream", &bin)}],
        "bufferViews": views,
        "accessors": accessors
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("uvs.gltf");
    std::fs::write(&path, serde_json::to_vec(&gltf).unwrap()).unwrap();
    load(&path).unwrap()
}

fn file_uvs(k: usize) -> [Vec2; 3] {
    let k = k as f32;
    [
        Vec2::new(k + 0.25, 0.5),
        Vec2::new(k + 0.5, 0.75),
        Vec2::new(k + 0.75, 0.25),
    ]
}

#[test]
fn texture_coordinates_follow_their_triangles_after_untextured_primitives() {
    let scene = scene_of(&[false, false, true, false]);
    assert_eq!(scene.triangles.len(), 4);
    assert_eq!(scene.uvs.len(), 4, "one entry per triangle");
    // Triangle order is file order: triangle k lies at x = 2k.
    for (k, t) in scene.triangles.iter().enumerate() {
        assert_eq!(t.positions[0].x, k as f32 * 2.0);
    }
    // The textured triangle, and the untextured one after it, keep what the file says.
    assert_eq!(scene.uvs[2], file_uvs(2));
    assert_eq!(scene.uvs[3], file_uvs(3));
}

#[test]
fn an_untextured_scene_keeps_no_texture_coordinates() {
    let scene = scene_of(&[false, false]);
    assert_eq!(scene.triangles.len(), 2);
    assert!(scene.uvs.is_empty());
}

/// Texture coordinates read from their own packed view (straight from the bytes) and from a view
/// shared with the positions (through the `gltf` crate's reader) are the same, bit for bit.
#[test]
fn packed_and_interleaved_texture_coordinates_are_the_same() {
    let textured = [false, true, true];
    let (packed, interleaved) = (
        scene_laid_out(&textured, false),
        scene_laid_out(&textured, true),
    );
    let bits = |scene: &Scene| -> Vec<u32> {
        scene
            .uvs
            .iter()
            .flatten()
            .flat_map(|uv| uv.to_array().map(f32::to_bits))
            .collect()
    };
    assert_eq!(packed.uvs.len(), 3);
    assert_eq!(bits(&packed), bits(&interleaved));
    assert_eq!(packed.uvs[2], file_uvs(2));
    assert_eq!(packed.triangles, interleaved.triangles);
}
