//! `textured`: a 2 × 2 m ceiling panel whose emissive texture is mostly black
//! with a few bright spots, cut into n × n quads (2n² emissive triangles)
//! with texture coordinates, over a floor with a checker base-colour texture.
//! Emitted radiance = emissiveFactor (1) × strength × texel (glTF), so from
//! the factor alone every triangle looks equally bright, while the texture
//! leaves most of them black: power computed without the texture sends most
//! light samples to triangles that emit nothing.

use glam::Vec3;
use rand_core::SeedableRng;
use rand_pcg::Pcg32;

use super::super::gltf_write::{GltfBuilder, GltfMaterial, NodeTransform, TextureSampling};
use super::{add_camera, add_object, below, matte, uniform, QuadMesh};

/// Side of the emissive texture, texels.
pub const TEXTURE_SIZE: usize = 64;
/// Number of bright spots in the texture.
const SPOTS: usize = 5;
/// Emissive strength of the panel (the texture's white is this radiance).
const STRENGTH: f32 = 40.0;
/// Half side of the panel, metres, and its height.
const PANEL_HALF: f32 = 1.0;
const PANEL_HEIGHT: f32 = 2.5;

/// The n of the n × n panel with `lights` = 2·n² emissive triangles, if any.
pub fn textured_side(lights: usize) -> Option<usize> {
    super::grid_side(lights)
}

/// The panel cut into `n` × `n` quads; `seed` places the bright spots.
pub fn textured(n: usize, seed: u64) -> GltfBuilder {
    assert!(n > 0, "the panel needs at least one quad");
    let mut rng = Pcg32::seed_from_u64(seed);
    let mut b = GltfBuilder::new();

    let checker = b.add_png_texture("checker", checker_png(), TextureSampling::LinearRepeat);
    let floor_material = b.add_material(GltfMaterial {
        base_color_texture: Some(checker),
        ..matte("checker floor", [0.8; 3])
    });
    let mut floor = QuadMesh::default();
    floor.quad(Vec3::ZERO, Vec3::Z * 4.0, Vec3::X * 4.0); // faces +y
                                                          // Four checker repeats across the floor; corners in the quad's vertex order.
    let floor_uvs = [[0.0, 0.0], [0.0, 4.0], [4.0, 4.0], [4.0, 0.0]];
    let m = b.add_mesh_with_uvs(
        "floor",
        &floor.positions,
        Some(&floor.normals),
        Some(&floor_uvs),
        Some(&floor.indices),
        floor_material,
    );
    b.add_node("floor", Some(m), None, NodeTransform::Identity);

    let spots = b.add_png_texture("spots", spots_png(&mut rng), TextureSampling::NearestClamp);
    let panel_material = b.add_material(GltfMaterial {
        name: "spotted panel".into(),
        base_color: [0.0; 3],
        emissive: [1.0; 3],
        emissive_strength: STRENGTH,
        emissive_texture: Some(spots),
        ..GltfMaterial::default()
    });
    let (positions, uvs, indices) = panel(n);
    let m = b.add_mesh_with_uvs(
        "spotted panel",
        &positions,
        None,
        Some(&uvs),
        Some(&indices),
        panel_material,
    );
    b.add_node("spotted panel", Some(m), None, NodeTransform::Identity);

    let walls = b.add_material(matte("walls", [0.5; 3]));
    let mut back = QuadMesh::default();
    back.quad(Vec3::new(0.0, 1.5, -2.0), Vec3::X * 4.0, Vec3::Y * 1.5); // faces +z
    add_object(&mut b, "back wall", &back, walls, NodeTransform::Identity);

    add_camera(&mut b, [0.0, 1.4, 4.5], [0.0, 0.9, 0.0], 55.0);
    b
}

/// The panel's vertices (a shared (n+1)² lattice at y = `PANEL_HEIGHT`), uvs
/// (u along +x, v along +z, the image's top row at −z) and indices of its
/// 2n² triangles facing −y.
fn panel(n: usize) -> (Vec<[f32; 3]>, Vec<[f32; 2]>, Vec<u32>) {
    let mut positions = Vec::with_capacity((n + 1) * (n + 1));
    let mut uvs = Vec::with_capacity((n + 1) * (n + 1));
    for k in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f32 / n as f32, k as f32 / n as f32);
            let x = -PANEL_HALF + 2.0 * PANEL_HALF * u;
            let z = -PANEL_HALF + 2.0 * PANEL_HALF * v;
            positions.push([x, PANEL_HEIGHT, z]);
            uvs.push([u, v]);
        }
    }
    let at = |i: usize, k: usize| u32::try_from(k * (n + 1) + i).expect("panel too large");
    let mut indices = Vec::with_capacity(6 * n * n);
    for k in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (at(i, k), at(i + 1, k), at(i + 1, k + 1), at(i, k + 1));
            // (+x) × (+z) = −y: counter-clockwise seen from below.
            indices.extend([a, b, c, a, c, d]);
        }
    }
    (positions, uvs, indices)
}

/// A `TEXTURE_SIZE`² RGB image, black but for `SPOTS` discs of radius 1.5 to
/// 4 texels in saturated warm and cool whites (sRGB codes up to 255).
fn spots_png(rng: &mut Pcg32) -> Vec<u8> {
    const COLOURS: [[u8; 3]; 3] = [[255, 240, 210], [210, 230, 255], [255, 180, 90]];
    let size = TEXTURE_SIZE;
    let mut texels = vec![0u8; size * size * 3];
    for _ in 0..SPOTS {
        let (cx, cy) = (uniform(rng, 6.0, 58.0), uniform(rng, 6.0, 58.0));
        let radius = uniform(rng, 1.5, 4.0);
        let colour = COLOURS[below(rng, COLOURS.len())];
        for y in 0..size {
            for x in 0..size {
                let (dx, dy) = (x as f32 + 0.5 - cx, y as f32 + 0.5 - cy);
                if dx * dx + dy * dy <= radius * radius {
                    texels[3 * (y * size + x)..][..3].copy_from_slice(&colour);
                }
            }
        }
    }
    encode_rgb8_png(size, &texels)
}

/// An 8 × 8 checker of two greys (sRGB codes 230 and 60), 2 × 2 squares.
fn checker_png() -> Vec<u8> {
    let texels: Vec<u8> = (0..64)
        .flat_map(|i| {
            let (x, y) = (i % 8 / 2, i / 8 / 2);
            [if (x + y) % 2 == 0 { 230 } else { 60 }; 3]
        })
        .collect();
    encode_rgb8_png(8, &texels)
}

/// A square 8-bit RGB PNG of side `size` in memory (sRGB, as glTF expects
/// of colour textures).
fn encode_rgb8_png(size: usize, texels: &[u8]) -> Vec<u8> {
    let side = u32::try_from(size).expect("texture side fits in u32");
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, side, side);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .expect("writing to memory cannot fail");
    writer
        .write_image_data(texels)
        .expect("the texel count matches the header");
    writer.finish().expect("writing to memory cannot fail");
    out
}
