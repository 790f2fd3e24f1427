//! What the `gltf` crate takes on trust, checked before it is used: the GLB header and chunk
//! lengths, indices between the file's own objects, and every accessor's type, extent, range and
//! finiteness. Each check returns the message for the loader's error.

use std::borrow::Cow;

use gltf::accessor::{DataType, Dimensions};

/// Checks what the `gltf` crate's GLB reader takes on trust, so that a truncated file or one
/// whose header or chunks claim more bytes than it has gets a message saying so: the header's
/// total length must cover the header (a smaller one underflows inside the crate) and fit in
/// the bytes present, and the JSON chunk and the optional BIN chunk after it must fit in it.
pub(super) fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let word = |bytes: &[u8], at: usize| {
        bytes
            .get(at..at + 4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
    };
    let Some(length) = word(bytes, 8) else {
        return Err(format!("GLB header is truncated ({} bytes)", bytes.len()));
    };
    if length < 12 {
        return Err(format!(
            "GLB header declares a total length of {length} bytes"
        ));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(format!(
            "GLB header declares a total length of {length} bytes but the file has {} \
             (truncated?)",
            bytes.len()
        ));
    }
    let bytes = &bytes[..length];
    let mut at = 12;
    for chunk in ["JSON", "BIN"] {
        if chunk == "BIN" && at >= length {
            break;
        }
        let (Some(chunk_length), Some(_)) = (word(bytes, at), word(bytes, at + 4)) else {
            return Err(format!(
                "GLB {chunk} chunk header at byte {at} is cut off by the end of the file \
                 ({length} bytes)"
            ));
        };
        let end = (at + 8).saturating_add(chunk_length as usize);
        if end > length {
            return Err(format!(
                "GLB {chunk} chunk at byte {at} declares {chunk_length} bytes but only {} \
                 remain in the file (truncated?)",
                length.saturating_sub(at + 8)
            ));
        }
        at = end;
    }
    Ok(())
}

/// The `gltf` crate's validator reads each primitive's POSITION accessor without a bounds check.
pub(super) fn check_unchecked_indices(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = Checked::Valid(gltf::json::mesh::Semantic::Positions);
            if let Some(index) = prim.attributes.get(&position) {
                if index.value() >= root.accessors.len() {
                    return Err(format!(
                        "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} does not \
                         exist ({} accessors)",
                        index.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    // `Image::source` unwraps these (found by the fuzzer).
    for (i, image) in root.images.iter().enumerate() {
        match (&image.buffer_view, &image.uri) {
            (Some(view), _) if view.value() >= root.buffer_views.len() => {
                return Err(format!(
                    "images[{i}].bufferView: buffer view {} does not exist ({} buffer views)",
                    view.value(),
                    root.buffer_views.len()
                ))
            }
            (Some(_), _) if image.mime_type.is_none() => {
                return Err(format!(
                    "images[{i}]: an image in a bufferView needs a mimeType"
                ))
            }
            (None, None) => return Err(format!("images[{i}]: has neither uri nor bufferView")),
            _ => {}
        }
    }
    Ok(())
}

pub(super) fn out_of_range(what: &str, acc: &gltf::Accessor) -> String {
    format!(
        "{what} (accessor {}): {} elements do not fit in its buffer view or buffer",
        acc.index(),
        acc.count()
    )
}

/// A per-vertex attribute must have one entry per POSITION.
pub(super) fn per_vertex<T>(
    what: &str,
    acc: &gltf::Accessor,
    values: Vec<T>,
    vertices: usize,
) -> Result<Vec<T>, String> {
    if values.len() != vertices {
        return Err(format!(
            "{what} (accessor {}) has {} entries but POSITION has {vertices}",
            acc.index(),
            values.len()
        ));
    }
    Ok(values)
}

pub(super) fn check_accessor(
    acc: &gltf::Accessor,
    what: &str,
    dims: &[Dimensions],
    types: &[DataType],
    buffers: &[Cow<[u8]>],
) -> Result<(), String> {
    if !dims.contains(&acc.dimensions()) || !types.contains(&acc.data_type()) {
        return Err(format!(
            "{what} (accessor {}) has type {:?} {:?}, expected one of {:?} {:?}",
            acc.index(),
            acc.dimensions(),
            acc.data_type(),
            dims,
            types
        ));
    }
    if acc.count() == 0 {
        return Err(format!("{what} (accessor {}) is empty", acc.index()));
    }
    if acc.view().is_none() && acc.sparse().is_none() {
        return Err(format!(
            "{what} (accessor {}) has no buffer view",
            acc.index()
        ));
    }
    check_accessor_extent(acc, buffers)
        .map_err(|m| format!("{what} (accessor {}): {m}", acc.index()))
}

/// An accessor without a buffer view (all zeros plus sparse values) may not have more elements
/// than this: the count would otherwise be an allocation of any size the file asks for.
pub(super) const MAX_VIEWLESS_ELEMENTS: usize = 1 << 24;

/// Checks, with overflow-checked arithmetic, that every element the `gltf` crate's reader will
/// touch lies inside its buffer view and every view inside its buffer's data, and that strides
/// are at least the element size. The crate computes these ranges unchecked (an overflow, or a
/// stride smaller than the element, panics inside it), so this runs before any read.
pub(super) fn check_accessor_extent(
    acc: &gltf::Accessor,
    buffers: &[Cow<[u8]>],
) -> Result<(), String> {
    let size = acc.size();
    if let Some(view) = acc.view() {
        check_elements(&view, acc.offset(), acc.count(), size, buffers)?;
    } else if acc.count() > MAX_VIEWLESS_ELEMENTS {
        return Err(format!(
            "{} elements without a buffer view (at most {MAX_VIEWLESS_ELEMENTS})",
            acc.count()
        ));
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        if n == 0 || n > acc.count() {
            return Err(format!("sparse count {n} is not in 1..={}", acc.count()));
        }
        let indices = sparse.indices();
        let index_size = indices.index_type().size();
        check_elements(&indices.view(), indices.offset(), n, index_size, buffers)
            .map_err(|m| format!("sparse indices: {m}"))?;
        let values = sparse.values();
        check_elements(&values.view(), values.offset(), n, size, buffers)
            .map_err(|m| format!("sparse values: {m}"))?;
    }
    Ok(())
}

/// `count` (≥ 1) elements of `size` bytes from `offset` in `view`, at the view's stride.
pub(super) fn check_elements(
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    size: usize,
    buffers: &[Cow<[u8]>],
) -> Result<(), String> {
    let present = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > present) {
        return Err(format!(
            "buffer view {} (offset {}, length {}) extends past the {present} bytes of buffer {}",
            view.index(),
            view.offset(),
            view.length(),
            view.buffer().index()
        ));
    }
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "buffer view {} has stride {stride}, less than the element size {size}",
            view.index()
        ));
    }
    let end = count
        .checked_sub(1)
        .and_then(|n| n.checked_mul(stride))
        .and_then(|n| n.checked_add(offset))
        .and_then(|n| n.checked_add(size));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "{count} elements of {size} bytes at offset {offset}, stride {stride} do not fit in \
             buffer view {} ({} bytes)",
            view.index(),
            view.length()
        ));
    }
    Ok(())
}
