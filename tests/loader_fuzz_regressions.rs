//! Minimised inputs from `tests/fuzz_loader.rs`, each of which once panicked (inside the `gltf`
//! crate) or asked for an unbounded allocation. Every one must now give a clean `LoadError`.

use std::path::Path;

use base64::Engine;
use manylights::scene::{
    load_gltf_bytes, load_gltf_bytes_allowing, CameraChoice, LoadError, LoadPolicy,
};
use serde_json::{json, Value};

/// One triangle: three f32 VEC3 positions (36 bytes) in buffer 0, view 0, accessor 0.
fn triangle() -> Value {
    let floats: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let bin: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"uri": uri, "byteLength": bin.len()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": bin.len()}],
        "accessors": [{
            "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
            "min": [0, 0, 0], "max": [1, 1, 0]
        }]
    })
}

fn load(bytes: &[u8]) -> Result<manylights::scene::Scene, LoadError> {
    let path = Path::new("regression.gltf");
    load_gltf_bytes(bytes, path, Path::new("."), &CameraChoice::First)
}

fn load_json(doc: &Value) -> Result<manylights::scene::Scene, LoadError> {
    load(&serde_json::to_vec(doc).unwrap())
}

/// Asserts a clean error naming the file and containing `needle`.
fn assert_error(result: Result<manylights::scene::Scene, LoadError>, needle: &str) {
    let Err(e) = result else {
        panic!("the input must be refused");
    };
    let text = e.to_string();
    assert!(text.contains("regression.gltf"), "{text}");
    assert!(text.contains(needle), "expected '{needle}' in: {text}");
}

#[test]
fn the_fixture_itself_loads() {
    let scene = load_json(&triangle()).unwrap();
    assert_eq!(scene.triangles.len(), 1);
}

/// Fuzzer: gltf-json mesh.rs:151 "index out of bounds: the len is 34 but the index is
/// 2147483647" — the crate's validator indexes the POSITION accessor unchecked.
#[test]
fn position_accessor_index_past_the_accessors_is_an_error() {
    let mut doc = triangle();
    doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(2147483647);
    assert_error(load_json(&doc), "accessor 2147483647 does not exist");
    doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(1);
    assert_error(load_json(&doc), "accessor 1 does not exist");
}

/// Fuzzer: gltf accessor/util.rs:384 "attempt to multiply with overflow" — stride × (count − 1)
/// computed unchecked (in release it wraps and can select a wrong but in-bounds range).
#[test]
fn accessor_count_whose_extent_overflows_is_an_error() {
    // As POSITION of an unindexed primitive, the count is refused as a triangle count first.
    let mut doc = triangle();
    doc["accessors"][0]["count"] = json!(6148914691236517206u64);
    assert_error(load_json(&doc), "declares 2049638230412172402 triangles");
    // As NORMAL it reaches the accessor's extent check.
    let mut doc = triangle();
    let mut huge = doc["accessors"][0].clone();
    huge["count"] = json!(6148914691236517206u64);
    doc["accessors"].as_array_mut().unwrap().push(huge);
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(1);
    assert_error(load_json(&doc), "do not fit in buffer view 0");
}

#[test]
fn accessor_larger_than_its_view_is_an_error() {
    let mut doc = triangle();
    doc["accessors"][0]["count"] = json!(4);
    assert_error(load_json(&doc), "do not fit in buffer view 0");
    let mut doc = triangle();
    doc["accessors"][0]["byteOffset"] = json!(4);
    assert_error(load_json(&doc), "do not fit in buffer view 0");
}

/// A byteStride smaller than the element makes the crate's item reader slice past its chunk.
#[test]
fn stride_smaller_than_the_element_is_an_error() {
    let mut doc = triangle();
    doc["bufferViews"][0]["byteStride"] = json!(4);
    assert_error(load_json(&doc), "stride 4, less than the element size 12");
}

/// view offset + length is computed unchecked inside the crate.
#[test]
fn buffer_view_whose_end_overflows_is_an_error() {
    let mut doc = triangle();
    doc["bufferViews"][0]["byteOffset"] = json!(18446744073709551600u64);
    doc["bufferViews"][0]["byteLength"] = json!(36);
    assert_error(load_json(&doc), "extends past the 36 bytes of buffer 0");
}

