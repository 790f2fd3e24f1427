//! The byte-level mutations of the two fuzz tests (`fuzz_exr.rs`, `fuzz_loader/`), each tuned by
//! its format: flip a bit, overwrite a byte, write an interesting little-endian word, truncate,
//! duplicate a chunk, delete a chunk, insert a byte. Deterministic from the PCG state.

use rand_core::Rng;
use rand_pcg::Pcg32;

/// A uniform index below n (0 when n = 0).
pub fn below(rng: &mut Pcg32, n: usize) -> usize {
    if n == 0 {
        0
    } else {
        (rng.next_u32() as usize) % n
    }
}

/// How a format's fuzzer tunes the shared mutations.
pub struct ByteMutations<'a> {
    /// Little-endian words worth writing: counts, lengths and offsets at their edges.
    pub interesting: &'a [u32],
    /// Snap those words to a 4-aligned offset three times in four (a binary header's fields).
    pub aligned: bool,
    /// The longest chunk duplicated.
    pub max_duplicate: usize,
    /// The longest chunk deleted.
    pub max_delete: usize,
}

impl ByteMutations<'_> {
    /// Applies mutation `kind` to `data`: 0 flips a bit, 1 overwrites a byte, 2 writes an
    /// interesting word, 3 truncates, 4 duplicates a chunk elsewhere, 5 deletes one. Returns
    /// false, `data` untouched, for any other kind or when `data` is too short for it: the
    /// caller's own mutations, then `insert_byte`.
    pub fn apply(&self, kind: usize, rng: &mut Pcg32, data: &mut Vec<u8>) -> bool {
        let len = data.len();
        match kind {
            0 if len > 0 => {
                let i = below(rng, len);
                data[i] ^= 1 << below(rng, 8);
            }
            1 if len > 0 => {
                let i = below(rng, len);
                data[i] = rng.next_u32() as u8;
            }
            2 if len >= 4 => {
                let mut i = below(rng, len - 3);
                if self.aligned && !rng.next_u32().is_multiple_of(4) {
                    i &= !3;
                }
                let w = self.interesting[below(rng, self.interesting.len())];
                data[i..i + 4].copy_from_slice(&w.to_le_bytes());
            }
            3 => data.truncate(below(rng, len + 1)),
            4 if len > 0 => {
                let start = below(rng, len);
                let n = 1 + below(rng, (len - start).min(self.max_duplicate));
                let chunk = data[start..start + n].to_vec();
                let at = below(rng, len + 1);
                data.splice(at..at, chunk);
            }
            5 if len > 0 => {
                let start = below(rng, len);
                let n = 1 + below(rng, (len - start).min(self.max_delete));
                data.drain(start..start + n);
            }
            _ => return false,
        }
        true
    }
}

/// Inserts a random byte at a random place.
pub fn insert_byte(rng: &mut Pcg32, data: &mut Vec<u8>) {
    let at = below(rng, data.len() + 1);
    data.insert(at, rng.next_u32() as u8);
}
