//! Error figures of one or more renders of the same configuration against a reference, over all
//! pixels and over lit-surface pixels (see `mask`), raw and corrected for the reference's noise.
//!
//! For a value i (pixel × channel) with render x, reference r, truth μ and the reference's
//! variance of the mean v = Var\[r] (its EXR variance layer), the render and the reference being
//! independent:
//!     E[(x − r)²] = E[(x − μ)²] + Var\[r],
//! so  t = (x − r)² − v  is an unbiased estimate of the render's own squared error against the
//! truth, and  MSE_corr = mean t = MSE − mean Var\[ref]  (relMSE likewise, each term divided by
//! r² + 1e-2). With R renders, Tᵢ = mean over renders of tᵢ; the Tᵢ of different pixels are
//! independent (separate sample streams in render and reference), so
//!     95% interval of MSE_corr = mean T ± 1.96 · sd(T) / √N        (N values, N large),
//! which covers the noise of the renders and of the reference together; the spread of the true
//! per-pixel errors enters sd(T) as well, making it conservative. The raw MSE's interval is the
//! spread across renders: mean ± t₀.₉₇₅,R−1 · sd / √R (R ≥ 2, as the seeds differ).

use serde::Serialize;

use super::fit::t_975;
use super::metrics::REL_MSE_EPSILON;
use crate::image::RgbImage;

/// Share of a region's summed squared error held by its worst pixel above which a
/// configuration is flagged as heavy-tailed.
pub const WORST_PIXEL_SHARE_FLAG: f64 = 0.1;

/// What renders are measured against: the reference's mean, its variance of the mean, and the
/// lit-surface mask (one flag per pixel), the last two when known.
#[derive(Clone, Copy)]
pub struct Against<'a> {
    pub mean: &'a RgbImage,
    pub variance: Option<&'a RgbImage>,
    pub lit: Option<&'a [bool]>,
}

/// Figures of one region (all pixels, or lit-surface pixels).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RegionErrors {
    /// Pixels in the region.
    pub pixels: usize,
    /// Mean over renders of the region's MSE.
    pub mse: f64,
    /// 95% interval across renders (None with one render).
    pub mse_interval: Option<[f64; 2]>,
    pub relmse: f64,
    pub relmse_interval: Option<[f64; 2]>,
    /// MSE − mean Var\[ref] over the region (None without a variance layer).
    pub mse_corrected: Option<f64>,
    /// Its 95% interval from the spread over values (see the module header).
    pub mse_corrected_interval: Option<[f64; 2]>,
    pub relmse_corrected: Option<f64>,
    pub relmse_corrected_interval: Option<[f64; 2]>,
    /// mean Var\[ref] over the region: what the correction subtracts from the MSE.
    pub reference_variance: Option<f64>,
    /// The largest share of the region's summed squared error held by one pixel.
    pub worst_pixel_share: f64,
}

/// Figures over all pixels and over lit-surface pixels (None without a mask or when no pixel
/// is lit surface).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Errors {
    pub all: RegionErrors,
    pub lit: Option<RegionErrors>,
}

/// One render's figures per region: (MSE, relMSE).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageFigures {
    pub all: (f64, f64),
    pub lit: Option<(f64, f64)>,
}

/// Sums over renders of each value's squared and relative squared error.
pub struct ErrorAccumulator {
    renders: u32,
    squared: Vec<f64>,
    relative: Vec<f64>,
    per_render: Vec<ImageFigures>,
}

impl ErrorAccumulator {
    /// An empty accumulator for images of `pixels` pixels.
    pub fn new(pixels: usize) -> ErrorAccumulator {
        ErrorAccumulator {
            renders: 0,
            squared: vec![0.0; 3 * pixels],
            relative: vec![0.0; 3 * pixels],
            per_render: Vec::new(),
        }
    }

    /// Adds one render (of the reference's size) and returns its own figures.
    pub fn add(&mut self, image: &RgbImage, against: &Against) -> ImageFigures {
        assert_eq!(image.pixels.len() * 3, self.squared.len(), "image size");
        let mut all = (0.0, 0.0, 0usize);
        let mut lit = (0.0, 0.0, 0usize);
        for (p, (x, r)) in image.pixels.iter().zip(&against.mean.pixels).enumerate() {
            let is_lit = against.lit.is_some_and(|m| m[p]);
            for c in 0..3 {
                let (x, r) = (x[c] as f64, r[c] as f64);
                let d2 = (x - r) * (x - r);
                let rel = d2 / (r * r + REL_MSE_EPSILON);
                self.squared[3 * p + c] += d2;
                self.relative[3 * p + c] += rel;
                all = (all.0 + d2, all.1 + rel, all.2 + 1);
                if is_lit {
                    lit = (lit.0 + d2, lit.1 + rel, lit.2 + 1);
                }
            }
        }
        self.renders += 1;
        let mean = |s: (f64, f64, usize)| (s.0 / s.2.max(1) as f64, s.1 / s.2.max(1) as f64);
        let figures = ImageFigures {
            all: mean(all),
            lit: (lit.2 > 0).then(|| mean(lit)),
        };
        self.per_render.push(figures);
        figures
    }

