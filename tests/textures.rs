//! Emissive and base-colour textures: a square emitter split into 8×8×2 small triangles under a
//! mostly dark 8×8 emissive texture with a few bright texels, above a Lambertian plane whose
//! base colour comes from a texture. Checked here independently of the renderer:
//! - each emitting triangle's selection power against a brute-force stratified average of the
//!   bilinear texture over its uv footprint (own bilinear filter, wrap and sRGB code);
//! - the rendered plane against Lambert's polygon formula when the texture is constant on each
//!   triangle (all three uvs of a triangle at one texel centre);
//! - on the same emitter split into 2×2×2 large triangles (across which Le(uv) varies much),
//!   power and light-BVH selection (textured power, Le read at each sample's uv) against uniform
//!   selection and BSDF sampling (Le read at the hit's uv), block by block within 5σ;
//! - missing, corrupt and oversized images, and TEXCOORD_1, as errors naming the image.

#[path = "common/lambert.rs"]
mod lambert;

use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{DVec3, Vec2};
use manylights::color::luminance;
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::lights::{Light, Lights};
use manylights::scene::{load_gltf, CameraChoice, LoadError, Scene};
use manylights::select::SelectorKind;
use serde_json::json;

/// Texture size (texels per side), and the emitter grid (cells per side) for small triangles.
const TEX: usize = 8;
const FINE: usize = 8;
/// A coarse grid whose triangles span many texels: Le(uv) then differs much from their mean.
const COARSE: usize = 2;
/// The emitter: the square [X0, X0 + SIDE] × [Y0, Y0 + SIDE] at height Z_E, facing −Z.
const X0: f64 = 0.6;
const Y0: f64 = -0.5;
const SIDE: f64 = 1.0;
const Z_E: f64 = 0.15;
const EMISSIVE_FACTOR: f64 = 4.0;
/// The plane's base-colour texel (sRGB code) under a white factor.
const ALBEDO_CODE: u8 = 188;
/// The camera looks straight down from (CAMERA_X, 0, CAMERA_HEIGHT) at the strip of the plane
/// next to the emitter (which it does not see), where BSDF samples often hit the emitter.
const CAMERA_X: f64 = 0.3;
const CAMERA_HEIGHT: f64 = 3.0;
const YFOV_DEG: f64 = 10.0;
const SIZE: u32 = 24;

const REPEAT: u32 = 10497;
const CLAMP: u32 = 33071;
const MIRROR: u32 = 33648;

/// The emissive texture, 8-bit sRGB codes: black but for four texels.
fn emissive_codes() -> Vec<[u8; 3]> {
    let mut codes = vec![[0u8; 3]; TEX * TEX];
    codes[2 * TEX + 1] = [255, 255, 255];
    codes[5 * TEX + 5] = [255, 128, 32];
    codes[TEX + 6] = [40, 200, 255];
    codes[6 * TEX + 3] = [20, 20, 20];
    codes
}

