//! Jittered stratification of a known count of points: point i of `count` lies in stratum
//! π(i) of a seeded permutation π, uniformly jittered inside it. In 1D the strata are the
//! `count` intervals of width 1/count, each hit exactly once; in 2D a grid of nx × ny ≥ count
//! cells (nx = ⌈√count⌉, ny = ⌈count/nx⌉), each hit at most once and exactly once when
//! nx·ny = count. Each point is uniform on [0,1)^d (π(i) is uniform over the strata).

use super::scramble::{hash, permute};

/// The fraction of 2^32 at `(stratum + jitter/2^32) / strata`, exact in integers.
#[inline]
pub fn in_stratum(stratum: u64, jitter: u32, strata: u64) -> u32 {
    if stratum >> 32 == 0 {
        (((stratum << 32) | jitter as u64) / strata) as u32
    } else {
        ((((stratum as u128) << 32) | jitter as u128) / strata as u128) as u32
    }
}

/// Point `index` of `count` stratified in 1D.
#[inline]
pub fn sample_1d(index: u64, count: u64, seed: u64) -> u32 {
    let stratum = permute(index, count, seed);
    in_stratum(stratum, (hash(seed, index) >> 32) as u32, count)
}

/// The nx × ny grid for `count` points: the most nearly square one with nx·ny ≥ count.
pub fn grid(count: u64) -> (u64, u64) {
    let mut nx = (count as f64).sqrt().ceil() as u64;
    while nx > 1 && (nx - 1) * (nx - 1) >= count {
        nx -= 1;
    }
    while nx * nx < count {
        nx += 1;
    }
    (nx, count.div_ceil(nx).max(1))
}

/// Point `index` of `count` on the jittered nx × ny grid.
#[inline]
pub fn sample_2d(index: u64, count: u64, seed: u64) -> [u32; 2] {
    let (nx, ny) = grid(count);
    let stratum = permute(index, nx * ny, seed);
    let jitter = hash(seed, index);
    [
        in_stratum(stratum % nx, (jitter >> 32) as u32, nx),
        in_stratum(stratum / nx, jitter as u32, ny),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_nearly_square_and_covers_the_count() {
        for count in 1..2000u64 {
            let (nx, ny) = grid(count);
            assert!(nx * ny >= count, "{count}: {nx}x{ny}");
            assert!(nx * (ny - 1) < count, "{count}: {nx}x{ny} has an empty row");
            assert!(nx.abs_diff(ny) <= 1, "{count}: {nx}x{ny}");
        }
        assert_eq!(grid(64), (8, 8));
        assert_eq!(grid(32), (6, 6));
    }

    #[test]
    fn in_stratum_stays_inside_the_stratum() {
        for strata in [1u64, 3, 7, 1 << 20, (1 << 33) + 5] {
            for stratum in [0, strata / 2, strata - 1] {
                for jitter in [0u32, 1 << 31, u32::MAX] {
                    let x = in_stratum(stratum, jitter, strata) as f64 / 2f64.powi(32);
                    let (lo, hi) = (
                        stratum as f64 / strata as f64,
                        (stratum + 1) as f64 / strata as f64,
                    );
                    assert!(
                        x >= lo - 1e-9 && x < hi,
                        "{stratum}/{strata} jitter {jitter}: {x}"
                    );
                }
            }
        }
    }
}
