//! What Blender's glTF exporter writes, loaded and rendered against independent values:
//! photometric punctual lights (its default lighting mode writes Φ/(4π)·683 cd for a point light
//! of Φ watts and E·683 lx for a sun of E W/m²) seen through an orthographic camera on a
//! Lambertian plane, KHR_texture_transform (listed in extensionsRequired, as Blender does for a
//! Mapping node) read at texels named by hand, the footprint-mean emitter power under a
//! transform against a brute-force average, and required extensions we do not implement.

use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{Vec2, Vec3};
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::lights::Lights;
use manylights::scene::{load_gltf, CameraChoice, LoadError, Projection, PunctualUnits};
use manylights::select::SelectorKind;

const RHO: f32 = 0.5;
/// Half the side of the orthographic view (xmag = ymag), metres.
const MAG: f32 = 1.0;
const PLANE_HALF: f32 = 3.0;
const CAMERA_HEIGHT: f32 = 5.0;

/// A glTF file with one square plane at y = 0 facing +Y (uv = (x, z) mapped to [0, 1]²), a
/// Lambertian material (KHR_materials_specular 0, metallic 0) or an emissive one, an
/// orthographic camera looking down −Y from `CAMERA_HEIGHT` (right = +X, up = −Z), the given
/// KHR_lights_punctual lights on their own nodes and extra top-level fields merged in.
fn write_scene(
    dir: &Path,
    name: &str,
    lights: serde_json::Value,
    extra: serde_json::Value,
) -> PathBuf {
    let h = PLANE_HALF;
    let positions = [[-h, 0.0, h], [h, 0.0, h], [h, 0.0, -h], [-h, 0.0, -h]];
    let uvs = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    bin.extend(uvs.iter().flatten().flat_map(|f| f.to_le_bytes()));
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let mut json = serde_json::json!({
        "asset": {"version": "2.0", "generator": "hand-written like Khronos glTF Blender I/O"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_specular"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0},
            {"name": "Camera", "camera": 0, "translation": [0, CAMERA_HEIGHT, 0], "rotation": [-s, 0, 0, s]}
        ],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": MAG, "ymag": MAG, "znear": 0.1, "zfar": 100}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{
            "pbrMetallicRoughness": {"baseColorFactor": [RHO, RHO, RHO, 1], "metallicFactor": 0, "roughnessFactor": 1},
            "extensions": {"KHR_materials_specular": {"specularFactor": 0}}
        }],
        "buffers": [{"uri": uri, "byteLength": bin.len()}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-h, 0, -h], "max": [h, 0, h]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]
    });
    let lights = lights.as_array().cloned().unwrap_or_default();
    if !lights.is_empty() {
        let nodes = json["nodes"].as_array_mut().unwrap();
        let mut definitions = Vec::new();
        for (i, (light, node)) in lights.iter().map(|l| (&l[0], &l[1])).enumerate() {
            definitions.push(light.clone());
            let mut node = node.clone();
            node["extensions"] = serde_json::json!({"KHR_lights_punctual": {"light": i}});
            nodes.push(node);
        }
        let count = nodes.len();
        json["scenes"][0]["nodes"] = (0..count).collect::<Vec<_>>().into();
        json["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": definitions}});
    }
    for (key, value) in extra.as_object().cloned().unwrap_or_default() {
        json[key] = value;
    }
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec_pretty(&json).unwrap()).unwrap();
    path
}

/// Renders the file's own camera at `size`² with bvh + mis, K = N = 1, and returns each pixel's
/// mean and variance of the mean (luminance channel 0: every quantity here is grey).
fn render_pixels(path: &Path, size: u32, spp: u32) -> Vec<(f64, f64)> {
    let scene = load_gltf(path, &CameraChoice::First).unwrap();
    let camera = scene.camera.clone().unwrap();
    let prepared = PreparedScene::new(scene, SelectorKind::Bvh);
    let estimator = prepared.estimator(Strategy::Mis, 1, 1);
    let opts = RenderOptions::new(size, size, spp, 7);
    let (film, _) = render(&estimator, &camera, &opts);
    let means = film.mean_rgb();
    let variances = film.variance_of_mean_rgb();
    means
        .iter()
        .zip(&variances)
        .map(|(m, v)| (m[0] as f64, v[0] as f64))
        .collect()
}

