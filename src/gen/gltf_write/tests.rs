//! Round trips through the loader, determinism and the writer's own checks.

use super::*;
use std::fs;
use std::path::PathBuf;

/// A unique path in the system temp folder (removed by the caller).
fn temp_file(tag: &str, ext: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    std::env::temp_dir().join(format!("manylights-{tag}-{}-{n}.{ext}", std::process::id()))
}

/// Decodes standard padded base64 (test helper only).
fn base64_decode(text: &str) -> Vec<u8> {
    base64::engine::general_purpose::STANDARD
        .decode(text)
        .expect("valid base64")
}

/// Parses a file with the `gltf` crate (validating it) and returns the
/// document and its single buffer.
fn parse(bytes: &[u8]) -> (gltf::Document, Vec<u8>) {
    let gltf = gltf::Gltf::from_slice(bytes).expect("valid glTF");
    let blob = match gltf.document.buffers().next().map(|b| b.source()) {
        None => Vec::new(),
        Some(gltf::buffer::Source::Bin) => gltf.blob.clone().expect("GLB blob"),
        Some(gltf::buffer::Source::Uri(uri)) => {
            let data = uri
                .strip_prefix("data:application/octet-stream;base64,")
                .unwrap();
            base64_decode(data)
        }
    };
    (gltf.document, blob)
}

/// Writes `builder` to a temporary `.ext` file and loads it back.
pub(crate) fn round_trip(builder: &GltfBuilder, ext: &str) -> (gltf::Document, Vec<u8>) {
    let path = temp_file("rt", ext);
    builder.write(&path).unwrap();
    let bytes = fs::read(&path);
    fs::remove_file(&path).unwrap();
    parse(&bytes.unwrap())
}

/// Checks that `doc` holds exactly what `builder` collected.
pub(crate) fn assert_matches(builder: &GltfBuilder, doc: &gltf::Document, blob: &[u8]) {
    assert_eq!(doc.meshes().len(), builder.meshes.len());
    assert_eq!(doc.materials().len(), builder.materials.len());
    assert_eq!(doc.nodes().len(), builder.nodes.len());
    assert_eq!(doc.cameras().len(), builder.cameras.len());
    for (mesh, want) in doc.meshes().zip(&builder.meshes) {
        assert_eq!(mesh.name(), Some(want.name.as_str()));
        let prim = mesh.primitives().next().unwrap();
        assert_eq!(prim.mode(), gltf::mesh::Mode::Triangles);
        assert_eq!(prim.material().index(), Some(want.material));
        let reader = prim.reader(|_| Some(blob));
        let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        assert_eq!(positions, want.positions);
        let normals: Option<Vec<[f32; 3]>> = reader.read_normals().map(Iterator::collect);
        assert_eq!(normals, want.normals);
        let indices: Option<Vec<u32>> = reader.read_indices().map(|i| i.into_u32().collect());
        assert_eq!(indices, want.indices);
        let uvs: Option<Vec<[f32; 2]>> = reader.read_tex_coords(0).map(|t| t.into_f32().collect());
        assert_eq!(uvs, want.uvs);
    }
    for (mat, want) in doc.materials().zip(&builder.materials) {
        assert_eq!(mat.name(), Some(want.name.as_str()));
        assert_eq!(mat.emissive_factor(), want.emissive);
        assert_eq!(
            mat.emissive_strength().unwrap_or(1.0),
            want.emissive_strength
        );
        assert_eq!(mat.double_sided(), want.double_sided);
        let pbr = mat.pbr_metallic_roughness();
        assert_eq!(pbr.base_color_factor()[..3], want.base_color);
        assert_eq!(pbr.roughness_factor(), want.roughness);
    }
}

