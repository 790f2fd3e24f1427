//! The environment light: radiance arriving from infinitely far away, built from the scene's
//! [`EnvironmentImage`] (scaled texels and rotation; its module states the equirectangular
//! convention) and importance-sampled texel by texel.
//!
//! Radiance is piecewise constant: L(ω) is the value of the texel ω falls in (nearest, no
//! filtering), so the sampling density matches the integrand's shape exactly. Sampling draws a
//! texel from the 2D piecewise-constant distribution f_ij = luminance(L_ij)·sinθ_j (θ_j at the
//! row centre) and a point uniformly in it, p(u, v) = f_ij / ∫∫f; with dω = 2π²·sinθ du dv the
//! solid-angle density is p(ω) = p(u, v) / (2π²·sinθ) (pbrt-v4 §12.5.2).

use std::f64::consts::PI;
use std::sync::Arc;

use glam::{DVec3, Vec3};

pub mod sky_irradiance;

use crate::color::luminance;
use crate::sampling::distribution::Distribution2D;
use crate::sampling::warp::equirectangular_direction;
use crate::scene::EnvironmentImage;
use sky_irradiance::IrradianceTable;

/// A direction drawn from the map: unit direction toward the sky, the radiance arriving from it
/// and the density in solid angle.
#[derive(Clone, Copy, Debug)]
pub struct EnvironmentSample {
    pub wi: Vec3,
    pub radiance: Vec3,
    pub pdf: f32,
}

/// The scene's environment image with what sampling and the oracle need: its texel
/// distribution, integral and irradiance table.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    /// The scaled texels (row 0 at the zenith), their size and the rotation.
    image: Arc<EnvironmentImage>,
    distribution: Distribution2D,
    /// (sin α, cos α) of the rotation about +Y.
    rotation: (f32, f32),
    /// ∫ L dω over the sphere per channel, the exact texel sum Σ L_ij·Ω_j.
    integral: DVec3,
    /// Unshadowed irradiance (luminance) onto a receiver of any normal, for the oracle.
    irradiance: IrradianceTable,
}

impl EnvironmentMap {
    /// Builds the sampling distribution ∝ luminance(L_ij)·sinθ_j, the integral and the
    /// irradiance table of `image`.
    pub fn new(image: Arc<EnvironmentImage>) -> EnvironmentMap {
        let (width, height) = (image.width(), image.height());
        let texels = image.texels();
        let mut weights = Vec::with_capacity(texels.len());
        let mut integral = DVec3::ZERO;
        for j in 0..height {
            let sin_theta = (PI * (j as f64 + 0.5) / height as f64).sin();
            let omega = texel_solid_angle(j, width, height);
            for l in &texels[j * width..(j + 1) * width] {
                weights.push(luminance(*l) as f64 * sin_theta);
                integral += l.as_dvec3() * omega;
            }
        }
        let (sin, cos) = image.rotation_degrees().to_radians().sin_cos();
        let luminances: Vec<f32> = texels.iter().map(|l| luminance(*l)).collect();
        EnvironmentMap {
            irradiance: IrradianceTable::new(&luminances, width, height),
            distribution: Distribution2D::new(&weights, width, height),
            rotation: (sin, cos),
            integral,
            image,
        }
    }

    /// ∫ L(ω) dω over the sphere, per channel (exact for the piecewise-constant map).
    pub fn integral(&self) -> DVec3 {
        self.integral
    }

    /// ∫ luminance(L(ω)) dω over the sphere.
    pub fn luminance_integral(&self) -> f64 {
        0.2126 * self.integral.x + 0.7152 * self.integral.y + 0.0722 * self.integral.z
    }

    /// Unshadowed irradiance in luminance, ∫ luminance(L(ω))·max(0, n·ω) dω, onto a receiver
    /// of unit world normal `n` (a table accurate to a few percent; see `sky_irradiance`).
    pub fn irradiance(&self, n: Vec3) -> f64 {
        self.irradiance.at(self.to_map_frame(n))
    }