/// An accessor with no buffer view is `count` zeros plus sparse values: a huge count would be
/// a huge allocation (the allocator guard of the fuzzer aborts on these).
#[test]
fn viewless_sparse_accessor_with_a_huge_count_is_an_error() {
    // As NORMAL (as POSITION the triangle cap would refuse the count first).
    let mut doc = triangle();
    let normal = doc["accessors"][0].clone();
    doc["accessors"].as_array_mut().unwrap().push(normal);
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(1);
    let acc = &mut doc["accessors"][1];
    acc.as_object_mut().unwrap().remove("bufferView");
    acc["count"] = json!(1u64 << 40);
    acc["sparse"] = json!({
        "count": 1,
        "indices": {"bufferView": 0, "componentType": 5125},
        "values": {"bufferView": 0}
    });
    assert_error(load_json(&doc), "elements without a buffer view");
}

/// sparse.count − 1 is computed unchecked inside the crate.
#[test]
fn sparse_count_zero_is_an_error() {
    let mut doc = triangle();
    doc["accessors"][0]["sparse"] = json!({
        "count": 0,
        "indices": {"bufferView": 0, "componentType": 5125},
        "values": {"bufferView": 0}
    });
    assert_error(load_json(&doc), "sparse count 0 is not in 1..=3");
}

#[test]
fn valid_sparse_accessor_still_loads() {
    // Buffer: the three positions, then sparse index 0 (u32) and its value (0, 0, -1).
    let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    bin.extend(0u32.to_le_bytes());
    bin.extend([0.0f32, 0.0, -1.0].iter().flat_map(|f| f.to_le_bytes()));
    let mut doc = triangle();
    doc["buffers"][0] = json!({
        "uri": format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&bin)
        ),
        "byteLength": bin.len()
    });
    doc["bufferViews"] = json!([
        {"buffer": 0, "byteOffset": 0, "byteLength": 36},
        {"buffer": 0, "byteOffset": 36, "byteLength": 4},
        {"buffer": 0, "byteOffset": 40, "byteLength": 12}
    ]);
    doc["accessors"][0]["min"] = json!([0, 0, -1]);
    doc["accessors"][0]["sparse"] = json!({
        "count": 1,
        "indices": {"bufferView": 1, "componentType": 5125},
        "values": {"bufferView": 2}
    });
    let scene = load_json(&doc).unwrap();
    assert_eq!(scene.triangles.len(), 1);
    assert_eq!(
        scene.triangles[0].positions[0],
        glam::Vec3::new(0.0, 0.0, -1.0)
    );
}

/// The GLB header's total length is trusted by the crate: a value below 12 underflows.
#[test]
fn glb_total_length_below_the_header_is_an_error() {
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&4u32.to_le_bytes());
    assert_error(load(&glb), "GLB header declares a total length of 4 bytes");
    assert_error(load(b"glTF\x02\0"), "GLB header is truncated");
}

/// A chain of nodes, each listing the next as a child twice, would be traversed 2^depth times.
#[test]
fn node_reached_twice_is_an_error() {
    let mut doc = triangle();
    let depth = 64;
    let mut nodes: Vec<Value> = (0..depth)
        .map(|i| json!({"children": [i + 1, i + 1]}))
        .collect();
    nodes.push(json!({"mesh": 0}));
    doc["nodes"] = json!(nodes);
    let start = std::time::Instant::now();
    assert_error(load_json(&doc), "is reached twice from the scene");
    assert!(start.elapsed().as_secs() < 5);
    // A root listed twice in the scene is the same mistake.
    let mut doc = triangle();
    doc["scenes"][0]["nodes"] = json!([0, 0]);
    assert_error(load_json(&doc), "node 0: is reached twice");
}

/// KHR_lights_punctual references: a node's light index must exist in the root's light list.
#[test]
fn punctual_light_references_are_checked() {
    let mut doc = triangle();
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["nodes"][0]["extensions"] = json!({"KHR_lights_punctual": {"light": 3}});
    assert!(load_json(&doc).is_err(), "no root light list");
    doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [{"type": "point"}]}});
    assert!(load_json(&doc).is_err(), "light 3 of 1");
    doc["nodes"][0]["extensions"]["KHR_lights_punctual"]["light"] = json!(0);
    let scene = load_json(&doc).unwrap();
    assert_eq!(scene.triangles.len(), 1);
}

