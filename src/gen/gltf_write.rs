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
pub struct Material {
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

impl Default for Material {
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
    materials: Vec<Material>,
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
    pub fn add_material(&mut self, material: Material) -> usize {
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
        match &transform {
            NodeTransform::Identity => {}
            NodeTransform::Trs {
                translation,
                rotation,
                scale,
            } => {
                assert_finite(translation.iter().chain(rotation).chain(scale), name);
            }
            NodeTransform::Matrix(m) => assert_finite(m.iter(), name),
        }
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

/// Accumulates the binary buffer plus its buffer views and accessors.
#[derive(Default)]
struct BinWriter {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl BinWriter {
    /// Appends `bytes` as a new 4-byte-aligned buffer view (with a target
    /// for vertex and index data, none for images); returns its index.
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        let offset = self.data.len();
        self.data.extend_from_slice(bytes);
        self.data.resize(self.data.len().next_multiple_of(4), 0);
        let mut view = json!({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": bytes.len(),
        });
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.views.push(view);
        self.views.len() - 1
    }

    /// Adds a float accessor of `N`-vectors ("VEC2", "VEC3"), with min/max when `bounds` is set.
    fn floats<const N: usize>(&mut self, values: &[[f32; N]], kind: &str, bounds: bool) -> usize {
        let bytes: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let mut acc = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": values.len(),
            "type": kind,
        });
        if bounds {
            let (min, max) = bounds_of(values);
            acc["min"] = num_array(&min);
            acc["max"] = num_array(&max);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// Adds a scalar index accessor, 16-bit when every index fits.
    fn indices(&mut self, indices: &[u32]) -> usize {
        let short = indices.iter().all(|&i| i <= u32::from(u16::MAX));
        let (bytes, component): (Vec<u8>, u32) = if short {
            let b = indices
                .iter()
                .flat_map(|&i| (i as u16).to_le_bytes())
                .collect();
            (b, UNSIGNED_SHORT)
        } else {
            (
                indices.iter().flat_map(|i| i.to_le_bytes()).collect(),
                UNSIGNED_INT,
            )
        };
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": component,
            "count": indices.len(),
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }
}

/// Writes a mesh's buffers into `bin` and returns its JSON object.
fn mesh_json(mesh: &MeshData, bin: &mut BinWriter) -> Value {
    let mut attributes = Map::new();
    attributes.insert(
        "POSITION".into(),
        json!(bin.floats(&mesh.positions, "VEC3", true)),
    );
    if let Some(normals) = &mesh.normals {
        attributes.insert("NORMAL".into(), json!(bin.floats(normals, "VEC3", false)));
    }
    if let Some(uvs) = &mesh.uvs {
        attributes.insert("TEXCOORD_0".into(), json!(bin.floats(uvs, "VEC2", false)));
    }
    let mut primitive = json!({
        "attributes": attributes,
        "material": mesh.material,
        "mode": MODE_TRIANGLES,
    });
    if let Some(indices) = &mesh.indices {
        primitive["indices"] = json!(bin.indices(indices));
    }
    json!({ "name": mesh.name, "primitives": [primitive] })
}

/// Returns the JSON object of a material.
fn material_json(m: &Material) -> Value {
    let [r, g, b] = m.base_color;
    let mut out = json!({
        "name": m.name,
        "pbrMetallicRoughness": {
            "baseColorFactor": num_array(&[r, g, b, 1.0]),
            "metallicFactor": num(m.metallic),
            "roughnessFactor": num(m.roughness),
        },
        "emissiveFactor": num_array(&m.emissive),
        "doubleSided": m.double_sided,
    });
    if let Some(texture) = m.base_color_texture {
        out["pbrMetallicRoughness"]["baseColorTexture"] = json!({ "index": texture });
    }
    if let Some(texture) = m.emissive_texture {
        out["emissiveTexture"] = json!({ "index": texture });
    }
    let mut extensions = Map::new();
    if m.emissive_strength != 1.0 {
        extensions.insert(
            EMISSIVE_STRENGTH_EXT.into(),
            json!({ "emissiveStrength": num(m.emissive_strength) }),
        );
    }
    if m.specular != 1.0 {
        extensions.insert(
            SPECULAR_EXT.into(),
            json!({ "specularFactor": num(m.specular) }),
        );
    }
    if !extensions.is_empty() {
        out["extensions"] = Value::Object(extensions);
    }
    out
}

/// Returns the JSON object of a sampler.
fn sampler_json(sampling: TextureSampling) -> Value {
    let (filter, wrap) = match sampling {
        TextureSampling::NearestClamp => (NEAREST, CLAMP_TO_EDGE),
        TextureSampling::LinearRepeat => (LINEAR, REPEAT),
    };
    json!({ "magFilter": filter, "minFilter": filter, "wrapS": wrap, "wrapT": wrap })
}

/// Returns the JSON object of a perspective camera.
fn camera_json(c: &CameraData) -> Value {
    let mut perspective = json!({ "yfov": num(c.yfov), "znear": num(c.znear) });
    if let Some(aspect) = c.aspect_ratio {
        perspective["aspectRatio"] = num(aspect);
    }
    json!({ "name": c.name, "type": "perspective", "perspective": perspective })
}

/// Returns the JSON object of a node.
fn node_json(n: &NodeData) -> Value {
    let mut out = json!({ "name": n.name });
    if let Some(mesh) = n.mesh {
        out["mesh"] = json!(mesh);
    }
    if let Some(camera) = n.camera {
        out["camera"] = json!(camera);
    }
    if !n.children.is_empty() {
        out["children"] = json!(n.children);
    }
    match &n.transform {
        NodeTransform::Identity => {}
        NodeTransform::Trs {
            translation,
            rotation,
            scale,
        } => {
            out["translation"] = num_array(translation);
            out["rotation"] = num_array(rotation);
            out["scale"] = num_array(scale);
        }
        NodeTransform::Matrix(m) => out["matrix"] = num_array(m),
    }
    out
}

/// Inserts `values` under `key` unless it is empty (glTF forbids empty arrays).
fn insert_array(doc: &mut Map<String, Value>, key: &str, values: Vec<Value>) {
    if !values.is_empty() {
        doc.insert(key.into(), Value::Array(values));
    }
}

/// A JSON number that prints as the shortest decimal reading back as `x`.
fn num(x: f32) -> Value {
    let shortest: f64 = x
        .to_string()
        .parse()
        .expect("a finite f32 prints as a number");
    json!(shortest)
}

/// A JSON array of [`num`]s.
fn num_array(values: &[f32]) -> Value {
    Value::Array(values.iter().map(|&v| num(v)).collect())
}

/// Component-wise minimum and maximum of a non-empty point list.
fn bounds_of<const N: usize>(points: &[[f32; N]]) -> ([f32; N], [f32; N]) {
    points.iter().fold(
        ([f32::INFINITY; N], [f32::NEG_INFINITY; N]),
        |(lo, hi), p| {
            (
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            )
        },
    )
}

/// Panics unless every value is finite (JSON cannot store NaN or infinity).
fn assert_finite<'a>(mut values: impl Iterator<Item = &'a f32>, what: &str) {
    assert!(values.all(|v| v.is_finite()), "{what:?}: non-finite value");
}

/// Pads `bytes` with `fill` to a multiple of four.
fn padded(mut bytes: Vec<u8>, fill: u8) -> Vec<u8> {
    bytes.resize(bytes.len().next_multiple_of(4), fill);
    bytes
}

/// Converts a byte length to the 32-bit field of the GLB format.
fn u32_len(len: usize) -> u32 {
    u32::try_from(len).expect("GLB files are limited to 4 GiB")
}

/// Appends one GLB chunk (length, type, already padded data).
fn push_chunk(out: &mut Vec<u8>, kind: u32, data: &[u8]) {
    out.extend_from_slice(&u32_len(data.len()).to_le_bytes());
    out.extend_from_slice(&kind.to_le_bytes());
    out.extend_from_slice(data);
}

#[cfg(test)]
pub(crate) mod tests {
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
            let uvs: Option<Vec<[f32; 2]>> =
                reader.read_tex_coords(0).map(|t| t.into_f32().collect());
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
        let plain = b.add_material(Material {
            name: "plain".into(),
            ..Material::default()
        });
        let glow = b.add_material(Material {
            name: "glow".into(),
            emissive: [1.0, 0.5, 0.25],
            emissive_strength: 7.5,
            double_sided: true,
            ..Material::default()
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
        let m = b.add_material(Material {
            name: "textured".into(),
            emissive: [1.0; 3],
            emissive_texture: Some(glow),
            base_color_texture: Some(tiles),
            specular: 0.0,
            ..Material::default()
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
        b.add_material(Material::default());
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
}