    /// The figures over every render added so far (at least one).
    pub fn finish(&self, against: &Against) -> Errors {
        let all = self.region(against, |_| true, |f| Some(f.all));
        let lit = against.lit.and_then(|mask| {
            mask.iter()
                .any(|&l| l)
                .then(|| self.region(against, |p| mask[p], |f| f.lit))
        });
        Errors {
            all: all.expect("one render at least"),
            lit: lit.flatten(),
        }
    }

    fn region(
        &self,
        against: &Against,
        inside: impl Fn(usize) -> bool,
        figures: impl Fn(&ImageFigures) -> Option<(f64, f64)>,
    ) -> Option<RegionErrors> {
        let per: Vec<(f64, f64)> = self.per_render.iter().filter_map(&figures).collect();
        if per.is_empty() {
            return None;
        }
        let renders = self.renders.max(1) as f64;
        let mses: Vec<f64> = per.iter().map(|f| f.0).collect();
        let rels: Vec<f64> = per.iter().map(|f| f.1).collect();
        let (mse, mse_interval) = mean_and_interval(&mses);
        let (relmse, relmse_interval) = mean_and_interval(&rels);

        let mut pixels = 0usize;
        let mut worst = 0.0f64;
        let mut total = 0.0f64;
        let mut corr = [Moments::default(), Moments::default()];
        let mut ref_var = Moments::default();
        for p in (0..self.squared.len() / 3).filter(|&p| inside(p)) {
            pixels += 1;
            let mut pixel_sum = 0.0;
            for c in 0..3 {
                let i = 3 * p + c;
                let sq = self.squared[i] / renders;
                pixel_sum += sq;
                if let Some(v) = against.variance {
                    let v = v.pixels[p][c] as f64;
                    let r = against.mean.pixels[p][c] as f64;
                    corr[0].add(sq - v);
                    corr[1].add(self.relative[i] / renders - v / (r * r + REL_MSE_EPSILON));
                    ref_var.add(v);
                }
            }
            worst = worst.max(pixel_sum);
            total += pixel_sum;
        }
        let corrected = against
            .variance
            .map(|_| corr.map(|m| m.mean_and_interval()));
        Some(RegionErrors {
            pixels,
            mse,
            mse_interval,
            relmse,
            relmse_interval,
            mse_corrected: corrected.map(|c| c[0].0),
            mse_corrected_interval: corrected.map(|c| c[0].1),
            relmse_corrected: corrected.map(|c| c[1].0),
            relmse_corrected_interval: corrected.map(|c| c[1].1),
            reference_variance: against.variance.map(|_| ref_var.mean()),
            worst_pixel_share: if total > 0.0 { worst / total } else { 0.0 },
        })
    }
}

/// One configuration's mean MSE at increasing spp: (spp, MSE over all pixels, MSE over
/// lit-surface pixels). Returns, for each step where either MSE does not fall, why: with
/// independent samples it should fall in proportion to the spp, so a flat or rising step is a
/// sign of heavy tails (rare huge samples) rather than of slow convergence.
pub fn not_falling(series: &[(u32, f64, Option<f64>)]) -> Vec<String> {
    let mut reasons = Vec::new();
    for pair in series.windows(2) {
        let ((s0, a0, l0), (s1, a1, l1)) = (pair[0], pair[1]);
        if a1 >= a0 {
            reasons.push(format!("MSE does not fall from {s0} to {s1} spp"));
        }
        if let (Some(l0), Some(l1)) = (l0, l1) {
            if l1 >= l0 {
                reasons.push(format!(
                    "lit-surface MSE does not fall from {s0} to {s1} spp"
                ));
            }
        }
    }
    reasons
}

