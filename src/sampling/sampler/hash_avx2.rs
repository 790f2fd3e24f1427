//! `scramble::hash` for eight indices at once in AVX2 lanes (two registers of four 64-bit
//! lanes), the same bits as one at a time. AVX2 multiplies 32-bit halves only, so each 64-bit
//! product (mod 2^64) is put together from three of them: lo·lo + ((hi·lo + lo·hi) << 32).

use std::arch::x86_64::*;

use super::scramble::HASH_OFFSET;
use crate::sampling::rng::MIX64_MULTIPLIERS as MIX;

/// `hash(seeds[d][lane], index[lane])` for every group d and lane: the index is mixed once and
/// shared by the groups, as `hash` mixes it the same way for every seed.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub unsafe fn hashes<const D: usize>(index: [u64; 8], seeds: &[[u64; 8]; D]) -> [[u64; 8]; D] {
    let half = |lanes: &[u64; 8], h: usize| _mm256_loadu_si256(lanes[4 * h..].as_ptr().cast());
    let offset = _mm256_set1_epi64x(HASH_OFFSET as i64);
    let mixed = [0, 1].map(|h| mix64(_mm256_add_epi64(half(&index, h), offset)));
    let mut out = [[0u64; 8]; D];
    for (row, seed) in out.iter_mut().zip(seeds) {
        for (h, &m) in mixed.iter().enumerate() {
            let v = mix64(_mm256_xor_si256(half(seed, h), m));
            _mm256_storeu_si256(row[4 * h..].as_mut_ptr().cast(), v);
        }
    }
    out
}

/// `rng::mix64` in each 64-bit lane.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn mix64(z: __m256i) -> __m256i {
    let z = _mm256_xor_si256(z, _mm256_srli_epi64::<30>(z));
    let z = times(z, MIX[0]);
    let z = _mm256_xor_si256(z, _mm256_srli_epi64::<27>(z));
    let z = times(z, MIX[1]);
    _mm256_xor_si256(z, _mm256_srli_epi64::<31>(z))
}

/// z · c mod 2^64 in each 64-bit lane.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn times(z: __m256i, c: u64) -> __m256i {
    let (c_lo, c_hi) = (
        _mm256_set1_epi64x(i64::from(c as u32)),
        _mm256_set1_epi64x((c >> 32) as i64),
    );
    let low = _mm256_mul_epu32(z, c_lo);
    let cross = _mm256_add_epi64(
        _mm256_mul_epu32(_mm256_srli_epi64::<32>(z), c_lo),
        _mm256_mul_epu32(z, c_hi),
    );
    _mm256_add_epi64(low, _mm256_slli_epi64::<32>(cross))
}

#[cfg(test)]
mod tests {
    use super::super::scramble::hash;
    use super::*;
    use crate::sampling::rng::mix64 as scalar_mix64;

    #[test]
    fn eight_lanes_give_the_scalar_hashes_bit_for_bit() {
        if !crate::cpu::has_avx2_fma() {
            return;
        }
        let mut state = 0x0bad_cafe_dead_beefu64;
        let mut next = || {
            state = scalar_mix64(state.wrapping_add(1));
            state
        };
        for round in 0..20_000u64 {
            // Consecutive, arbitrary and extreme indices; seeds shared or not.
            let index: [u64; 8] = std::array::from_fn(|lane| match round % 3 {
                0 => round * 8 + lane as u64,
                1 => u64::MAX - lane as u64,
                _ => next(),
            });
            let shared = next();
            let seeds: [[u64; 8]; 3] = std::array::from_fn(|_| {
                std::array::from_fn(|_| if round % 2 == 0 { shared } else { next() })
            });
            // SAFETY: the CPU has AVX2 (checked above).
            let got = unsafe { hashes(index, &seeds) };
            for (d, row) in got.iter().enumerate() {
                for lane in 0..8 {
                    let want = hash(seeds[d][lane], index[lane]);
                    assert_eq!(row[lane], want, "group {d}, index {}", index[lane]);
                }
            }
        }
    }
}
