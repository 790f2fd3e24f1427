//! The glTF loader against files whose content the test knows: our writer's output and
//! hand-written buffers. Transforms (TRS, matrix, hierarchy, mirroring), index widths,
//! .gltf versus .glb, degenerate triangles, materials and camera choice.

use std::path::Path;

use glam::Vec3;
use manylights::gen::generate;
use manylights::gen::gltf_write::{GltfBuilder, GltfMaterial, NodeTransform};
use manylights::lights::Lights;
use manylights::scene::{load_gltf, CameraChoice, LoadError, Projection};

use crate::common;
use common::{write_gltf, U16, U32, U8};

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn cornell_loads_with_its_transforms_applied() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cornell.glb");
    generate::cornell().write(&path).unwrap();
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    assert_eq!(scene.triangles.len(), 36);
    // No material has a texture: the texture coordinates are not kept.
    assert!(scene.uvs.is_empty());
    let lights = Lights::from_scene(&scene);
    assert_eq!(lights.len(), 2);
    for l in lights.triangles() {
        // The light quad is placed by a matrix node just below the ceiling, facing down.
        assert!(close(l.normal, -Vec3::Y), "light normal {}", l.normal);
        assert!((l.p0.y - 1.999).abs() < 1e-5, "light at y = {}", l.p0.y);
        assert!(!l.two_sided);
    }
    let (lo, hi) = scene.bounds();
    assert!(close(lo, Vec3::new(-1.0, 0.0, -1.0)) && close(hi, Vec3::new(1.0, 2.0, 1.0)));
    let camera = scene.camera.unwrap();
    assert!(close(camera.position, Vec3::new(0.0, 1.0, 3.4)));
    assert!(close(camera.forward, -Vec3::Z));
    let Projection::Perspective { yfov } = camera.projection else {
        panic!("a perspective camera")
    };
    assert!((yfov - 40f32.to_radians()).abs() < 1e-5);
}

#[test]
fn gltf_and_glb_load_the_same_scene() {
    let dir = tempfile::tempdir().unwrap();
    let builder = generate::many_lights(3, 500);
    let (glb, gltf) = (dir.path().join("t.glb"), dir.path().join("t.gltf"));
    builder.write(&glb).unwrap();
    builder.write(&gltf).unwrap();
    let a = load_gltf(&glb, &CameraChoice::First).unwrap();
    let b = load_gltf(&gltf, &CameraChoice::First).unwrap();
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.materials, b.materials);
    assert_eq!(Lights::from_scene(&a).len(), 500);
}

/// One triangle facing +Z in its local frame, under `transform`.
fn single_triangle_scene(path: &Path, transform: NodeTransform, parent: Option<NodeTransform>) {
    let mut b = GltfBuilder::new();
    let m = b.add_material(GltfMaterial {
        name: "glow".into(),
        emissive: [1.0, 0.5, 0.25],
        emissive_strength: 4.0,
        double_sided: true,
        ..GltfMaterial::default()
    });
    let mesh = b.add_mesh(
        "tri",
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        None,
        None,
        m,
    );
    let node = b.add_node("tri", Some(mesh), None, transform);
    if let Some(p) = parent {
        let parent = b.add_node("parent", None, None, p);
        b.add_child(parent, node);
    }
    b.write(path).unwrap();
}