fn srgb_decode(code: u8) -> f64 {
    let c = code as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn png(width: usize, height: usize, codes: &[[u8; 3]]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let data: Vec<u8> = codes.iter().flatten().copied().collect();
    encoder
        .write_header()
        .unwrap()
        .write_image_data(&data)
        .unwrap();
    out
}

/// How the emitter's triangles map to the texture.
#[derive(Clone, Copy, PartialEq)]
enum Uvs {
    /// A grid of this many cells per side, uv = −0.1 + 1.25·(position − corner)/SIDE over the
    /// square: footprints cross texel cells and the texture's edges (REPEAT in u,
    /// MIRRORED_REPEAT in v).
    Continuous(usize),
    /// A TEX×TEX grid with all three uvs of cell (a, b)'s triangles at texel (a, b)'s centre:
    /// constant emission per triangle.
    TexelCentres,
}

/// Where the emissive image comes from.
enum EmissiveImage {
    /// A buffer view holding these bytes.
    View(Vec<u8>),
    /// A URI (data: or a file next to the scene).
    Uri(String),
}

/// The emitter's triangles (positions facing −Z, and uvs), in file order.
fn emitter_triangles(uvs: Uvs) -> Vec<([DVec3; 3], [Vec2; 3])> {
    let grid = match uvs {
        Uvs::Continuous(grid) => grid,
        Uvs::TexelCentres => TEX,
    };
    let s = SIDE / grid as f64;
    let uv_of = |p: DVec3, a: usize, b: usize| match uvs {
        Uvs::Continuous(_) => Vec2::new(
            (-0.1 + 1.25 * (p.x - X0) / SIDE) as f32,
            (-0.1 + 1.25 * (p.y - Y0) / SIDE) as f32,
        ),
        Uvs::TexelCentres => Vec2::new(
            ((a as f64 + 0.5) / TEX as f64) as f32,
            ((b as f64 + 0.5) / TEX as f64) as f32,
        ),
    };
    let mut out = Vec::new();
    for b in 0..grid {
        for a in 0..grid {
            let c = |da: usize, db: usize| {
                DVec3::new(X0 + (a + da) as f64 * s, Y0 + (b + db) as f64 * s, Z_E)
            };
            // Clockwise seen from above: the front face looks down at the plane.
            for tri in [[c(0, 0), c(1, 1), c(1, 0)], [c(0, 0), c(0, 1), c(1, 1)]] {
                out.push((tri, tri.map(|p| uv_of(p, a, b))));
            }
        }
    }
    out
}

/// Writes the scene as `name`.gltf in `dir`: the textured emitter, the plane (Lambertian,
/// base colour from a 1×1 texture) and a camera looking straight down at the plane.
fn write_scene(dir: &Path, name: &str, uvs: Uvs, image: EmissiveImage, tex_coord: u32) -> PathBuf {
    let emitter = emitter_triangles(uvs);
    let plane: Vec<[DVec3; 3]> = {
        let c = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        vec![
            [c(-3.0, -3.0), c(3.0, -3.0), c(3.0, 3.0)],
            [c(-3.0, -3.0), c(3.0, 3.0), c(-3.0, 3.0)],
        ]
    };
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8]| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let f32_bytes = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|f| f.to_le_bytes()).collect() };
    let mut accessors = Vec::new();
    let mut mesh = |bin: &mut Vec<u8>, tris: &[[DVec3; 3]], uv: &[[Vec2; 3]]| {
        let p: Vec<f32> = tris
            .iter()
            .flatten()
            .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect();
        let t: Vec<f32> = uv.iter().flatten().flat_map(|t| [t.x, t.y]).collect();
        let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
        for v in p.chunks(3) {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        let pv = push_view(bin, &f32_bytes(&p));
        let tv = push_view(bin, &f32_bytes(&t));
        accessors.push(
            json!({"bufferView": pv, "componentType": 5126, "count": p.len() / 3,
            "type": "VEC3", "min": lo, "max": hi}),
        );
        accessors.push(
            json!({"bufferView": tv, "componentType": 5126, "count": t.len() / 2,
            "type": "VEC2"}),
        );
        (accessors.len() - 2, accessors.len() - 1)
    };
    let tris: Vec<[DVec3; 3]> = emitter.iter().map(|e| e.0).collect();
    let uv: Vec<[Vec2; 3]> = emitter.iter().map(|e| e.1).collect();
    let (emitter_pos, emitter_uv) = mesh(&mut bin, &tris, &uv);
    let (plane_pos, plane_uv) = mesh(&mut bin, &plane, &[[Vec2::ZERO; 3]; 2]);
    let emissive_image = match image {
        EmissiveImage::View(bytes) => {
            json!({"bufferView": push_view(&mut bin, &bytes), "mimeType": "image/png"})
        }
        EmissiveImage::Uri(uri) => json!({"uri": uri}),
    };
    let albedo_png = png(1, 1, &[[ALBEDO_CODE; 3]]);
    let data_uri = |mime: &str, bytes: &[u8]| {
        let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
        format!("data:{mime};base64,{b64}")
    };
    let (wrap_s, wrap_t) = match uvs {
        Uvs::Continuous(_) => (REPEAT, MIRROR),
        Uvs::TexelCentres => (CLAMP, CLAMP),
    };
    let gltf = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_materials_specular"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"mesh": 1},
            {"camera": 0, "translation": [CAMERA_X, 0.0, CAMERA_HEIGHT]}
        ],
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": YFOV_DEG.to_radians(), "aspectRatio": 1.0, "znear": 0.01}}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": emitter_pos, "TEXCOORD_0": emitter_uv},
                             "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": plane_pos, "TEXCOORD_0": plane_uv},
                             "material": 1}]}
        ],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
             "emissiveFactor": [EMISSIVE_FACTOR, EMISSIVE_FACTOR, EMISSIVE_FACTOR],
             "emissiveTexture": {"index": 0, "texCoord": tex_coord}},
            {"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}, "metallicFactor": 0},
             "extensions": {"KHR_materials_specular": {"specularFactor": 0}}}
        ],
        "textures": [{"source": 0, "sampler": 0}, {"source": 1}],
        "samplers": [{"wrapS": wrap_s, "wrapT": wrap_t}],
        "images": [emissive_image, {"uri": data_uri("image/png", &albedo_png)}],
        "buffers": [{"byteLength": bin.len(), "uri": data_uri("application/octet-stream", &bin)}],
        "bufferViews": views,
        "accessors": accessors
    });
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_vec(&gltf).unwrap()).unwrap();
    path
}

