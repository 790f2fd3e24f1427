//! Hash-driven bijections shared by the sequences: a seeded permutation of [0, n) and Owen's
//! nested uniform scrambling of 32-bit binary fractions.

use crate::sampling::rng::mix64;

/// `h(seed, value)`: 64 well-mixed bits, different for every (seed, value) pair in practice.
#[inline]
pub fn hash(seed: u64, value: u64) -> u64 {
    mix64(seed ^ mix64(value.wrapping_add(HASH_OFFSET)))
}

/// What [`hash`] adds to its value before mixing it.
pub const HASH_OFFSET: u64 = 0x9e37_79b9_7f4a_7c15;

/// Seed number `n` derived from a well-mixed `seed`: one SplitMix64 step (Steele, Lea & Flood
/// 2014), cheaper than `hash` for small constant n.
#[inline]
pub fn subseed(seed: u64, n: u64) -> u64 {
    mix64(seed.wrapping_add(n.wrapping_add(1).wrapping_mul(0x9e37_79b9_7f4a_7c15)))
}

/// The element at `index` of a permutation of [0, n) chosen by a well-mixed (hashed) `seed`,
/// n ≥ 1.
///
/// A w-bit bijective hash (w = bits of n − 1) is applied until the value falls in [0, n) (cycle
/// walking, as in Kensler 2013, "Correlated Multi-Jittered Sampling"), then rotated by an offset
/// r ∈ [0, n) taken from the seed's bits. The rotation makes P(index) uniform on [0, n) over
/// seeds whatever the hash's quality; the walk takes fewer than two rounds on average.
#[inline]
pub fn permute(index: u64, n: u64, seed: u64) -> u64 {
    debug_assert!(index < n, "permute: index {index} outside [0, {n})");
    if n <= 1 {
        return 0;
    }
    let bits = 64 - (n - 1).leading_zeros();
    let mask = u64::MAX >> (64 - bits);
    let shift = (bits / 2).max(1);
    let (s0, s1) = (seed, seed.rotate_left(29));
    let mut x = index;
    loop {
        // Each step is a bijection of the w-bit integers: xor with a constant, multiplication
        // by an odd number mod 2^w, x ⊕ (x >> s), addition mod 2^w.
        x ^= s0 & mask;
        x = x.wrapping_mul(0xe170_893d_9a2f_1c5b) & mask;
        x ^= x >> shift;
        x = x.wrapping_add(s1) & mask;
        x = x.wrapping_mul((s1 >> 7) | 1) & mask;
        x ^= x >> shift;
        x = x.wrapping_mul(0x0929_eb3f_a3c5_62b7) & mask;
        x ^= x >> shift;
        if x < n {
            break;
        }
    }
    // r = ⌊n · (the seed's bits as a fraction of 2^64)⌋ (Lemire's multiply-shift range map).
    let r = ((seed.rotate_left(43) as u128 * n as u128) >> 64) as u64;
    // (x + r) mod n without overflow: both are below n.
    if x >= n - r {
        x - (n - r)
    } else {
        x + r
    }
}

/// Laine & Karras's hash (2011) as improved by Vegdahl and used by Burley 2020: a bijection of
/// u32 in which each bit depends only on itself and the bits below it.
#[inline]
pub fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Owen's nested uniform scrambling of the binary fraction x / 2^32 (Burley 2020, "Practical
/// Hash-based Owen Scrambling"): bit i is flipped by a hash of the bits above it, so every
/// elementary interval [j/2^m, (j+1)/2^m) maps onto another one and the result is uniform.
#[inline]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permute_is_a_bijection_for_every_size() {
        for n in [1u64, 2, 3, 5, 7, 8, 9, 31, 64, 100, 257, 1000] {
            for seed in (0..20u64).map(|s| hash(s, n)) {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let p = permute(i, n, seed);
                    assert!(p < n && !seen[p as usize], "n {n} seed {seed}: {i} -> {p}");
                    seen[p as usize] = true;
                }
            }
        }
    }

    #[test]
    fn permuted_index_is_uniform_over_seeds() {
        // Chi-square over seeds of where index 3 of a permutation of [0, 10) lands: 9 degrees
        // of freedom, mean 9, standard deviation √18; allow mean + 5σ.
        let (n, trials) = (10u64, 50_000u64);
        let mut counts = [0u64; 10];
        for seed in 0..trials {
            counts[permute(3, n, hash(seed, 0)) as usize] += 1;
        }
        let expected = trials as f64 / n as f64;
        let chi2: f64 = counts
            .iter()
            .map(|&c| (c as f64 - expected).powi(2) / expected)
            .sum();
        assert!(
            chi2 < 9.0 + 5.0 * 18f64.sqrt(),
            "chi2 {chi2}, counts {counts:?}"
        );
    }

    #[test]
    fn owen_scramble_maps_elementary_intervals_onto_elementary_intervals() {
        // The 2^m fractions j·2^(32−m) + t for fixed low bits t land in distinct intervals of
        // width 2^−m: the scramble permutes those intervals.
        for seed in [0u32, 1, 0xdead_beef, u32::MAX] {
            for m in [1u32, 3, 6, 10] {
                let mut seen = vec![false; 1 << m];
                for j in 0..1u32 << m {
                    let x = (j << (32 - m)) | 0x1234 >> m;
                    let cell = (owen_scramble(x, seed) >> (32 - m)) as usize;
                    assert!(!seen[cell], "seed {seed} m {m}: interval {cell} hit twice");
                    seen[cell] = true;
                }
            }
        }
    }
}
