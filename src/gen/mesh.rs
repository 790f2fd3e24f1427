//! Indexed triangle meshes with flat normals for the generators: quads, triangles and boxes,
//! and the node that shows one in a glTF file.

use glam::Vec3;

use super::gltf_write::{GltfBuilder, NodeTransform};

/// Indexed quads with flat per-vertex normals.
#[derive(Default)]
pub(super) struct QuadMesh {
    pub(super) positions: Vec<[f32; 3]>,
    pub(super) normals: Vec<[f32; 3]>,
    pub(super) indices: Vec<u32>,
}

impl QuadMesh {
    /// Adds the quad centred at `c` with half-edge vectors `u` and `v`; its
    /// front face (counter-clockwise winding) faces along `u × v`.
    pub(super) fn quad(&mut self, c: Vec3, u: Vec3, v: Vec3) {
        let base = u32::try_from(self.positions.len()).expect("mesh too large");
        let n = u.cross(v).normalize().to_array();
        for p in [c - u - v, c + u - v, c + u + v, c - u + v] {
            self.positions.push(p.to_array());
            self.normals.push(n);
        }
        self.indices.extend([0, 1, 2, 0, 2, 3].map(|k| base + k));
    }

    /// Adds one triangle (front face by its winding) as three new vertices.
    pub(super) fn triangle(&mut self, corners: [Vec3; 3]) {
        let base = u32::try_from(self.positions.len()).expect("mesh too large");
        let n = geometric_normal_of(corners).to_array();
        for p in corners {
            self.positions.push(p.to_array());
            self.normals.push(n);
        }
        self.indices.extend([base, base + 1, base + 2]);
    }

    /// Adds an axis-aligned closed box with outward-facing quads.
    pub(super) fn cuboid(&mut self, min: Vec3, max: Vec3) {
        let centre = (min + max) * 0.5;
        let half = (max - min) * 0.5;
        let axis = |k: usize| Vec3::AXES[k] * half[k];
        for a in 0..3 {
            // e_b × e_c = e_a for the cyclic successors b and c of a.
            let (u, v) = (axis((a + 1) % 3), axis((a + 2) % 3));
            self.quad(centre + axis(a), u, v);
            self.quad(centre - axis(a), v, u);
        }
    }

    /// The triangles as a non-indexed vertex list.
    pub(super) fn triangle_soup(&self) -> Vec<[f32; 3]> {
        self.indices
            .iter()
            .map(|&i| self.positions[i as usize])
            .collect()
    }
}

/// Adds a mesh with normals and indices plus a node showing it; returns the node.
pub(super) fn add_object(
    b: &mut GltfBuilder,
    name: &str,
    mesh: &QuadMesh,
    material: usize,
    transform: NodeTransform,
) -> usize {
    let m = b.add_mesh(
        name,
        &mesh.positions,
        Some(&mesh.normals),
        Some(&mesh.indices),
        material,
    );
    b.add_node(name, Some(m), None, transform)
}

/// The unit normal of the counter-clockwise front face.
fn geometric_normal_of([a, b, c]: [Vec3; 3]) -> Vec3 {
    (b - a).cross(c - a).normalize()
}
