//! The Halton sequence (Halton 1960) with Owen scrambling: coordinate d of point i is the
//! radical inverse of i in the d-th prime base b, Σ_j a_j b^(−j−1) for i = Σ_j a_j b^j, with
//! each digit a_j replaced by π_node(a_j), a seeded permutation of the b digits chosen by the
//! digits already emitted (nested uniform scrambling, Owen 1995). Each point is uniform, and
//! the first b^m points keep one point in each interval [k/b^m, (k+1)/b^m).
//!
//! Digits are permuted until the index is exhausted and the resolution reaches 2^20 (so the
//! first million points of a dimension are exactly Owen-scrambled); the digits below are
//! uniform random bits hashed from the digits above, which is what the scrambling of the
//! remaining zero digits would produce.

use super::scramble::{hash, owen_scramble, permute};

/// The prime base of each dimension of the layout (see `sampler`).
pub const PRIMES: [u64; 10] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29];

/// Scrambled digits reach at least this resolution before the hashed tail.
const MIN_SCALE: u64 = 1 << 20;

/// Point `index` in `base`, a fraction of 2^32.
#[inline]
pub fn sample(index: u64, base: u64, seed: u64) -> u32 {
    if base == 2 {
        // Base 2: the bit-reversed index, Owen-scrambled in one hash. Indices beyond 2^32
        // continue with a fresh scramble.
        let seed = hash(seed, index >> 32);
        return owen_scramble((index as u32).reverse_bits(), seed);
    }
    let (mut rest, mut reversed, mut scale) = (index, 0u64, 1u64);
    while scale < 1 << 32 && (rest > 0 || scale < MIN_SCALE) {
        let digit = rest % base;
        rest /= base;
        // The node is the digits emitted so far: (reversed, scale) names it uniquely.
        let node = hash(seed, reversed ^ scale.rotate_left(40));
        reversed = reversed * base + permute(digit, base, node);
        scale *= base;
    }
    let tail = (hash(
        seed ^ 0x94d0_49bb_1331_11eb,
        reversed ^ scale.rotate_left(40),
    ) >> 32) as u32;
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
