//! A minimal, deterministic glTF 2.0 writer.
//!
//! [`GltfBuilder`] collects materials, PNG textures, triangle meshes,
//! perspective cameras and a node hierarchy, and writes them either as one
//! binary `.glb` file or as a `.gltf` JSON file whose single buffer is
//! embedded as a base64 data URI (images live in that buffer too, behind
//! buffer views). The same inputs always produce the same bytes.

use std::io::Write;
use std::path::Path;

use anyhow::bail;
use base64::Engine;
use glam::{Mat3, Quat, Vec3};
use serde_json::{json, Map, Value};

use crate::image::write_atomically;

mod json;
use json::*;

/// Name of the extension used for emissive strengths other than 1.
const EMISSIVE_STRENGTH_EXT: &str = "KHR_materials_emissive_strength";
/// Name of the extension used for specular factors other than 1.
const SPECULAR_EXT: &str = "KHR_materials_specular";

/// glTF component type and buffer-view target codes.
const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const MODE_TRIANGLES: u32 = 4;
/// Sampler filter and wrap codes.
const NEAREST: u32 = 9728;
const LINEAR: u32 = 9729;
const CLAMP_TO_EDGE: u32 = 33071;
const REPEAT: u32 = 10497;

/// GLB container constants.
const GLB_MAGIC: u32 = 0x4654_6C67;
const GLB_VERSION: u32 = 2;
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// A metallic-roughness material with an optional emission.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfMaterial {
    /// Material name.
    pub name: String,
    /// Linear RGB base colour; alpha is always 1.
    pub base_color: [f32; 3],
    /// Metallic factor in [0, 1].
    pub metallic: f32,
    /// Roughness factor in [0, 1].
    pub roughness: f32,
    /// `emissiveFactor`, each component in [0, 1].
    pub emissive: [f32; 3],
    /// Multiplier on `emissive`; written as `KHR_materials_emissive_strength`
    /// when it is not 1.
    pub emissive_strength: f32,
    /// Whether both sides of each triangle are rendered (and emit).
    pub double_sided: bool,
    /// `KHR_materials_specular` `specularFactor` in [0, 1] (0 leaves a pure
    /// Lambertian surface); written only when it is not 1.
    pub specular: f32,
    /// `emissiveTexture` (a texture index, sRGB, multiplied by `emissive`).
    pub emissive_texture: Option<usize>,
    /// `baseColorTexture` (a texture index, sRGB, multiplied by `base_color`).
    pub base_color_texture: Option<usize>,
}

impl Default for GltfMaterial {
    /// A white, rough, non-emissive, one-sided dielectric.
    fn default() -> Self {
        Self {
            name: String::new(),
            base_color: [1.0; 3],
            metallic: 0.0,
            roughness: 1.0,
            emissive: [0.0; 3],
            emissive_strength: 1.0,
            double_sided: false,
            specular: 1.0,
            emissive_texture: None,
            base_color_texture: None,
        }
    }
}

/// How a texture is sampled: filtering and wrapping on both axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureSampling {
    /// Nearest texel, coordinates clamped to the edge (exact texel footprints).
    NearestClamp,
    /// Bilinear, repeating (tiled patterns).
    LinearRepeat,
}

/// The local transform of a node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NodeTransform {
    /// No transform.
    Identity,
    /// Translation, rotation (unit quaternion, `[x, y, z, w]`) and scale,
    /// applied as `T * R * S`.
    Trs {
        /// Translation.
        translation: [f32; 3],
        /// Rotation quaternion `[x, y, z, w]`.
        rotation: [f32; 4],
        /// Per-axis scale.
        scale: [f32; 3],
    },
    /// A 4×4 affine matrix in column-major order.
    Matrix([f32; 16]),
}

impl NodeTransform {
    /// The glTF node properties that hold it, with their numbers: none for the identity,
    /// `translation`, `rotation` and `scale`, or `matrix`.
    fn properties(&self) -> Vec<(&'static str, &[f32])> {
        match self {
            NodeTransform::Identity => Vec::new(),
            NodeTransform::Trs {
                translation,
                rotation,
                scale,
            } => vec![
                ("translation", translation),
                ("rotation", rotation),
                ("scale", scale),
            ],
            NodeTransform::Matrix(m) => vec![("matrix", m)],
        }
    }
}

/// Stored data of one single-primitive triangle mesh.
#[derive(Clone, Debug)]
struct MeshData {
    name: String,
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    uvs: Option<Vec<[f32; 2]>>,
    indices: Option<Vec<u32>>,
    material: usize,
}