#[test]
fn trs_matrix_and_hierarchy_compose_parent_times_child() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.glb");
    // Child: scale 2 then translate (1, 0, 0); parent: a matrix translating by (0, 0, 5).
    let child = NodeTransform::Trs {
        translation: [1.0, 0.0, 0.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        scale: [2.0, 2.0, 2.0],
    };
    let mut m = [0.0f32; 16];
    (m[0], m[5], m[10], m[15]) = (1.0, 1.0, 1.0, 1.0);
    m[14] = 5.0; // column-major: translation in the last column
    single_triangle_scene(&path, child, Some(NodeTransform::Matrix(m)));
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    let t = &scene.triangles[0];
    assert!(close(t.positions[0], Vec3::new(1.0, 0.0, 5.0)));
    assert!(close(t.positions[1], Vec3::new(3.0, 0.0, 5.0)));
    assert!(close(t.positions[2], Vec3::new(1.0, 2.0, 5.0)));
    assert!((t.area() - 2.0).abs() < 1e-6);
    // Emission = factor × KHR_materials_emissive_strength, two-sided.
    let m = scene.material_of(0);
    assert_eq!(m.emission, Vec3::new(4.0, 2.0, 1.0));
    assert!(m.double_sided);
    let lights = Lights::from_scene(&scene);
    // Φ = π·A·luminance(L)·2 (two-sided); the crate's luminance is f32, hence the tolerance.
    let expected =
        std::f64::consts::PI * 2.0 * crate::color::luminance(m.emission.as_dvec3()) * 2.0;
    assert!((lights.total_power() - expected).abs() < 1e-6 * expected);
}

#[test]
fn a_mirroring_transform_keeps_the_front_face() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.glb");
    let mirror = NodeTransform::Trs {
        translation: [0.0, 0.0, 0.0],
        rotation: [0.0, 0.0, 0.0, 1.0],
        scale: [-1.0, 1.0, 1.0],
    };
    single_triangle_scene(&path, mirror, None);
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    // Mirroring x reverses the winding; glTF says the front face stays the one facing +Z.
    assert!(close(scene.triangles[0].geometric_normal(), Vec3::Z));
}

#[test]
fn every_index_width_and_no_indices_give_the_same_triangles() {
    let dir = tempfile::tempdir().unwrap();
    // A quad (two triangles) plus a degenerate third triangle (repeated vertex).
    let positions = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
    let indices = [0, 1, 2, 0, 2, 3, 1, 1, 3];
    let mut loaded = Vec::new();
    for (name, component) in [("u8", U8), ("u16", U16), ("u32", U32)] {
        let path = write_gltf(
            dir.path(),
            name,
            &positions,
            Some((&indices, component)),
            true,
        );
        let scene = load_gltf(Path::new(&path), &CameraChoice::First).unwrap();
        assert_eq!(scene.stats.degenerate_triangles, 1, "{name}");
        loaded.push(scene.triangles);
    }
    assert_eq!(loaded[0], loaded[1]);
    assert_eq!(loaded[0], loaded[2]);
    assert_eq!(loaded[0].len(), 2);
    // Without indices, consecutive vertex triples are the triangles.
    let flat: Vec<f32> = indices[..6]
        .iter()
        .flat_map(|&i| positions[3 * i as usize..3 * i as usize + 3].to_vec())
        .collect();
    let path = write_gltf(dir.path(), "none", &flat, None, true);
    let scene = load_gltf(Path::new(&path), &CameraChoice::First).unwrap();
    assert_eq!(scene.triangles, loaded[0]);
    // glTF's default material (no material given): white, metallic 1, roughness 1, no emission.
    assert_eq!(
        scene.materials,
        vec![manylights::scene::Material::default()]
    );
}

#[test]
fn cameras_are_chosen_by_index_or_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cams.glb");
    let mut b = GltfBuilder::new();
    let m = b.add_material(GltfMaterial::default());
    let mesh = b.add_mesh(
        "tri",
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        None,
        None,
        m,
    );
    b.add_node("tri", Some(mesh), None, NodeTransform::Identity);
    for (name, z) in [("near", 2.0), ("far", 9.0)] {
        let cam = b.add_perspective_camera(name, 0.7, Some(2.0), 0.01);
        let t = NodeTransform::Trs {
            translation: [0.0, 0.0, z],
            rotation: [0.0, 0.0, 0.0, 1.0],
            scale: [1.0; 3],
        };
        b.add_node(name, None, Some(cam), t);
    }
    b.write(&path).unwrap();
    let z_of =
        |choice: CameraChoice| load_gltf(&path, &choice).map(|s| s.camera.unwrap().position.z);
    assert_eq!(z_of(CameraChoice::First).unwrap(), 2.0);
    assert_eq!(z_of(CameraChoice::Index(1)).unwrap(), 9.0);
    assert_eq!(z_of(CameraChoice::Name("far".into())).unwrap(), 9.0);
    let err = z_of(CameraChoice::Name("side".into())).unwrap_err();
    assert!(
        matches!(err, LoadError::Invalid { .. }) && err.to_string().contains("'side'"),
        "{err}"
    );
    let err = z_of(CameraChoice::Index(2)).unwrap_err();
    assert!(
        err.to_string()
            .contains("0 'near' (perspective), 1 'far' (perspective)"),
        "{err}"
    );
    // Resolution follows the camera's aspect ratio (2.0) unless --height is given.
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    assert_eq!(scene.camera.unwrap().resolution(300, None), (300, 150));
}

