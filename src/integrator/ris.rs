//! Resampled importance sampling (RIS; Talbot, Bitterli, Wyman & Jarosz 2005; Talbot's thesis),
//! the core of ReSTIR without reuse, as the `ris` and `ris-mis` strategies.
//!
//! Per K×N slot, M candidates x_1 … x_M, each a light l ~ p_l(·|x) from the selector and a point
//! on it (solid angle where it applies), with density p(x_i) = p_l · p(ω | l) per steradian (a
//! delta light: the probability p_l of its one direction). The target is the luminance of the
//! unshadowed integrand, p̂(x) = lum(f · Le · cosθ). Each candidate gets the resampling weight
//!     w_i = p̂(x_i) / (M · p(x_i)),
//! one candidate y is kept with probability w_y / Σw (a streaming reservoir), one shadow ray is
//! traced toward it, and the slot's estimate is
//!     f · Le · V · cosθ(y) / p̂(y) · Σ_i w_i.
//! Why it is unbiased: E[f(y)/p̂(y) · Σw] = E[Σ_i w_i · f(x_i)/p̂(x_i)] (choosing y ∝ w and
//! multiplying by Σw cancel), and each term is ∫ f / M over where p̂ > 0. So the condition is
//! p̂ > 0 wherever f·Le·V·cosθ ≠ 0; the unshadowed luminance satisfies it (its Rec.709 weights
//! are positive and V ≤ 1). A candidate with p̂ = 0 has w = 0, is never kept, and carries no
//! light. With M = 1, y = x_1 and the estimate is f·Le·V·cosθ / p(x_1): `ris` with M = 1 is
//! `light-solid-angle` (the same numbers; equal up to f32 rounding).
//!
//! `ris-mis` adds the slot's BSDF direction as candidate M+1 in the same resampling, with
//! balance-heuristic multiple-proposal weights m_i(x) = p_i(x) / Σ_j p_j(x) (Talbot 2005):
//!     w_i = m_i(x_i) · p̂(x_i) / p_i(x_i) = p̂(x_i) / (M · p_light(x_i) + p_bsdf(x_i)),
//! p_light(x) = pmf(l | x) · p(ω | l) (the selector's exact pmf for a light hit by the BSDF
//! ray) and p_bsdf the BRDF's solid-angle pdf. Σ_i m_i(x) = 1 wherever f ≠ 0 (a BSDF ray reaches
//! only visible points, where the light candidates also do; at occluded points f = 0), so the
//! same identity makes it unbiased. Delta lights cannot be reached by the BSDF: m = 1/M there.
//! The BSDF candidate's visibility is its own closest hit, so it needs no shadow ray.
//!
//! Numbers: candidate 1 takes the slot's light choice and light point from the sampler (hence
//! the M = 1 identity); candidates 2 … M and every reservoir decision take theirs from a
//! SplitMix64 stream seeded by hashing those two numbers, so the image is still a pure function
//! of (seed, pixel, sample) and the same for any thread count.
//!
//! Rays per slot: `ris` one shadow ray (none when every candidate has p̂ = 0); `ris-mis` one
//! BSDF ray and at most one shadow ray.

use glam::Vec3;

use super::{Estimator, ShadingPoint};
use crate::color::luminance;
use crate::lights::{Light, Technique};
use crate::sampling::rng::mix64;
use crate::sampling::sampler::CameraSample;

use super::SampleCounts;

/// How a candidate's visibility is tested, should it be kept.
#[derive(Clone, Copy)]
enum Visibility {
    /// A point on a triangle light, whose normal faces the receiver.
    Segment { point: Vec3, light_side: Vec3 },
    /// A point light at this distance along the candidate's direction.
    Distance(f32),
    /// A direction to infinity (directional light, environment).
    Infinite,
    /// Already known visible: the BSDF ray's own closest hit.
    Visible,
}

/// One resampling candidate: its direction, unshadowed f · Le · cosθ (per steradian, or per
/// delta light), and how to test its visibility.
#[derive(Clone, Copy)]
struct Candidate {
    wi: Vec3,
    f_le_cos: Vec3,
    visibility: Visibility,
}

/// A streaming reservoir of one candidate (Chao 1982): after each offer, the kept candidate is
/// candidate i with probability w_i / Σw.
struct Reservoir {
    kept: Option<(Candidate, f32)>,
    weight_sum: f32,
}

