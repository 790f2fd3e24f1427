//! glTF metallic-roughness BRDF: Lambert diffuse plus GGX specular.
//!
//! f(wo, wi) = (1 − m)·(1 − F_d)·baseColor/π + [(1 − m)·F_d + m·F_m] · D(h) · V(wo, wi), with
//! Schlick Fresnel F_d = s·(0.04 + 0.96(1 − v·h)⁵) for the dielectric (s = KHR_materials_specular
//! factor) and F_m = c + (1 − c)(1 − v·h)⁵ for the metal (c = baseColor), i.e. F0 =
//! mix(0.04, baseColor, metallic) when s = 1; D the GGX (Trowbridge–Reitz) distribution with
//! α = roughness²; V the height-correlated Smith visibility term G₂ / (4 n·l n·v)
//! (Heitz 2014). This is the glTF 2.0 specification's Appendix B model.

use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

use crate::color::luminance;
use crate::sampling::warp::{self, Frame};
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
    /// p_s, the probability with which `sample` draws the specular lobe (see
    /// `specular_probability`).
    p_specular: f32,
}

impl Brdf {
    pub fn new(m: &Material) -> Brdf {
        Brdf::with_base_color(m, m.base_color)
    }

    /// The material's BRDF with `base_color` in place of its factor (a textured base colour).
    pub fn with_base_color(m: &Material, base_color: Vec3) -> Brdf {
        let mut brdf = Brdf {
            base_color,
            metallic: m.metallic,
            specular: m.specular,
            alpha: (m.roughness * m.roughness).max(MIN_ALPHA),
            p_specular: 0.0,
        };
        brdf.p_specular = brdf.specular_probability();
        brdf
    }

    /// f(wo, wi) per steradian (without the cosine), for unit vectors on the side of the unit
    /// shading normal `n`; zero when either direction lies below it.
    #[inline]
    pub fn eval(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        self.evaluate(n, wo, wi).f
    }

