//! Checkpoints of a reference being rendered, so that an interrupted reference resumes where it
//! stopped instead of starting over.
//!
//! A checkpoint holds the merged state after a whole pass: every pixel's sample count, f64 mean
//! and f64 M2 (Welford's Σ(x − mean)²) bit for bit, the pass and sample counts, the seconds
//! spent, the non-finite sample counts, and what the pixels depend on — the scene's content
//! hash and the [`ReferenceOptions`]. Resuming merges the next passes into exactly these bits in
//! the order an uninterrupted run would, so the finished reference is bit-identical to one
//! never interrupted (passes draw sample indices from the total so far; see
//! [`super::progressive::resume_progressive`]).
//!
//! File layout (little-endian): the 8-byte magic `MLCKPT01`; the header's length (u64) and the
//! header as JSON; width × height pixel records of 7 × 8 bytes (count u64, mean 3 × f64,
//! M2 3 × f64), row-major; and a 64-bit FNV-1a of everything before it (the same hash as
//! [`super::fnv1a64`]). The file is written
//! atomically (temporary file, fsync, rename), so a kill while writing leaves the previous
//! checkpoint intact; a damaged or foreign file is refused by its magic, sizes or checksum.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context};
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::progressive::{PassCount, Progressive};
use super::reference::ReferenceOptions;
use super::SceneSetup;
use crate::film::{Film, PixelStats};
use crate::image::write_atomically;
use crate::integrator::RenderStats;

const MAGIC: &[u8; 8] = b"MLCKPT02";
/// Bytes of one pixel record: count, mean (3 × f64), M2 (3 × f64), surface-hit count.
const PIXEL_BYTES: u64 = 64;
/// A header longer than this is not one this program wrote.
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// What a checkpoint says about the run it belongs to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointHeader {
    pub scene: PathBuf,
    /// The scene's content hash, 16 hex digits (as in the reference sidecar).
    pub scene_hash: String,
    pub options: ReferenceOptions,
    /// Samples per pixel of each pass.
    pub pass_spp: u32,
    pub passes: u32,
    pub spp: u32,
    pub seconds: f64,
    pub camera_samples: u64,
    pub nan_samples: u64,
    pub inf_samples: u64,
    pub fireflies: u64,
}

/// The checkpoint file of the reference `exr`: the same name with `.checkpoint` appended.
pub fn checkpoint_path(exr: &Path) -> PathBuf {
    let mut s = exr.as_os_str().to_owned();
    s.push(".checkpoint");
    PathBuf::from(s)
}

/// Writes the state `p` of the reference of `setup` with `options` to `path`, atomically.
pub fn write_checkpoint(
    path: &Path,
    setup: &SceneSetup,
    options: &ReferenceOptions,
    pass_spp: u32,
    p: &Progressive,
) -> anyhow::Result<()> {
    let header = CheckpointHeader {
        scene: setup.path.clone(),
        scene_hash: format!("{:016x}", setup.hash),
        options: options.clone(),
        pass_spp,
        passes: p.count.passes,
        spp: p.count.spp,
        seconds: p.seconds,
        camera_samples: p.stats.camera_samples,
        nan_samples: p.stats.nan_samples,
        inf_samples: p.stats.inf_samples,
        fireflies: p.stats.fireflies,
    };
    let json = serde_json::to_vec(&header)?;
    write_atomically(path, |w| {
        // Streamed (a 4K film is half a gigabyte), hashed as it goes.
        let mut hash = FNV_OFFSET;
        let mut put = |bytes: &[u8]| -> std::io::Result<()> {
            hash = fnv_update(hash, bytes);
            w.write_all(bytes)
        };
        put(MAGIC)?;
        put(&(json.len() as u64).to_le_bytes())?;
        put(&json)?;
        for px in &p.film.pixels {
            let mut record = [0u8; PIXEL_BYTES as usize];
            record[..8].copy_from_slice(&px.count.to_le_bytes());
            record[56..].copy_from_slice(&px.surface.to_le_bytes());
            let values = px.mean.to_array().into_iter().chain(px.m2.to_array());
            for (slot, v) in record[8..56].chunks_exact_mut(8).zip(values) {
                slot.copy_from_slice(&v.to_bits().to_le_bytes());
            }
            put(&record)?;
        }
        w.write_all(&hash.to_le_bytes())?;
        Ok(())
    })
}