fn load(path: &Path) -> Result<Scene, LoadError> {
    load_gltf(path, &CameraChoice::First)
}

fn scene(uvs: Uvs) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let image = EmissiveImage::View(png(TEX, TEX, &emissive_codes()));
    load(&write_scene(dir.path(), "emitter", uvs, image, 0)).unwrap()
}

/// The texel a wrapped integer index reads, defined through the texel centre's position:
/// repeat takes it modulo 1, mirrored repeat reflects it into [0, 1], clamp clamps the index.
fn wrapped(i: i64, n: usize, mode: u32) -> usize {
    let centre = (i as f64 + 0.5) / n as f64;
    let folded = match mode {
        REPEAT => centre - centre.floor(),
        MIRROR => {
            let t = centre - 2.0 * (centre / 2.0).floor();
            if t > 1.0 {
                2.0 - t
            } else {
                t
            }
        }
        _ => return i.clamp(0, n as i64 - 1) as usize,
    };
    ((folded * n as f64).floor() as usize).min(n - 1)
}

/// Emitted radiance at uv: factor × Σ_texels t_k · hat(x − x_k) · hat(y − y_k), in f64.
fn emission(uv: Vec2, wrap: (u32, u32)) -> DVec3 {
    let codes = emissive_codes();
    let x = uv.x as f64 * TEX as f64 - 0.5;
    let y = uv.y as f64 * TEX as f64 - 0.5;
    let mut sum = DVec3::ZERO;
    for j in y.floor() as i64..=y.floor() as i64 + 1 {
        for i in x.floor() as i64..=x.floor() as i64 + 1 {
            let weight =
                (1.0 - (x - i as f64).abs()).max(0.0) * (1.0 - (y - j as f64).abs()).max(0.0);
            let texel = codes[wrapped(j, TEX, wrap.1) * TEX + wrapped(i, TEX, wrap.0)];
            sum += weight * DVec3::from_array(texel.map(srgb_decode));
        }
    }
    EMISSIVE_FACTOR * sum
}

