//! glTF 2.0 loader (.gltf with external or embedded buffers, and .glb).
//!
//! Reads every TRIANGLES primitive of the default scene through the node hierarchy (TRS or
//! matrix), with POSITION, NORMAL, TEXCOORD_0 and indices of any width. Every accessor is checked
//! (type, range, finiteness, index bounds) before use, so a broken file gives an error naming the
//! file and the element instead of a panic or garbage. Whatever the `gltf` crate computes unchecked
//! from the file (GLB lengths, accessor and buffer-view extents, strides) is checked first
//! (`gltf_checks.rs`); materials and textures are converted in `gltf_materials.rs`;
//! `tests/fuzz_loader/` fuzzes all of this. Non-finite positions are an error (they
//! signal a broken exporter, not a scene to be rendered partially); zero-area triangles are
//! skipped and counted.
//!
//! Textures: a material's baseColorTexture and emissiveTexture (the latter only when the
//! emissive factor is non-zero, since it multiplies it) are decoded once, PNG or JPEG, from a
//! buffer view, a data URI or a file relative to the scene, into linear RGB with their sampler's
//! wrap modes; min/mag filters are ignored (always bilinear). Only TEXCOORD_0 is supported: a
//! texture read through another set is an error rather than a silently wrong picture. A missing,
//! unreadable or undecodable image is an error naming the image and its file. A reference's
//! KHR_texture_transform (offset, rotation, scale, and its texCoord override) travels with the
//! texture (see `texture.rs`); one image referenced with two transforms is decoded twice.
//!
//! Extensions: KHR_lights_punctual (intensities kept in the file's photometric units),
//! KHR_materials_emissive_strength, KHR_materials_specular and KHR_texture_transform are
//! implemented; a file requiring any other is refused with a message naming it and what it
//! would change. Cameras: perspective and orthographic (`camera.rs`).

use std::borrow::Cow;
use std::io::Read;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::gltf_camera::choose_camera;
pub use super::gltf_camera::CameraChoice;
use super::gltf_checks::{
    check_accessor, check_glb_header, check_unchecked_indices, out_of_range, per_vertex,
};
use super::gltf_extensions::{check_required_extensions, convert_light};
use super::gltf_files::{read_uri, FileAccess};
use super::gltf_packed::{read_indices, read_vec2, read_vec3};
use super::memory::{declared_sizes, human, triangle_count, MemoryBudget, MemoryEstimate};
use super::{
    geometric_normal, LoadStats, Material, PunctualUnits, Scene, Texture, Triangle,
    NAMED_SKIPPED_PRIMITIVES,
};

/// Why a scene file could not be loaded; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: not a valid glTF 2.0 file: {message}", path.display())]
    Format { path: PathBuf, message: String },
    #[error("{}: {element}: {message}", path.display())]
    Invalid {
        path: PathBuf,
        element: String,
        message: String,
    },
}

/// Node hierarchies deeper than this are refused (a hostile file; cycles are caught as nodes
/// reached twice).
const MAX_NODE_DEPTH: usize = 256;

/// At most this many triangles per scene (2^25, about 12 GB once rendering structures are
/// built): a small file whose nodes instance a mesh many times is refused, from the accessor
/// counts it declares, before any buffer is read.
pub const MAX_TRIANGLES: u64 = 1 << 25;

/// What a load may read and use besides the scene's own folder.
#[derive(Clone, Debug, Default)]
pub struct LoadPolicy {
    /// Further folders (canonical paths) whose files external URIs may name
    /// (`--allow-external-files`).
    pub allowed: Vec<PathBuf>,
    /// Refuse, before any buffer is read, a scene whose [`MemoryEstimate`] exceeds the budget.
    pub memory: Option<MemoryBudget>,
}

/// Loads the default scene of a glTF or GLB file, reading external files only from its folder.
pub fn load_gltf(path: &Path, camera: &CameraChoice) -> Result<Scene, LoadError> {
    load_gltf_allowing(path, camera, &LoadPolicy::default())
}

/// [`load_gltf`] under `policy`: external files also from its folders, and its memory budget.
pub fn load_gltf_allowing(
    path: &Path,
    camera: &CameraChoice,
    policy: &LoadPolicy,
) -> Result<Scene, LoadError> {
    let bytes = read_scene_file(path)?;
    load_gltf_bytes_allowing(&bytes, path, scene_folder(path), camera, policy)
}