/// FNV-1a's starting value; [`fnv_update`] from it over all bytes gives [`fnv1a64`].
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// Continues a 64-bit FNV-1a hash `h` over `bytes`.
fn fnv_update(h: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(h, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Reads a checkpoint: its header and the state it saved. Refuses (naming the file) anything
/// that is not a complete checkpoint of this format.
pub fn read_checkpoint(path: &Path) -> anyhow::Result<(CheckpointHeader, Progressive)> {
    let named = || format!("checkpoint {}", path.display());
    let mut file = std::fs::File::open(path).with_context(|| format!("cannot read {}", named()))?;
    let size = file.metadata().with_context(named)?.len();
    let mut head = [0u8; 16];
    file.read_exact(&mut head)
        .map_err(|_| anyhow::anyhow!("{}: too short to be a checkpoint", named()))?;
    ensure!(
        &head[..8] == MAGIC,
        "{}: not a manylights checkpoint",
        named()
    );
    let header_len = u64::from_le_bytes(head[8..16].try_into().expect("8 bytes"));
    ensure!(
        header_len <= MAX_HEADER_BYTES.min(size),
        "{}: header length {header_len} is corrupt",
        named()
    );
    let mut json = vec![0u8; header_len as usize];
    file.read_exact(&mut json)
        .with_context(|| format!("{}: truncated header", named()))?;
    let header: CheckpointHeader = serde_json::from_slice(&json)
        .with_context(|| format!("{}: header is not valid", named()))?;
    let (w, h) = (header.options.width as u64, header.options.height as u64);
    let expected = 16 + header_len + w * h * PIXEL_BYTES + 8;
    if size != expected {
        bail!(
            "{}: {size} bytes, but a {w}x{h} checkpoint has {expected} (truncated or corrupt)",
            named()
        );
    }
    // The size was checked against the file, so this allocation is what the disk holds.
    let mut rest = Vec::with_capacity((size - 16 - header_len) as usize);
    file.read_to_end(&mut rest).with_context(named)?;
    let (pixels, checksum) = rest.split_at(rest.len() - 8);
    let hash = [&head[..], &json, pixels]
        .into_iter()
        .fold(FNV_OFFSET, fnv_update);
    ensure!(
        hash.to_le_bytes() == checksum,
        "{}: checksum does not match (the file is damaged)",
        named()
    );
    let word = |r: &[u8], i: usize| u64::from_le_bytes(r[8 * i..8 * i + 8].try_into().unwrap());
    let f = |r: &[u8], i: usize| f64::from_bits(word(r, i));
    let pixels = pixels
        .chunks_exact(PIXEL_BYTES as usize)
        .map(|r| PixelStats {
            count: word(r, 0),
            mean: DVec3::new(f(r, 1), f(r, 2), f(r, 3)),
            m2: DVec3::new(f(r, 4), f(r, 5), f(r, 6)),
            surface: word(r, 7),
        })
        .collect();
    let stats = RenderStats {
        camera_samples: header.camera_samples,
        nan_samples: header.nan_samples,
        inf_samples: header.inf_samples,
        fireflies: header.fireflies,
        ..RenderStats::default()
    };
    let state = Progressive {
        film: Film {
            width: header.options.width,
            height: header.options.height,
            pixels,
        },
        stats,
        count: PassCount {
            passes: header.passes,
            spp: header.spp,
        },
        seconds: header.seconds,
    };
    Ok((header, state))
}

/// What differs between a checkpoint and the run that wants to resume it (empty: it matches).
pub fn differences(
    header: &CheckpointHeader,
    setup: &SceneSetup,
    options: &ReferenceOptions,
    pass_spp: u32,
) -> Vec<String> {
    let mut out = Vec::new();
    let hash = format!("{:016x}", setup.hash);
    if header.scene_hash != hash {
        out.push(format!(
            "the scene (checkpoint: {} with hash {}, now: {} with hash {hash})",
            header.scene.display(),
            header.scene_hash,
            setup.path.display()
        ));
    }
    let (a, b) = (&header.options, options);
    let mut differ = |what: &str, then: String, now: String| {
        if then != now {
            out.push(format!("{what} (checkpoint: {then}, now: {now})"));
        }
    };
    differ("--width", a.width.to_string(), b.width.to_string());
    differ("--height", a.height.to_string(), b.height.to_string());
    differ(
        "--camera",
        format!("{:?}", a.camera),
        format!("{:?}", b.camera),
    );
    let e = |o: &ReferenceOptions| o.estimator;
    differ(
        "--selector",
        format!("{:?}", e(a).selector),
        format!("{:?}", e(b).selector),
    );
    differ(
        "--strategy",
        format!("{:?}", e(a).strategy),
        format!("{:?}", e(b).strategy),
    );
    differ("--k", e(a).k.to_string(), e(b).k.to_string());
    differ("--n", e(a).n.to_string(), e(b).n.to_string());
    differ(
        "--sampler",
        format!("{:?}", e(a).sampler),
        format!("{:?}", e(b).sampler),
    );
    differ("--seed", a.seed.to_string(), b.seed.to_string());
    differ("--spp", format!("{:?}", a.spp), format!("{:?}", b.spp));
    differ("--time", format!("{:?}", a.time), format!("{:?}", b.time));
    differ(
        "pass size",
        header.pass_spp.to_string(),
        pass_spp.to_string(),
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streamed_hash_is_fnv1a_of_the_whole() {
        let bytes: Vec<u8> = (0..1000u32).map(|i| (i * 7 + i / 13) as u8).collect();
        let (a, b) = bytes.split_at(337);
        let streamed = fnv_update(fnv_update(FNV_OFFSET, a), b);
        assert_eq!(streamed, super::super::fnv1a64(&bytes));
    }
}
