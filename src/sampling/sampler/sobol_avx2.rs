//! Eight scrambled Sobol points at once in AVX2 lanes: the arithmetic of `sobol.rs`, lane by
//! lane, with the same results bit for bit. Owen scrambling (Laine–Karras, four 32-bit
//! multiplications) and bit reversal (two nibble lookups and a byte swap) are integer lane
//! operations; the generator matrices' XOR tables are read with gathers.

use std::arch::x86_64::*;

use super::sobol::{SeedLanes, DIM1_REVERSED, DIM2_REVERSED};

/// The points of indices `index` (one a lane, below 2^32) of groups seeded `seeds`:
/// `sobol::sample_3d` in each lane, each coordinate kept reversed (`Reversed`).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn sample_3d(index: __m256i, seeds: &SeedLanes) -> [__m256i; 3] {
    let reversed = shuffled(index, seeds);
    let [x, y] = first_two(reversed, seeds);
    let z = laine_karras(generate(&DIM2_REVERSED, reversed), load(seeds.third));
    [x, y, z]
}

/// The first coordinate of those points: `sobol::sample_1d` in each lane.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn sample_1d(index: __m256i, seeds: &SeedLanes) -> __m256i {
    laine_karras(reverse_bits(shuffled(index, seeds)), load(seeds.first))
}

/// The first two coordinates of those points: `sobol::sample_2d` in each lane.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn sample_2d(index: __m256i, seeds: &SeedLanes) -> [__m256i; 2] {
    first_two(shuffled(index, seeds), seeds)
}

/// Scrambled van der Corput and Sobol dimension 1 of the shuffled indices given reversed.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn first_two(reversed: __m256i, seeds: &SeedLanes) -> [__m256i; 2] {
    let x = laine_karras(reverse_bits(reversed), load(seeds.first));
    let y = laine_karras(generate(&DIM1_REVERSED, reversed), load(seeds.second));
    [x, y]
}

/// The shuffled indices, reversed (`sobol::shuffled_reversed`).
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn shuffled(index: __m256i, seeds: &SeedLanes) -> __m256i {
    laine_karras(reverse_bits(index), load(seeds.shuffle))
}

/// Each reversed coordinate as a 32-bit binary fraction: `Reversed::bits` in each lane.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn bits(reversed: __m256i) -> [u32; 8] {
    let mut out = [0u32; 8];
    _mm256_storeu_si256(out.as_mut_ptr().cast(), reverse_bits(reversed));
    out
}

/// The f32 in [0, 1) of each reversed coordinate: `Reversed::unit` in each lane, i.e. the top
/// 24 bits of the coordinate times 2^−24.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn units(reversed: __m256i) -> [f32; 8] {
    let top = _mm256_cvtepi32_ps(_mm256_srli_epi32::<8>(reverse_bits(reversed)));
    let mut out = [0f32; 8];
    _mm256_storeu_ps(
        out.as_mut_ptr(),
        _mm256_mul_ps(top, _mm256_set1_ps(1.0 / 16_777_216.0)),
    );
    out
}

/// Eight lanes from memory.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn load(lanes: [u32; 8]) -> __m256i {
    _mm256_loadu_si256(lanes.as_ptr().cast())
}

/// `scramble::laine_karras` in each lane.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn laine_karras(x: __m256i, seed: __m256i) -> __m256i {
    let times = |x, c: u32| _mm256_mullo_epi32(x, _mm256_set1_epi32(c as i32));
    let x = _mm256_xor_si256(x, times(x, 0x3d20_adea));
    let x = _mm256_add_epi32(x, seed);
    let odd = _mm256_or_si256(_mm256_srli_epi32::<16>(seed), _mm256_set1_epi32(1));
    let x = _mm256_mullo_epi32(x, odd);
    let x = _mm256_xor_si256(x, times(x, 0x0552_6c56));
    _mm256_xor_si256(x, times(x, 0x53a2_2864))
}

/// Nibble v with its four bits in reverse order, at index v.
const REVERSED_NIBBLE: [u8; 16] = [
    0x0, 0x8, 0x4, 0xc, 0x2, 0xa, 0x6, 0xe, 0x1, 0x9, 0x5, 0xd, 0x3, 0xb, 0x7, 0xf,
];
/// The byte shuffle that reverses the bytes of each 32-bit lane.
const BYTES_REVERSED: [u8; 16] = [3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12];