fn luminance64(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[test]
fn triangle_power_matches_a_brute_force_average_over_its_texels() {
    let scene = scene(Uvs::Continuous(FINE));
    let lights = Lights::from_scene(&scene);
    let expected = emitter_triangles(Uvs::Continuous(FINE));
    assert_eq!(lights.triangle_count(), expected.len());
    let brightest = emissive_codes()
        .iter()
        .map(|c| luminance64(EMISSIVE_FACTOR * DVec3::from_array(c.map(srgb_decode))))
        .fold(0.0, f64::max);
    let (mut zero, mut lit) = (0, 0);
    for light in lights.triangles() {
        let t = light.triangle as usize;
        let (positions, uvs) = expected[t];
        assert_eq!(scene.triangles[t].uvs, uvs, "triangle {t}'s uvs as written");
        let area = 0.5
            * (positions[1] - positions[0])
                .cross(positions[2] - positions[0])
                .length();
        // 224² strata of the barycentric square, two jittered points in each (fixed sequence):
        // mean and the stratified estimator's variance Σ (f₁ − f₂)² / (4 N²).
        let strata = 224;
        let (mut sum, mut diff2) = (0.0, 0.0);
        let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ t as u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for a in 0..strata {
            for b in 0..strata {
                let mut pair = [0.0; 2];
                for value in &mut pair {
                    let u1 = (a as f64 + next()) / strata as f64;
                    let u2 = (b as f64 + next()) / strata as f64;
                    let (b1, b2) = (u1.sqrt() * (1.0 - u2), u1.sqrt() * u2);
                    let uv = uvs[0].as_dvec2()
                        + b1 * (uvs[1] - uvs[0]).as_dvec2()
                        + b2 * (uvs[2] - uvs[0]).as_dvec2();
                    *value = luminance64(emission(uv.as_vec2(), (REPEAT, MIRROR)));
                }
                sum += pair[0] + pair[1];
                diff2 += (pair[0] - pair[1]).powi(2);
            }
        }
        let n = (strata * strata) as f64;
        let mean = sum / (2.0 * n);
        let sigma = (diff2 / (4.0 * n * n)).sqrt();
        let brute = std::f64::consts::PI * area * mean;
        let power = light.power();
        // 5σ of the brute force, the power floor (1e-6 of the brightest reachable texel) and
        // f32 rounding of the stored radiance.
        let tolerance =
            std::f64::consts::PI * area * (5.0 * sigma + 1e-6 * brightest) + 1e-5 * brute;
        assert!(
            (power - brute).abs() <= tolerance,
            "triangle {t}: power {power} but the brute-force average gives {brute} (±{tolerance})"
        );
        if brute > 0.0 {
            assert!(power > 0.0, "triangle {t} emits but has zero power");
            lit += 1;
        } else {
            zero += 1;
        }
    }
    // The premise: a mostly dark texture, so that power from the factor alone would mislead.
    assert!(
        zero > 0 && lit > 0 && lit < expected.len() / 2,
        "{lit} lit, {zero} dark"
    );
}

/// ρ/π · Σ_triangles L_k · E_k at plane point (x, y), with L_k the texel under triangle k.
fn plane_radiance(x: f64, y: f64) -> DVec3 {
    let p = DVec3::new(x, y, 0.0);
    let rho = srgb_decode(ALBEDO_CODE);
    emitter_triangles(Uvs::TexelCentres)
        .iter()
        .map(|(tri, uv)| {
            emission(uv[0], (CLAMP, CLAMP)) * lambert::irradiance(p, DVec3::Z, tri, 1.0)
        })
        .sum::<DVec3>()
        * rho
        / std::f64::consts::PI
}

/// The box filter's average of the plane's radiance over pixel (i, j) (8×8 midpoint quadrature).
fn expected_pixel(i: u32, j: u32) -> DVec3 {
    let t = (0.5 * YFOV_DEG.to_radians()).tan();
    let q = 8;
    let mut sum = DVec3::ZERO;
    for a in 0..q {
        for b in 0..q {
            let sx = (2.0 * (i as f64 + (a as f64 + 0.5) / q as f64) / SIZE as f64 - 1.0) * t;
            let sy = (1.0 - 2.0 * (j as f64 + (b as f64 + 0.5) / q as f64) / SIZE as f64) * t;
            sum += plane_radiance(CAMERA_X + CAMERA_HEIGHT * sx, CAMERA_HEIGHT * sy);
        }
    }
    sum / (q * q) as f64
}

fn render_scene(
    scene: &Scene,
    selector: SelectorKind,
    strategy: Strategy,
    spp: u32,
) -> manylights::film::Film {
    let prepared = PreparedScene::new(scene.clone(), selector);
    let estimator = prepared.estimator(strategy, 1, 1);
    let camera = prepared.scene.camera.clone().unwrap();
    let opts = RenderOptions::new(SIZE, SIZE, spp, 5);
    let (film, stats) = render(&estimator, &camera, &opts);
    assert_eq!(stats.nan_samples + stats.inf_samples, 0);
    film
}

#[test]
fn camera_sees_only_the_plane() {
    let reach = (CAMERA_HEIGHT - Z_E) * (0.5 * YFOV_DEG.to_radians()).tan();
    assert!(X0 > CAMERA_X + reach, "the emitter is visible");
}

#[test]
fn texel_constant_emitter_lights_the_plane_as_lambert_predicts() {
    let scene = scene(Uvs::TexelCentres);
    // Constant emission per triangle: each light's power is its texel's, exactly.
    let lights = Lights::from_scene(&scene);
    let triangles = emitter_triangles(Uvs::TexelCentres);
    for l in &lights.lights {
        let Light::Triangle(light) = l else { continue };
        let (_, uv) = triangles[light.triangle as usize];
        let expected = luminance64(emission(uv[0], (CLAMP, CLAMP)));
        let got = luminance(light.radiance) as f64;
        assert!(
            (got - expected).abs() <= 1e-5 * expected.max(1e-3),
            "{got} vs {expected}"
        );
    }
    let film = render_scene(&scene, SelectorKind::Power, Strategy::LightSolidAngle, 512);
    let (mut sum, mut expected_sum, mut var_sum) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for j in 0..SIZE {
        for i in 0..SIZE {
            let px = &film.pixels[(j * SIZE + i) as usize];
            let expected = expected_pixel(i, j);
            let sigma = px.variance_of_mean().map(f64::sqrt);
            for k in 0..3 {
                assert!(
                    (px.mean[k] - expected[k]).abs() < 5.0 * sigma[k],
                    "pixel ({i},{j}) channel {k}: {} but Lambert gives {} (σ {})",
                    px.mean[k],
                    expected[k],
                    sigma[k]
                );
            }
            sum += px.mean;
            expected_sum += expected;
            var_sum += px.variance_of_mean();
        }
    }
    for k in 0..3 {
        let error = (sum[k] - expected_sum[k]).abs();
        let sigma = var_sum[k].sqrt();
        assert!(
            error < 5.0 * sigma,
            "channel {k}: image sum {} vs Lambert {} (σ {sigma})",
            sum[k],
            expected_sum[k]
        );
    }
}

/// Per 4×4 block and channel: (sum of pixel means, sum of their variances of the mean).
fn blocks(film: &manylights::film::Film) -> Vec<(DVec3, DVec3)> {
    let b = 4;
    let mut out = vec![(DVec3::ZERO, DVec3::ZERO); ((SIZE / b) * (SIZE / b)) as usize];
    for j in 0..SIZE {
        for i in 0..SIZE {
            let px = &film.pixels[(j * SIZE + i) as usize];
            let block = &mut out[((j / b) * (SIZE / b) + i / b) as usize];
            block.0 += px.mean;
            block.1 += px.variance_of_mean();
        }
    }
    out
}

#[test]
fn textured_power_and_bvh_selection_agree_with_uniform_selection_and_bsdf_sampling() {
    let scene = scene(Uvs::Continuous(COARSE));
    let baseline = blocks(&render_scene(
        &scene,
        SelectorKind::Uniform,
        Strategy::LightArea,
        512,
    ));
    assert!(baseline.iter().all(|b| b.0.min_element() > 0.0));
    for (selector, strategy, spp) in [
        (SelectorKind::Power, Strategy::LightSolidAngle, 128),
        (SelectorKind::Bvh, Strategy::LightSolidAngle, 128),
        (SelectorKind::Power, Strategy::Mis, 64),
        (SelectorKind::Uniform, Strategy::Bsdf, 512),
    ] {
        let other = blocks(&render_scene(&scene, selector, strategy, spp));
        for (n, (a, b)) in baseline.iter().zip(&other).enumerate() {
            for k in 0..3 {
                let sigma = (a.1[k] + b.1[k]).sqrt();
                assert!(
                    (a.0[k] - b.0[k]).abs() < 5.0 * sigma,
                    "{selector:?} {strategy:?} block {n} channel {k}: {} vs uniform {} (σ {sigma})",
                    b.0[k],
                    a.0[k]
                );
            }
        }
    }
}

/// The error's text, which must name the image; the load must not panic.
fn load_error(path: &Path) -> String {
    match load(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e @ LoadError::Invalid { .. }) => e.to_string(),
        Err(e) => panic!("{}: unexpected error kind: {e}", path.display()),
    }
}