/// The world point (x, z) on the plane that image position (px, py) of a `size`² image shows.
fn plane_point(px: f64, py: f64, size: u32) -> (f64, f64) {
    let n = size as f64;
    let x = (2.0 * px / n - 1.0) * MAG as f64;
    let z = -(1.0 - 2.0 * py / n) * MAG as f64;
    (x, z)
}

/// A Blender point light of 100 W (exported as 100/(4π)·683 cd) at height h: each pixel of the
/// orthographic view from above shows ρ/π · (I/683) · h/r³ averaged over its square footprint
/// (16×16 midpoint quadrature, computed here), within 5σ of the render's own variance.
#[test]
fn blender_point_light_in_candela_lights_the_plane_as_i_over_683_cos_over_r2() {
    let dir = tempfile::tempdir().unwrap();
    let watts = 100.0f64;
    let candela = watts / (4.0 * std::f64::consts::PI) * 683.0;
    let (lx, ly, lz) = (0.3, 0.8, -0.2);
    let lights = serde_json::json!([[
        {"name": "Point", "type": "point", "color": [1, 1, 1], "intensity": candela},
        {"translation": [lx, ly, lz]}
    ]]);
    let path = write_scene(dir.path(), "point", lights, serde_json::json!({}));
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    assert_eq!(scene.punctual_units, PunctualUnits::Photometric);
    let lights = Lights::from_scene(&scene);
    assert!(
        (lights.total_power() - watts).abs() < 1e-3 * watts,
        "a 100 W Blender light has {} W",
        lights.total_power()
    );
    let size = 8;
    let pixels = render_pixels(&path, size, 64);
    let irradiance = |x: f64, z: f64| {
        let r2 = (x - lx).powi(2) + ly * ly + (z - lz).powi(2);
        candela / 683.0 * ly / r2.powf(1.5)
    };
    const Q: usize = 16;
    for (index, &(mean, var)) in pixels.iter().enumerate() {
        let (i, j) = ((index as u32 % size) as f64, (index as u32 / size) as f64);
        let mut sum = 0.0;
        for a in 0..Q {
            for b in 0..Q {
                let px = i + (a as f64 + 0.5) / Q as f64;
                let py = j + (b as f64 + 0.5) / Q as f64;
                let (x, z) = plane_point(px, py, size);
                sum += irradiance(x, z);
            }
        }
        let expected = RHO as f64 / std::f64::consts::PI * sum / (Q * Q) as f64;
        let tolerance = 5.0 * var.sqrt() + 1e-4 * expected;
        assert!(
            (mean - expected).abs() < tolerance,
            "pixel ({i}, {j}): {mean} vs {expected} ± {tolerance}"
        );
    }
}