/// The folder external buffer URIs of the scene file `path` resolve against.
pub fn scene_folder(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new("."))
}

/// Reads a scene file's bytes. It must be a regular file (a device such as /dev/zero or a FIFO
/// would never end). A GLB is read only as far as its header's total length says; when the file
/// is shorter, only what is there is read (the loader then reports the truncation), so a header
/// claiming gigabytes allocates nothing.
pub fn read_scene_file(path: &Path) -> Result<Vec<u8>, LoadError> {
    let io = |source: std::io::Error| LoadError::Io {
        path: path.into(),
        source,
    };
    // Checked before opening: opening a FIFO for reading blocks until a writer appears.
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        )));
    }
    let mut file = std::fs::File::open(path).map_err(io)?;
    let size = meta.len();
    let mut header = Vec::with_capacity(12);
    (&mut file).take(12).read_to_end(&mut header).map_err(io)?;
    let limit = match header.get(8..12) {
        Some(l) if header.starts_with(b"glTF") => {
            u64::from(u32::from_le_bytes([l[0], l[1], l[2], l[3]])).min(size)
        }
        _ => size,
    };
    let mut bytes = header;
    let rest = limit.saturating_sub(bytes.len() as u64);
    bytes
        .try_reserve_exact(usize::try_from(rest).unwrap_or(usize::MAX))
        .map_err(|e| io(std::io::Error::new(std::io::ErrorKind::OutOfMemory, e)))?;
    file.take(rest).read_to_end(&mut bytes).map_err(io)?;
    Ok(bytes)
}

/// Loads the default scene of a glTF or GLB file already in memory. `path_for_messages` names
/// the file in errors; external buffer URIs resolve relative to `base_dir` and must stay inside
/// it (see `gltf_files`). Never panics: any input gives a scene or a [`LoadError`].
pub fn load_gltf_bytes(
    bytes: &[u8],
    path_for_messages: &Path,
    base_dir: &Path,
    camera: &CameraChoice,
) -> Result<Scene, LoadError> {
    load_gltf_bytes_allowing(
        bytes,
        path_for_messages,
        base_dir,
        camera,
        &LoadPolicy::default(),
    )
}