#[test]
fn missing_corrupt_and_oversized_images_are_errors_naming_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let uri = |name: &str| EmissiveImage::Uri(name.into());

    let path = write_scene(
        dir.path(),
        "missing",
        Uvs::Continuous(FINE),
        uri("glow.png"),
        0,
    );
    let err = load_error(&path);
    assert!(err.contains("image 0") && err.contains("glow.png"), "{err}");
    // The same file once the image exists beside it: it loads, with the texture's size.
    std::fs::write(
        dir.path().join("glow.png"),
        png(TEX, TEX, &emissive_codes()),
    )
    .unwrap();
    let scene = load(&path).unwrap();
    assert_eq!(scene.textures.len(), 2);
    assert_eq!((scene.textures[0].width, scene.textures[0].height), (8, 8));

    let mut corrupt = png(TEX, TEX, &emissive_codes());
    let len = corrupt.len();
    corrupt[len / 2..].iter_mut().for_each(|b| *b = 0x5A);
    let path = write_scene(
        dir.path(),
        "corrupt",
        Uvs::Continuous(FINE),
        EmissiveImage::View(corrupt),
        0,
    );
    let err = load_error(&path);
    assert!(err.contains("image 0") && err.contains("PNG"), "{err}");

    let path = write_scene(
        dir.path(),
        "text",
        Uvs::Continuous(FINE),
        EmissiveImage::View(b"hello".to_vec()),
        0,
    );
    let err = load_error(&path);
    assert!(
        err.contains("image 0") && err.contains("neither PNG nor JPEG"),
        "{err}"
    );

    // A well-formed header declaring 2^17 × 2^17 texels: refused before decoding.
    let mut huge = png(TEX, TEX, &emissive_codes());
    huge[16..20].copy_from_slice(&(1u32 << 17).to_be_bytes());
    huge[20..24].copy_from_slice(&(1u32 << 17).to_be_bytes());
    let crc = crc32(&huge[12..29]);
    huge[29..33].copy_from_slice(&crc.to_be_bytes());
    let path = write_scene(
        dir.path(),
        "huge",
        Uvs::Continuous(FINE),
        EmissiveImage::View(huge),
        0,
    );
    let err = load_error(&path);
    assert!(
        err.contains("image 0") && err.contains("131072×131072"),
        "{err}"
    );

    let image = EmissiveImage::View(png(TEX, TEX, &emissive_codes()));
    let path = write_scene(dir.path(), "texcoord1", Uvs::Continuous(FINE), image, 1);
    let err = load_error(&path);
    assert!(
        err.contains("emissiveTexture") && err.contains("TEXCOORD_1"),
        "{err}"
    );
}

#[test]
fn cli_reports_textures_and_exits_3_on_a_missing_image() {
    let dir = tempfile::tempdir().unwrap();
    let image = EmissiveImage::View(png(TEX, TEX, &emissive_codes()));
    let good = write_scene(dir.path(), "good", Uvs::Continuous(FINE), image, 0);
    let run = |path: &Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_manylights"))
            .args(["info", path.to_str().unwrap()])
            .output()
            .unwrap()
    };
    let out = run(&good);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("textures           2 (8×8, 1×1)"),
        "{stdout}"
    );
    let bad = write_scene(
        dir.path(),
        "bad",
        Uvs::Continuous(FINE),
        EmissiveImage::Uri("nope.png".into()),
        0,
    );
    let out = run(&bad);
    assert_eq!(out.status.code(), Some(3));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("image 0") && stderr.contains("nope.png"),
        "{stderr}"
    );
}

/// CRC-32 (IEEE) of a PNG chunk's type and data.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}
