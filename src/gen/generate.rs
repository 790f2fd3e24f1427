//! Procedural test scenes built with [`GltfBuilder`].
//!
//! * [`cornell`]: a Cornell-like box lit by one small one-sided area light;
//!   [`cornell_split`] cuts that light into many triangles of varied radiance.
//! * [`many_lights`]: a night town with thousands of small emissive quads
//!   (windows, street lamps, floating neon strips) hidden behind buildings,
//!   for benchmarking light selection.
//! * [`city`], [`grid`], [`extremes()`], [`textured`]: one file each, see there.
//!
//! Every generator is a pure function of its arguments: same arguments, same bytes.

mod city;
pub mod extremes;
mod grid;
mod textured;
mod town;

pub use city::{city, CITY_MAX_LIGHTS};
pub use extremes::extremes;
pub use grid::{grid, grid_side};
pub use textured::{textured, textured_side};
pub use town::many_lights;

use std::collections::BTreeMap;

use glam::{Mat4, Quat, Vec3};
use rand_core::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use super::gltf_write::{look_at_rotation, GltfBuilder, GltfMaterial, NodeTransform};
use super::mesh::{add_object, QuadMesh};

/// Builds a 2 m Cornell-like box: floor at y = 0, ceiling at y = 2, walls at
/// x = ±1 (red left, green right), back wall at z = −1, open towards +z where
/// the camera stands, two rotated boxes, and one downward-facing emissive
/// quad just below the ceiling.
pub fn cornell() -> GltfBuilder {
    cornell_with(None)
}

/// The Cornell box of [`cornell`] with its ceiling light cut into exactly
/// `triangles` (≥ 2) triangles, each with its own radiance: 15 × [1, 0.85, 0.6]
/// times a factor drawn log-uniformly from 0.1 to 10 (over [`SPLIT_LEVELS`]
/// shared materials). The rest of the scene is byte for byte that of [`cornell`].
pub fn cornell_split(triangles: usize, seed: u64) -> GltfBuilder {
    assert!(triangles >= 2, "the split light needs at least 2 triangles");
    cornell_with(Some((triangles, seed)))
}

/// Number of radiance levels of [`cornell_split`]'s light.
pub const SPLIT_LEVELS: usize = 16;

/// The box with a single ceiling quad (`None`) or with the quad cut into
/// `(triangles, seed)`.
fn cornell_with(split: Option<(usize, u64)>) -> GltfBuilder {
    let mut b = GltfBuilder::new();
    let white = b.add_material(matte("white", [0.73; 3]));
    let red = b.add_material(matte("red", [0.63, 0.065, 0.05]));
    let green = b.add_material(matte("green", [0.14, 0.45, 0.091]));
    let glossy = b.add_material(GltfMaterial {
        roughness: 0.3,
        ..matte("glossy white", [0.73; 3])
    });
    let lamp_material = |name: String, strength: f32| GltfMaterial {
        emissive: [1.0, 0.85, 0.6],
        emissive_strength: strength,
        ..matte(&name, [0.78; 3])
    };

    let mut walls = QuadMesh::default();
    walls.quad(Vec3::ZERO, Vec3::Z, Vec3::X); // floor, faces +y
    walls.quad(Vec3::new(0.0, 2.0, 0.0), Vec3::X, Vec3::Z); // ceiling, faces −y
    walls.quad(Vec3::new(0.0, 1.0, -1.0), Vec3::X, Vec3::Y); // back, faces +z
    add_object(
        &mut b,
        "white walls",
        &walls,
        white,
        NodeTransform::Identity,
    );
    let mut left = QuadMesh::default();
    left.quad(Vec3::new(-1.0, 1.0, 0.0), Vec3::Y, Vec3::Z); // faces +x
    add_object(&mut b, "red wall", &left, red, NodeTransform::Identity);
    let mut right = QuadMesh::default();
    right.quad(Vec3::new(1.0, 1.0, 0.0), Vec3::Z, Vec3::Y); // faces −x
    add_object(&mut b, "green wall", &right, green, NodeTransform::Identity);

    let boxes = b.add_node("boxes", None, None, NodeTransform::Identity);
    let short = cornell_box(&mut b, "short box", white, [0.35, 0.0, 0.3], -0.3, 0.6);
    let tall = cornell_box(&mut b, "tall box", glossy, [-0.35, 0.0, -0.35], 0.3, 1.2);
    b.add_child(boxes, short);
    b.add_child(boxes, tall);

    // The light is modelled at the origin and lifted by a matrix transform.
    let lift =
        NodeTransform::Matrix(Mat4::from_translation(Vec3::new(0.0, 1.999, 0.0)).to_cols_array());
    let (half_x, half_z) = (0.25, 0.2); // 0.5 × 0.4 m, faces −y
    match split {
        None => {
            // Added here, it is still material 4 (materials are numbered in order of addition).
            let lamp = b.add_material(lamp_material("ceiling light".into(), 15.0));
            let mut light = QuadMesh::default();
            light.quad(Vec3::ZERO, Vec3::X * half_x, Vec3::Z * half_z);
            add_object(&mut b, "ceiling light", &light, lamp, lift);
        }
        Some((triangles, seed)) => {
            let mut rng = Pcg32::seed_from_u64(seed);
            let mut levels: BTreeMap<usize, QuadMesh> = BTreeMap::new();
            for tri in split_rectangle(half_x, half_z, triangles) {
                levels
                    .entry(below(&mut rng, SPLIT_LEVELS))
                    .or_default()
                    .triangle(tri);
            }
            let parent = b.add_node("ceiling light", None, None, lift);
            for (level, mesh) in &levels {
                let factor = 10f32.powf(-1.0 + 2.0 * *level as f32 / (SPLIT_LEVELS - 1) as f32);
                let name = format!("ceiling light L{level:02}");
                let m = b.add_material(lamp_material(name.clone(), 15.0 * factor));
                let mesh_index = b.add_mesh(&name, &mesh.positions, None, None, m);
                let node = b.add_node(&name, Some(mesh_index), None, NodeTransform::Identity);
                b.add_child(parent, node);
            }
        }
    }

    add_camera(&mut b, [0.0, 1.0, 3.4], [0.0, 1.0, 0.0], 40.0);
    b
}