/// Stored data of one texture: its PNG image and how it is sampled.
#[derive(Clone, Debug)]
struct TextureData {
    name: String,
    png: Vec<u8>,
    sampling: TextureSampling,
}

/// Stored data of one node.
#[derive(Clone, Debug)]
struct NodeData {
    name: String,
    mesh: Option<usize>,
    camera: Option<usize>,
    transform: NodeTransform,
    children: Vec<usize>,
    parent: Option<usize>,
}

/// Stored data of one perspective camera.
#[derive(Clone, Debug)]
struct CameraData {
    name: String,
    yfov: f32,
    aspect_ratio: Option<f32>,
    znear: f32,
}

/// Collects a glTF scene and writes it as `.glb` or `.gltf`.
///
/// Indices returned by the `add_*` methods refer to the element in its
/// glTF array and are what the other methods expect. Invalid arguments
/// (out-of-range indices, non-finite numbers, malformed meshes) are
/// programming errors and panic.
#[derive(Clone, Debug, Default)]
pub struct GltfBuilder {
    materials: Vec<GltfMaterial>,
    meshes: Vec<MeshData>,
    nodes: Vec<NodeData>,
    cameras: Vec<CameraData>,
    textures: Vec<TextureData>,
}

impl GltfBuilder {
    /// Creates an empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its index.
    ///
    /// # Panics
    /// If a factor is non-finite or outside its valid range, or a texture
    /// does not exist.
    pub fn add_material(&mut self, material: GltfMaterial) -> usize {
        let m = &material;
        let unit =
            m.base_color
                .iter()
                .chain(&m.emissive)
                .chain([&m.metallic, &m.roughness, &m.specular]);
        for &v in unit {
            assert!(
                (0.0..=1.0).contains(&v),
                "material {:?}: factor {v} not in [0, 1]",
                m.name
            );
        }
        assert!(
            m.emissive_strength.is_finite() && m.emissive_strength >= 0.0,
            "material {:?}: invalid emissive strength {}",
            m.name,
            m.emissive_strength
        );
        for texture in [m.emissive_texture, m.base_color_texture]
            .into_iter()
            .flatten()
        {
            assert!(
                texture < self.textures.len(),
                "material {:?}: no texture {texture}",
                m.name
            );
        }
        self.materials.push(material);
        self.materials.len() - 1
    }

    /// Adds a texture showing the PNG image `png` (stored in the binary
    /// buffer) and returns its index.
    ///
    /// # Panics
    /// If `png` does not start with the PNG signature.
    pub fn add_png_texture(
        &mut self,
        name: &str,
        png: Vec<u8>,
        sampling: TextureSampling,
    ) -> usize {
        assert!(
            png.starts_with(b"\x89PNG\r\n\x1a\n"),
            "texture {name:?}: not a PNG image"
        );
        self.textures.push(TextureData {
            name: name.to_owned(),
            png,
            sampling,
        });
        self.textures.len() - 1
    }

    /// Adds a mesh with one triangle-list primitive and returns its index.
    ///
    /// Without `indices`, consecutive vertex triples form the triangles.
    ///
    /// # Panics
    /// If `positions` is empty or not finite, `normals` has a different
    /// length, an index is out of range, the triangle count is fractional,
    /// or `material` does not exist.
    pub fn add_mesh(
        &mut self,
        name: &str,
        positions: &[[f32; 3]],
        normals: Option<&[[f32; 3]]>,
        indices: Option<&[u32]>,
        material: usize,
    ) -> usize {
        self.add_mesh_with_uvs(name, positions, normals, None, indices, material)
    }

