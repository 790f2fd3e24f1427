//! One camera sample's estimate of L(x, ωo) = Le(x, ωo) + ∫ f · Le · V · G dA'.
//!
//! Light sampling (`light-area`, `light-solid-angle`): K lights l_k ~ p_l(·|x), N points x' on
//! each, and
//!     L_r ≈ Σ_k Σ_n f · Le · V · G / (K · N · p_l · p(x')),
//! with G = cosθ·cosθ'/r² and p(x') = 1/A in area measure, or G = cosθ and p = 1/Ω in solid-angle
//! measure. A delta light (point, spot, directional) is sampled exactly once (N = 1 for it).
//! `bsdf`: K·N directions from the BRDF, adding the emission they hit: Σ f·Le·cosθ / (K·N·p(ω)).
//! `mis`: each of the K·N light samples and a matching BSDF sample, weighted by the power
//! heuristic w_a = p_a² / (p_light² + p_bsdf²) in solid angle, with p_light = p_l · p(ω | l) and,
//! for a BSDF ray that hits light l, p_l from the selector's pmf (Veach & Guibas 1995).
//! `hemisphere-*`: K·N directions uniform or cosine-distributed: Σ f·Le·cosθ / (K·N·p(ω)).
//! The environment map is one more light: light sampling draws its N directions from the map's
//! own density p(ω) (solid angle) with a shadow ray to infinity; camera, BSDF and hemisphere rays
//! that leave the scene add its radiance, a BSDF ray's MIS weight using p_l(env) · p(ω).
//!
//! Rays per K×N slot: light-area, light-solid-angle: one shadow ray per light sample (none when
//! the light faces away or f = 0); bsdf and hemisphere-*: one ray; mis: one shadow + one BSDF ray.

use glam::Vec3;

use super::Strategy;
use crate::accel::{offset_ray_origin, Accel, Hit};
use crate::lights::{emits_toward, EnvironmentMap, Light, Lights, Technique, TriangleLight};
use crate::material::{Brdf, Evaluation};
use crate::sampling::prefetch::prefetch;
use crate::sampling::sampler::CameraSample;
use crate::sampling::warp::{self, Frame};
use crate::scene::Scene;
use crate::select::{LightSelector, Lobe, ShadingContext};

// RIS reads the shading point and the emission helpers of this module, so it is a child of it.
#[path = "ris.rs"]
mod ris;

/// Rays traced and sampling decisions, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SampleCounts {
    pub camera_rays: u64,
    pub shadow_rays: u64,
    /// Rays traced toward BSDF-sampled or hemisphere directions.
    pub bounce_rays: u64,
    /// Triangle-light samples drawn in solid angle (Arvo) and by area (including the fallback).
    pub spherical_samples: u64,
    pub area_samples: u64,
    /// Camera rays whose first hit is a surface without emission (the lit-surface mask).
    pub surface_hits: u64,
}

impl SampleCounts {
    pub fn total_rays(&self) -> u64 {
        self.camera_rays + self.shadow_rays + self.bounce_rays
    }

    pub fn add(&mut self, o: &SampleCounts) {
        self.camera_rays += o.camera_rays;
        self.shadow_rays += o.shadow_rays;
        self.bounce_rays += o.bounce_rays;
        self.spherical_samples += o.spherical_samples;
        self.area_samples += o.area_samples;
        self.surface_hits += o.surface_hits;
    }
}

/// Everything needed to estimate radiance along camera rays. Cheap to share across threads.
pub struct Estimator<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub lights: &'a Lights,
    /// None when the scene has no lights.
    pub selector: Option<&'a LightSelector>,
    /// `Brdf::new` of each of the scene's materials.
    pub brdfs: &'a [Brdf],
    pub strategy: Strategy,
    pub k: u32,
    pub n: u32,
    /// Candidates per K×N slot for `ris` and `ris-mis` (see `with_candidates`).
    pub m: u32,
}