/// Cuts the rectangle [−hx, hx] × [−hz, hz] in the y = 0 plane into exactly
/// `count` (≥ 2) triangles facing −y: rows along z, each row a zigzag strip
/// between its two edges, cut at evenly spaced points.
fn split_rectangle(hx: f32, hz: f32, count: usize) -> Vec<[Vec3; 3]> {
    let rows = ((count as f32 * hz / (2.0 * hx)).sqrt().round() as usize).clamp(1, count / 2);
    let mut out = Vec::with_capacity(count);
    for r in 0..rows {
        let in_row = count * (r + 1) / rows - count * r / rows;
        let z0 = -hz + 2.0 * hz * r as f32 / rows as f32;
        let z1 = -hz + 2.0 * hz * (r + 1) as f32 / rows as f32;
        let (bottom, top) = (in_row.div_ceil(2), in_row / 2);
        let at =
            |k: usize, of: usize, z: f32| Vec3::new(-hx + 2.0 * hx * k as f32 / of as f32, 0.0, z);
        let (mut i, mut j) = (0, 0);
        while i < bottom || j < top {
            let advance_bottom = j == top
                || (i < bottom && (i + 1) as f32 / bottom as f32 <= (j + 1) as f32 / top as f32);
            let tri = if advance_bottom {
                i += 1;
                [at(i - 1, bottom, z0), at(i, bottom, z0), at(j, top, z1)]
            } else {
                j += 1;
                [at(i, bottom, z0), at(j, top, z1), at(j - 1, top, z1)]
            };
            out.push(facing(tri, Vec3::NEG_Y));
        }
    }
    out
}

/// The triangle, its last two corners swapped if needed so that its
/// counter-clockwise front face looks along `normal`.
fn facing([a, b, c]: [Vec3; 3], normal: Vec3) -> [Vec3; 3] {
    if (b - a).cross(c - a).dot(normal) >= 0.0 {
        [a, b, c]
    } else {
        [a, c, b]
    }
}

/// A one-sided rough dielectric of the given colour.
fn matte(name: &str, base_color: [f32; 3]) -> GltfMaterial {
    GltfMaterial {
        name: name.to_owned(),
        base_color,
        roughness: 0.8,
        ..GltfMaterial::default()
    }
}

/// Adds a closed box standing on the floor at `position`, rotated by
/// `angle` radians about +y, 0.6 m wide and `height` tall, as a scaled
/// unit cube; returns its node.
fn cornell_box(
    b: &mut GltfBuilder,
    name: &str,
    material: usize,
    position: [f32; 3],
    angle: f32,
    height: f32,
) -> usize {
    let mut cube = QuadMesh::default();
    cube.cuboid(Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5));
    let transform = NodeTransform::Trs {
        translation: position,
        rotation: Quat::from_rotation_y(angle).to_array(),
        scale: [0.6, height, 0.6],
    };
    add_object(b, name, &cube, material, transform)
}