impl Reservoir {
    fn new() -> Reservoir {
        Reservoir {
            kept: None,
            weight_sum: 0.0,
        }
    }

    /// Offers `c` with target p̂ = `p_hat` and weight `w`, kept when u · Σw < w (u uniform).
    #[inline]
    fn offer(&mut self, c: Candidate, p_hat: f32, w: f32, u: f32) {
        if !(w > 0.0 && w.is_finite()) {
            return;
        }
        self.weight_sum += w;
        if u * self.weight_sum < w {
            self.kept = Some((c, p_hat));
        }
    }
}

/// SplitMix64 (Steele, Lea & Flood 2014): the numbers of candidates 2 … M and of the reservoir.
struct CandidateStream(u64);

impl CandidateStream {
    fn new(light_choice: f64, light_point: [f32; 2]) -> CandidateStream {
        let point =
            (u64::from(light_point[0].to_bits()) << 32) | u64::from(light_point[1].to_bits());
        CandidateStream(mix64(
            light_choice.to_bits() ^ mix64(point ^ 0x5851_f42d_4c95_7f2d),
        ))
    }

    #[inline]
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        mix64(self.0)
    }

    /// Uniform in [0, 1) with 53 bits (a light choice).
    #[inline]
    fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// Two uniform numbers in [0, 1) with 24 bits each, from one draw.
    #[inline]
    fn next_2d(&mut self) -> [f32; 2] {
        let x = self.next_u64();
        let unit = |bits: u64| (bits >> 40) as f32 * (1.0 / 16_777_216.0);
        [unit(x), unit(x << 24)]
    }

    #[inline]
    fn next_f32(&mut self) -> f32 {
        self.next_2d()[0]
    }
}