    /// f(wo, wi) as `eval`, with the terms `pdf_of` shares with it.
    #[inline]
    pub fn evaluate(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Evaluation {
        const BELOW: Evaluation = Evaluation {
            f: Vec3::ZERO,
            terms: None,
        };
        let Some(t) = self.half_vector_terms(n, wo, wi) else {
            return BELOW;
        };
        if self.is_lambert() {
            // m = 0 and F_d = s·(…) = 0: the formula below reduces to 1·1·(1/π)·baseColor, the
            // same bits, without its Fresnel terms.
            return Evaluation {
                f: FRAC_1_PI * self.base_color,
                terms: Some(t),
            };
        }
        let schlick = (1.0 - t.v_dot_h).powi(5);
        let f_dielectric = self.specular * (0.04 + 0.96 * schlick);
        let f_metal = self.base_color + (Vec3::ONE - self.base_color) * schlick;
        let m = self.metallic;
        let diffuse = (1.0 - m) * (1.0 - f_dielectric) * FRAC_1_PI * self.base_color;
        let fresnel = Vec3::splat((1.0 - m) * f_dielectric) + m * f_metal;
        let f = if fresnel == Vec3::ZERO {
            diffuse
        } else {
            let (n_dot_v, n_dot_l, a2) = (t.n_dot_v, t.n_dot_l, self.alpha * self.alpha);
            let vis = 0.5
                / (n_dot_l * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt()
                    + n_dot_v * (n_dot_l * n_dot_l * (1.0 - a2) + a2).sqrt());
            diffuse + fresnel * (t.d * vis)
        };
        Evaluation { f, terms: Some(t) }
    }

    /// Whether the material has no specular lobe (metallic = specular = 0): f is baseColor/π,
    /// and p_s = 0.
    #[inline]
    fn is_lambert(&self) -> bool {
        self.metallic == 0.0 && self.specular == 0.0
    }

    /// The cosines n·wo, n·wi, wo·h and GGX D(h) = α²/(π·((n·h)²(α² − 1) + 1)²) at the half
    /// vector h = (wo + wi)/|wo + wi|; None when either direction lies below n. For a material
    /// without a specular lobe h is not formed: wo·h and D are left 1 and 0, and neither f nor
    /// the pdf (p_s = 0) reads them.
    #[inline]
    fn half_vector_terms(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Option<HalfVectorTerms> {
        let n_dot_v = n.dot(wo);
        let n_dot_l = n.dot(wi);
        if n_dot_v <= 0.0 || n_dot_l <= 0.0 {
            return None;
        }
        if self.is_lambert() {
            return Some(HalfVectorTerms {
                n_dot_v,
                n_dot_l,
                v_dot_h: 1.0,
                d: 0.0,
            });
        }
        let h = (wo + wi).normalize();
        let a2 = self.alpha * self.alpha;
        let n_dot_h = n.dot(h).clamp(0.0, 1.0);
        let denom = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
        Some(HalfVectorTerms {
            n_dot_v,
            n_dot_l,
            v_dot_h: wo.dot(h).clamp(0.0, 1.0),
            d: a2 * FRAC_1_PI / (denom * denom),
        })
    }
}

/// The terms of f(wo, wi) that the pdf of the same pair shares.
#[derive(Clone, Copy, Debug)]
struct HalfVectorTerms {
    n_dot_v: f32,
    n_dot_l: f32,
    v_dot_h: f32,
    d: f32,
}

/// f(wo, wi) for one pair of directions, keeping what `Brdf::pdf_of` needs of it, so a sample
/// whose density is needed too (an MIS weight) pays for the half vector and D(h) once.
#[derive(Clone, Copy, Debug)]
pub struct Evaluation {
    pub f: Vec3,
    /// None when either direction lies below the shading normal.
    terms: Option<HalfVectorTerms>,
}

impl Brdf {
    /// Probability of sampling the specular lobe: its albedo estimate (F at normal incidence)
    /// against the diffuse one, kept within [0.1, 0.9] when both lobes exist so that grazing
    /// Fresnel gain on a dark metal is still sampled; 0 or 1 when one lobe is absent.
    fn specular_probability(&self) -> f32 {
        let m = self.metallic;
        let has_diffuse = (1.0 - m) * luminance(self.base_color) > 0.0;
        let has_specular = (1.0 - m) * self.specular + m > 0.0;
        match (has_diffuse, has_specular) {
            (_, false) => 0.0,
            (false, true) => 1.0,
            (true, true) => {
                let (w_s, w_d) = self.albedo_estimates();
                (w_s / (w_s + w_d)).clamp(0.1, 0.9)
            }
        }
    }

    /// The specular and diffuse albedo estimates (w_s, w_d): F at normal incidence, and the
    /// diffuse lobe's luminance.
    #[inline]
    fn albedo_estimates(&self) -> (f32, f32) {
        let m = self.metallic;
        let w_s = (1.0 - m) * self.specular * 0.04 + m * luminance(self.base_color);
        let w_d = (1.0 - m) * (1.0 - 0.04 * self.specular) * luminance(self.base_color);
        (w_s, w_d)
    }

    /// (α, w_s, w_d): GGX's α and the albedo estimates that `specular_probability` weighs.
    pub fn lobe_weights(&self) -> (f32, f32, f32) {
        let (w_s, w_d) = self.albedo_estimates();
        (self.alpha, w_s, w_d)
    }

    /// Samples wi: the specular lobe with probability p_s (GGX visible normals, Heitz 2018,
    /// reflected about the sampled half vector, from `u`), else the cosine-weighted diffuse
    /// lobe (`cosine`: `warp::cosine_hemisphere(u)`, asked for only when that lobe is taken).
    /// None when the sample falls below the surface or the material reflects nothing.
    pub fn sample(
        &self,
        n: Vec3,
        wo: Vec3,
        u_lobe: f32,
        u: [f32; 2],
        cosine: impl FnOnce() -> Vec3,
    ) -> Option<Vec3> {
        let frame = Frame::new(n);
        let p_s = self.p_specular;
        let wi = if u_lobe < p_s {
            let wo_local = Vec3::new(frame.t.dot(wo), frame.b.dot(wo), frame.n.dot(wo));
            if wo_local.z <= 0.0 {
                return None;
            }
            let h = frame.to_world(sample_ggx_visible_normal(wo_local, self.alpha, u));
            2.0 * wo.dot(h) * h - wo
        } else if p_s < 1.0 {
            let local = cosine();
            debug_assert_eq!(
                local,
                warp::cosine_hemisphere(u),
                "the diffuse lobe's warp of u"
            );
            frame.to_world(local)
        } else {
            return None;
        };
        (n.dot(wi) > 0.0).then_some(wi)
    }

    /// The solid-angle pdf of `sample` producing wi:
    /// p_s · D(h)·G₁(wo) / (4·n·wo) + (1 − p_s) · n·wi/π.
    pub fn pdf(&self, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
        self.half_vector_terms(n, wo, wi)
            .map_or(0.0, |t| self.pdf_from_terms(&t))
    }

    /// `pdf` of the pair that `evaluation` evaluated.
    #[inline]
    pub fn pdf_of(&self, evaluation: &Evaluation) -> f32 {
        evaluation.terms.map_or(0.0, |t| self.pdf_from_terms(&t))
    }

    #[inline]
    fn pdf_from_terms(&self, t: &HalfVectorTerms) -> f32 {
        let p_s = self.p_specular;
        let diffuse = (1.0 - p_s) * t.n_dot_l * FRAC_1_PI;
        if p_s == 0.0 {
            return diffuse;
        }
        let (n_dot_v, a2) = (t.n_dot_v, self.alpha * self.alpha);
        let g1 = 2.0 * n_dot_v / (n_dot_v + (a2 + (1.0 - a2) * n_dot_v * n_dot_v).sqrt());
        p_s * t.d * g1 / (4.0 * n_dot_v) + diffuse
    }
}

/// A GGX microfacet normal distributed as D_wo(h) = G₁(wo)·max(0, wo·h)·D(h)/(n·wo), in the local
/// frame (z = normal), by sampling the projected hemisphere of the stretched configuration
/// (Heitz 2018, "Sampling the GGX Distribution of Visible Normals").
fn sample_ggx_visible_normal(wo: Vec3, alpha: f32, u: [f32; 2]) -> Vec3 {
    let v = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let len2 = v.x * v.x + v.y * v.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-v.y, v.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = v.cross(t1);
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + v.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * v;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-7)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{rng::PixelRng, warp};

    #[test]
    fn pure_lambert_is_albedo_over_pi() {
        let brdf = Brdf::new(&Material::lambert(Vec3::new(0.2, 0.5, 0.8)));
        let wi = Vec3::new(0.3, 0.1, 0.9).normalize();
        // Exactly: the lobe-less path returns baseColor/π and the cosine density, as the full
        // formula gives them with m = F_d = 0.
        let f = brdf.eval(Vec3::Z, Vec3::Z, wi);
        assert_eq!(f, FRAC_1_PI * Vec3::new(0.2, 0.5, 0.8));
        assert_eq!(brdf.pdf(Vec3::Z, Vec3::Z, wi), wi.z * FRAC_1_PI);
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

    /// ∫ f·cos dω estimated with the BRDF's own samples (f·cos/pdf) must equal the estimate with
    /// cosine samples: both are unbiased for the same integral only if pdf matches sample.
    #[test]
    fn sampled_directions_follow_the_pdf() {
        let materials = [
            Material {
                base_color: Vec3::new(0.8, 0.5, 0.2),
                metallic: 0.0,
                roughness: 0.4,
                ..Material::default()
            },
            Material {
                base_color: Vec3::new(0.9, 0.8, 0.6),
                metallic: 1.0,
                roughness: 0.25,
                ..Material::default()
            },
            Material {
                base_color: Vec3::new(0.3, 0.3, 0.3),
                metallic: 0.5,
                roughness: 0.7,
                ..Material::default()
            },
        ];
        let wo = Vec3::new(0.5, -0.2, 0.7).normalize();
        for m in &materials {
            let brdf = Brdf::new(m);
            let mut rng = PixelRng::new(8, 1);
            let count = 400_000;
            let estimate = |rng: &mut PixelRng, own: bool| {
                let (mut s, mut s2) = (0.0f64, 0.0f64);
                for _ in 0..count {
                    let (wi, pdf) = if own {
                        let (u_lobe, u) = (rng.next_f32(), rng.next_2d());
                        match brdf.sample(Vec3::Z, wo, u_lobe, u, || warp::cosine_hemisphere(u)) {
                            Some(wi) => (wi, brdf.pdf(Vec3::Z, wo, wi)),
                            None => continue,
                        }
                    } else {
                        let w = warp::cosine_hemisphere(rng.next_2d());
                        (w, warp::cosine_hemisphere_pdf(w.z))
                    };
                    assert!(pdf > 0.0);
                    let y = (luminance(brdf.eval(Vec3::Z, wo, wi)) * wi.z / pdf) as f64;
                    s += y;
                    s2 += y * y;
                }
                let mean = s / count as f64;
                (
                    mean,
                    ((s2 / count as f64 - mean * mean) / count as f64).sqrt(),
                )
            };
            let (a, sa) = estimate(&mut rng, true);
            let (b, sb) = estimate(&mut rng, false);
            let sigma = (sa * sa + sb * sb).sqrt();
            assert!(
                (a - b).abs() < 5.0 * sigma,
                "{m:?}: own {a} vs cosine {b} (σ {sigma})"
            );
            // For a glossy metal the BRDF's own sampling must beat cosine sampling clearly.
            if m.metallic == 1.0 {
                assert!(sa < 0.5 * sb, "{m:?}: σ own {sa} vs cosine {sb}");
            }
        }
    }

    /// `pdf_of` the terms `evaluate` kept gives exactly what `pdf` gives on its own, on both
    /// sides of the surface and for a material with each lobe alone (f itself is checked by
    /// the Lambert and quadrature tests).
    #[test]
    fn pdf_of_an_evaluation_equals_pdf() {
        let materials = [
            Material::lambert(Vec3::new(0.2, 0.5, 0.8)),
            Material {
                metallic: 0.3,
                roughness: 0.6,
                ..Material::default()
            },
            Material {
                base_color: Vec3::ONE,
                metallic: 1.0,
                roughness: 0.1,
                ..Material::default()
            },
        ];
        let mut rng = PixelRng::new(5, 6);
        for m in &materials {
            let brdf = Brdf::new(m);
            for _ in 0..1000 {
                let wo = warp::uniform_hemisphere(rng.next_2d());
                let wi = warp::uniform_hemisphere(rng.next_2d()) * Vec3::new(1.0, 1.0, 0.9);
                let wi = if rng.next_f32() < 0.2 { -wi } else { wi };
                let e = brdf.evaluate(Vec3::Z, wo, wi);
                assert_eq!(
                    brdf.pdf_of(&e).to_bits(),
                    brdf.pdf(Vec3::Z, wo, wi).to_bits()
                );
            }
        }
    }

    #[test]
    fn pdf_integrates_to_at_most_one() {
        // ∫ pdf dω over the hemisphere = 1 − P(sample below the surface) ≤ 1, ≈ 1 for rough.
        let brdf = Brdf::new(&Material {
            metallic: 0.3,
            roughness: 0.6,
            ..Material::default()
        });
        let wo = Vec3::new(0.2, 0.1, 0.9).normalize();
        let mut rng = PixelRng::new(2, 2);
        let count = 400_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..count {
            let w = warp::uniform_hemisphere(rng.next_2d());
            let y = (brdf.pdf(Vec3::Z, wo, w) / warp::UNIFORM_HEMISPHERE_PDF) as f64;
            s += y;
            s2 += y * y;
        }
        let mean = s / count as f64;
        let sigma = ((s2 / count as f64 - mean * mean) / count as f64).sqrt();
        assert!(mean < 1.0 + 5.0 * sigma && mean > 0.95, "{mean} ± {sigma}");
    }
}
