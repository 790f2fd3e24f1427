//! Alias table for O(1) sampling of a discrete distribution (Walker 1977,
//! built with Vose's 1991 numerically stable O(n) method).
//!
//! Used to pick one emitter among many in proportion to a weight (e.g. the
//! power of each emissive triangle), and to return the exact probability of
//! any index for multiple-importance-sampling weights.

use super::prefetch::prefetch;

/// One bin of the table.
///
/// Layout: 8 + 8 + 4 bytes, padded to 24 bytes by the alignment of `f64`.
///
/// The threshold is kept in `f64` rather than `f32`: in `f32` it would carry a
/// relative error up to 2⁻²⁴ ≈ 6·10⁻⁸, so the probability with which an index
/// is actually drawn would differ from [`AliasTable::pmf`] by that much. The
/// pmf is used as the divisor of Monte Carlo estimators, so such a mismatch is
/// a bias; with `f64` the two agree to ~10⁻¹⁵ relative, and the bin still fits
/// in 24 bytes (saving 8 bytes with `f32` would buy nothing but that bias).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Bin {
    /// Probability, given that this bin was chosen, of returning the bin's own
    /// index rather than `alias`. Exactly 0 for zero-weight indices.
    threshold: f64,
    /// Exact probability of this bin's own index: `w_i / W`.
    pmf: f64,
    /// Index returned when the bin's own index is rejected. Always an index of
    /// positive weight.
    alias: u32,
}

/// Where a draw from an [`AliasTable`] starts (see [`AliasTable::start`]).
#[derive(Debug, Clone, Copy)]
pub struct Start {
    /// `min(⌊u·n⌋, n − 1)`, a valid bin.
    bin: usize,
    /// `u·n`.
    scaled: f64,
}

/// Alias table over indices `0..n` with probabilities proportional to given
/// weights `w_i`.
///
/// With `W = Σ w_i`, each of the `n` bins is chosen with probability `1/n`;
/// bin `i` then returns `i` with probability `threshold_i` and `alias_i`
/// otherwise, so
///
/// `P(i) = (threshold_i + Σ_{j: alias_j = i} (1 − threshold_j)) / n = w_i / W`.
///
/// Construction (Vose): scale `p_i = n·w_i/W`; repeatedly pair an entry with
/// `p_s < 1` with one with `p_l ≥ 1`, set `threshold_s = p_s`, `alias_s = l`,
/// and give `l` the residual `p_l ← (p_l + p_s) − 1` (this form of the
/// subtraction is the numerically stable one). Entries left when one worklist
/// runs dry differ from 1 only by round-off and get threshold 1.
#[derive(Debug, Clone)]
pub struct AliasTable {
    bins: Vec<Bin>,
}

impl AliasTable {
    /// Bytes per entry: an f64 threshold, the f64 exact pmf and a u32 alias, padded to 24.
    pub const BYTES_PER_ENTRY: usize = std::mem::size_of::<Bin>();

    /// Builds the table for `weights` in O(n).
    ///
    /// Returns `None` (the caller then falls back to uniform selection, or
    /// reports invalid input) when:
    /// - `weights` is empty, or has more than 2³² entries;
    /// - any weight is negative, NaN or infinite (the caller validates);
    /// - no weight is positive, or the total overflows `f64`.
    ///
    /// Zero weights are allowed: such indices are never sampled.
    pub fn new(weights: &[f64]) -> Option<AliasTable> {
        let n = weights.len();
        if n == 0 || n - 1 > u32::MAX as usize {
            return None;
        }
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        let total = neumaier_sum(weights);
        if !(total.is_finite() && total > 0.0) {
            return None;
        }
        Some(AliasTable {
            bins: vose_bins(weights, total),
        })
    }

    /// Number of indices `n` (including zero-weight ones).
    pub fn len(&self) -> usize {
        self.bins.len()
    }

    /// Always `false`: an empty table cannot be built.
    pub fn is_empty(&self) -> bool {
        self.bins.is_empty()
    }

    /// Exact probability `w_i / W` of drawing index `i` (0 outside `0..n`).
    #[inline]
    pub fn pmf(&self, i: usize) -> f64 {
        self.bins.get(i).map_or(0.0, |bin| bin.pmf)
    }