/// A Blender sun of 3 W/m² (exported as 3·683 lx) at 35° from the zenith: every pixel shows
/// ρ/π · 3 · cos 35° exactly (a delta light: no noise); read as radiometric, 683× that.
#[test]
fn blender_sun_in_lux_gives_lambert_radiance_and_radiometric_mode_keeps_the_number() {
    let dir = tempfile::tempdir().unwrap();
    let theta = 35f64.to_radians();
    // The sun node's −Z turned by θ about +Z toward +X... rotate −Z into (sin θ, −cos θ, 0):
    // first −90° about X (−Z → −Y), then θ about Z (−Y → (sin θ, −cos θ, 0)).
    let (s, c) = ((0.5 * theta).sin(), (0.5 * theta).cos());
    let (qx, qw) = (
        -std::f64::consts::FRAC_1_SQRT_2,
        std::f64::consts::FRAC_1_SQRT_2,
    );
    // q = qz(θ) · qx(−90°)
    let rotation = [c * qx, s * qx, s * qw, c * qw];
    let lights = serde_json::json!([[
        {"name": "Sun", "type": "directional", "intensity": 3.0 * 683.0},
        {"rotation": rotation}
    ]]);
    let path = write_scene(dir.path(), "sun", lights, serde_json::json!({}));
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    let d = scene.punctual[0].direction;
    assert!(
        (d - Vec3::new(theta.sin() as f32, -theta.cos() as f32, 0.0)).length() < 1e-5,
        "{d}"
    );
    let expected = RHO as f64 / std::f64::consts::PI * 3.0 * theta.cos();
    for (mean, _) in render_pixels(&path, 4, 4) {
        assert!(
            (mean - expected).abs() < 1e-5 * expected,
            "{mean} vs {expected}"
        );
    }
    let raw = Lights::from_scene(&scene.with_punctual_units(PunctualUnits::Radiometric));
    let photometric = Lights::from_scene(&load_gltf(&path, &CameraChoice::First).unwrap());
    let ratio = raw.total_power() / photometric.total_power();
    assert!((ratio - 683.0).abs() < 1e-3, "{ratio}");
}

/// A 4×4 RGB PNG whose texel (i, j) is (40·i + 10, 40·j + 10, 200) in 8-bit sRGB.
fn ramp_png() -> Vec<u8> {
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, 4, 4);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().unwrap();
        let data: Vec<u8> = (0..4u8)
            .flat_map(|j| (0..4u8).flat_map(move |i| [40 * i + 10, 40 * j + 10, 200]))
            .collect();
        writer.write_image_data(&data).unwrap();
    }
    bytes
}

/// The plane made an emitter whose emissive texture (the ramp) is read through the spec's own
/// example transform: offset (0, 1), rotation π/2, scale ½ — "the lower left quadrant of the
/// source image, rotated clockwise 90°". By hand: uv' = (v/2, 1 − u/2).
fn textured_extra(transform: serde_json::Value, required: &[&str]) -> serde_json::Value {
    let png = base64::engine::general_purpose::STANDARD.encode(ramp_png());
    let mut texture_info = serde_json::json!({"index": 0});
    if !transform.is_null() {
        texture_info["extensions"] = serde_json::json!({"KHR_texture_transform": transform});
    }
    serde_json::json!({
        "extensionsUsed": ["KHR_materials_specular", "KHR_texture_transform"],
        "extensionsRequired": required,
        "materials": [{
            "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
            "emissiveFactor": [1, 1, 1],
            "emissiveTexture": texture_info,
            "extensions": {"KHR_materials_specular": {"specularFactor": 0}}
        }],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 10497, "wrapT": 10497}],
        "images": [{"uri": format!("data:image/png;base64,{png}")}]
    })
}

fn spec_example() -> serde_json::Value {
    serde_json::json!({"offset": [0, 1], "rotation": std::f64::consts::FRAC_PI_2, "scale": [0.5, 0.5]})
}

