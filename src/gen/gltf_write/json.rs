//! The JSON and binary halves of a glTF file: buffer views and accessors appended to one binary
//! buffer, and the JSON objects of meshes, materials, samplers, cameras and nodes.

use super::*;

/// Accumulates the binary buffer plus its buffer views and accessors.
#[derive(Default)]
pub(super) struct BinWriter {
    pub(super) data: Vec<u8>,
    pub(super) views: Vec<Value>,
    pub(super) accessors: Vec<Value>,
}

impl BinWriter {
    /// Appends `bytes` as a new 4-byte-aligned buffer view (with a target
    /// for vertex and index data, none for images); returns its index.
    pub(super) fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
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
    pub(super) fn floats<const N: usize>(
        &mut self,
        values: &[[f32; N]],
        kind: &str,
        bounds: bool,
    ) -> usize {
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
    pub(super) fn indices(&mut self, indices: &[u32]) -> usize {
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
pub(super) fn mesh_json(mesh: &MeshData, bin: &mut BinWriter) -> Value {
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
pub(super) fn material_json(m: &GltfMaterial) -> Value {
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
pub(super) fn sampler_json(sampling: TextureSampling) -> Value {
    let (filter, wrap) = match sampling {
        TextureSampling::NearestClamp => (NEAREST, CLAMP_TO_EDGE),
        TextureSampling::LinearRepeat => (LINEAR, REPEAT),
    };
    json!({ "magFilter": filter, "minFilter": filter, "wrapS": wrap, "wrapT": wrap })
}

/// Returns the JSON object of a perspective camera.
pub(super) fn camera_json(c: &CameraData) -> Value {
    let mut perspective = json!({ "yfov": num(c.yfov), "znear": num(c.znear) });
    if let Some(aspect) = c.aspect_ratio {
        perspective["aspectRatio"] = num(aspect);
    }
    json!({ "name": c.name, "type": "perspective", "perspective": perspective })
}

/// Returns the JSON object of a node.
pub(super) fn node_json(n: &NodeData) -> Value {
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
    for (key, values) in n.transform.properties() {
        out[key] = num_array(values);
    }
    out
}

/// Inserts `values` under `key` unless it is empty (glTF forbids empty arrays).
pub(super) fn insert_array(doc: &mut Map<String, Value>, key: &str, values: Vec<Value>) {
    if !values.is_empty() {
        doc.insert(key.into(), Value::Array(values));
    }
}

/// A JSON number that prints as the shortest decimal reading back as `x`.
pub(super) fn num(x: f32) -> Value {
    let shortest: f64 = x
        .to_string()
        .parse()
        .expect("a finite f32 prints as a number");
    json!(shortest)
}

/// A JSON array of [`num`]s.
pub(super) fn num_array(values: &[f32]) -> Value {
    Value::Array(values.iter().map(|&v| num(v)).collect())
}

/// Component-wise minimum and maximum of a non-empty point list.
pub(super) fn bounds_of<const N: usize>(points: &[[f32; N]]) -> ([f32; N], [f32; N]) {
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
pub(super) fn assert_finite<'a>(mut values: impl Iterator<Item = &'a f32>, what: &str) {
    assert!(values.all(|v| v.is_finite()), "{what:?}: non-finite value");
}

/// Pads `bytes` with `fill` to a multiple of four.
pub(super) fn padded(mut bytes: Vec<u8>, fill: u8) -> Vec<u8> {
    bytes.resize(bytes.len().next_multiple_of(4), fill);
    bytes
}

/// Converts a byte length to the 32-bit field of the GLB format.
pub(super) fn u32_len(len: usize) -> u32 {
    u32::try_from(len).expect("GLB files are limited to 4 GiB")
}

/// Appends one GLB chunk (length, type, already padded data).
pub(super) fn push_chunk(out: &mut Vec<u8>, kind: u32, data: &[u8]) {
    out.extend_from_slice(&u32_len(data.len()).to_le_bytes());
    out.extend_from_slice(&kind.to_le_bytes());
    out.extend_from_slice(data);
}