    /// R_y(−α)·w: a world direction in the map's frame.
    #[inline]
    fn to_map_frame(&self, w: Vec3) -> DVec3 {
        let (sin, cos) = self.rotation;
        DVec3::new(
            (w.x * cos - w.z * sin) as f64,
            w.y as f64,
            (w.x * sin + w.z * cos) as f64,
        )
    }

    /// The texel (column, row) that unit world direction `w` falls in, and sinθ (f64).
    #[inline]
    fn texel_of(&self, w: Vec3) -> (usize, usize, f64) {
        let DVec3 { x, y, z } = self.to_map_frame(w);
        let y = y.clamp(-1.0, 1.0);
        let phi = (-x).atan2(z);
        let u = if phi < 0.0 { phi + 2.0 * PI } else { phi } / (2.0 * PI);
        let v = y.acos() / PI;
        let (width, height) = (self.image.width(), self.image.height());
        let column = ((u * width as f64) as usize).min(width - 1);
        let row = ((v * height as f64) as usize).min(height - 1);
        (column, row, (x * x + z * z).sqrt())
    }

    /// World direction of map coordinates (u, v) ∈ [0,1)², and sinθ.
    #[inline]
    fn direction(&self, u: f64, v: f64) -> (Vec3, f64) {
        let DVec3 { x, y, z } = equirectangular_direction(u, v);
        let (sin, cos) = (self.rotation.0 as f64, self.rotation.1 as f64);
        let w = DVec3::new(x * cos + z * sin, y, -x * sin + z * cos);
        (w.as_vec3(), (x * x + z * z).sqrt())
    }

    /// L(ω) arriving from unit direction `w` (pointing away from the receiver).
    #[inline]
    pub fn radiance(&self, w: Vec3) -> Vec3 {
        let (column, row, _) = self.texel_of(w);
        self.texel(column, row)
    }

    /// The scaled radiance of texel (column, row).
    #[inline]
    fn texel(&self, column: usize, row: usize) -> Vec3 {
        self.image.texels()[row * self.image.width() + column]
    }

    /// A direction ∝ luminance(L)·sinθ per texel, from two uniform numbers; None when it lands
    /// on a pole (sinθ = 0, probability 0).
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
        let ([su, sv], [column, row], p_uv) = self.distribution.sample(u);
        let (wi, sin_theta) = self.direction(su, sv);
        if !(sin_theta > 0.0 && p_uv > 0.0) {
            return None;
        }
        Some(EnvironmentSample {
            wi,
            radiance: self.texel(column, row),
            pdf: (p_uv / (2.0 * PI * PI * sin_theta)) as f32,
        })
    }

    /// The solid-angle density with which `sample` returns unit direction `w`.
    #[inline]
    pub fn pdf(&self, w: Vec3) -> f32 {
        let (column, row, sin_theta) = self.texel_of(w);
        if sin_theta <= 0.0 {
            return 0.0;
        }
        (self.distribution.pdf(column, row) / (2.0 * PI * PI * sin_theta)) as f32
    }
}

/// Solid angle of a texel of row j: (2π/W)·(cos θ_j − cos θ_{j+1}), θ_j = π·j/H.
fn texel_solid_angle(row: usize, width: usize, height: usize) -> f64 {
    let theta = |j: usize| PI * j as f64 / height as f64;
    2.0 * PI / width as f64 * (theta(row).cos() - theta(row + 1).cos())
}

/// The environment as one light of a scene: its map and the radius of the scene's bounding
/// sphere, which sizes its power for selection.
#[derive(Clone, Debug)]
pub struct EnvironmentLight {
    pub map: Arc<EnvironmentMap>,
    pub scene_radius: f32,
}

