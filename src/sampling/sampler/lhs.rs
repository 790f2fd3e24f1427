//! Latin hypercube sampling (N-rooks, McKay, Beckman & Conover 1979): each coordinate of point
//! i of `count` is stratified in 1D by its own seeded permutation, so every one of the `count`
//! rows and every column holds exactly one point, with no joint 2D stratification.

use super::scramble::subseed;
use super::stratified;

/// Point `index` of `count`: x and y stratified with independent permutations.
#[inline]
pub fn sample_2d(index: u64, count: u64, seed: u64) -> [u32; 2] {
    [
        stratified::sample_1d(index, count, seed),
        stratified::sample_1d(index, count, subseed(seed, 0)),
    ]
}
