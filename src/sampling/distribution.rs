//! Piecewise-constant distributions on [0,1) and [0,1)², sampled by inverting their CDFs
//! (pbrt-v4 §A.1 and §A.5). A 1D function of n values f_i has density p(x) = f_i / ∫f with
//! ∫f = Σ f_i / n on bin i = ⌊n·x⌋; the 2D one samples a row from the marginal Σ_j f_ij and then
//! a column from that row's conditional, so p(u, v) = f_ij / ∫∫f. CDFs are f64; a function that
//! is zero everywhere is sampled uniformly (density 1), so sampling never fails.

/// A piecewise-constant density on [0,1) over `func.len()` equal bins.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f64>,
    /// cdf[i] = Σ_{k<i} f_k / Σ f (n + 1 entries, cdf[n] = 1).
    cdf: Vec<f64>,
    /// ∫₀¹ f(x) dx = Σ f_i / n (0 when every value is 0: then sampled uniformly).
    integral: f64,
}

impl Distribution1D {
    /// Builds the CDF of `func` (non-negative, finite values; at least one).
    pub fn new(func: Vec<f64>) -> Distribution1D {
        assert!(!func.is_empty(), "a distribution needs at least one bin");
        debug_assert!(func.iter().all(|f| f.is_finite() && *f >= 0.0));
        let n = func.len() as f64;
        let mut cdf = Vec::with_capacity(func.len() + 1);
        let mut sum = 0.0;
        cdf.push(0.0);
        for f in &func {
            sum += f;
            cdf.push(sum);
        }
        if sum > 0.0 {
            cdf.iter_mut().for_each(|c| *c /= sum);
        } else {
            cdf.iter_mut()
                .enumerate()
                .for_each(|(i, c)| *c = i as f64 / n);
        }
        *cdf.last_mut().expect("n + 1 entries") = 1.0;
        Distribution1D {
            func,
            cdf,
            integral: sum / n,
        }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// ∫₀¹ f(x) dx.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Probability of bin i: cdf\[i+1] − cdf\[i].
    pub fn bin_probability(&self, i: usize) -> f64 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// Density at a point of bin i (with respect to dx on [0,1)).
    #[inline]
    pub fn pdf(&self, i: usize) -> f64 {
        if self.integral > 0.0 {
            self.func[i] / self.integral
        } else {
            1.0
        }
    }

    /// Inverts the CDF at u ∈ [0,1): (x ∈ [0,1), its bin, density). The bin is the last with
    /// cdf\[i] ≤ u, so a bin of zero probability is never returned.
    #[inline]
    pub fn sample(&self, u: f64) -> (f64, usize, f64) {
        let n = self.func.len();
        let i = (self.cdf.partition_point(|&c| c <= u).max(1) - 1).min(n - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let x = ((i as f64 + du) / n as f64).min(1.0 - f64::EPSILON);
        (x, i, self.pdf(i))
    }
}

/// A piecewise-constant density on [0,1)² over a width × height grid (row-major, row 0 at v = 0).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    /// One distribution over the columns of each row.
    conditional: Vec<Distribution1D>,
    /// Over rows, with each row's integral as its value.
    marginal: Distribution1D,
}

impl Distribution2D {
    /// Builds from `func` of `width × height` non-negative finite values, row by row.
    pub fn new(func: &[f64], width: usize, height: usize) -> Distribution2D {
        assert!(width > 0 && height > 0 && func.len() == width * height);
        let conditional: Vec<Distribution1D> = func
            .chunks_exact(width)
            .map(|row| Distribution1D::new(row.to_vec()))
            .collect();
        let marginal = Distribution1D::new(conditional.iter().map(|c| c.integral()).collect());
        Distribution2D {
            conditional,
            marginal,
        }
    }

    /// ∫∫ f(u, v) du dv = Σ f_ij / (width · height).
    pub fn integral(&self) -> f64 {
        self.marginal.integral()
    }

    /// Density p(u, v) = f_ij / ∫∫f at a point of cell (column, row).
    #[inline]
    pub fn pdf(&self, column: usize, row: usize) -> f64 {
        self.marginal.pdf(row) * self.conditional[row].pdf(column)
    }

