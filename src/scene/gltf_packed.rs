//! Reading an accessor straight from its bytes where its elements lie back to back in one
//! buffer view (no sparse part, no stride or one equal to the element size), as exporters write
//! positions, normals, texture coordinates and indices. The `gltf` crate's reader decodes
//! element by element through its stride logic (about a quarter of a 200k-emitter city's load);
//! these give the same values from whole slices, and `None` (the caller then uses the crate's
//! reader) for anything else. The caller has checked the accessor's type and extent
//! (`gltf_checks.rs`).

use std::borrow::Cow;

use glam::{Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};

/// The bytes of `acc`'s elements of `size` bytes, or `None` unless they are packed in one view.
fn packed<'a>(acc: &gltf::Accessor, buffers: &'a [Cow<[u8]>], size: usize) -> Option<&'a [u8]> {
    let view = acc.view()?;
    if acc.sparse().is_some() || view.stride().is_some_and(|stride| stride != size) {
        return None;
    }
    let start = view.offset().checked_add(acc.offset())?;
    let end = start.checked_add(acc.count().checked_mul(size)?)?;
    let view_end = view.offset().checked_add(view.length())?;
    if end > view_end {
        return None;
    }
    buffers.get(view.buffer().index())?.get(start..end)
}

/// The elements of a packed F32 accessor of `dimensions` with `N` components each (little-endian,
/// as glTF stores them), or `None` for any other accessor.
fn floats<'a, const N: usize>(
    acc: &gltf::Accessor,
    buffers: &'a [Cow<[u8]>],
    dimensions: Dimensions,
) -> Option<impl Iterator<Item = [f32; N]> + 'a> {
    if acc.dimensions() != dimensions || acc.data_type() != DataType::F32 {
        return None;
    }
    let bytes = packed(acc, buffers, 4 * N)?;
    Some(bytes.chunks_exact(4 * N).map(|element| {
        std::array::from_fn(|k| {
            let b = &element[4 * k..4 * k + 4];
            f32::from_le_bytes([b[0], b[1], b[2], b[3]])
        })
    }))
}

/// A packed F32 VEC3 accessor's elements (positions, normals).
pub(super) fn read_vec3(acc: &gltf::Accessor, buffers: &[Cow<[u8]>]) -> Option<Vec<Vec3>> {
    Some(
        floats::<3>(acc, buffers, Dimensions::Vec3)?
            .map(Vec3::from)
            .collect(),
    )
}

/// A packed F32 VEC2 accessor's elements (texture coordinates stored as floats).
pub(super) fn read_vec2(acc: &gltf::Accessor, buffers: &[Cow<[u8]>]) -> Option<Vec<Vec2>> {
    Some(
        floats::<2>(acc, buffers, Dimensions::Vec2)?
            .map(Vec2::from)
            .collect(),
    )
}

/// A packed scalar U8, U16 or U32 accessor's elements as u32 (index accessors).
pub(super) fn read_indices(acc: &gltf::Accessor, buffers: &[Cow<[u8]>]) -> Option<Vec<u32>> {
    if acc.dimensions() != Dimensions::Scalar {
        return None;
    }
    match acc.data_type() {
        DataType::U8 => Some(
            packed(acc, buffers, 1)?
                .iter()
                .map(|&i| u32::from(i))
                .collect(),
        ),
        DataType::U16 => Some(
            packed(acc, buffers, 2)?
                .chunks_exact(2)
                .map(|b| u32::from(u16::from_le_bytes([b[0], b[1]])))
                .collect(),
        ),
        DataType::U32 => Some(
            packed(acc, buffers, 4)?
                .chunks_exact(4)
                .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
        ),
        _ => None,
    }
}