/// A small scene using every feature: u16 and u32 indices, a
/// non-indexed mesh, normals, both transform kinds and a hierarchy.
fn sample() -> GltfBuilder {
    let mut b = GltfBuilder::new();
    let plain = b.add_material(GltfMaterial {
        name: "plain".into(),
        ..GltfMaterial::default()
    });
    let glow = b.add_material(GltfMaterial {
        name: "glow".into(),
        emissive: [1.0, 0.5, 0.25],
        emissive_strength: 7.5,
        double_sided: true,
        ..GltfMaterial::default()
    });
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let up = [[0.0, 0.0, 1.0]; 3];
    let m0 = b.add_mesh("tri", &tri, Some(&up), Some(&[0, 1, 2]), plain);
    let big: Vec<[f32; 3]> = (0..70_002).map(|i| [i as f32 * 0.1, -0.3, 1e-3]).collect();
    let big_idx: Vec<u32> = (0..70_002).rev().collect();
    let m1 = b.add_mesh("big", &big, None, Some(&big_idx), glow);
    let m2 = b.add_mesh("soup", &tri, None, None, glow);
    let cam = b.add_perspective_camera("cam", 0.7, Some(1.5), 0.01);
    let root = b.add_node("root", None, None, NodeTransform::Identity);
    let trs = NodeTransform::Trs {
        translation: [1.0, 2.0, 3.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        scale: [2.0, 2.0, 2.0],
    };
    let n0 = b.add_node("a", Some(m0), None, trs);
    let mut matrix = [0.0; 16];
    for k in [0, 5, 10, 15] {
        matrix[k] = 1.0;
    }
    matrix[13] = 4.0;
    let n1 = b.add_node("b", Some(m1), None, NodeTransform::Matrix(matrix));
    b.add_node("c", Some(m2), Some(cam), NodeTransform::Identity);
    b.add_child(root, n0);
    b.add_child(n0, n1);
    b
}

#[test]
fn round_trip_glb_and_gltf() {
    let b = sample();
    for ext in ["glb", "gltf"] {
        let (doc, blob) = round_trip(&b, ext);
        assert_matches(&b, &doc, &blob);
        let roots: Vec<&str> = doc
            .default_scene()
            .unwrap()
            .nodes()
            .map(|n| n.name().unwrap())
            .collect();
        assert_eq!(roots, ["root", "c"]);
        let node_b = doc.nodes().nth(2).unwrap();
        assert_eq!(node_b.transform().decomposed().0, [0.0, 4.0, 0.0]);
        let cam = doc.cameras().next().unwrap();
        let gltf::camera::Projection::Perspective(p) = cam.projection() else {
            panic!("expected a perspective camera");
        };
        assert_eq!(
            (p.yfov(), p.aspect_ratio(), p.znear(), p.zfar()),
            (0.7, Some(1.5), 0.01, None)
        );
    }
}

#[test]
fn glb_layout_is_well_formed() {
    let bytes = sample().to_glb_bytes();
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(word(4), 2);
    assert_eq!(word(8), bytes.len());
    let json_len = word(12);
    assert_eq!(&bytes[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let bin_at = 20 + json_len;
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(bin_at + 8 + word(bin_at), bytes.len());
    let doc: Value = serde_json::from_slice(&bytes[20..bin_at]).unwrap();
    assert_eq!(
        doc["asset"],
        json!({ "version": "2.0", "generator": "manylights" })
    );
    assert_eq!(doc["extensionsUsed"], json!([EMISSIVE_STRENGTH_EXT]));
    assert_eq!(doc["accessors"][4]["componentType"], json!(UNSIGNED_INT));
    assert_eq!(doc["accessors"][0]["max"], json!([1.0, 1.0, 0.0]));
    assert_eq!(
        doc["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"],
        json!([1.0, 1.0, 1.0, 1.0])
    );
}

#[test]
fn textures_uvs_and_specular_round_trip() {
    // The 8-byte PNG signature is all the builder checks; the bytes are stored verbatim.
    let png = b"\x89PNG\r\n\x1a\nnot really an image".to_vec();
    let mut b = GltfBuilder::new();
    let glow = b.add_png_texture("glow", png.clone(), TextureSampling::NearestClamp);
    let tiles = b.add_png_texture("tiles", png.clone(), TextureSampling::LinearRepeat);
    let m = b.add_material(GltfMaterial {
        name: "textured".into(),
        emissive: [1.0; 3],
        emissive_texture: Some(glow),
        base_color_texture: Some(tiles),
        specular: 0.0,
        ..GltfMaterial::default()
    });
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    let mesh = b.add_mesh_with_uvs("tri", &tri, None, Some(&uv), None, m);
    b.add_node("tri", Some(mesh), None, NodeTransform::Identity);
    for ext in ["glb", "gltf"] {
        let (doc, blob) = round_trip(&b, ext);
        assert_matches(&b, &doc, &blob);
        let mat = doc.materials().next().unwrap();
        assert_eq!(mat.specular().map(|s| s.specular_factor()), Some(0.0));
        let emissive = mat.emissive_texture().unwrap().texture();
        let base = mat.pbr_metallic_roughness().base_color_texture().unwrap();
        assert_eq!((emissive.index(), base.texture().index()), (0, 1));
        let filter = emissive.sampler().mag_filter();
        assert_eq!(filter, Some(gltf::texture::MagFilter::Nearest));
        let wrap = base.texture().sampler().wrap_s();
        assert_eq!(wrap, gltf::texture::WrappingMode::Repeat);
        let gltf::image::Source::View { view, mime_type } = emissive.source().source() else {
            panic!("image not in a buffer view");
        };
        assert_eq!(mime_type, "image/png");
        assert_eq!(&blob[view.offset()..view.offset() + view.length()], png);
    }
}

#[test]
fn strength_one_needs_no_extension() {
    let mut b = GltfBuilder::new();
    b.add_material(GltfMaterial::default());
    let (doc, _) = round_trip(&b, "glb");
    assert_eq!(doc.extensions_used().count(), 0);
    assert_eq!(doc.meshes().len(), 0);
}

#[test]
fn look_at_points_minus_z_at_target() {
    let eye = [1.0, 2.0, 3.0];
    let target = [-2.0, 0.5, -1.0];
    let q = Quat::from_array(look_at_rotation(eye, target, [0.0, 1.0, 0.0]));
    let want = (Vec3::from(target) - Vec3::from(eye)).normalize();
    assert!((q * Vec3::NEG_Z).distance(want) < 1e-6);
    assert!((q * Vec3::X).y.abs() < 1e-6, "camera must not roll");
    assert!((q * Vec3::Y).y > 0.0);
    let down = Quat::from_array(look_at_rotation(
        [0.0; 3],
        [0.0, -1.0, 0.0],
        [0.0, 1.0, 0.0],
    ));
    assert!((down * Vec3::NEG_Z).distance(Vec3::NEG_Y) < 1e-6);
}

#[test]
fn write_replaces_the_file_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("atomic.glb");
    fs::write(&path, b"old contents").unwrap();
    let b = sample();
    b.write(&path).unwrap();
    assert_eq!(fs::read(&path).unwrap(), b.to_glb_bytes());
    let names: Vec<_> = fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["atomic.glb"]);
}

#[test]
fn bad_extension_and_bad_folder_are_errors() {
    let b = sample();
    let err = b.write(&temp_file("ext", "obj")).unwrap_err();
    assert!(err.to_string().contains("unsupported extension"), "{err:#}");
    let missing = std::env::temp_dir()
        .join("manylights-no-such-dir")
        .join("x.glb");
    let err = b.write(&missing).unwrap_err();
    assert!(
        format!("{err:#}").contains("manylights-no-such-dir"),
        "{err:#}"
    );
}