/// [`load_gltf_bytes`] under `policy` (see [`LoadPolicy`]).
pub fn load_gltf_bytes_allowing(
    bytes: &[u8],
    path_for_messages: &Path,
    base_dir: &Path,
    camera: &CameraChoice,
    policy: &LoadPolicy,
) -> Result<Scene, LoadError> {
    let files = FileAccess {
        scene_folder: base_dir,
        allowed: &policy.allowed,
    };
    let path = path_for_messages;
    let format = |message: String| LoadError::Format {
        path: path.into(),
        message,
    };
    check_glb_header(bytes).map_err(format)?;
    // Parse, check what the crate's validator indexes unchecked, then validate.
    let (root, blob) = parse(bytes).map_err(|e| format(e.to_string()))?;
    check_unchecked_indices(&root).map_err(format)?;
    check_required_extensions(&root).map_err(format)?;
    let document = gltf::Document::from_json(root).map_err(|e| format(e.to_string()))?;
    let invalid = |element: String, message: String| LoadError::Invalid {
        path: path.into(),
        element,
        message,
    };

    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| invalid("scenes".into(), "the file has no scene".into()))?;
    let sizes = declared_sizes(&scene);
    let declared = sizes.triangles;
    if let Some(budget) = &policy.memory {
        let estimate = MemoryEstimate {
            file_bytes: bytes.len() as u64,
            pixels: budget.film_pixels,
            sizes,
        };
        if estimate.total() > budget.max_bytes {
            return Err(invalid(
                format!("scene {}", scene.index()),
                format!(
                    "rendering it needs {}, more than the {} allowed (--max-memory; by default \
                     the memory the system has available)",
                    estimate.describe(),
                    human(budget.max_bytes)
                ),
            ));
        }
    }
    if declared > MAX_TRIANGLES {
        return Err(invalid(
            format!("scene {}", scene.index()),
            format!(
                "declares {declared} triangles over its node instances, more than the \
                 {MAX_TRIANGLES} allowed"
            ),
        ));
    }
    let buffers = load_buffers(&document, blob, files).map_err(|(e, m)| invalid(e, m))?;
    let mut loader = Loader {
        buffers: &buffers,
        files,
        materials: Vec::new(),
        material_map: vec![None; document.materials().len() + 1],
        textures: Vec::new(),
        texture_map: std::collections::HashMap::new(),
    };

    let (mut triangles, mut uvs) = (Vec::new(), Vec::new());
    let mut stats = LoadStats::default();
    let mut cameras = Vec::new();
    let mut punctual = Vec::new();
    let mut stack: Vec<(gltf::Node, Mat4, usize)> =
        scene.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    stack.reverse();
    // glTF nodes form disjoint trees: a node reached twice (two parents, listed twice, or a
    // cycle) is an error — a shared node in a chain would otherwise be visited 2^depth times.
    let mut visited = vec![false; document.nodes().len()];
    while let Some((node, parent, depth)) = stack.pop() {
        let element = format!("node {}{}", node.index(), quoted(node.name()));
        if depth > MAX_NODE_DEPTH {
            return Err(invalid(
                element,
                format!("hierarchy deeper than {MAX_NODE_DEPTH} nodes"),
            ));
        }
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(invalid(
                element,
                "is reached twice from the scene (a node has at most one parent)".into(),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(invalid(element, "transform is not finite".into()));
        }
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let element = format!(
                    "mesh {}{} primitive {}",
                    mesh.index(),
                    quoted(mesh.name()),
                    prim.index()
                );
                if !has_area(prim.mode()) {
                    stats.skipped_primitives += 1;
                    if stats.skipped_primitive_names.len() < NAMED_SKIPPED_PRIMITIVES {
                        let mode = format!("{:?}", prim.mode()).to_uppercase();
                        stats
                            .skipped_primitive_names
                            .push(format!("{element} ({mode})"));
                    }
                    continue;
                }
                let material = loader
                    .material_index(&prim.material())
                    .map_err(|(e, m)| invalid(e, m))?;
                loader
                    .read_primitive(
                        &prim,
                        material,
                        &world,
                        (&mut triangles, &mut uvs),
                        &mut stats,
                    )
                    .map_err(|m| invalid(element, m))?;
            }
        }
        if let Some(cam) = node.camera() {
            cameras.push((node.clone(), cam, world));
        }
        if let Some(light) = node.light() {
            punctual.push(convert_light(&light, &world));
        }
        let children: Vec<_> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world, depth + 1)));
    }

    let camera = choose_camera(&cameras, camera).map_err(|m| invalid("camera".into(), m))?;
    let (materials, textures) = (loader.materials, loader.textures);
    let textured = materials.iter().any(uses_uvs);
    if textured {
        // Texture coordinates are kept from the first textured primitive on (`read_primitive`).
        uvs.resize(triangles.len(), [Vec2::ZERO; 3]);
    }
    let scene_element = format!("scene {}", scene.index());
    let mut scene = Scene::with_uvs(triangles, uvs, materials, camera)
        .and_then(|s| s.with_punctual(punctual))
        .map(|s| s.with_punctual_units(PunctualUnits::Photometric))
        .and_then(|s| s.with_textures(textures))
        .map_err(|m| invalid(scene_element, m))?;
    scene.stats.skipped_primitives = stats.skipped_primitives;
    scene.stats.skipped_primitive_names = stats.skipped_primitive_names;
    scene.stats.degenerate_triangles += stats.degenerate_triangles;
    Ok(scene)
}

/// `f` of a triangle's three vertex indices, written out: `[u32; 3]::map` went through the
/// array's generic drain (a 200k-emitter city's load: 279 → 249 M instructions without it).
#[inline(always)]
fn per_corner<T>(ids: [u32; 3], f: impl Fn(u32) -> T) -> [T; 3] {
    [f(ids[0]), f(ids[1]), f(ids[2])]
}

/// Whether a material reads texture coordinates (it has a base colour or emissive texture).
fn uses_uvs(material: &Material) -> bool {
    material.base_color_texture.is_some() || material.emissive_texture.is_some()
}

/// Whether primitives of this mode cover area (triangles, strips and fans); points and lines
/// have none to shade or emit from.
fn has_area(mode: Mode) -> bool {
    matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    )
}

/// The vertex triples of a primitive as a TRIANGLES list, with glTF 2.0's winding (§3.7.2.1):
/// strip triangle i is (v_i, v_{i+1+i%2}, v_{i+2−i%2}), fan triangle i is (v_{i+1}, v_{i+2}, v_0).
fn triangle_list(mode: Mode, indices: Vec<u32>) -> Vec<u32> {
    let n = triangle_count(mode, indices.len());
    match mode {
        Mode::TriangleStrip => (0..n)
            .flat_map(|i| {
                let odd = i % 2;
                [indices[i], indices[i + 1 + odd], indices[i + 2 - odd]]
            })
            .collect(),
        Mode::TriangleFan => (0..n)
            .flat_map(|i| [indices[i + 1], indices[i + 2], indices[0]])
            .collect(),
        _ => indices,
    }
}

