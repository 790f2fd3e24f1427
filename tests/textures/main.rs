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
//! - missing, corrupt and oversized images, and TEXCOORD_1, as errors naming the image;
//! - texture coordinates kept in triangle order after untextured primitives, none when untextured.

use crate::lambert;

mod errors;
mod lighting;
mod power;
mod uvs;

pub(crate) use std::path::{Path, PathBuf};

pub(crate) use base64::Engine;
pub(crate) use glam::{DVec3, Vec2};
// Expected values take luminance from `tests/common`; the crate's is for what it computed.
pub(crate) use crate::color::luminance as luminance64;
pub(crate) use manylights::color::luminance;
pub(crate) use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
pub(crate) use manylights::lights::{Light, Lights};
pub(crate) use manylights::scene::{load_gltf, CameraChoice, LoadError, Scene};
pub(crate) use manylights::select::SelectorKind;
pub(crate) use serde_json::json;

/// Texture size (texels per side), and the emitter grid (cells per side) for small triangles.
pub(crate) const TEX: usize = 8;
pub(crate) const FINE: usize = 8;
/// A coarse grid whose triangles span many texels: Le(uv) then differs much from their mean.
pub(crate) const COARSE: usize = 2;
/// The emitter: the square [X0, X0 + SIDE] × [Y0, Y0 + SIDE] at height Z_E, facing −Z.
pub(crate) const X0: f64 = 0.6;
pub(crate) const Y0: f64 = -0.5;
pub(crate) const SIDE: f64 = 1.0;
pub(crate) const Z_E: f64 = 0.15;
pub(crate) const EMISSIVE_FACTOR: f64 = 4.0;
/// The plane's base-colour texel (sRGB code) under a white factor.
pub(crate) const ALBEDO_CODE: u8 = 188;
/// The camera looks straight down from (CAMERA_X, 0, CAMERA_HEIGHT) at the strip of the plane
/// next to the emitter (which it does not see), where BSDF samples often hit the emitter.
pub(crate) const CAMERA_X: f64 = 0.3;
pub(crate) const CAMERA_HEIGHT: f64 = 3.0;
pub(crate) const YFOV_DEG: f64 = 10.0;
pub(crate) const SIZE: u32 = 24;

pub(crate) const REPEAT: u32 = 10497;
pub(crate) const CLAMP: u32 = 33071;
pub(crate) const MIRROR: u32 = 33648;

/// The emissive texture, 8-bit sRGB codes: black but for four texels.
pub(crate) fn emissive_codes() -> Vec<[u8; 3]> {
    let mut codes = vec![[0u8; 3]; TEX * TEX];
    codes[2 * TEX + 1] = [255, 255, 255];
    codes[5 * TEX + 5] = [255, 128, 32];
    codes[TEX + 6] = [40, 200, 255];
    codes[6 * TEX + 3] = [20, 20, 20];
    codes
}

pub(crate) fn srgb_decode(code: u8) -> f64 {
    let c = code as f64 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

pub(crate) fn png(width: usize, height: usize, codes: &[[u8; 3]]) -> Vec<u8> {
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
pub(crate) enum Uvs {
    /// A grid of this many cells per side, uv = −0.1 + 1.25·(position − corner)/SIDE over the
    /// square: footprints cross texel cells and the texture's edges (REPEAT in u,
    /// MIRRORED_REPEAT in v).
    Continuous(usize),
    /// A TEX×TEX grid with all three uvs of cell (a, b)'s triangles at texel (a, b)'s centre:
    /// constant emission per triangle.
    TexelCentres,
}

/// Where the emissive image comes from.
pub(crate) enum EmissiveImage {
    /// A buffer view holding these bytes.
    View(Vec<u8>),
    /// A URI (data: or a file next to the scene).
    Uri(String),
}

/// The emitter's triangles (positions facing −Z, and uvs), in file order.
pub(crate) fn emitter_triangles(uvs: Uvs) -> Vec<([DVec3; 3], [Vec2; 3])> {
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
pub(crate) fn write_scene(
    dir: &Path,
    name: &str,
    uvs: Uvs,
    image: EmissiveImage,
    tex_coord: u32,
) -> PathBuf {
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

pub(crate) fn load(path: &Path) -> Result<Scene, LoadError> {
    load_gltf(path, &CameraChoice::First)
}

pub(crate) fn scene(uvs: Uvs) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let image = EmissiveImage::View(png(TEX, TEX, &emissive_codes()));
    load(&write_scene(dir.path(), "emitter", uvs, image, 0)).unwrap()
}

/// The texel a wrapped integer index reads, defined through the texel centre's position:
/// repeat takes it modulo 1, mirrored repeat reflects it into [0, 1], clamp clamps the index.
pub(crate) fn wrapped(i: i64, n: usize, mode: u32) -> usize {
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
pub(crate) fn emission(uv: Vec2, wrap: (u32, u32)) -> DVec3 {
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