#[test]
fn texture_transform_reads_the_texel_the_transform_names() {
    let dir = tempfile::tempdir().unwrap();
    let extra = textured_extra(spec_example(), &["KHR_texture_transform"]);
    let path = write_scene(dir.path(), "mapped", serde_json::json!([]), extra);
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    let texture = &scene.textures[0];
    let texel = |i: usize, j: usize| texture.texels[j * 4 + i];
    // Mesh uv → (v/2, 1 − u/2) → texel centre ((k + ½)/4): exact texels under bilinear filtering.
    let cases = [
        (Vec2::new(0.25, 0.75), (1, 3)),
        (Vec2::new(0.75, 0.25), (0, 2)),
        (Vec2::new(0.75, 0.75), (1, 2)),
        (Vec2::new(0.25, 0.25), (0, 3)),
    ];
    for (uv, (i, j)) in cases {
        let got = texture.at(uv);
        assert!(
            (got - texel(i, j)).abs().max_element() < 1e-5,
            "uv {uv}: {got} vs texel ({i}, {j}) {}",
            texel(i, j)
        );
    }
    // Without the extension the same uvs read other texels: the transform is what moved them.
    let plain = write_scene(
        dir.path(),
        "plain",
        serde_json::json!([]),
        textured_extra(serde_json::Value::Null, &[]),
    );
    let plain = load_gltf(&plain, &CameraChoice::First).unwrap();
    let got = plain.textures[0].at(Vec2::new(0.375, 0.875));
    assert!((got - texel(1, 3)).abs().max_element() < 1e-5);
    assert!((plain.textures[0].at(Vec2::new(0.25, 0.75)) - texel(1, 3)).length() > 1e-3);
}

/// The light's power uses the transformed footprint: the exact mean equals a brute-force
/// average of `emission_at` over 2·300² equal sub-triangle centroids of each triangle.
#[test]
fn textured_emitter_power_follows_the_transform() {
    let dir = tempfile::tempdir().unwrap();
    let transform =
        serde_json::json!({"offset": [0.3, -0.2], "rotation": 0.7, "scale": [1.7, 0.6]});
    let extra = textured_extra(transform, &["KHR_texture_transform"]);
    let path = write_scene(dir.path(), "power", serde_json::json!([]), extra);
    let scene = load_gltf(&path, &CameraChoice::First).unwrap();
    const N: usize = 300;
    for triangle in 0..scene.triangles.len() {
        let mut sum = glam::DVec3::ZERO;
        let mut count = 0usize;
        for i in 0..N {
            for j in 0..N - i {
                let mut add = |b1: f64, b2: f64| {
                    sum += scene.emission_at(triangle, b1 as f32, b2 as f32).as_dvec3();
                    count += 1;
                };
                add(
                    (i as f64 + 1.0 / 3.0) / N as f64,
                    (j as f64 + 1.0 / 3.0) / N as f64,
                );
                if j + 1 < N - i {
                    add(
                        (i as f64 + 2.0 / 3.0) / N as f64,
                        (j as f64 + 2.0 / 3.0) / N as f64,
                    );
                }
            }
        }
        assert_eq!(count, N * N);
        let brute = sum / count as f64;
        let exact = scene.mean_emission(triangle).as_dvec3();
        assert!(
            (exact - brute).abs().max_element() < 2e-4 * brute.max_element(),
            "triangle {triangle}: {exact} vs brute force {brute}"
        );
    }
    // And the transform changes the answer (the untransformed footprint's mean differs).
    let plain = textured_extra(serde_json::Value::Null, &[]);
    let plain = write_scene(dir.path(), "plain", serde_json::json!([]), plain);
    let plain = load_gltf(&plain, &CameraChoice::First).unwrap();
    assert!((plain.mean_emission(0) - scene.mean_emission(0)).length() > 1e-3);
}

#[test]
fn texcoord_override_is_honoured() {
    let dir = tempfile::tempdir().unwrap();
    // The reference asks for TEXCOORD_1; the transform overrides it back to 0.
    let mut extra = textured_extra(serde_json::json!({"texCoord": 0}), &[]);
    extra["materials"][0]["emissiveTexture"]["texCoord"] = 1.into();
    let path = write_scene(dir.path(), "override", serde_json::json!([]), extra.clone());
    load_gltf(&path, &CameraChoice::First).unwrap();
    // The other way round: an override to a set we do not read is refused, naming it.
    extra["materials"][0]["emissiveTexture"]["texCoord"] = 0.into();
    extra["materials"][0]["emissiveTexture"]["extensions"]["KHR_texture_transform"]["texCoord"] =
        1.into();
    let path = write_scene(dir.path(), "override1", serde_json::json!([]), extra);
    let err = load_gltf(&path, &CameraChoice::First).unwrap_err();
    assert!(err.to_string().contains("TEXCOORD_1"), "{err}");
}