    /// Samples a row from the marginal with u\[1], then a column of it with u\[0]:
    /// ((u, v) ∈ [0,1)², (column, row), p(u, v)).
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> ([f64; 2], [usize; 2], f64) {
        let (v, row, p_row) = self.marginal.sample(u[1] as f64);
        let (x, column, p_column) = self.conditional[row].sample(u[0] as f64);
        ([x, v], [column, row], p_row * p_column)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::sampling::rng::PixelRng;

    /// Pearson's χ² of `counts` against expected probabilities `p` over `total` draws, and its
    /// degrees of freedom (bins with p > 0, minus one). Draws in a bin with p = 0 fail at once.
    pub(crate) fn chi_square(counts: &[u64], p: &[f64], total: u64) -> (f64, usize) {
        let mut chi2 = 0.0;
        let mut bins = 0;
        for (&c, &p) in counts.iter().zip(p) {
            if p == 0.0 {
                assert_eq!(c, 0, "a bin of probability 0 was drawn");
                continue;
            }
            let expected = p * total as f64;
            chi2 += (c as f64 - expected).powi(2) / expected;
            bins += 1;
        }
        (chi2, bins - 1)
    }

    /// χ² with `dof` degrees of freedom is below mean + 5·sd = dof + 5·√(2·dof) except with
    /// negligible probability (fixed seeds make the tests deterministic anyway).
    pub(crate) fn assert_chi_square_passes(chi2: f64, dof: usize) {
        let bound = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
        assert!(
            chi2 < bound,
            "χ² = {chi2:.1} with {dof} dof (bound {bound:.1})"
        );
    }

    #[test]
    fn one_dimensional_samples_match_the_function() {
        let func = vec![0.0, 1.0, 5.0, 0.0, 0.0, 2.5, 0.1, 3.0];
        let d = Distribution1D::new(func.clone());
        let total: f64 = func.iter().sum();
        assert!((d.integral() - total / 8.0).abs() < 1e-12);
        let p: Vec<f64> = func.iter().map(|f| f / total).collect();
        let mut rng = PixelRng::new(3, 1);
        let draws = 200_000;
        let mut counts = vec![0u64; func.len()];
        for _ in 0..draws {
            let (x, i, pdf) = d.sample(rng.next_f64());
            assert!((0.0..1.0).contains(&x) && (x * 8.0) as usize == i);
            assert!((pdf - func[i] / d.integral()).abs() < 1e-12);
            counts[i] += 1;
        }
        let (chi2, dof) = chi_square(&counts, &p, draws);
        assert_chi_square_passes(chi2, dof);
        // The density integrates to 1: Σ pdf_i · (1/n).
        let sum: f64 = (0..8).map(|i| d.pdf(i) / 8.0).sum();
        assert!((sum - 1.0).abs() < 1e-12);
    }

    #[test]
    fn sampling_inverts_the_cdf_within_a_bin() {
        // Two bins of equal weight: u = 0.25 lies halfway into bin 0, u = 0.75 into bin 1.
        let d = Distribution1D::new(vec![2.0, 2.0]);
        assert_eq!(d.sample(0.25).0, 0.25);
        assert_eq!(d.sample(0.75).0, 0.75);
        assert_eq!(d.sample(0.0).1, 0);
        // u just below 1 stays in the last positive bin and below 1.
        let d = Distribution1D::new(vec![1.0, 0.0]);
        let (x, i, _) = d.sample(1.0 - f64::EPSILON / 2.0);
        assert!(i == 0 && x < 1.0);
    }

    #[test]
    fn an_all_zero_function_is_sampled_uniformly() {
        let d = Distribution1D::new(vec![0.0; 4]);
        assert_eq!(d.integral(), 0.0);
        for (u, bin) in [(0.1, 0), (0.3, 1), (0.6, 2), (0.99, 3)] {
            let (_, i, pdf) = d.sample(u);
            assert_eq!((i, pdf), (bin, 1.0));
        }
        let d2 = Distribution2D::new(&[0.0; 6], 3, 2);
        let (_, _, pdf) = d2.sample([0.5, 0.5]);
        assert_eq!(pdf, 1.0);
    }

    #[test]
    fn two_dimensional_samples_match_the_function_and_the_pdf_integrates_to_one() {
        let (w, h) = (6, 5);
        // Row 1 is all zero; a bright cell at (4, 3); a smooth rest.
        let func: Vec<f64> = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                match (i, j) {
                    (_, 1) => 0.0,
                    (4, 3) => 40.0,
                    _ => 0.5 + (i * j) as f64 * 0.1,
                }
            })
            .collect();
        let d = Distribution2D::new(&func, w, h);
        let total: f64 = func.iter().sum();
        assert!((d.integral() - total / (w * h) as f64).abs() < 1e-12);
        let integral: f64 = (0..w * h)
            .map(|k| d.pdf(k % w, k / w) / (w * h) as f64)
            .sum();
        assert!((integral - 1.0).abs() < 1e-12, "∫∫ p = {integral}");
        let p: Vec<f64> = func.iter().map(|f| f / total).collect();
        let mut rng = PixelRng::new(5, 2);
        let draws = 300_000;
        let mut counts = vec![0u64; w * h];
        for _ in 0..draws {
            let ([x, y], [i, j], pdf) = d.sample(rng.next_2d());
            assert!((x * w as f64) as usize == i && (y * h as f64) as usize == j);
            assert!((pdf - d.pdf(i, j)).abs() < 1e-9 * pdf);
            counts[j * w + i] += 1;
        }
        let (chi2, dof) = chi_square(&counts, &p, draws);
        assert_chi_square_passes(chi2, dof);
    }
}