#[test]
fn punctual_lights_are_placed_by_their_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_gltf(
        dir.path(),
        "lit",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        None,
        true,
    );
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    json["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
    json["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 8.0},
        {"type": "spot", "intensity": 3.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.4}},
        {"type": "directional", "intensity": 2.0}
    ]}});
    // Rotating −Z (a light's direction) by −90° about +X gives −Y: quaternion (−sin 45°, 0, 0, cos 45°).
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let nodes = json["nodes"].as_array_mut().unwrap();
    nodes.push(serde_json::json!({"translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}}));
    nodes.push(serde_json::json!({"translation": [0, 5, 0], "rotation": [-h, 0, 0, h], "extensions": {"KHR_lights_punctual": {"light": 1}}}));
    nodes.push(serde_json::json!({"rotation": [-h, 0, 0, h], "extensions": {"KHR_lights_punctual": {"light": 2}}}));
    json["scenes"][0]["nodes"] = serde_json::json!([0, 1, 2, 3]);
    std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();

    use manylights::scene::PunctualKind;
    let scene = load_gltf(Path::new(&path), &CameraChoice::First).unwrap();
    assert_eq!(scene.punctual.len(), 3);
    let [point, spot, sun] = [&scene.punctual[0], &scene.punctual[1], &scene.punctual[2]];
    assert_eq!(point.kind, PunctualKind::Point);
    assert!(close(point.position, Vec3::new(1.0, 2.0, 3.0)));
    assert_eq!(point.intensity, Vec3::new(8.0, 4.0, 2.0));
    match spot.kind {
        PunctualKind::Spot {
            cos_inner,
            cos_outer,
        } => {
            assert!(
                (cos_inner - 0.2f32.cos()).abs() < 1e-6 && (cos_outer - 0.4f32.cos()).abs() < 1e-6
            )
        }
        k => panic!("expected a spot, got {k:?}"),
    }
    assert!(close(spot.position, Vec3::new(0.0, 5.0, 0.0)) && close(spot.direction, -Vec3::Y));
    assert_eq!(sun.kind, PunctualKind::Directional);
    assert!(close(sun.direction, -Vec3::Y));
    assert_eq!(Lights::from_scene(&scene).len(), 3);
}

/// Rewrites the single primitive of a file from `common::write_gltf` to glTF mode `mode`; with
/// `keep_triangles`, a TRIANGLES copy of it is kept first (a scene needs some area to load).
fn set_primitive_mode(path: &str, mode: u32, keep_triangles: bool) {
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let mut changed = json["meshes"][0]["primitives"][0].clone();
    changed["mode"] = mode.into();
    let primitives = json["meshes"][0]["primitives"].as_array_mut().unwrap();
    if keep_triangles {
        primitives.push(changed);
    } else {
        primitives[0] = changed;
    }
    std::fs::write(path, serde_json::to_vec(&json).unwrap()).unwrap();
}

/// Twice the signed area of a polygon in the xy plane (the shoelace formula), counter-clockwise
/// positive: an independent total for the triangles a strip or fan makes of it.
fn shoelace(xy: &[[f32; 2]]) -> f64 {
    (0..xy.len())
        .map(|i| {
            let (a, b) = (xy[i], xy[(i + 1) % xy.len()]);
            f64::from(a[0]) * f64::from(b[1]) - f64::from(b[0]) * f64::from(a[1])
        })
        .sum()
}

#[test]
fn strips_and_fans_become_front_facing_triangles_covering_the_polygon() {
    let dir = tempfile::tempdir().unwrap();
    // A strip zig-zagging along x (top, bottom, top, …), and the same band as a polygon.
    let strip_xy = [
        [0.0, 1.0],
        [0.0, 0.0],
        [1.0, 1.0],
        [1.0, 0.0],
        [2.5, 1.2],
        [3.0, 0.0],
    ];
    let band = [
        [0.0, 0.0],
        [1.0, 0.0],
        [3.0, 0.0],
        [2.5, 1.2],
        [1.0, 1.0],
        [0.0, 1.0],
    ];
    // A convex counter-clockwise pentagon, fanned from its first vertex.
    let fan_xy = [[0.0, 0.0], [2.0, 0.0], [2.5, 1.5], [1.0, 2.5], [-0.5, 1.2]];
    for (name, mode, xy, polygon) in [
        ("strip", 5, &strip_xy[..], &band[..]),
        ("fan", 6, &fan_xy[..], &fan_xy[..]),
    ] {
        let positions: Vec<f32> = xy.iter().flat_map(|p| [p[0], p[1], 0.0]).collect();
        let path = write_gltf(dir.path(), name, &positions, None, true);
        set_primitive_mode(&path, mode, false);
        let scene = load_gltf(Path::new(&path), &CameraChoice::First).unwrap();
        assert_eq!(scene.triangles.len(), xy.len() - 2, "{name}");
        assert_eq!(scene.stats.skipped_primitives, 0, "{name}");
        for t in &scene.triangles {
            assert!(
                close(t.geometric_normal(), Vec3::Z),
                "{name}: a triangle faces away"
            );
        }
        let area: f64 = scene.triangles.iter().map(|t| f64::from(t.area())).sum();
        let expected = 0.5 * shoelace(polygon);
        assert!(
            (area - expected).abs() < 1e-5 * expected,
            "{name}: {area} vs {expected}"
        );
    }
}

#[test]
fn primitives_without_area_are_counted_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let positions = [
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0,
    ];
    for (mode, label) in [
        (0, "POINTS"),
        (1, "LINES"),
        (2, "LINELOOP"),
        (3, "LINESTRIP"),
    ] {
        let path = write_gltf(dir.path(), label, &positions, None, true);
        set_primitive_mode(&path, mode, true);
        let scene = load_gltf(Path::new(&path), &CameraChoice::First).unwrap();
        assert_eq!(scene.triangles.len(), 2, "{label}: the TRIANGLES copy only");
        assert_eq!(scene.stats.skipped_primitives, 1, "{label}");
        assert_eq!(
            scene.stats.skipped_primitive_names,
            vec![format!("mesh 0 'plate' primitive 1 ({label})")]
        );
    }
}

/// Positions and normals of two triangles, written (a) each in its own tightly packed view,
/// which the loader reads from the bytes directly, (b) interleaved in one view with a stride of
/// 24 bytes and (c) as a sparse accessor over a view of zeros, which both go through the `gltf`
/// crate's reader; with u8, u16 and u32 indices, packed. Every layout must give the same
/// triangles, bit for bit (signed zeros and values that are not round included).
#[test]
fn packed_strided_and_sparse_accessors_load_the_same_triangles() {
    use serde_json::json;
    let positions: [[f32; 3]; 4] = [
        [-0.0, 0.1, 0.0],
        [1.0e-3, -2.5, 7.3],
        [3.75, 1.0 / 3.0, -0.0],
        [-1.25e4, 0.7, 2.0],
    ];
    let normals: [[f32; 3]; 4] = [
        [0.0, 0.0, 1.0],
        [0.6, 0.0, 0.8],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let indices = [0u32, 1, 2, 2, 1, 3];
    let dir = tempfile::tempdir().unwrap();
    let floats = |values: &[[f32; 3]]| -> Vec<u8> {
        values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    };
    let load_layout = |name: &str, component: u32| {
        let mut bin = Vec::new();
        let mut views = Vec::new();
        let mut view = |bin: &mut Vec<u8>, bytes: &[u8], stride: Option<usize>| {
            let mut v = json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()});
            if let Some(stride) = stride {
                v["byteStride"] = json!(stride);
            }
            bin.extend_from_slice(bytes);
            // Views start at multiples of 4, as accessors of 4-byte components need.
            bin.resize(bin.len().next_multiple_of(4), 0);
            views.push(v);
            views.len() - 1
        };
        let vec3 = |view: usize, offset: usize| {
            json!({"bufferView": view, "byteOffset": offset, "componentType": 5126, "count": 4,
                "type": "VEC3", "min": [-1.25e4, -2.5, 0.0], "max": [3.75, 1.0, 7.3]})
        };
        let (position, normal) = match name {
            "packed" => {
                let p = view(&mut bin, &floats(&positions), None);
                let n = view(&mut bin, &floats(&normals), Some(12));
                (vec3(p, 0), vec3(n, 0))
            }
            "strided" => {
                let interleaved: Vec<[f32; 3]> = positions
                    .iter()
                    .zip(&normals)
                    .flat_map(|(p, n)| [*p, *n])
                    .collect();
                let both = view(&mut bin, &floats(&interleaved), Some(24));
                (vec3(both, 0), vec3(both, 12))
            }
            _ => {
                let zeros = view(&mut bin, &[0; 48], None);
                let ids = view(&mut bin, &[0, 1, 2, 3], None);
                let values = view(&mut bin, &floats(&positions), None);
                let mut p = vec3(zeros, 0);
                p["sparse"] = json!({"count": 4,
                    "indices": {"bufferView": ids, "componentType": 5121},
                    "values": {"bufferView": values}});
                let n = view(&mut bin, &floats(&normals), None);
                (p, vec3(n, 0))
            }
        };
        let index_bytes: Vec<u8> = match component {
            5121 => indices.iter().map(|&i| i as u8).collect(),
            5123 => indices
                .iter()
                .flat_map(|&i| (i as u16).to_le_bytes())
                .collect(),
            _ => indices.iter().flat_map(|&i| i.to_le_bytes()).collect(),
        };
        let index_view = view(&mut bin, &index_bytes, None);
        let gltf = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1},
                "indices": 2}]}],
            "buffers": [{"byteLength": bin.len(), "uri": format!("{name}{component}.bin")}],
            "bufferViews": views,
            "accessors": [position, normal,
                {"bufferView": index_view, "componentType": component, "count": 6,
                 "type": "SCALAR"}]
        });
        std::fs::write(dir.path().join(format!("{name}{component}.bin")), &bin).unwrap();
        let path = dir.path().join(format!("{name}{component}.gltf"));
        std::fs::write(&path, serde_json::to_vec(&gltf).unwrap()).unwrap();
        load_gltf(&path, &CameraChoice::First).unwrap().triangles
    };
    let bits = |triangles: Vec<manylights::scene::Triangle>| -> Vec<u32> {
        triangles
            .iter()
            .flat_map(|t| t.positions.into_iter().chain(t.normals))
            .flat_map(|v| v.to_array().map(f32::to_bits))
            .collect()
    };
    let reference = bits(load_layout("strided", 5125));
    assert_eq!(reference.len(), 2 * 6 * 3);
    // The first vertex's x is −0.0 in the file: the loader's transform makes it +0.0.
    assert_eq!(reference[0], 0.0f32.to_bits());
    for (name, component) in [
        ("packed", 5121),
        ("packed", 5123),
        ("packed", 5125),
        ("sparse", 5125),
        ("strided", 5121),
    ] {
        assert_eq!(
            bits(load_layout(name, component)),
            reference,
            "{name} {component}"
        );
    }
}
