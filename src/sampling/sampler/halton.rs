//! The Halton sequence (Halton 1960) with Owen scrambling: coordinate d of point i is the
//! radical inverse of i in the d-th prime base b, Σ_j a_j b^(−j−1) for i = Σ_j a_j b^j, with
//! each digit a_j replaced by π_node(a_j), a seeded permutation of the b digits chosen by the
//! digits already emitted (nested uniform scrambling, Owen 1995). Each point is uniform, and
//! the first b^m points keep one point in each interval [k/b^m, (k+1)/b^m).
//!
//! Digits are permuted until the index is exhausted and the resolution reaches 2^16 (so the
//! first 65536 points of a dimension are exactly Owen-scrambled); the digits below are
//! uniform random bits hashed from the digits above, which is what the scrambling of the
//! remaining zero digits would produce.

use super::scramble::{hash, owen_scramble, permute};
use crate::sampling::rng::mix64;

/// The prime base of each dimension of the layout (see `sampler`).
pub const PRIMES: [u64; 10] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29];

/// Scrambled digits reach at least this resolution before the hashed tail.
const MIN_SCALE: u64 = 1 << 16;

/// Point `index` in `base` (one of `PRIMES`), a fraction of 2^32.
#[inline]
pub fn sample(index: u64, base: u64, seed: u64) -> u32 {
    // One instance per base, so the digit divisions are by constants.
    match base {
        2 => base_two(index, seed),
        3 => scrambled::<3>(index, seed),
        5 => scrambled::<5>(index, seed),
        7 => scrambled::<7>(index, seed),
        11 => scrambled::<11>(index, seed),
        13 => scrambled::<13>(index, seed),
        17 => scrambled::<17>(index, seed),
        19 => scrambled::<19>(index, seed),
        23 => scrambled::<23>(index, seed),
        _ => scrambled::<29>(index, seed),
    }
}

/// Base 2: the bit-reversed index, Owen-scrambled in one hash. Indices beyond 2^32 continue
/// with a fresh scramble.
#[inline]
fn base_two(index: u64, seed: u64) -> u32 {
    let seed = match index >> 32 {
        0 => seed,
        high => hash(seed, high),
    };
    owen_scramble((index as u32).reverse_bits(), seed as u32)
}

#[inline]
fn scrambled<const BASE: u64>(index: u64, seed: u64) -> u32 {
    let (mut rest, mut reversed, mut scale) = (index, 0u64, 1u64);
    while scale < 1 << 32 && (rest > 0 || scale < MIN_SCALE) {
        let digit = rest % BASE;
        rest /= BASE;
        // The node is the digits emitted so far; reversed + scale ∈ [scale, 2·scale) names it
        // uniquely.
        let node = mix64(seed ^ (reversed + scale));
        reversed = reversed * BASE + permute(digit, BASE, node);
        scale *= BASE;
    }
    let tail = (hash(seed, reversed + scale) >> 32) as u32;
    ((((reversed as u128) << 32) | tail as u128) / scale as u128) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_b_to_the_m_points_fill_every_interval() {
        for &base in &PRIMES {
            let m = if base < 10 { 3 } else { 2 };
            let n = base.pow(m);
            for seed in [1u64, 99] {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let cell = (sample(i, base, seed) as u64 * n) >> 32;
                    assert!(
                        !seen[cell as usize],
                        "base {base} seed {seed}: cell {cell} twice"
                    );
                    seen[cell as usize] = true;
                }
            }
        }
    }
}