/// A buffer URI naming a device (or a directory) must not be read: /dev/zero never ends. The
/// path policy refuses /dev/zero as an absolute path; with /dev admitted it is still refused.
#[test]
fn buffer_uri_that_is_not_a_regular_file_is_an_error() {
    let dev = [std::path::PathBuf::from("/dev").canonicalize().unwrap()];
    for (uri, allowed) in [("/dev/zero", &dev[..]), (".", &[][..])] {
        let mut doc = triangle();
        doc["buffers"][0]["uri"] = json!(uri);
        let start = std::time::Instant::now();
        let bytes = serde_json::to_vec(&doc).unwrap();
        let path = Path::new("regression.gltf");
        let choice = &CameraChoice::First;
        let loaded = load_gltf_bytes_allowing(
            &bytes,
            path,
            Path::new("."),
            choice,
            &LoadPolicy {
                allowed: allowed.to_vec(),
                memory: None,
            },
        );
        assert_error(loaded, "not a regular file");
        assert!(start.elapsed().as_secs() < 5);
    }
    let mut doc = triangle();
    doc["buffers"][0]["uri"] = json!("/dev/zero");
    assert_error(load_json(&doc), "'/dev/zero' is an absolute path");
}

/// The triangle with an emissive material whose texture reads image 0, described by `image`.
fn textured_triangle(image: Value) -> Value {
    let mut doc = triangle();
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["materials"] = json!([{
        "emissiveFactor": [1, 1, 1],
        "emissiveTexture": {"index": 0}
    }]);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([image]);
    doc
}

/// Fuzzer (textured.glb seed): gltf image.rs:125 and :128 `Option::unwrap()` on `None` —
/// `Image::source` unwraps the mimeType of a bufferView image, and the uri of an image that has
/// neither; and image.rs:124 indexes its bufferView unchecked.
#[test]
fn image_without_mime_type_or_source_is_an_error() {
    assert_error(
        load_json(&textured_triangle(json!({"bufferView": 0}))),
        "needs a mimeType",
    );
    assert_error(
        load_json(&textured_triangle(json!({"name": "nothing"}))),
        "neither uri nor bufferView",
    );
    assert_error(
        load_json(&textured_triangle(
            json!({"bufferView": 7, "mimeType": "image/png"}),
        )),
        "buffer view 7 does not exist",
    );
    // The same image with its mimeType reaches the decoder, which refuses the float bytes.
    assert_error(
        load_json(&textured_triangle(
            json!({"bufferView": 0, "mimeType": "image/png"}),
        )),
        "neither PNG nor JPEG",
    );
}

/// Heavy instancing: 40 nodes each instancing a mesh whose index accessor declares 3,000,000
/// indices (1,000,000 triangles): 40 M triangles, more than MAX_TRIANGLES — refused from the
/// declared counts before its (absent) 3 MB buffer file is even looked for.
#[test]
fn instancing_past_the_triangle_cap_is_refused_before_reading_buffers() {
    let mut doc = triangle();
    let indices = 3_000_000u64;
    doc["buffers"]
        .as_array_mut()
        .unwrap()
        .push(json!({"uri": "absent-indices.bin", "byteLength": indices}));
    doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 1, "byteLength": indices}));
    doc["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({"bufferView": 1, "componentType": 5121, "count": indices, "type": "SCALAR"}));
    doc["meshes"][0]["primitives"][0]["indices"] = json!(1);
    let nodes: Vec<Value> = (0..40).map(|_| json!({"mesh": 0})).collect();
    doc["nodes"] = json!(nodes);
    doc["scenes"][0]["nodes"] = json!((0..40).collect::<Vec<_>>());
    assert!(
        40 * indices / 3 > manylights::scene::MAX_TRIANGLES,
        "premise"
    );
    assert_error(load_json(&doc), "declares 40000000 triangles");
    // Below the cap the same file gets as far as its buffer (which is absent).
    doc["scenes"][0]["nodes"] = json!([0]);
    assert_error(load_json(&doc), "absent-indices.bin");
}

/// Found by the coverage-guided fuzzer (`fuzz/`, target gltf_loader): scenes/textured.glb mutated
/// so that its 511 emissive triangles have large uv footprints, each integrated texel cell by
/// texel cell for its emitter's power (0.60 s for this 13 kB file before footprints were capped
/// at 2^18 cells). It loads, and every emitter's power is finite.
#[test]
fn emissive_triangles_with_large_uv_footprints_load_with_finite_powers() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_inputs/large-uv-footprints.glb");
    let bytes = std::fs::read(&path).unwrap();
    let scene = load_gltf_bytes(&bytes, &path, Path::new("."), &CameraChoice::First).unwrap();
    let lights = manylights::lights::Lights::from_scene(&scene);
    assert!(lights.len() > 100);
    assert!(lights.powers().iter().all(|p| p.is_finite() && *p >= 0.0));
}