    /// [`GltfBuilder::add_mesh`] with optional per-vertex texture
    /// coordinates (`TEXCOORD_0`).
    ///
    /// # Panics
    /// As [`GltfBuilder::add_mesh`], and if `uvs` has a different length
    /// than `positions` or is not finite.
    pub fn add_mesh_with_uvs(
        &mut self,
        name: &str,
        positions: &[[f32; 3]],
        normals: Option<&[[f32; 3]]>,
        uvs: Option<&[[f32; 2]]>,
        indices: Option<&[u32]>,
        material: usize,
    ) -> usize {
        assert!(!positions.is_empty(), "mesh {name:?}: no positions");
        if let Some(uv) = uvs {
            assert_eq!(uv.len(), positions.len(), "mesh {name:?}: uv count");
            assert_finite(uv.iter().flatten(), name);
        }
        assert_finite(positions.iter().flatten(), name);
        if let Some(n) = normals {
            assert_eq!(n.len(), positions.len(), "mesh {name:?}: normal count");
            assert_finite(n.iter().flatten(), name);
        }
        let corner_count = indices.map_or(positions.len(), <[u32]>::len);
        assert!(
            corner_count > 0 && corner_count.is_multiple_of(3),
            "mesh {name:?}: not a triangle list"
        );
        if let Some(idx) = indices {
            assert!(
                idx.iter().all(|&i| (i as usize) < positions.len()),
                "mesh {name:?}: index out of range"
            );
        }
        assert!(
            material < self.materials.len(),
            "mesh {name:?}: no material {material}"
        );
        self.meshes.push(MeshData {
            name: name.to_owned(),
            positions: positions.to_vec(),
            normals: normals.map(<[_]>::to_vec),
            uvs: uvs.map(<[_]>::to_vec),
            indices: indices.map(<[_]>::to_vec),
            material,
        });
        self.meshes.len() - 1
    }

    /// Adds a perspective camera (infinite far plane) and returns its index.
    ///
    /// # Panics
    /// If `yfov_radians`, `aspect_ratio` or `znear` is not positive and finite.
    pub fn add_perspective_camera(
        &mut self,
        name: &str,
        yfov_radians: f32,
        aspect_ratio: Option<f32>,
        znear: f32,
    ) -> usize {
        for v in [Some(yfov_radians), aspect_ratio, Some(znear)]
            .into_iter()
            .flatten()
        {
            assert!(
                v.is_finite() && v > 0.0,
                "camera {name:?}: invalid parameter {v}"
            );
        }
        self.cameras.push(CameraData {
            name: name.to_owned(),
            yfov: yfov_radians,
            aspect_ratio,
            znear,
        });
        self.cameras.len() - 1
    }

    /// Adds a node and returns its index. Nodes that never become a child
    /// (see [`GltfBuilder::add_child`]) are roots of the default scene.
    ///
    /// # Panics
    /// If `mesh` or `camera` does not exist or `transform` is not finite.
    pub fn add_node(
        &mut self,
        name: &str,
        mesh: Option<usize>,
        camera: Option<usize>,
        transform: NodeTransform,
    ) -> usize {
        assert!(
            mesh.is_none_or(|m| m < self.meshes.len()),
            "node {name:?}: no such mesh"
        );
        assert!(
            camera.is_none_or(|c| c < self.cameras.len()),
            "node {name:?}: no such camera"
        );
        let numbers = transform.properties().into_iter().flat_map(|(_, v)| v);
        assert_finite(numbers, name);
        self.nodes.push(NodeData {
            name: name.to_owned(),
            mesh,
            camera,
            transform,
            children: Vec::new(),
            parent: None,
        });
        self.nodes.len() - 1
    }

    /// Makes node `child` a child of node `parent`.
    ///
    /// # Panics
    /// If either node does not exist, `child` already has a parent, or the
    /// link would create a cycle.
    pub fn add_child(&mut self, parent: usize, child: usize) {
        assert!(
            parent < self.nodes.len() && child < self.nodes.len(),
            "no such node"
        );
        assert!(
            self.nodes[child].parent.is_none(),
            "node {child} already has a parent"
        );
        let mut ancestor = Some(parent);
        while let Some(a) = ancestor {
            assert!(
                a != child,
                "linking node {child} under {parent} creates a cycle"
            );
            ancestor = self.nodes[a].parent;
        }
        self.nodes[child].parent = Some(parent);
        self.nodes[parent].children.push(child);
    }

