//! glTF metallic-roughness BRDF: Lambert diffuse plus GGX specular.
//!
//! f(wo, wi) = (1 − m)·(1 − F_d)·baseColor/π + [(1 − m)·F_d + m·F_m] · D(h) · V(wo, wi), with
//! Schlick Fresnel F_d = s·(0.04 + 0.96(1 − v·h)⁵) for the dielectric (s = KHR_materials_specular
//! factor) and F_m = c + (1 − c)(1 − v·h)⁵ for the metal (c = baseColor), i.e. F0 =
//! mix(0.04, baseColor, metallic) when s = 1; D the GGX (Trowbridge–Reitz) distribution with
//! α = roughness²; V the height-correlated Smith visibility term G₂ / (4 n·l n·v)
//! (Heitz 2014). This is the glTF 2.0 specification's Appendix B model.

use glam::Vec3;
use std::f32::consts::FRAC_1_PI;

use crate::scene::Material;

/// GGX α below this is clamped: a perfect mirror cannot be reached by light sampling.
const MIN_ALPHA: f32 = 1e-3;

/// The BRDF of one material, with the constant factors precomputed.
#[derive(Clone, Copy, Debug)]
pub struct Brdf {
    base_color: Vec3,
    metallic: f32,
    specular: f32,
    alpha: f32,
}

impl Brdf {
    pub fn new(m: &Material) -> Brdf {
        Brdf {
            base_color: m.base_color,
            metallic: m.metallic,
            specular: m.specular,
            alpha: (m.roughness * m.roughness).max(MIN_ALPHA),
        }
    }

    /// f(wo, wi) per steradian (without the cosine), for unit vectors on the side of the unit
    /// shading normal `n`; zero when either direction lies below it.
    #[inline]
    pub fn eval(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        let n_dot_v = n.dot(wo);
        let n_dot_l = n.dot(wi);
        if n_dot_v <= 0.0 || n_dot_l <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize();
        let v_dot_h = wo.dot(h).clamp(0.0, 1.0);
        let schlick = (1.0 - v_dot_h).powi(5);
        let f_dielectric = self.specular * (0.04 + 0.96 * schlick);
        let f_metal = self.base_color + (Vec3::ONE - self.base_color) * schlick;
        let m = self.metallic;
        let diffuse = (1.0 - m) * (1.0 - f_dielectric) * FRAC_1_PI * self.base_color;
        let fresnel = Vec3::splat((1.0 - m) * f_dielectric) + m * f_metal;
        if fresnel == Vec3::ZERO {
            return diffuse;
        }
        let a2 = self.alpha * self.alpha;
        let n_dot_h = n.dot(h).clamp(0.0, 1.0);
        let denom = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
        let d = a2 * FRAC_1_PI / (denom * denom);
        let vis = 0.5
            / (n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt()
                + n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt());
        diffuse + fresnel * (d * vis)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{rng::PixelRng, warp};

    #[test]
    fn pure_lambert_is_albedo_over_pi() {
        let brdf = Brdf::new(&Material::lambert(Vec3::new(0.2, 0.5, 0.8)));
        let wi = Vec3::new(0.3, 0.1, 0.9).normalize();
        let f = brdf.eval(Vec3::Z, Vec3::Z, wi);
        assert!((f - Vec3::new(0.2, 0.5, 0.8) * FRAC_1_PI).length() < 1e-7);
        assert_eq!(brdf.eval(Vec3::Z, Vec3::Z, -wi), Vec3::ZERO);
    }

    #[test]
    fn ggx_distribution_and_visibility_conserve_energy() {
        // A white metal (F = 1) reflects ∫ f cos dω ≤ 1, and close to 1 when smooth
        // (single-scattering GGX loses a little energy, more when rough).
        for (roughness, lower) in [(0.2f32, 0.97), (0.5, 0.90)] {
            let m = Material {
                base_color: Vec3::ONE,
                metallic: 1.0,
                roughness,
                ..Material::default()
            };
            let brdf = Brdf::new(&m);
            let wo = Vec3::new(0.0, 0.0, 1.0);
            let mut rng = PixelRng::new(3, 4);
            let count = 400_000;
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..count {
                let wi = warp::cosine_hemisphere(rng.next_2d());
                let y = (brdf.eval(Vec3::Z, wo, wi).x / warp::cosine_hemisphere_pdf(wi.z) * wi.z)
                    as f64;
                s += y;
                s2 += y * y;
            }
            let mean = s / count as f64;
            let sigma = ((s2 / count as f64 - mean * mean) / count as f64).sqrt();
            assert!(
                mean < 1.0 + 5.0 * sigma && mean > lower,
                "roughness {roughness}: {mean}"
            );
        }
    }
}
