//! Per-pixel accumulation: f64 running mean and sample variance (Welford 1962) of the camera
//! samples' radiance, with non-finite samples counted and left out; statistics of separate
//! passes merge exactly (Chan, Golub & LeVeque 1979).

use glam::{DVec3, Vec3};

/// Running statistics of one pixel's samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    pub count: u64,
    pub mean: DVec3,
    /// Σ (x − mean)², updated incrementally.
    pub m2: DVec3,
    /// How many of the `count` samples' primary rays hit a surface without emission.
    pub surface: u64,
}

impl PixelStats {
    #[inline]
    pub fn add(&mut self, x: DVec3) {
        self.count += 1;
        let delta = x - self.mean;
        self.mean += delta / self.count as f64;
        self.m2 += delta * (x - self.mean);
    }

    /// Combines the statistics of two disjoint sets of samples into those of their union
    /// (Chan et al.): with δ = mean_b − mean_a and n = n_a + n_b,
    /// mean = mean_a + δ·n_b/n and M2 = M2_a + M2_b + δ²·n_a·n_b/n.
    pub fn merge(&mut self, other: &PixelStats) {
        if other.count == 0 {
            return;
        }
        let (na, nb) = (self.count as f64, other.count as f64);
        let n = na + nb;
        let delta = other.mean - self.mean;
        self.mean += delta * (nb / n);
        self.m2 += other.m2 + delta * delta * (na * nb / n);
        self.count += other.count;
        self.surface += other.surface;
    }

    /// Fraction of the samples whose primary ray hit a surface without emission (0 without
    /// samples).
    pub fn surface_fraction(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.surface as f64 / self.count as f64
        }
    }

    /// Unbiased sample variance of one sample, s² = M2 / (n − 1).
    pub fn sample_variance(&self) -> DVec3 {
        if self.count < 2 {
            DVec3::ZERO
        } else {
            self.m2 / (self.count - 1) as f64
        }
    }

    /// Estimated variance of the pixel mean, s² / n.
    pub fn variance_of_mean(&self) -> DVec3 {
        if self.count < 2 {
            DVec3::ZERO
        } else {
            self.sample_variance() / self.count as f64
        }
    }
}

/// Whether a sample is usable, and if not, why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleClass {
    Finite,
    Nan,
    Infinite,
}

pub fn classify(x: Vec3) -> SampleClass {
    if x.is_nan() {
        SampleClass::Nan
    } else if !x.is_finite() {
        SampleClass::Infinite
    } else {
        SampleClass::Finite
    }
}

/// The image being accumulated: row-major, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<PixelStats>,
}

impl Film {
    /// Merges the statistics of another render of the same image size, pixel by pixel.
    pub fn merge(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "films of different sizes"
        );
        for (a, b) in self.pixels.iter_mut().zip(&other.pixels) {
            a.merge(b);
        }
    }

    pub fn mean_rgb(&self) -> Vec<[f32; 3]> {
        self.pixels
            .iter()
            .map(|p| p.mean.as_vec3().to_array())
            .collect()
    }

    /// Per pixel, the fraction of samples whose primary ray hit a surface without emission.
    pub fn surface_fractions(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .map(|p| p.surface_fraction() as f32)
            .collect()
    }

    pub fn variance_of_mean_rgb(&self) -> Vec<[f32; 3]> {
        self.pixels
            .iter()
            .map(|p| p.variance_of_mean().as_vec3().to_array())
            .collect()
    }

    /// Mean over all pixels of the per-channel-averaged pixel value (f64).
    pub fn image_mean(&self) -> f64 {
        let sum: f64 = self.pixels.iter().map(|p| p.mean.element_sum() / 3.0).sum();
        sum / self.pixels.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welford_matches_the_two_pass_formulas() {
        let xs = [1.0, 4.0, 4.0, 10.0, -3.5, 1e-3];
        let mut p = PixelStats::default();
        xs.iter().for_each(|&x| p.add(DVec3::splat(x)));
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
        assert!((p.mean.x - mean).abs() < 1e-12);
        assert!((p.sample_variance().x - var).abs() < 1e-12);
        assert!((p.variance_of_mean().x - var / n).abs() < 1e-12);
    }

    #[test]
    fn merging_passes_equals_accumulating_all_samples_in_one() {
        let xs = [3.0, -1.0, 0.25, 8.0, 8.0, 1e-4, 42.0, -7.5, 0.0];
        let mut all = PixelStats::default();
        xs.iter().for_each(|&x| all.add(DVec3::splat(x)));
        for split in 0..=xs.len() {
            let (mut a, mut b) = (PixelStats::default(), PixelStats::default());
            xs[..split].iter().for_each(|&x| a.add(DVec3::splat(x)));
            xs[split..].iter().for_each(|&x| b.add(DVec3::splat(x)));
            a.merge(&b);
            assert_eq!(a.count, all.count);
            assert!(
                (a.mean - all.mean).abs().max_element() < 1e-12,
                "split {split}"
            );
            assert!((a.m2 - all.m2).abs().max_element() < 1e-10, "split {split}");
        }
    }

    #[test]
    fn a_million_equal_samples_accumulate_without_drift() {
        let mut p = PixelStats::default();
        let x = DVec3::new(0.1, 1e-7, 12345.678);
        (0..1_000_000).for_each(|_| p.add(x));
        assert_eq!(p.mean, x);
        assert!(p.sample_variance().max_element() < 1e-20);
    }

    #[test]
    fn classify_separates_nan_and_inf() {
        assert_eq!(classify(Vec3::new(1.0, f32::NAN, 0.0)), SampleClass::Nan);
        assert_eq!(
            classify(Vec3::new(f32::INFINITY, 0.0, 0.0)),
            SampleClass::Infinite
        );
        assert_eq!(classify(Vec3::ONE), SampleClass::Finite);
    }
}