/// 16 bytes in both halves of a register (a byte shuffle's table).
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn broadcast(bytes: [u8; 16]) -> __m256i {
    _mm256_broadcastsi128_si256(_mm_loadu_si128(bytes.as_ptr().cast()))
}

/// `u32::reverse_bits` in each lane: each byte's nibbles reversed and swapped by two table
/// lookups, then the bytes of each lane in reverse order.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn reverse_bits(x: __m256i) -> __m256i {
    // Nibble v reversed, as the low nibble of a byte and as the high one (nibbles shifted
    // within each byte: none crosses into the next).
    let low = broadcast(REVERSED_NIBBLE);
    let high = _mm256_slli_epi16::<4>(low);
    let nibble = _mm256_set1_epi8(0x0f);
    let lo = _mm256_and_si256(x, nibble);
    let hi = _mm256_and_si256(_mm256_srli_epi16::<4>(x), nibble);
    let bytes = _mm256_or_si256(_mm256_shuffle_epi8(high, lo), _mm256_shuffle_epi8(low, hi));
    let swap = broadcast(BYTES_REVERSED);
    _mm256_shuffle_epi8(bytes, swap)
}

/// `sobol::generate` in each lane: the XOR of the four tables' entries for the index's bytes.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn generate(tables: &[[u32; 256]; 4], index: __m256i) -> __m256i {
    let byte = _mm256_set1_epi32(0xff);
    let entry = |table: &[u32; 256], bytes: __m256i| {
        _mm256_i32gather_epi32::<4>(table.as_ptr().cast(), _mm256_and_si256(bytes, byte))
    };
    let a = entry(&tables[0], index);
    let b = entry(&tables[1], _mm256_srli_epi32::<8>(index));
    let c = entry(&tables[2], _mm256_srli_epi32::<16>(index));
    let d = entry(&tables[3], _mm256_srli_epi32::<24>(index));
    _mm256_xor_si256(_mm256_xor_si256(a, b), _mm256_xor_si256(c, d))
}

#[cfg(test)]
mod tests {
    use super::super::sobol::{sample_3d as scalar_3d, GroupSeeds, Reversed};
    use super::*;
    use crate::sampling::rng::mix64;

    #[test]
    fn eight_lanes_give_the_scalar_points_bit_for_bit() {
        if !crate::cpu::has_avx2_fma() {
            return;
        }
        let mut state = 0x0123_4567_89ab_cdefu64;
        for round in 0..20_000u64 {
            let mut index = [0u32; 8];
            let mut seeds64 = [0u64; 8];
            for lane in 0..8 {
                state = mix64(state.wrapping_add(round * 8 + lane as u64));
                // Small, consecutive and arbitrary indices; a seed shared or not.
                index[lane] = match round % 3 {
                    0 => (round * 8 + lane as u64) as u32,
                    1 => u32::MAX - lane as u32,
                    _ => state as u32,
                };
                seeds64[lane] = if round % 2 == 0 {
                    mix64(round)
                } else {
                    mix64(state)
                };
            }
            let mut seeds = SeedLanes::default();
            for (lane, &seed) in seeds64.iter().enumerate() {
                seeds.set(lane, &GroupSeeds::of(seed));
            }
            let words = |v: __m256i| {
                let mut out = [0u32; 8];
                // SAFETY: an unaligned store of eight lanes.
                unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), v) };
                out
            };
            // SAFETY: the CPU has AVX2 (checked above).
            let (points, units, bits) = unsafe {
                let points = sample_3d(load(index), &seeds);
                (
                    points.map(words),
                    points.map(|c| units(c)),
                    points.map(|c| bits(c)),
                )
            };
            for lane in 0..8 {
                let scalar = scalar_3d(u64::from(index[lane]), seeds64[lane]);
                let at = |c: [u32; 8]| c[lane];
                let context = format!("index {} seed {:#x}", index[lane], seeds64[lane]);
                assert_eq!(points.map(at), scalar.map(Reversed::word), "{context}");
                assert_eq!(bits.map(at), scalar.map(Reversed::bits), "{context}");
                let unit_bits = |c: [f32; 8]| c[lane].to_bits();
                let scalar_units = scalar.map(|r| r.unit().to_bits());
                assert_eq!(units.map(unit_bits), scalar_units, "{context}");
            }
        }
    }
}