    /// Writes the scene to `path`: binary glTF for a `.glb` extension, JSON
    /// with an embedded base64 buffer for `.gltf`. The file is written to a
    /// temporary sibling first and then renamed into place.
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        let bytes = if ext.eq_ignore_ascii_case("glb") {
            self.to_glb_bytes()
        } else if ext.eq_ignore_ascii_case("gltf") {
            self.to_gltf_bytes()
        } else {
            bail!(
                "{}: unsupported extension (expected .glb or .gltf)",
                path.display()
            );
        };
        write_atomically(path, |out| Ok(out.write_all(&bytes)?))
    }

    /// Returns the scene as a binary glTF (GLB) file.
    ///
    /// # Panics
    /// If the file would exceed the 4 GiB limit of the GLB format.
    pub fn to_glb_bytes(&self) -> Vec<u8> {
        let (mut doc, bin) = self.document();
        if !bin.is_empty() {
            doc["buffers"] = json!([{ "byteLength": bin.len() }]);
        }
        let json = serde_json::to_vec(&doc).expect("a JSON value always serialises");
        let json_chunk = padded(json, b' ');
        let bin_chunk = padded(bin, 0);
        let mut total = 12 + 8 + json_chunk.len();
        if !bin_chunk.is_empty() {
            total += 8 + bin_chunk.len();
        }
        let mut out = Vec::with_capacity(total);
        for word in [GLB_MAGIC, GLB_VERSION, u32_len(total)] {
            out.extend_from_slice(&word.to_le_bytes());
        }
        push_chunk(&mut out, CHUNK_JSON, &json_chunk);
        if !bin_chunk.is_empty() {
            push_chunk(&mut out, CHUNK_BIN, &bin_chunk);
        }
        out
    }

    /// Returns the scene as `.gltf` JSON with the buffer as a data URI.
    fn to_gltf_bytes(&self) -> Vec<u8> {
        let (mut doc, bin) = self.document();
        if !bin.is_empty() {
            let uri = format!(
                "data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&bin)
            );
            doc["buffers"] = json!([{ "byteLength": bin.len(), "uri": uri }]);
        }
        let mut out = serde_json::to_vec_pretty(&doc).expect("a JSON value always serialises");
        out.push(b'\n');
        out
    }

    /// Builds the JSON document (without `buffers`) and the binary buffer.
    fn document(&self) -> (Value, Vec<u8>) {
        let mut bin = BinWriter::default();
        let meshes: Vec<Value> = self.meshes.iter().map(|m| mesh_json(m, &mut bin)).collect();
        let mut doc = Map::new();
        doc.insert(
            "asset".into(),
            json!({ "version": "2.0", "generator": "manylights" }),
        );
        let mut extensions = Vec::new();
        if self.materials.iter().any(|m| m.emissive_strength != 1.0) {
            extensions.push(EMISSIVE_STRENGTH_EXT);
        }
        if self.materials.iter().any(|m| m.specular != 1.0) {
            extensions.push(SPECULAR_EXT);
        }
        if !extensions.is_empty() {
            doc.insert("extensionsUsed".into(), json!(extensions));
        }
        let roots: Vec<usize> = (0..self.nodes.len())
            .filter(|&i| self.nodes[i].parent.is_none())
            .collect();
        // The `gltf` crate rejects a scene without nodes, so omit it instead.
        if !roots.is_empty() {
            doc.insert("scene".into(), json!(0));
            doc.insert("scenes".into(), json!([{ "nodes": roots }]));
        }
        insert_array(
            &mut doc,
            "nodes",
            self.nodes.iter().map(node_json).collect(),
        );
        insert_array(&mut doc, "meshes", meshes);
        insert_array(
            &mut doc,
            "materials",
            self.materials.iter().map(material_json).collect(),
        );
        insert_array(
            &mut doc,
            "cameras",
            self.cameras.iter().map(camera_json).collect(),
        );
        let images: Vec<Value> = self
            .textures
            .iter()
            .map(|t| {
                let view = bin.view(&t.png, None);
                json!({ "name": t.name, "bufferView": view, "mimeType": "image/png" })
            })
            .collect();
        insert_array(&mut doc, "images", images);
        insert_array(
            &mut doc,
            "samplers",
            self.textures
                .iter()
                .map(|t| sampler_json(t.sampling))
                .collect(),
        );
        insert_array(
            &mut doc,
            "textures",
            (0..self.textures.len())
                .map(|i| json!({ "sampler": i, "source": i }))
                .collect(),
        );
        insert_array(&mut doc, "accessors", bin.accessors);
        insert_array(&mut doc, "bufferViews", bin.views);
        (Value::Object(doc), bin.data)
    }
}

/// Returns the rotation `[x, y, z, w]` of a node at `eye` whose local −Z axis
/// points at `target` and whose local +Y is as close to `up` as possible
/// (the glTF camera convention). If `up` is parallel to the view direction
/// another up vector is used; `eye` and `target` must differ.
pub fn look_at_rotation(eye: [f32; 3], target: [f32; 3], up: [f32; 3]) -> [f32; 4] {
    let back = (Vec3::from(eye) - Vec3::from(target)).normalize();
    let mut right = Vec3::from(up).cross(back);
    if right.length_squared() < 1e-12 {
        right = back.any_orthonormal_vector();
    }
    let right = right.normalize();
    let true_up = back.cross(right);
    Quat::from_mat3(&Mat3::from_cols(right, true_up, back))
        .normalize()
        .to_array()
}

#[cfg(test)]
pub(crate) mod tests;