/// Mean of per-render figures and its 95% interval across renders (t quantile; None for one).
pub fn mean_and_interval(xs: &[f64]) -> (f64, Option<[f64; 2]>) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let interval = (xs.len() >= 2).then(|| {
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let half = t_975(xs.len() - 1) * sd / n.sqrt();
        [mean - half, mean + half]
    });
    (mean, interval)
}

/// Running sums for a mean and the normal 95% interval of that mean over many values.
#[derive(Clone, Copy, Default)]
struct Moments {
    n: f64,
    sum: f64,
    sum_sq: f64,
}

impl Moments {
    fn add(&mut self, x: f64) {
        self.n += 1.0;
        self.sum += x;
        self.sum_sq += x * x;
    }

    fn mean(&self) -> f64 {
        self.sum / self.n.max(1.0)
    }

    fn mean_and_interval(&self) -> (f64, [f64; 2]) {
        let mean = self.mean();
        let var = if self.n > 1.0 {
            ((self.sum_sq - self.n * mean * mean) / (self.n - 1.0)).max(0.0)
        } else {
            0.0
        };
        let half = 1.96 * (var / self.n.max(1.0)).sqrt();
        (mean, [mean - half, mean + half])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_and_correction_match_hand_computed_values() {
        let reference = RgbImage::row(vec![[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]);
        let variance = RgbImage::row(vec![[0.01, 0.01, 0.01], [0.0, 0.0, 0.0]]);
        let lit = [true, false];
        let against = Against {
            mean: &reference,
            variance: Some(&variance),
            lit: Some(&lit),
        };
        let mut acc = ErrorAccumulator::new(2);
        let f = acc.add(
            &RgbImage::row(vec![[1.5, 1.0, 1.0], [0.0, 0.0, 3.0]]),
            &against,
        );
        // All: squared errors 0.25 and 9 over 6 values; lit: 0.25 over 3.
        assert!((f.all.0 - 9.25 / 6.0).abs() < 1e-12);
        assert!((f.lit.unwrap().0 - 0.25 / 3.0).abs() < 1e-12);
        let e = acc.finish(&against);
        let lit = e.lit.unwrap();
        assert_eq!((e.all.pixels, lit.pixels), (2, 1));
        assert!((lit.mse_corrected.unwrap() - (0.25 - 0.03) / 3.0).abs() < 1e-9);
        assert!((e.all.reference_variance.unwrap() - 0.03 / 6.0).abs() < 1e-9);
        let rel = (0.25 - 0.03) / 1.01 / 3.0;
        assert!((lit.relmse_corrected.unwrap() - rel).abs() < 1e-9);
        assert!((e.all.worst_pixel_share - 9.0 / 9.25).abs() < 1e-12);
        assert!(e.all.mse_interval.is_none());
        // A second render with no error halves the means and gives an interval across renders.
        acc.add(&reference, &against);
        let e = acc.finish(&against);
        assert!((e.all.mse - 9.25 / 12.0).abs() < 1e-12);
        let [lo, hi] = e.all.mse_interval.unwrap();
        let half = 12.706 * (9.25f64 / 6.0) / 2.0f64.sqrt() / 2.0f64.sqrt();
        assert!((hi - lo - 2.0 * half).abs() < 1e-9);
    }

    #[test]
    fn a_rising_step_is_named_and_a_falling_series_is_not() {
        let falling = [
            (1, 1.0, Some(0.5)),
            (4, 0.26, Some(0.12)),
            (16, 0.06, Some(0.03)),
        ];
        assert!(not_falling(&falling).is_empty());
        // Heavy tails: the 64-spp MSE above the 16-spp one (power + light-area on a city).
        let rising = [(16, 0.06, Some(0.03)), (64, 0.08, Some(0.01))];
        assert_eq!(
            not_falling(&rising),
            ["MSE does not fall from 16 to 64 spp"]
        );
        let lit_flat = [(16, 0.06, Some(0.03)), (64, 0.02, Some(0.03))];
        assert_eq!(
            not_falling(&lit_flat),
            ["lit-surface MSE does not fall from 16 to 64 spp"]
        );
    }

    #[test]
    fn no_mask_or_no_lit_pixel_gives_no_lit_figures() {
        let reference = RgbImage::row(vec![[1.0; 3]]);
        let none = [false];
        for lit in [None, Some(&none[..])] {
            let against = Against {
                mean: &reference,
                variance: None,
                lit,
            };
            let mut acc = ErrorAccumulator::new(1);
            acc.add(&reference, &against);
            let e = acc.finish(&against);
            assert!(e.lit.is_none());
            assert!(e.all.mse_corrected.is_none());
        }
    }
}