/// The first visible point, with its normals turned toward the viewer.
struct ShadingPoint {
    p: Vec3,
    /// Geometric normal on the viewer's side.
    ng: Vec3,
    /// Interpolated shading normal, on the same side as `ng`.
    ns: Vec3,
    wo: Vec3,
    brdf: Brdf,
    /// x moved off its surface along `ng` (`offset_ray_origin`): where every ray from x starts.
    origin: Vec3,
}

impl ShadingPoint {
    /// The selector's receiver: p, the shading normal and the BRDF's specular lobe there.
    fn context(&self) -> ShadingContext {
        let (alpha, w_s, w_d) = self.brdf.lobe_weights();
        ShadingContext {
            p: self.p,
            n: self.ns,
            lobe: Lobe::of_receiver(alpha, w_s, w_d, self.ns, self.wo),
        }
    }
}

/// The power heuristic (β = 2) weight of a sample drawn with density `p_a` against `p_b`.
#[inline]
pub fn power_heuristic(p_a: f32, p_b: f32) -> f32 {
    let (a, b) = (p_a * p_a, p_b * p_b);
    if a == 0.0 {
        0.0
    } else if a.is_infinite() {
        1.0
    } else {
        a / (a + b)
    }
}

impl Estimator<'_> {
    /// Radiance arriving at the camera along the unit direction `dir` from `origin`.
    pub fn radiance(
        &self,
        origin: Vec3,
        dir: Vec3,
        cs: &CameraSample,
        counts: &mut SampleCounts,
    ) -> Vec3 {
        let hit = self.accel.closest_hit(origin, dir, f32::INFINITY);
        self.radiance_from(hit, dir, cs, None, counts)
    }

    /// Radiance arriving at the camera along the unit direction `dir` whose closest hit is
    /// `hit` (traced by the caller, e.g. a pixel's samples in one packet). `first_light` is
    /// light slot 0's choice when the caller made it already from `cs.light_choice(0)`
    /// (`prefetch_lights`), else None.
    pub fn radiance_from(
        &self,
        hit: Option<Hit>,
        dir: Vec3,
        cs: &CameraSample,
        first_light: Option<usize>,
        counts: &mut SampleCounts,
    ) -> Vec3 {
        counts.camera_rays += 1;
        let Some(hit) = hit else {
            return self.environment_radiance(dir);
        };
        let tri = &self.scene.triangles[hit.triangle as usize];
        counts.surface_hits += !self.scene.materials[tri.material as usize].is_emissive() as u64;
        let wo = -dir;
        let emitted = self.emission_at(&hit, wo);
        let x = self.shading_point(&hit, wo);
        let reflected = match self.strategy {
            Strategy::LightArea => {
                self.light_samples(&x, Technique::Area, false, cs, first_light, counts)
            }
            Strategy::LightSolidAngle => {
                self.light_samples(&x, Technique::SolidAngle, false, cs, first_light, counts)
            }
            Strategy::Bsdf => {
                let first = self.bsdf_ray(&x, 0, cs, counts);
                self.bsdf_samples_after(&x, false, first, cs, counts)
            }
            Strategy::Mis => {
                // The first BSDF ray goes out before the light samples, so that the cache miss
                // on the triangle it hits overlaps their work instead of stalling its own
                // shading; the sum is the same.
                let first = self.bsdf_ray(&x, 0, cs, counts);
                if let Some((_, Some(hit))) = &first {
                    prefetch(&self.scene.triangles[hit.triangle as usize]);
                }
                self.light_samples(&x, Technique::SolidAngle, true, cs, first_light, counts)
                    + self.bsdf_samples_after(&x, true, first, cs, counts)
            }
            Strategy::HemisphereUniform | Strategy::HemisphereCosine => {
                self.hemisphere(&x, cs, counts)
            }
            Strategy::Ris => self.resampled(&x, false, cs, counts),
            Strategy::RisMis => self.resampled(&x, true, cs, counts),
        };
        emitted + reflected
    }

    /// Le at a hit point toward unit direction `w` (zero on a one-sided emitter's back), its
    /// emissive texture read at the hit's uv.
    #[inline(always)]
    fn emission_at(&self, hit: &Hit, w: Vec3) -> Vec3 {
        let tri = &self.scene.triangles[hit.triangle as usize];
        let m = &self.scene.materials[tri.material as usize];
        if m.is_emissive() && emits_toward(tri.geometric_normal(), m.double_sided, w) {
            self.scene
                .emission_at(hit.triangle as usize, hit.b1, hit.b2)
        } else {
            Vec3::ZERO
        }
    }

    /// Le at point x' of a triangle light toward unit direction `w`: the texture read at x''s
    /// barycentrics when the light is textured.
    #[inline]
    fn light_emission(&self, light: &TriangleLight, point: Vec3, w: Vec3) -> Vec3 {
        let le = light.emitted(w);
        if !light.textured || le == Vec3::ZERO {
            return le;
        }
        let (b1, b2) = light.barycentrics(point);
        self.scene.emission_at(light.triangle as usize, b1, b2)
    }

    fn shading_point(&self, hit: &Hit, wo: Vec3) -> ShadingPoint {
        let tri = &self.scene.triangles[hit.triangle as usize];
        let [p0, p1, p2] = tri.positions;
        let b0 = 1.0 - hit.b1 - hit.b2;
        let p = p0 + hit.b1 * (p1 - p0) + hit.b2 * (p2 - p0);
        let side = tri.geometric_normal().dot(wo).signum();
        let ng = side * tri.geometric_normal();
        let [n0, n1, n2] = tri.normals;
        // The shading normal is kept on the geometric normal's side, even where a file's
        // normals disagree with its winding.
        let ns = (b0 * n0 + hit.b1 * n1 + hit.b2 * n2).normalize_or(ng);
        let ns = if ns.dot(ng) < 0.0 { -ns } else { ns };
        let material = &self.scene.materials[tri.material as usize];
        // An untextured base colour is the material's factor: its BRDF is built once.
        let brdf = match material.base_color_texture {
            None => self.brdfs[tri.material as usize],
            Some(_) => {
                let base_color = self
                    .scene
                    .base_color_at(hit.triangle as usize, hit.b1, hit.b2);
                Brdf::with_base_color(material, base_color)
            }
        };
        ShadingPoint {
            p,
            ng,
            ns,
            wo,
            brdf,
            origin: offset_ray_origin(p, ng),
        }
    }

    /// Σ over K lights and N samples of f · Le · V · G / (K · N · p_l · p(x')), each weighted by
    /// the power heuristic against BSDF sampling when `mis`. Slot 0 takes `first_light` when
    /// given (the selector's choice from `cs.light_choice(0)`, made by the caller), with p_l
    /// its `pmf`, which equals the p_l of that choice bit for bit.
    fn light_samples(
        &self,
        x: &ShadingPoint,
        technique: Technique,
        mis: bool,
        cs: &CameraSample,
        first_light: Option<usize>,
        counts: &mut SampleCounts,
    ) -> Vec3 {
        let Some(selector) = self.selector else {
            return Vec3::ZERO;
        };
        let ctx = x.context();
        let (k, n) = (self.k as f32, self.n as f32);
        let mut sum = Vec3::ZERO;
        for slot in 0..self.k {
            let choice = match first_light {
                Some(l) if slot == 0 => Some((l, selector.pmf(self.lights, &ctx, l))),
                _ => selector.sample(self.lights, &ctx, cs.light_choice(slot)),
            };
            let Some((l, p_l)) = choice else {
                continue;
            };
            let p_l = p_l as f32;
            match &self.lights.lights[l] {
                Light::Triangle(light) => {
                    if light.cannot_reach(x.p, x.ng) {
                        continue;
                    }
                    for i in 0..self.n {
                        let u = cs.light_point(slot, i);
                        let (f_le_g, p_x, w) =
                            self.triangle_sample(x, light, p_l, technique, mis, u, counts);
                        sum += f_le_g * w / (k * n * p_l * p_x);
                    }
                }
                Light::Environment(env) => {
                    for i in 0..self.n {
                        let u = cs.light_point(slot, i);
                        let (f_le_cos, p_w, w) =
                            self.environment_sample(x, &env.map, p_l, mis, u, counts);
                        sum += f_le_cos * w / (k * n * p_l * p_w);
                    }
                }
                delta => sum += self.delta_sample(x, delta, counts) / (k * p_l),
            }
        }
        sum
    }

    /// One point x' on a triangle light: (f · Le · V · G, p(x'), MIS weight), G and p(x') in the
    /// measure the point was drawn in. A sample that carries no light returns p(x') = 1 and zero.
    #[allow(clippy::too_many_arguments)]
    fn triangle_sample(
        &self,
        x: &ShadingPoint,
        light: &TriangleLight,
        p_l: f32,
        technique: Technique,
        mis: bool,
        u: [f32; 2],
        counts: &mut SampleCounts,
    ) -> (Vec3, f32, f32) {
        const NOTHING: (Vec3, f32, f32) = (Vec3::ZERO, 1.0, 0.0);
        let Some(s) = light.sample(x.p, technique, u) else {
            return NOTHING;
        };
        if s.spherical {
            counts.spherical_samples += 1;
        } else {
            counts.area_samples += 1;
        }
        let wi = s.wi;
        if x.ng.dot(wi) <= 0.0 {
            return NOTHING;
        }
        let le = self.light_emission(light, s.point, -wi);
        let brdf = x.brdf.evaluate(x.ns, x.wo, wi);
        let f = brdf.f;
        if le == Vec3::ZERO || f == Vec3::ZERO {
            return NOTHING;
        }
        counts.shadow_rays += 1;
        if self
            .accel
            .segment_occluded_from(x.origin, s.point, light.side_toward(-wi))
        {
            return NOTHING;
        }
        let g = x.ns.dot(wi) * s.jacobian;
        let weight = if mis {
            // Both densities in solid angle: p_light = p_l · p(x') / jacobian.
            power_heuristic(p_l * s.p_x / s.jacobian, x.brdf.pdf_of(&brdf))
        } else {
            1.0
        };
        (f * le * g, s.p_x, weight)
    }

    /// One direction from the environment map: (f · L · V · cosθ, p(ω) in solid angle, MIS
    /// weight); a direction that carries no light returns p = 1 and zero.
    fn environment_sample(
        &self,
        x: &ShadingPoint,
        env: &EnvironmentMap,
        p_l: f32,
        mis: bool,
        u: [f32; 2],
        counts: &mut SampleCounts,
    ) -> (Vec3, f32, f32) {
        const NOTHING: (Vec3, f32, f32) = (Vec3::ZERO, 1.0, 0.0);
        let Some(s) = env.sample(u) else {
            return NOTHING;
        };
        if x.ng.dot(s.wi) <= 0.0 || s.pdf <= 0.0 {
            return NOTHING;
        }
        let brdf = x.brdf.evaluate(x.ns, x.wo, s.wi);
        let f = brdf.f;
        if f == Vec3::ZERO || s.radiance == Vec3::ZERO {
            return NOTHING;
        }
        counts.shadow_rays += 1;
        if self.direction_occluded(x, s.wi, f32::INFINITY) {
            return NOTHING;
        }
        let weight = if mis {
            power_heuristic(p_l * s.pdf, x.brdf.pdf_of(&brdf))
        } else {
            1.0
        };
        (f * s.radiance * x.ns.dot(s.wi), s.pdf, weight)
    }

    /// Radiance of the environment along a ray that leaves the scene (zero without one).
    #[inline]
    fn environment_radiance(&self, dir: Vec3) -> Vec3 {
        self.lights
            .environment()
            .map_or(Vec3::ZERO, |(_, env)| env.radiance(dir))
    }

    /// f · I·falloff/r² (or E) · V · cosθ for a delta light, sampled exactly.
    fn delta_sample(&self, x: &ShadingPoint, light: &Light, counts: &mut SampleCounts) -> Vec3 {
        let Some(s) = light.sample_delta(x.p) else {
            return Vec3::ZERO;
        };
        if x.ng.dot(s.wi) <= 0.0 {
            return Vec3::ZERO;
        }
        let f = x.brdf.eval(x.ns, x.wo, s.wi);
        if f == Vec3::ZERO || s.li == Vec3::ZERO {
            return Vec3::ZERO;
        }
        counts.shadow_rays += 1;
        if self.direction_occluded(x, s.wi, s.dist) {
            return Vec3::ZERO;
        }
        f * s.li * x.ns.dot(s.wi)
    }

    /// Whether anything lies between x and the point `dist` along the unit direction `wi` (to
    /// infinity when `dist` is infinite): the shadow ray of a point light, a directional light or
    /// the environment, started off the surface.
    fn direction_occluded(&self, x: &ShadingPoint, wi: Vec3, dist: f32) -> bool {
        let origin = x.origin;
        if dist.is_finite() {
            let to_light = x.p + wi * dist - origin;
            let length = to_light.length();
            self.accel.occluded(origin, to_light / length, length)
        } else {
            self.accel.occluded(origin, wi, f32::INFINITY)
        }
    }

    /// BSDF slot j's direction and the closest hit of its ray (None: nothing hit); None when
    /// the BRDF gives no direction or it falls below the geometric surface (no ray).
    #[inline]
    fn bsdf_ray(
        &self,
        x: &ShadingPoint,
        j: u32,
        cs: &CameraSample,
        counts: &mut SampleCounts,
    ) -> Option<(Vec3, Option<Hit>)> {
        let u = cs.bsdf_numbers(j);
        let wi = x
            .brdf
            .sample(x.ns, x.wo, u.lobe, u.direction, || u.cosine_direction())?;
        if x.ng.dot(wi) <= 0.0 {
            return None;
        }
        counts.bounce_rays += 1;
        Some((wi, self.accel.closest_hit(x.origin, wi, f32::INFINITY)))
    }

    /// Σ over K·N BRDF-sampled directions of f · Le · cosθ / (K · N · p(ω)), each weighted by
    /// the power heuristic against light sampling when `mis`; slot 0's ray is `first`, already
    /// traced by `bsdf_ray`.
    fn bsdf_samples_after(
        &self,
        x: &ShadingPoint,
        mis: bool,
        first: Option<(Vec3, Option<Hit>)>,
        cs: &CameraSample,
        counts: &mut SampleCounts,
    ) -> Vec3 {
        let samples = (self.k * self.n) as f32;
        let mut sum = Vec3::ZERO;
        if let Some(term) = first.and_then(|(wi, hit)| self.bsdf_term(x, mis, samples, wi, hit)) {
            sum += term;
        }
        for j in 1..self.k * self.n {
            let Some((wi, hit)) = self.bsdf_ray(x, j, cs, counts) else {
                continue;
            };
            if let Some(term) = self.bsdf_term(x, mis, samples, wi, hit) {
                sum += term;
            }
        }
        sum
    }

    /// f · Le · cosθ · w / (K · N · p(ω)) of one traced BSDF direction; None when it found no
    /// emission or its density is 0.
    #[inline(always)]
    fn bsdf_term(
        &self,
        x: &ShadingPoint,
        mis: bool,
        samples: f32,
        wi: Vec3,
        hit: Option<Hit>,
    ) -> Option<Vec3> {
        let (le, brdf, pdf) = self.emission_with_brdf(x, wi, &hit)?;
        if pdf <= 0.0 {
            return None;
        }
        let weight = match (mis, &hit) {
            (false, _) => 1.0,
            (true, Some(hit)) => self.bsdf_mis_weight(x, hit, wi, pdf),
            (true, None) => self.environment_mis_weight(x, wi, pdf),
        };
        Some(brdf.f * le * x.ns.dot(wi) * weight / (samples * pdf))
    }

    /// The emission a traced BSDF direction found (at the emitter it hit, else the environment's)
    /// with f and the BRDF's solid-angle density for that direction; None when it found none
    /// (only a direction that found emission needs f and its density).
    #[inline(always)]
    fn emission_with_brdf(
        &self,
        x: &ShadingPoint,
        wi: Vec3,
        hit: &Option<Hit>,
    ) -> Option<(Vec3, Evaluation, f32)> {
        let le = match hit {
            Some(hit) => self.emission_at(hit, -wi),
            None => self.environment_radiance(wi),
        };
        if le == Vec3::ZERO {
            return None;
        }
        let brdf = x.brdf.evaluate(x.ns, x.wo, wi);
        let pdf = x.brdf.pdf_of(&brdf);
        Some((le, brdf, pdf))
    }

    /// Power-heuristic weight of a BSDF sample that hit an emitter, against the light sampler's
    /// density for the same direction (1 where no light stands for the emission hit).
    fn bsdf_mis_weight(&self, x: &ShadingPoint, hit: &Hit, wi: Vec3, pdf_bsdf: f32) -> f32 {
        match self.light_density_at(x, hit, wi) {
            0.0 => 1.0,
            p_light => power_heuristic(pdf_bsdf, p_light),
        }
    }

    /// The density per steradian with which light sampling (solid-angle technique) reaches the
    /// emitter point a BSDF ray hit: p_l(light | x) · p(ω | light); zero for emission no light
    /// stands for.
    fn light_density_at(&self, x: &ShadingPoint, hit: &Hit, wi: Vec3) -> f32 {
        let (Some(selector), Some(l)) =
            (self.selector, self.lights.light_of_triangle(hit.triangle))
        else {
            return 0.0;
        };
        let Light::Triangle(light) = &self.lights.lights[l] else {
            return 0.0;
        };
        let p_l = selector.pmf(self.lights, &x.context(), l) as f32;
        p_l * light.pdf_solid_angle(x.p, Technique::SolidAngle, x.p + wi * hit.t)
    }

    /// Power-heuristic weight of a BSDF sample that left the scene, against the light sampler's
    /// density for that direction (1 without an environment light).
    fn environment_mis_weight(&self, x: &ShadingPoint, wi: Vec3, pdf_bsdf: f32) -> f32 {
        match self.environment_density(x, wi) {
            0.0 => 1.0,
            p_light => power_heuristic(pdf_bsdf, p_light),
        }
    }

    /// The density per steradian with which light sampling reaches direction `wi` through the
    /// environment: p_l(environment | x) · p(ω | environment); zero without one.
    fn environment_density(&self, x: &ShadingPoint, wi: Vec3) -> f32 {
        let (Some(selector), Some((l, env))) = (self.selector, self.lights.environment()) else {
            return 0.0;
        };
        selector.pmf(self.lights, &x.context(), l) as f32 * env.pdf(wi)
    }

    /// Σ over K·N directions of f · Le · cosθ / (K · N · p(ω)), uniform or cosine p(ω).
    fn hemisphere(&self, x: &ShadingPoint, cs: &CameraSample, counts: &mut SampleCounts) -> Vec3 {
        let frame = Frame::new(x.ns);
        let origin = x.origin;
        let samples = self.k * self.n;
        let mut sum = Vec3::ZERO;
        for j in 0..samples {
            let (local, pdf) = if self.strategy == Strategy::HemisphereUniform {
                (
                    warp::uniform_hemisphere(cs.bsdf_direction(j)),
                    warp::UNIFORM_HEMISPHERE_PDF,
                )
            } else {
                let w = cs.bsdf_cosine_direction(j);
                (w, warp::cosine_hemisphere_pdf(w.z))
            };
            let wi = frame.to_world(local);
            if x.ng.dot(wi) <= 0.0 || pdf <= 0.0 {
                continue;
            }
            counts.bounce_rays += 1;
            let le = match self.accel.closest_hit(origin, wi, f32::INFINITY) {
                Some(hit) => self.emission_at(&hit, -wi),
                None => self.environment_radiance(wi),
            };
            if le == Vec3::ZERO {
                continue;
            }
            let f = x.brdf.eval(x.ns, x.wo, wi);
            sum += f * le * local.z / (samples as f32 * pdf);
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn power_heuristic_weights_of_a_pair_sum_to_one() {
        for (a, b) in [
            (1.0f32, 1.0),
            (0.3, 7.0),
            (1e-20, 1e10),
            (5.0, 0.0),
            (0.0, 2.0),
            (f32::INFINITY, 1.0),
        ] {
            let sum = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((sum - 1.0).abs() < 1e-6, "w({a},{b}) + w({b},{a}) = {sum}");
        }
        assert_eq!(power_heuristic(1.0, 3.0), 0.1);
    }
}
