//! `grid`: n × n equal, equally bright, one-sided emissive squares in a
//! horizontal plane 3 m above a diffuse floor, facing down. Every light has
//! the same power, so power selection equals uniform selection (p_l = 1/L):
//! the case where the uniform selector is already as good as power.

use glam::Vec3;

use super::super::gltf_write::{GltfBuilder, GltfMaterial, NodeTransform};
use super::{add_camera, add_object, matte, QuadMesh};

/// Side of the square the light grid covers, metres.
const EXTENT: f32 = 10.0;
/// Fraction of each cell's side its light covers (the rest is a gap).
const FILL: f32 = 0.8;
/// Height of the light plane above the floor, metres.
const HEIGHT: f32 = 3.0;

/// The n of an n × n grid of quads with `lights` = 2·n² emissive triangles,
/// or None when `lights` has no such form.
pub fn grid_side(lights: usize) -> Option<usize> {
    let n = ((lights / 2) as f64).sqrt().round() as usize;
    (n > 0 && 2 * n * n == lights).then_some(n)
}

/// n × n light squares of radiance 1 (total emitting area 64 m² whatever n),
/// over a 14 m floor of albedo 0.5, seen from a camera below the lights.
pub fn grid(n: usize) -> GltfBuilder {
    assert!(n > 0, "the grid needs at least one quad");
    let mut b = GltfBuilder::new();
    let floor_material = b.add_material(matte("floor", [0.5; 3]));
    let mut floor = QuadMesh::default();
    floor.quad(Vec3::ZERO, Vec3::Z * 7.0, Vec3::X * 7.0); // faces +y
    add_object(
        &mut b,
        "floor",
        &floor,
        floor_material,
        NodeTransform::Identity,
    );

    let light = b.add_material(GltfMaterial {
        name: "grid light".into(),
        base_color: [0.0; 3],
        emissive: [1.0; 3],
        ..GltfMaterial::default()
    });
    let pitch = EXTENT / n as f32;
    let half = 0.5 * FILL * pitch;
    let mut lights = QuadMesh::default();
    for i in 0..n {
        for k in 0..n {
            let at = |c: usize| -0.5 * EXTENT + (c as f32 + 0.5) * pitch;
            let centre = Vec3::new(at(i), HEIGHT, at(k));
            lights.quad(centre, Vec3::X * half, Vec3::Z * half); // faces −y
        }
    }
    add_object(
        &mut b,
        "grid lights",
        &lights,
        light,
        NodeTransform::Identity,
    );
    add_camera(&mut b, [0.0, 1.6, 9.0], [0.0, 0.8, 0.0], 60.0);
    b
}
