//! One camera sample's estimate of L(x, ωo) = Le(x, ωo) + ∫ f · Le · V · G dA'.
//!
//! `light-area`: K lights l_k ~ p_l, N points x' ~ 1/A on each, and
//!     L_r ≈ Σ_k Σ_n f · Le · V · G / (K · N · p_l · p(x')),   G = cosθ · cosθ' / |x − x'|².
//! `hemisphere-*`: K·N directions ω ~ p(ω), L_r ≈ Σ f · Le(hit) · cosθ / (K · N · p(ω)).

use glam::Vec3;

use super::Strategy;
use crate::accel::{offset_ray_origin, Accel, Hit};
use crate::lights::{emits_toward, Lights};
use crate::material::Brdf;
use crate::sampling::rng::PixelRng;
use crate::sampling::warp::{self, Frame};
use crate::scene::Scene;
use crate::select::LightSelector;

/// Rays traced by one or more camera samples, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SampleCounts {
    pub camera_rays: u64,
    pub shadow_rays: u64,
    pub hemisphere_rays: u64,
}

impl SampleCounts {
    pub fn total_rays(&self) -> u64 {
        self.camera_rays + self.shadow_rays + self.hemisphere_rays
    }

    pub fn add(&mut self, o: &SampleCounts) {
        self.camera_rays += o.camera_rays;
        self.shadow_rays += o.shadow_rays;
        self.hemisphere_rays += o.hemisphere_rays;
    }
}

/// Everything needed to estimate radiance along camera rays. Cheap to share across threads.
pub struct Estimator<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub lights: &'a Lights,
    /// None when the scene has no lights.
    pub selector: Option<&'a LightSelector>,
    pub strategy: Strategy,
    pub k: u32,
    pub n: u32,
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
}

impl Estimator<'_> {
    /// Radiance arriving at the camera along the unit direction `dir` from `origin`.
    pub fn radiance(
        &self,
        origin: Vec3,
        dir: Vec3,
        rng: &mut PixelRng,
        counts: &mut SampleCounts,
    ) -> Vec3 {
        counts.camera_rays += 1;
        let Some(hit) = self.accel.closest_hit(origin, dir, f32::INFINITY) else {
            return Vec3::ZERO;
        };
        let wo = -dir;
        let emitted = self.emission_at(hit.triangle, wo);
        let x = self.shading_point(&hit, wo);
        let reflected = match self.strategy {
            Strategy::LightArea => self.light_area(&x, rng, counts),
            Strategy::HemisphereUniform | Strategy::HemisphereCosine => {
                self.hemisphere(&x, rng, counts)
            }
        };
        emitted + reflected
    }

    /// Le of a triangle toward unit direction `w` (zero on a one-sided emitter's back).
    fn emission_at(&self, triangle: u32, w: Vec3) -> Vec3 {
        let tri = &self.scene.triangles[triangle as usize];
        let m = &self.scene.materials[tri.material as usize];
        if m.is_emissive() && emits_toward(tri.geometric_normal(), m.double_sided, w) {
            m.emission
        } else {
            Vec3::ZERO
        }
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
        let brdf = Brdf::new(&self.scene.materials[tri.material as usize]);
        ShadingPoint {
            p,
            ng,
            ns,
            wo,
            brdf,
        }
    }

    /// Σ over K lights and N area samples of f · Le · V · G / (K · N · p_l · p(x')).
    fn light_area(&self, x: &ShadingPoint, rng: &mut PixelRng, counts: &mut SampleCounts) -> Vec3 {
        let Some(selector) = self.selector else {
            return Vec3::ZERO;
        };
        let (k, n) = (self.k as f32, self.n as f32);
        let mut sum = Vec3::ZERO;
        for _ in 0..self.k {
            let (l, p_l) = selector.sample(rng.next_f64());
            let light = &self.lights.lights[l];
            let p_l = p_l as f32;
            for _ in 0..self.n {
                let x_light = light.sample_area(rng.next_2d());
                let p_x = 1.0 / light.area;
                let to_light = x_light - x.p;
                let dist2 = to_light.length_squared();
                let wi = to_light / dist2.sqrt();
                if x.ng.dot(wi) <= 0.0 {
                    continue;
                }
                let le = light.emitted(-wi);
                let f = x.brdf.eval(x.ns, x.wo, wi);
                if le == Vec3::ZERO || f == Vec3::ZERO {
                    continue;
                }
                let g = x.ns.dot(wi) * light.normal.dot(wi).abs() / dist2;
                counts.shadow_rays += 1;
                let light_side = if light.normal.dot(wi) < 0.0 {
                    light.normal
                } else {
                    -light.normal
                };
                if self.accel.segment_occluded(x.p, x.ng, x_light, light_side) {
                    continue;
                }
                sum += f * le * g / (k * n * p_l * p_x);
            }
        }
        sum
    }

    /// Σ over K·N directions of f · Le · cosθ / (K · N · p(ω)), uniform or cosine p(ω).
    fn hemisphere(&self, x: &ShadingPoint, rng: &mut PixelRng, counts: &mut SampleCounts) -> Vec3 {
        let frame = Frame::new(x.ns);
        let origin = offset_ray_origin(x.p, x.ng);
        let samples = self.k * self.n;
        let mut sum = Vec3::ZERO;
        for _ in 0..samples {
            let (local, pdf) = if self.strategy == Strategy::HemisphereUniform {
                (
                    warp::uniform_hemisphere(rng.next_2d()),
                    warp::UNIFORM_HEMISPHERE_PDF,
                )
            } else {
                let w = warp::cosine_hemisphere(rng.next_2d());
                (w, warp::cosine_hemisphere_pdf(w.z))
            };
            let wi = frame.to_world(local);
            if x.ng.dot(wi) <= 0.0 || pdf <= 0.0 {
                continue;
            }
            counts.hemisphere_rays += 1;
            let Some(hit) = self.accel.closest_hit(origin, wi, f32::INFINITY) else {
                continue;
            };
            let le = self.emission_at(hit.triangle, -wi);
            if le == Vec3::ZERO {
                continue;
            }
            let f = x.brdf.eval(x.ns, x.wo, wi);
            sum += f * le * local.z / (samples as f32 * pdf);
        }
        sum
    }
}