pub(super) fn quoted(name: Option<&str>) -> String {
    name.map(|n| format!(" '{n}'")).unwrap_or_default()
}

/// A buffer's bytes: borrowed from the file (a GLB's binary chunk) or read from elsewhere.
type Chunk<'a> = Cow<'a, [u8]>;

/// The JSON of a .gltf, or the JSON and binary chunk of a GLB, parsed as
/// `gltf::Gltf::from_slice_without_validation` parses them (same errors), except that the
/// binary chunk is borrowed from `bytes` instead of copied: a copy would add the whole file
/// (87 MB for the 1M-emitter city) to the load's peak memory.
fn parse(bytes: &[u8]) -> Result<(gltf::json::Root, Option<Chunk<'_>>), gltf::Error> {
    if !bytes.starts_with(b"glTF") {
        let root = gltf::json::deserialize::from_slice(bytes).map_err(gltf::Error::Deserialize)?;
        return Ok((root, None));
    }
    let glb = gltf::binary::Glb::from_slice(bytes)?;
    let root = gltf::json::deserialize::from_slice(&glb.json).map_err(gltf::Error::Deserialize)?;
    Ok((root, glb.bin))
}

/// Loads every buffer: the GLB binary chunk, a base64 data URI, or a file next to the scene.
fn load_buffers<'a>(
    document: &gltf::Document,
    mut blob: Option<Cow<'a, [u8]>>,
    files: FileAccess,
) -> Result<Vec<Cow<'a, [u8]>>, (String, String)> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let element = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                (
                    element.clone(),
                    "refers to the GLB binary chunk, which is missing".into(),
                )
            })?,
            gltf::buffer::Source::Uri(uri) => {
                let data = read_uri(uri, Some(buffer.length()), files);
                Cow::Owned(data.map_err(|m| (element.clone(), m))?)
            }
        };
        if data.len() < buffer.length() {
            return Err((
                element,
                format!(
                    "declares {} bytes but only {} are present",
                    buffer.length(),
                    data.len()
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

pub(super) struct Loader<'a> {
    pub(super) buffers: &'a [Cow<'a, [u8]>],
    /// Where external image files may be read.
    pub(super) files: FileAccess<'a>,
    pub(super) materials: Vec<Material>,
    /// glTF material index (last slot: the default material) → index into `materials`.
    pub(super) material_map: Vec<Option<u32>>,
    pub(super) textures: Vec<Texture>,
    /// (glTF texture index, its reference's uv transform as bits) → index into `textures`.
    pub(super) texture_map: std::collections::HashMap<(usize, Option<[u32; 6]>), u32>,
}

/// An error's element and message.
pub(super) type Located = (String, String);

impl Loader<'_> {
    /// The scene material for a glTF material, converted (and its textures decoded) on first use.
    fn read_primitive(
        &mut self,
        prim: &gltf::Primitive,
        material: u32,
        world: &Mat4,
        (out, out_uvs): (&mut Vec<Triangle>, &mut Vec<[Vec2; 3]>),
        stats: &mut LoadStats,
    ) -> Result<(), String> {
        let reader = prim.reader(|b| self.buffers.get(b.index()).map(|b| &**b));
        let pos_acc = prim
            .get(&gltf::Semantic::Positions)
            .ok_or("has no POSITION attribute")?;
        check_accessor(
            &pos_acc,
            "POSITION",
            &[Dimensions::Vec3],
            &[DataType::F32],
            self.buffers,
        )?;
        let positions: Vec<Vec3> = read_vec3(&pos_acc, self.buffers)
            .or_else(|| Some(reader.read_positions()?.map(Vec3::from).collect()))
            .ok_or_else(|| out_of_range("POSITION", &pos_acc))?;
        if positions.len() != pos_acc.count() {
            return Err(out_of_range("POSITION", &pos_acc));
        }
        if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
            return Err(format!(
                "POSITION (accessor {}) vertex {v} is not finite: {:?}",
                pos_acc.index(),
                positions[v]
            ));
        }
        let vertices = positions.len();
        let normals = prim
            .get(&gltf::Semantic::Normals)
            .map(|acc| {
                check_accessor(
                    &acc,
                    "NORMAL",
                    &[Dimensions::Vec3],
                    &[DataType::F32],
                    self.buffers,
                )?;
                let n = read_vec3(&acc, self.buffers)
                    .or_else(|| Some(reader.read_normals()?.map(Vec3::from).collect()))
                    .ok_or_else(|| out_of_range("NORMAL", &acc))?;
                per_vertex("NORMAL", &acc, n, vertices)
            })
            .transpose()?;
        let uvs = prim
            .get(&gltf::Semantic::TexCoords(0))
            .map(|acc| {
                let types = [DataType::F32, DataType::U8, DataType::U16];
                check_accessor(
                    &acc,
                    "TEXCOORD_0",
                    &[Dimensions::Vec2],
                    &types,
                    self.buffers,
                )?;
                let uv = read_vec2(&acc, self.buffers)
                    .or_else(|| {
                        Some(
                            reader
                                .read_tex_coords(0)?
                                .into_f32()
                                .map(Vec2::from)
                                .collect(),
                        )
                    })
                    .ok_or_else(|| out_of_range("TEXCOORD_0", &acc))?;
                per_vertex("TEXCOORD_0", &acc, uv, vertices)
            })
            .transpose()?;
        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => {
                check_accessor(
                    &acc,
                    "indices",
                    &[Dimensions::Scalar],
                    &[DataType::U8, DataType::U16, DataType::U32],
                    self.buffers,
                )?;
                let idx: Vec<u32> = read_indices(&acc, self.buffers)
                    .or_else(|| Some(reader.read_indices()?.into_u32().collect()))
                    .ok_or_else(|| out_of_range("indices", &acc))?;
                if idx.len() != acc.count() {
                    return Err(out_of_range("indices", &acc));
                }
                if let Some(k) = idx.iter().position(|&i| i as usize >= positions.len()) {
                    return Err(format!(
                        "index {} at position {k} of accessor {} is past the vertex count {}",
                        idx[k],
                        acc.index(),
                        positions.len()
                    ));
                }
                idx
            }
            None => (0..positions.len() as u32).collect(),
        };
        let mode = prim.mode();
        if mode == Mode::Triangles && !indices.len().is_multiple_of(3) {
            return Err(format!(
                "{} indices is not a multiple of 3 for TRIANGLES mode",
                indices.len()
            ));
        }
        let indices = triangle_list(mode, indices);
        // Grown for the triangles read (never for a count the file only declares), on huge pages:
        // rendering reads them at random.
        crate::alloc::on_huge_pages(|| out.reserve(indices.len() / 3));

        // Texture coordinates are kept from the first primitive with a textured material on,
        // the triangles before it given zeros (their materials read none): an untextured scene
        // never fills them (48 MB on the 1M-emitter city).
        let textured = uses_uvs(&self.materials[material as usize]);
        if textured && out_uvs.len() < out.len() {
            out_uvs.resize(out.len(), [Vec2::ZERO; 3]);
        }
        let keep_uvs = textured || !out_uvs.is_empty();
        let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
        let mirrored = Mat3::from_mat4(*world).determinant() < 0.0;
        let to_world = |p: Vec3| world.transform_point3(p);
        for tri in indices.chunks_exact(3) {
            // A mirroring transform flips the winding; swap two vertices to keep the front face.
            let ids = if mirrored {
                [tri[0], tri[2], tri[1]]
            } else {
                [tri[0], tri[1], tri[2]]
            };
            let p = per_corner(ids, |i| to_world(positions[i as usize]));
            let ng = geometric_normal(&p);
            if ng == Vec3::ZERO || !super::triangle_area(&p).is_normal() {
                stats.degenerate_triangles += 1;
                continue;
            }
            let n = per_corner(ids, |i| {
                normals
                    .as_ref()
                    .map(|ns| (normal_matrix * ns[i as usize]).normalize_or_zero())
                    .filter(|n| n.is_finite() && *n != Vec3::ZERO)
                    .unwrap_or(ng)
            });
            out.push(Triangle {
                positions: p,
                normals: n,
                material,
            });
            if keep_uvs {
                out_uvs.push(per_corner(ids, |i| {
                    uvs.as_ref().map_or(Vec2::ZERO, |u| u[i as usize])
                }));
            }
        }
        Ok(())
    }
}