#[test]
fn unimplemented_required_extensions_are_refused_by_name_with_their_effect() {
    let dir = tempfile::tempdir().unwrap();
    let extra = serde_json::json!({
        "extensionsUsed": ["KHR_materials_specular", "KHR_draco_mesh_compression"],
        "extensionsRequired": ["KHR_draco_mesh_compression"]
    });
    let path = write_scene(dir.path(), "draco", serde_json::json!([]), extra);
    let err = load_gltf(&path, &CameraChoice::First).unwrap_err();
    assert!(matches!(err, LoadError::Format { .. }), "{err}");
    let message = err.to_string();
    assert!(
        message.contains("KHR_draco_mesh_compression") && message.contains("compressed"),
        "{message}"
    );
}

#[test]
fn orthographic_camera_is_loaded_with_its_magnifications() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(
        dir.path(),
        "ortho",
        serde_json::json!([]),
        serde_json::json!({}),
    );
    let camera = load_gltf(&path, &CameraChoice::First)
        .unwrap()
        .camera
        .unwrap();
    assert_eq!(camera.projection, Projection::Orthographic { ymag: MAG });
    assert_eq!(camera.aspect_ratio, Some(1.0));
    assert!((camera.forward - Vec3::NEG_Y).length() < 1e-6);
    let err = load_gltf(&path, &CameraChoice::Index(3)).unwrap_err();
    assert!(
        err.to_string().contains("0 'Camera' (orthographic)"),
        "{err}"
    );
}

/// `info` on a Blender-style file with a 100 W point light, a 300 W spot and a 2 W/m² sun:
/// no emissive triangles, the three lights in their own section with their watts.
#[test]
fn info_lists_punctual_lights_apart_from_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let four_pi = 4.0 * std::f64::consts::PI;
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let lights = serde_json::json!([
        [{"type": "point", "intensity": 100.0 / four_pi * 683.0}, {"translation": [0, 2, 0]}],
        [{"type": "spot", "intensity": 300.0 / four_pi * 683.0,
          "spot": {"innerConeAngle": 0.6, "outerConeAngle": 0.7}},
         {"translation": [1, 2, 0], "rotation": [-s, 0, 0, s]}],
        [{"type": "directional", "intensity": 2.0 * 683.0}, {"rotation": [-s, 0, 0, s]}]
    ]);
    let path = write_scene(dir.path(), "three", lights, serde_json::json!({}));
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_manylights"))
        .arg("info")
        .arg(&path)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("emissive triangles 0 "), "{text}");
    assert!(
        text.contains("punctual lights    3 (photometric units"),
        "{text}"
    );
    let power_of = |kind: &str| -> f64 {
        let line = text.lines().find(|l| l.contains(kind)).unwrap();
        let watts = line.split("power ").nth(1).unwrap();
        watts.split(' ').next().unwrap().parse().unwrap()
    };
    assert!((power_of(" point ") - 100.0).abs() < 1e-2, "{text}");
    // The spot's power is the cone's share of 4π·I: 300 W × (1 − (cos 0.6 + cos 0.7)/2)/2.
    let spot = 300.0 * (1.0 - 0.5 * (0.6f64.cos() + 0.7f64.cos())) / 2.0;
    assert!((power_of(" spot ") - spot).abs() < 1e-3 * spot, "{text}");
    // The sun: π·R²·E with R the plane's bounding-sphere radius (half its diagonal).
    let r2 = 2.0 * (PLANE_HALF as f64).powi(2);
    let sun = std::f64::consts::PI * r2 * 2.0;
    assert!(
        (power_of(" directional ") - sun).abs() < 1e-3 * sun,
        "{text}"
    );
}