    /// Draws an index with probability `w_i / W` from one uniform `u ∈ [0, 1)`
    /// (use 53 random bits).
    ///
    /// `bin = min(⌊u·n⌋, n − 1)`, `frac = u·n − bin`; returns `bin` if
    /// `frac < threshold_bin`, else `alias_bin`. The fraction keeps
    /// `53 − log₂ n` bits of `u`. A `u` outside `[0, 1)` is clamped, and never
    /// yields a zero-weight index.
    pub fn sample(&self, u: f64) -> usize {
        self.sample_from(self.start(u))
    }

    /// Where `sample(u)` starts: the bin it reads first and u·n, kept by a
    /// caller that prefetches that bin (`prefetch_start`) and samples later
    /// (`sample_from`) without finding it again.
    #[inline(always)]
    pub fn start(&self, u: f64) -> Start {
        let n = self.bins.len();
        let scaled = u.clamp(0.0, 1.0) * n as f64;
        // `as` saturates (NaN → 0); the min handles u·n rounding up to n. Through i64, whose
        // conversion is one instruction, where usize's needs a second for values ≥ 2^63: u·n
        // is at most n ≤ 2^32, so both give the same integer.
        Start {
            bin: ((scaled as i64) as usize).min(n - 1),
            scaled,
        }
    }

    /// `sample(u)` from its `start(u)`.
    #[inline]
    pub fn sample_from(&self, start: Start) -> usize {
        let frac = start.scaled - start.bin as f64;
        let bin = &self.bins[start.bin];
        if frac < bin.threshold {
            start.bin
        } else {
            bin.alias as usize
        }
    }

    /// Starts loading the bin that `sample(u)` reads first: a hint that
    /// changes no result.
    #[inline]
    pub fn prefetch_sample(&self, u: f64) {
        self.prefetch_start(self.start(u));
    }

    /// Starts loading the bin that `sample_from(start)` reads: a hint that
    /// changes no result.
    #[inline]
    pub fn prefetch_start(&self, start: Start) {
        prefetch(&self.bins[start.bin]);
    }

    /// Starts loading index `i`'s bin (its pmf, which `sample_with_pmf` and
    /// `pmf` read) into the cache: a hint that changes no result.
    #[inline]
    pub fn prefetch(&self, i: usize) {
        if let Some(bin) = self.bins.get(i) {
            prefetch(bin);
        }
    }

    /// [`sample`](Self::sample) together with the [`pmf`](Self::pmf) of the
    /// drawn index.
    pub fn sample_with_pmf(&self, u: f64) -> (usize, f64) {
        let i = self.sample(u);
        (i, self.bins[i].pmf)
    }
}

/// Σ x_i with Neumaier's compensated summation: error ≈ one rounding of the
/// result, independent of n and of the spread of magnitudes.
fn neumaier_sum(values: &[f64]) -> f64 {
    let mut sum = 0.0_f64;
    let mut compensation = 0.0_f64;
    for &x in values {
        let t = sum + x;
        compensation += if sum.abs() >= x.abs() {
            (sum - t) + x
        } else {
            (x - t) + sum
        };
        sum = t;
    }
    sum + compensation
}

