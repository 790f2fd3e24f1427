//! Independent uniform points: every coordinate is 32 hashed bits of (pixel key, dimension,
//! sample index), so points at different indices are independent (plain Monte Carlo,
//! MSE ∝ 1/n).

use super::scramble::hash;

/// One coordinate, a fraction of 2^32.
#[inline]
pub fn sample_1d(index: u64, seed: u64) -> u32 {
    halves(hash(seed, index))[0]
}

/// Two coordinates from one 64-bit hash.
#[inline]
pub fn sample_2d(index: u64, seed: u64) -> [u32; 2] {
    halves(hash(seed, index))
}

/// The coordinates a 64-bit hash gives: its high half, then its low half.
#[inline]
pub fn halves(h: u64) -> [u32; 2] {
    [(h >> 32) as u32, h as u32]
}