impl Estimator<'_> {
    /// This estimator with M candidates per K×N slot for `ris` and `ris-mis` (M ≥ 1; other
    /// strategies ignore it).
    pub fn with_candidates(mut self, m: u32) -> Self {
        self.m = m.max(1);
        self
    }

    /// Σ over the K·N slots of one resampled sample each, / (K·N); with the BSDF direction as
    /// one more candidate when `mis`.
    pub(super) fn resampled(
        &self,
        x: &ShadingPoint,
        mis: bool,
        cs: &CameraSample,
        counts: &mut SampleCounts,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for k in 0..self.k {
            for n in 0..self.n {
                sum += self.resampled_slot(x, mis, cs, k, n, counts);
            }
        }
        sum / (self.k * self.n) as f32
    }

    /// One slot: M light candidates (and the BSDF one when `mis`), one kept, one shadow ray.
    fn resampled_slot(
        &self,
        x: &ShadingPoint,
        mis: bool,
        cs: &CameraSample,
        k: u32,
        n: u32,
        counts: &mut SampleCounts,
    ) -> Vec3 {
        let Some(selector) = self.selector else {
            return Vec3::ZERO;
        };
        let ctx = x.context();
        let m = self.m as f32;
        let (u_choice, u_point) = (cs.light_choice(k), cs.light_point(k, n));
        let mut stream = CandidateStream::new(u_choice, u_point);
        let mut reservoir = Reservoir::new();
        for i in 0..self.m {
            let (u_choice, u_point) = if i == 0 {
                (u_choice, u_point)
            } else {
                (stream.next_f64(), stream.next_2d())
            };
            let u_keep = stream.next_f32();
            let Some((l, p_l)) = selector.sample(self.lights, &ctx, u_choice) else {
                continue;
            };
            let Some((c, p_light, delta)) =
                self.light_candidate(x, &self.lights.lights[l], p_l as f32, u_point, counts)
            else {
                continue;
            };
            let p_hat = luminance(c.f_le_cos);
            let p_bsdf = if mis && !delta {
                x.brdf.pdf(x.ns, x.wo, c.wi)
            } else {
                0.0
            };
            reservoir.offer(c, p_hat, p_hat / (m * p_light + p_bsdf), u_keep);
        }
        if mis {
            let u_keep = stream.next_f32();
            if let Some((c, p_bsdf, p_light)) = self.bsdf_candidate(x, cs, k * self.n + n, counts) {
                let p_hat = luminance(c.f_le_cos);
                reservoir.offer(c, p_hat, p_hat / (m * p_light + p_bsdf), u_keep);
            }
        }
        let Some((y, p_hat)) = reservoir.kept else {
            return Vec3::ZERO;
        };
        if self.candidate_occluded(x, &y, counts) {
            return Vec3::ZERO;
        }
        y.f_le_cos * (reservoir.weight_sum / p_hat)
    }

    /// A candidate on `light` chosen with probability p_l: (candidate, p_light, is delta), p_light
    /// per steradian (p_l · p(ω | l)) or, for a delta light, the probability p_l. None when it
    /// carries no light (below the surface, back of the emitter, f = 0).
    fn light_candidate(
        &self,
        x: &ShadingPoint,
        light: &Light,
        p_l: f32,
        u: [f32; 2],
        counts: &mut SampleCounts,
    ) -> Option<(Candidate, f32, bool)> {
        let (wi, le, p_dir, visibility, delta) = match light {
            Light::Triangle(light) => {
                let s = light.sample(x.p, Technique::SolidAngle, u)?;
                if s.spherical {
                    counts.spherical_samples += 1;
                } else {
                    counts.area_samples += 1;
                }
                let le = self.light_emission(light, s.point, -s.wi);
                let visibility = Visibility::Segment {
                    point: s.point,
                    light_side: light.side_toward(-s.wi),
                };
                (s.wi, le, s.p_x / s.jacobian, visibility, false)
            }
            Light::Environment(env) => {
                let s = env.map.sample(u)?;
                (s.wi, s.radiance, s.pdf, Visibility::Infinite, false)
            }
            delta => {
                let s = delta.sample_delta(x.p)?;
                let visibility = if s.dist.is_finite() {
                    Visibility::Distance(s.dist)
                } else {
                    Visibility::Infinite
                };
                (s.wi, s.li, 1.0, visibility, true)
            }
        };
        if x.ng.dot(wi) <= 0.0 || le == Vec3::ZERO || p_dir.is_nan() || p_dir <= 0.0 {
            return None;
        }
        let f = x.brdf.eval(x.ns, x.wo, wi);
        if f == Vec3::ZERO {
            return None;
        }
        let candidate = Candidate {
            wi,
            f_le_cos: f * le * x.ns.dot(wi),
            visibility,
        };
        Some((candidate, p_l * p_dir, delta))
    }

    /// BSDF slot j's direction as a candidate: (candidate, p_bsdf, p_light), both per steradian,
    /// p_light the light candidates' density for the emitter (or environment) it reaches. None
    /// when the direction is below the surface or reaches no emission.
    fn bsdf_candidate(
        &self,
        x: &ShadingPoint,
        cs: &CameraSample,
        j: u32,
        counts: &mut SampleCounts,
    ) -> Option<(Candidate, f32, f32)> {
        let (wi, hit) = self.bsdf_ray(x, j, cs, counts)?;
        // Only a direction that found emission needs f and the two densities.
        let (le, brdf, p_bsdf) = self.emission_with_brdf(x, wi, &hit)?;
        if p_bsdf.is_nan() || p_bsdf <= 0.0 {
            return None;
        }
        let p_light = match &hit {
            Some(hit) => self.light_density_at(x, hit, wi),
            None => self.environment_density(x, wi),
        };
        let f = brdf.f;
        let candidate = Candidate {
            wi,
            f_le_cos: f * le * x.ns.dot(wi),
            visibility: Visibility::Visible,
        };
        Some((candidate, p_bsdf, p_light))
    }

    /// Traces the kept candidate's shadow ray (none for a BSDF candidate).
    fn candidate_occluded(
        &self,
        x: &ShadingPoint,
        c: &Candidate,
        counts: &mut SampleCounts,
    ) -> bool {
        match c.visibility {
            Visibility::Visible => false,
            Visibility::Segment { point, light_side } => {
                counts.shadow_rays += 1;
                self.accel
                    .segment_occluded_from(x.origin, point, light_side)
            }
            Visibility::Distance(dist) => {
                counts.shadow_rays += 1;
                self.direction_occluded(x, c.wi, dist)
            }
            Visibility::Infinite => {
                counts.shadow_rays += 1;
                self.direction_occluded(x, c.wi, f32::INFINITY)
            }
        }
    }
}