/// Adds a square-aspect perspective camera at `eye` looking at `target`.
fn add_camera(b: &mut GltfBuilder, eye: [f32; 3], target: [f32; 3], yfov_degrees: f32) {
    add_camera_with_aspect(b, eye, target, yfov_degrees, 1.0);
}

/// Adds a perspective camera of aspect ratio `aspect` (width / height) at
/// `eye` looking at `target`.
fn add_camera_with_aspect(
    b: &mut GltfBuilder,
    eye: [f32; 3],
    target: [f32; 3],
    yfov_degrees: f32,
    aspect: f32,
) {
    let camera = b.add_perspective_camera("camera", yfov_degrees.to_radians(), Some(aspect), 0.01);
    let transform = NodeTransform::Trs {
        translation: eye,
        rotation: look_at_rotation(eye, target, [0.0, 1.0, 0.0]),
        scale: [1.0; 3],
    };
    b.add_node("camera", None, Some(camera), transform);
}

/// Uniform `f32` in [0, 1) from the top 24 bits of a `u32`.
fn unit(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Uniform `f32` in [lo, hi).
fn uniform(rng: &mut Pcg32, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * unit(rng)
}

/// Uniform integer in 0..n (n > 0), by multiply-shift.
fn below(rng: &mut Pcg32, n: usize) -> usize {
    ((u64::from(rng.next_u32()) * n as u64) >> 32) as usize
}

/// Index into `weights` chosen with probability proportional to its weight.
fn weighted(rng: &mut Pcg32, weights: &[u32]) -> usize {
    let mut ticket = below(rng, weights.iter().sum::<u32>() as usize) as u32;
    for (i, &w) in weights.iter().enumerate() {
        if ticket < w {
            return i;
        }
        ticket -= w;
    }
    unreachable!("ticket below the weight sum")
}

#[cfg(test)]
mod tests {
    use super::super::gltf_write::tests::{assert_matches, round_trip};
    use super::*;

    /// One triangle of a loaded scene in world space.
    pub(super) struct Triangle {
        pub(super) material: usize,
        pub(super) mesh_name: String,
        corners: [Vec3; 3],
        normals: Option<[Vec3; 3]>,
    }

    impl Triangle {
        /// The unit geometric normal `(v1 − v0) × (v2 − v0)`.
        fn geometric_normal(&self) -> Vec3 {
            let [a, b, c] = self.corners;
            (b - a).cross(c - a).normalize()
        }

        pub(super) fn centroid(&self) -> Vec3 {
            (self.corners[0] + self.corners[1] + self.corners[2]) / 3.0
        }
    }

    /// All triangles of the default scene, transformed to world space.
    pub(super) fn world_triangles(doc: &gltf::Document, blob: &[u8]) -> Vec<Triangle> {
        let mut out = Vec::new();
        let mut stack: Vec<(gltf::Node, Mat4)> = doc
            .default_scene()
            .unwrap()
            .nodes()
            .map(|n| (n, Mat4::IDENTITY))
            .collect();
        while let Some((node, parent)) = stack.pop() {
            let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
            stack.extend(node.children().map(|c| (c, world)));
            let Some(mesh) = node.mesh() else { continue };
            let normal_matrix = glam::Mat3::from_mat4(world).inverse().transpose();
            for prim in mesh.primitives() {
                let reader = prim.reader(|_| Some(blob));
                let pos: Vec<Vec3> = reader
                    .read_positions()
                    .unwrap()
                    .map(|p| world.transform_point3(p.into()))
                    .collect();
                let nor: Option<Vec<Vec3>> = reader.read_normals().map(|n| {
                    n.map(|n| (normal_matrix * Vec3::from(n)).normalize())
                        .collect()
                });
                let idx: Vec<usize> = match reader.read_indices() {
                    Some(i) => i.into_u32().map(|i| i as usize).collect(),
                    None => (0..pos.len()).collect(),
                };
                for t in idx.chunks(3) {
                    out.push(Triangle {
                        material: prim.material().index().unwrap(),
                        mesh_name: mesh.name().unwrap().to_owned(),
                        corners: [pos[t[0]], pos[t[1]], pos[t[2]]],
                        normals: nor.as_ref().map(|n| [n[t[0]], n[t[1]], n[t[2]]]),
                    });
                }
            }
        }
        out
    }

    /// Emitted radiance scale (max colour component × strength) per material.
    pub(super) fn radiances(doc: &gltf::Document) -> Vec<f32> {
        doc.materials()
            .map(|m| {
                let e = m.emissive_factor();
                e[0].max(e[1]).max(e[2]) * m.emissive_strength().unwrap_or(1.0)
            })
            .collect()
    }

    /// Vertex normals, where present, agree with the winding.
    fn assert_normals_match_winding(tris: &[Triangle]) {
        for t in tris {
            for n in t.normals.iter().flatten() {
                assert!(n.dot(t.geometric_normal()) > 0.999, "{}", t.mesh_name);
            }
        }
    }

    #[test]
    fn cornell_round_trips() {
        let b = cornell();
        for ext in ["glb", "gltf"] {
            let (doc, blob) = round_trip(&b, ext);
            assert_matches(&b, &doc, &blob);
            assert_eq!(
                (
                    doc.meshes().len(),
                    doc.materials().len(),
                    doc.cameras().len()
                ),
                (6, 5, 1)
            );
        }
    }

    #[test]
    fn cornell_has_one_downward_emitter_and_inward_walls() {
        let (doc, blob) = round_trip(&cornell(), "glb");
        let radiance = radiances(&doc);
        let tris = world_triangles(&doc, &blob);
        assert_normals_match_winding(&tris);
        let emitters: Vec<&Triangle> = tris.iter().filter(|t| radiance[t.material] > 0.0).collect();
        assert_eq!(emitters.len(), 2);
        for t in emitters {
            assert!(t.geometric_normal().distance(Vec3::NEG_Y) < 1e-6);
            assert!(t.corners.iter().all(|c| (c.y - 1.999).abs() < 1e-6));
            assert!(t
                .corners
                .iter()
                .all(|c| c.x.abs() <= 0.25 && c.z.abs() <= 0.2));
            assert!(!doc.materials().nth(t.material).unwrap().double_sided());
        }
        let walls = tris.iter().filter(|t| t.mesh_name.contains("wall"));
        let room_centre = Vec3::new(0.0, 1.0, 0.0);
        for t in walls {
            assert!(
                t.geometric_normal().dot(room_centre - t.centroid()) > 0.0,
                "{}",
                t.mesh_name
            );
        }
        let boxes = tris.iter().filter(|t| t.mesh_name.contains("box"));
        for c in boxes.flat_map(|t| t.corners) {
            assert!(
                c.x.abs() < 1.0 && c.z.abs() < 1.0 && (0.0..=1.2001).contains(&c.y),
                "{c}"
            );
        }
    }

    #[test]
    fn generators_are_deterministic() {
        assert_eq!(cornell().to_glb_bytes(), cornell().to_glb_bytes());
        let town = many_lights(7, 12_000).to_glb_bytes();
        assert_eq!(town, many_lights(7, 12_000).to_glb_bytes());
        assert_ne!(town, many_lights(8, 12_000).to_glb_bytes());
    }

    #[test]
    fn many_lights_round_trips_with_wide_radiance_range() {
        let b = many_lights(1, 12_000);
        let (doc, blob) = round_trip(&b, "glb");
        assert_matches(&b, &doc, &blob);
        assert!(doc.materials().len() <= 150);
        assert!(b.to_glb_bytes().len() < 3_000_000);

        let radiance = radiances(&doc);
        let tris = world_triangles(&doc, &blob);
        assert_normals_match_winding(&tris);
        let lit: Vec<f32> = tris
            .iter()
            .map(|t| radiance[t.material])
            .filter(|&r| r > 0.0)
            .collect();
        assert!(
            (10_000..=14_000).contains(&lit.len()),
            "{} emissive triangles",
            lit.len()
        );
        let max = lit.iter().copied().fold(0.0, f32::max);
        let min = lit.iter().copied().fold(f32::INFINITY, f32::min);
        assert!(max / min >= 1e5, "radiance range {min} .. {max}");
        let two_sided = doc.materials().filter(|m| m.double_sided()).count();
        assert!(two_sided > 0 && two_sided < doc.materials().len());
    }

    #[test]
    fn small_and_odd_light_targets_work() {
        for target in [0, 1, 7, 301] {
            let b = many_lights(5, target);
            let (doc, blob) = round_trip(&b, "glb");
            let radiance = radiances(&doc);
            let lit = world_triangles(&doc, &blob)
                .iter()
                .filter(|t| radiance[t.material] > 0.0)
                .count();
            assert_eq!(lit, target.div_ceil(2) * 2);
        }
    }
}