/// Vose's construction, given validated weights with positive finite `total`.
///
/// Zero-weight entries are paired first: while any remain, the unpaired
/// positive entries hold more mass than their count, so some `p_l > 1` by a
/// margin far above round-off. Hence every zero gets threshold 0 and an alias
/// of positive weight, and none can be among the round-off leftovers.
fn vose_bins(weights: &[f64], total: f64) -> Vec<Bin> {
    let n = weights.len();
    let n_f64 = n as f64;
    // The table itself, which every choice reads at random: on huge pages.
    let mut bins: Vec<Bin> = crate::alloc::on_huge_pages(|| Vec::with_capacity(n));
    let mut residual: Vec<f64> = Vec::with_capacity(n);
    let mut zeros: Vec<u32> = Vec::new();
    let mut small: Vec<u32> = Vec::new();
    let mut large: Vec<u32> = Vec::new();
    for (i, &w) in weights.iter().enumerate() {
        let pmf = w / total;
        let p = pmf * n_f64;
        // Lossless: n ≤ 2³² was checked by the caller.
        let index = i as u32;
        bins.push(Bin {
            threshold: 1.0,
            pmf,
            alias: index,
        });
        residual.push(p);
        if p == 0.0 {
            zeros.push(index);
        } else if p < 1.0 {
            small.push(index);
        } else {
            large.push(index);
        }
    }
    while let Some(&l) = large.last() {
        let Some(s) = zeros.pop().or_else(|| small.pop()) else {
            break;
        };
        let p_s = residual[s as usize];
        bins[s as usize].threshold = p_s;
        bins[s as usize].alias = l;
        let p_l = (residual[l as usize] + p_s) - 1.0;
        residual[l as usize] = p_l;
        if p_l < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // Leftovers in `small` (or `large`) have p = 1 up to round-off and keep
    // threshold 1 with alias = self, as initialised.
    bins
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// Uniform in [0, 1) from the top 53 bits of a u64.
    fn uniform(rng: &mut Pcg64) -> f64 {
        (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// `n` weights, log-uniform over [1e-12, 1e12], with about `zero_fraction`
    /// of them exactly 0 (index 0 is always positive).
    fn log_uniform_weights(n: usize, zero_fraction: f64, seed: u64) -> Vec<f64> {
        let mut rng = Pcg64::seed_from_u64(seed);
        (0..n)
            .map(|i| {
                let is_zero = i > 0 && uniform(&mut rng) < zero_fraction;
                let w = 10f64.powf(-12.0 + 24.0 * uniform(&mut rng));
                if is_zero {
                    0.0
                } else {
                    w
                }
            })
            .collect()
    }

    /// Every table the tests check, with a name for messages.
    fn test_tables() -> Vec<(&'static str, Vec<f64>)> {
        vec![
            ("one entry", vec![2.5]),
            ("two entries", vec![1.0, 3.0]),
            ("two, one zero", vec![0.0, 7.0]),
            ("two, extreme", vec![1e-12, 1e12]),
            ("1,000 log-uniform", log_uniform_weights(1_000, 0.05, 1)),
            (
                "1,000,000 log-uniform",
                log_uniform_weights(1_000_000, 0.05, 2),
            ),
        ]
    }

    /// Probability implied by the bins:
    /// (threshold_i + Σ_{j: alias_j = i} (1 − threshold_j)) / n.
    fn implied_probabilities(table: &AliasTable) -> Vec<f64> {
        let n = table.len();
        let mut mass: Vec<f64> = table.bins.iter().map(|b| b.threshold).collect();
        for bin in &table.bins {
            mass[bin.alias as usize] += 1.0 - bin.threshold;
        }
        mass.iter().map(|m| m / n as f64).collect()
    }

    #[test]
    fn pmf_sums_to_one() {
        for (name, weights) in test_tables() {
            let table = AliasTable::new(&weights).unwrap();
            let pmfs: Vec<f64> = (0..table.len()).map(|i| table.pmf(i)).collect();
            let sum = neumaier_sum(&pmfs);
            assert!((sum - 1.0).abs() < 1e-12, "{name}: Σ pmf = {sum}");
        }
    }

    #[test]
    fn pmf_is_exact_weight_ratio() {
        for (name, weights) in test_tables() {
            let table = AliasTable::new(&weights).unwrap();
            let total: f64 = neumaier_sum(&weights);
            for (i, w) in weights.iter().enumerate() {
                assert_eq!(table.pmf(i), w / total, "{name}: pmf({i})");
            }
        }
    }

    #[test]
    fn bins_imply_the_pmf() {
        for (name, weights) in test_tables() {
            let table = AliasTable::new(&weights).unwrap();
            for (i, implied) in implied_probabilities(&table).into_iter().enumerate() {
                let pmf = table.pmf(i);
                let error = (implied - pmf).abs();
                assert!(
                    error <= 1e-9 * pmf || error <= 1e-15,
                    "{name}: index {i}: bins imply {implied}, pmf {pmf}"
                );
            }
        }
    }

    #[test]
    fn zero_weights_are_unreachable_by_construction() {
        for (name, weights) in test_tables() {
            let table = AliasTable::new(&weights).unwrap();
            for (i, bin) in table.bins.iter().enumerate() {
                assert!(
                    weights[bin.alias as usize] > 0.0,
                    "{name}: bin {i} aliases a zero"
                );
                if weights[i] == 0.0 {
                    assert_eq!(bin.threshold, 0.0, "{name}: zero-weight bin {i}");
                }
            }
        }
    }

    /// Upper 5σ quantile of the chi-square distribution with `dof` degrees of
    /// freedom, by the Wilson–Hilferty cube-root normal approximation.
    fn chi_square_5_sigma(dof: usize) -> f64 {
        let k = dof as f64;
        let a = 2.0 / (9.0 * k);
        k * (1.0 - a + 5.0 * a.sqrt()).powi(3)
    }

    /// Pearson's statistic over the positive-pmf indices, cells with expected
    /// count < 5 pooled into one (merged into the smallest other cell if the
    /// pool itself is < 5). Returns (statistic, degrees of freedom).
    fn chi_square(table: &AliasTable, counts: &[u64], samples: u64) -> (f64, usize) {
        let mut cells: Vec<(f64, f64)> = Vec::new();
        let mut pool = (0.0, 0.0);
        for (i, &count) in counts.iter().enumerate() {
            let expected = table.pmf(i) * samples as f64;
            if expected >= 5.0 {
                cells.push((expected, count as f64));
            } else if expected > 0.0 {
                pool.0 += expected;
                pool.1 += count as f64;
            }
        }
        if pool.0 >= 5.0 || cells.is_empty() {
            cells.push(pool);
        } else if pool.0 > 0.0 {
            let smallest = cells
                .iter_mut()
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .expect("cells is not empty");
            smallest.0 += pool.0;
            smallest.1 += pool.1;
        }
        let statistic = cells.iter().map(|(e, o)| (o - e) * (o - e) / e).sum();
        (statistic, cells.len() - 1)
    }

    #[test]
    fn sampled_frequencies_fit_the_pmf() {
        for (seed, (name, weights)) in test_tables().into_iter().enumerate() {
            let table = AliasTable::new(&weights).unwrap();
            let samples: u64 = if weights.len() >= 1_000_000 {
                20_000_000
            } else {
                200_000
            };
            let mut rng = Pcg64::seed_from_u64(1000 + seed as u64);
            let mut counts = vec![0u64; weights.len()];
            for _ in 0..samples {
                counts[table.sample(uniform(&mut rng))] += 1;
            }
            for (i, &w) in weights.iter().enumerate() {
                if w == 0.0 {
                    assert_eq!(counts[i], 0, "{name}: zero-weight index {i} sampled");
                }
            }
            let (statistic, dof) = chi_square(&table, &counts, samples);
            if dof == 0 {
                // One cell: the only check is that nothing else was drawn.
                assert_eq!(counts.iter().sum::<u64>(), samples);
                continue;
            }
            let limit = chi_square_5_sigma(dof);
            assert!(
                statistic < limit,
                "{name}: χ² = {statistic} with {dof} dof exceeds 5σ limit {limit}"
            );
        }
    }

    #[test]
    fn sample_with_pmf_matches_pmf() {
        let weights = log_uniform_weights(1_000, 0.05, 3);
        let table = AliasTable::new(&weights).unwrap();
        let mut rng = Pcg64::seed_from_u64(7);
        for _ in 0..10_000 {
            let u = uniform(&mut rng);
            let (i, p) = table.sample_with_pmf(u);
            assert_eq!(i, table.sample(u));
            assert_eq!(p, table.pmf(i));
        }
    }

    #[test]
    fn bin_is_24_bytes() {
        assert_eq!(std::mem::size_of::<Bin>(), 24);
    }

    #[test]
    fn invalid_weights_give_none() {
        assert!(AliasTable::new(&[]).is_none());
        assert!(AliasTable::new(&[0.0, 0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[1.0, -1.0]).is_none());
        assert!(AliasTable::new(&[1.0, f64::NAN]).is_none());
        assert!(AliasTable::new(&[1.0, f64::INFINITY]).is_none());
        assert!(AliasTable::new(&[f64::MAX, f64::MAX]).is_none());
    }

    #[test]
    fn single_positive_weight_among_zeros_is_always_drawn() {
        let mut weights = vec![0.0; 1000];
        weights[417] = 1e-300;
        let table = AliasTable::new(&weights).unwrap();
        assert_eq!(table.len(), 1000);
        assert!(!table.is_empty());
        assert_eq!(table.pmf(417), 1.0);
        let mut rng = Pcg64::seed_from_u64(11);
        for _ in 0..100_000 {
            assert_eq!(table.sample(uniform(&mut rng)), 417);
        }
        for u in [0.0, 1.0 - f64::EPSILON / 2.0, 1.0, -0.5, 2.0, f64::NAN] {
            assert_eq!(table.sample(u), 417, "u = {u}");
        }
    }
}