impl EnvironmentLight {
    /// Φ = π·R²·∫ luminance(L) dω: the power the sky sends through the scene's bounding sphere
    /// (a directional light's π·R²·E summed over directions; pbrt-v4's infinite-light Φ).
    pub fn power(&self) -> f64 {
        PI * (self.scene_radius as f64).powi(2) * self.map.luminance_integral()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::RgbImage;
    use crate::sampling::distribution::tests::{assert_chi_square_passes, chi_square};
    use crate::sampling::rng::PixelRng;

    /// A 16×8 map: a smooth sky, a black row, and one bright texel (a sun).
    fn test_map(rotate_degrees: f32) -> EnvironmentMap {
        let (w, h) = (16, 8);
        let pixels = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                match (i, j) {
                    (_, 6) => [0.0; 3],
                    (11, 2) => [300.0, 280.0, 250.0],
                    _ => [0.2 + 0.05 * i as f32, 0.4, 0.8 - 0.1 * j as f32],
                }
            })
            .collect();
        let image = RgbImage {
            width: w,
            height: h,
            pixels,
        };
        EnvironmentMap::new(Arc::new(
            EnvironmentImage::from_rgb(&image, 1.5, rotate_degrees).unwrap(),
        ))
    }

    #[test]
    fn the_convention_puts_the_zenith_in_row_zero_and_the_image_centre_at_minus_z() {
        let map = test_map(0.0);
        let (_, row, _) = map.texel_of(Vec3::Y);
        assert_eq!(row, 0);
        let (column, row, _) = map.texel_of(Vec3::new(0.0, -0.01, -1.0).normalize());
        assert_eq!((column, row), (8, 4));
        assert_eq!(map.texel_of(Vec3::new(1.0, 0.01, 0.0).normalize()).0, 12);
        assert_eq!(map.texel_of(Vec3::new(-1.0, 0.01, 0.0).normalize()).0, 4);
        // Rotating by 90° about +Y carries the map's −Z (centre) to world −X.
        let turned = test_map(90.0);
        let w = Vec3::new(-1.0, -0.01, 0.0).normalize();
        assert_eq!(turned.texel_of(w).0, 8);
        // The oracle's irradiance turns with the map: the turned map's E at n is the plain
        // map's at R_y(−90°)·n.
        for n in [Vec3::X, Vec3::new(0.3, 0.5, -0.8).normalize(), -Vec3::Z] {
            let back = Vec3::new(-n.z, n.y, n.x);
            let (a, b) = (turned.irradiance(n), map.irradiance(back));
            assert!(
                (a - b).abs() < 1e-6 * b,
                "{a} vs {b} (equal up to f32 rounding)"
            );
        }
        // direction() and texel_of() are inverse.
        for (u, v) in [(0.03, 0.2), (0.51, 0.77), (0.97, 0.5)] {
            for m in [&map, &turned] {
                let (w, _) = m.direction(u, v);
                let (c, r, _) = m.texel_of(w);
                assert_eq!((c, r), ((u * 16.0) as usize, (v * 8.0) as usize));
            }
        }
    }

    #[test]
    fn sampled_directions_follow_the_pdf() {
        // χ² of sampled directions binned on the world sphere: 32 bins in φ by 16 in θ, each
        // texel row split where cosθ is halfway (so a wrong sinθ in the density shows), the map
        // turned by 3 texels (67.5°) so that texel edges fall on bin edges. Each bin's expected
        // probability is ∫ pdf(ω) dω = ∫∫ pdf · sinθ dθ dφ by 4×4 midpoint quadrature, exact
        // where pdf·sinθ is constant over the bin, as it must be for texel-uniform sampling.
        let map = test_map(67.5);
        let (nphi, h) = (32, 8);
        let theta_edges: Vec<f64> = (0..=2 * h)
            .map(|k| {
                let (j, half) = (k / 2, k % 2);
                let (t0, t1) = (PI * j as f64 / h as f64, PI * (j + 1) as f64 / h as f64);
                match (half, j == h) {
                    (0, _) | (_, true) => t0,
                    _ => (0.5 * (t0.cos() + t1.cos())).acos(),
                }
            })
            .collect();
        let world = |theta: f64, phi: f64| {
            let (st, ct) = theta.sin_cos();
            Vec3::new((-st * phi.sin()) as f32, ct as f32, (st * phi.cos()) as f32)
        };
        let bins = nphi * 2 * h;
        let q = 4;
        let mut expected = vec![0.0; bins];
        for (b, e) in expected.iter_mut().enumerate() {
            let (i, k) = (b % nphi, b / nphi);
            let (t0, t1) = (theta_edges[k], theta_edges[k + 1]);
            let dphi = 2.0 * PI / nphi as f64;
            for a in 0..q {
                for c in 0..q {
                    let theta = t0 + (t1 - t0) * (a as f64 + 0.5) / q as f64;
                    let phi = dphi * (i as f64 + (c as f64 + 0.5) / q as f64);
                    let d_omega = theta.sin() * (t1 - t0) / q as f64 * dphi / q as f64;
                    *e += map.pdf(world(theta, phi)) as f64 * d_omega;
                }
            }
        }
        let total: f64 = expected.iter().sum();
        assert!((total - 1.0).abs() < 1e-4, "∫ pdf dω = {total}");

        let draws = 400_000u64;
        let mut rng = PixelRng::new(9, 4);
        let mut counts = vec![0u64; bins];
        for _ in 0..draws {
            let s = map.sample(rng.next_2d()).unwrap();
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            assert_eq!(s.radiance, map.radiance(s.wi));
            assert!((s.pdf - map.pdf(s.wi)).abs() <= 1e-3 * s.pdf);
            let theta = (s.wi.y as f64).clamp(-1.0, 1.0).acos();
            let phi = (-s.wi.x as f64).atan2(s.wi.z as f64).rem_euclid(2.0 * PI);
            let i = ((phi / (2.0 * PI) * nphi as f64) as usize).min(nphi - 1);
            let k = theta_edges[1..]
                .partition_point(|&t| t <= theta)
                .min(2 * h - 1);
            counts[k * nphi + i] += 1;
        }
        let (chi2, dof) = chi_square(&counts, &expected, draws);
        assert_chi_square_passes(chi2, dof);
    }

    #[test]
    fn importance_sampled_integral_matches_the_texel_sum() {
        let map = test_map(-45.0);
        // Exact ∫ L dω, computed here independently: Σ_j Σ_i L_ij · Ω_j.
        let mut exact = DVec3::ZERO;
        for j in 0..8 {
            let omega =
                2.0 * PI / 16.0 * ((PI * j as f64 / 8.0).cos() - (PI * (j + 1) as f64 / 8.0).cos());
            for i in 0..16 {
                exact += map.texel(i, j).as_dvec3() * omega;
            }
        }
        assert!((exact - map.integral()).abs().max_element() < 1e-9 * exact.max_element());
        let n = 100_000;
        let mut rng = PixelRng::new(1, 1);
        let (mut sum, mut sum2) = (DVec3::ZERO, DVec3::ZERO);
        for _ in 0..n {
            let y = match map.sample(rng.next_2d()) {
                Some(s) => (s.radiance / s.pdf).as_dvec3(),
                None => DVec3::ZERO,
            };
            sum += y;
            sum2 += y * y;
        }
        let mean = sum / n as f64;
        let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).max(DVec3::ZERO);
        let sigma = DVec3::new(sigma.x.sqrt(), sigma.y.sqrt(), sigma.z.sqrt());
        for c in 0..3 {
            assert!(
                (mean[c] - exact[c]).abs() < 5.0 * sigma[c] + 1e-6 * exact[c],
                "channel {c}: {} ± {} vs {}",
                mean[c],
                sigma[c],
                exact[c]
            );
        }
    }

    #[test]
    fn a_black_map_has_no_power_and_zero_radiance_everywhere() {
        let image = RgbImage {
            width: 4,
            height: 2,
            pixels: vec![[0.0; 3]; 8],
        };
        let image = EnvironmentImage::from_rgb(&image, 1.0, 0.0).unwrap();
        let map = Arc::new(EnvironmentMap::new(Arc::new(image)));
        let light = EnvironmentLight {
            map: map.clone(),
            scene_radius: 3.0,
        };
        assert_eq!(light.power(), 0.0);
        let s = map.sample([0.3, 0.6]).unwrap();
        assert_eq!(s.radiance, Vec3::ZERO);
    }
}
