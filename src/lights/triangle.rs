//! An emissive triangle, sampled uniformly by area (pdf 1/A) or in solid angle (pdf 1/Ω).

use glam::Vec3;

use super::spherical_triangle::SphericalTriangle;
use super::{emits_toward, luminance};
use crate::sampling::warp;

/// Solid-angle sampling is used for Ω strictly between these (sr); outside, area sampling, whose
/// pdf is better conditioned for tiny triangles and near-hemispheres (pbrt-v4's thresholds).
pub const MIN_SPHERICAL_SOLID_ANGLE: f32 = 3e-4;
pub const MAX_SPHERICAL_SOLID_ANGLE: f32 = 6.22;

/// How points on a triangle light are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    /// Uniform by area: p(x') = 1/A in area measure.
    Area,
    /// Uniform in the solid angle seen from the receiver (Arvo 1995): p(ω) = 1/Ω, with area
    /// sampling outside the solid-angle thresholds.
    SolidAngle,
}

/// A point x' on a triangle light drawn for receiver p, with the pieces of its weight:
/// the integrand's geometry is cosθ_x · `jacobian` and its density `p_x`, in the measure drawn —
/// area (jacobian = cosθ'/r², p_x = 1/A) or solid angle (jacobian = 1, p_x = 1/Ω).
/// Its density in solid angle, for MIS, is p_x / jacobian.
#[derive(Clone, Copy, Debug)]
pub struct TriangleSample {
    pub point: Vec3,
    /// Unit direction from the receiver to `point`.
    pub wi: Vec3,
    pub jacobian: f32,
    pub p_x: f32,
    /// Whether the solid-angle sampler was used (false: area).
    pub spherical: bool,
}

/// An emissive triangle: p(b1, b2) = p0 + b1·e1 + b2·e2.
#[derive(Clone, Debug)]
pub struct TriangleLight {
    pub p0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    /// Unit normal of the front face.
    pub normal: Vec3,
    pub area: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻²; for a textured emitter its mean over the triangle (the
    /// radiance at a point is the scene's `emission_at`).
    pub radiance: Vec3,
    pub two_sided: bool,
    /// Whether the emission varies over the triangle (an emissive texture).
    pub textured: bool,
    /// The scene triangle this light is.
    pub triangle: u32,
}

impl TriangleLight {
    /// Emitted power used for selection: Φ = π·A·luminance(L), doubled when two-sided (f64).
    pub fn power(&self) -> f64 {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        std::f64::consts::PI * self.area as f64 * luminance(self.radiance) as f64 * sides
    }

    pub fn vertices(&self) -> [Vec3; 3] {
        [self.p0, self.p0 + self.e1, self.p0 + self.e2]
    }

    /// The solid-angle view of this triangle from p, when that technique applies there
    /// (Ω strictly within the thresholds).
    fn spherical_at(&self, p: Vec3, technique: Technique) -> Option<SphericalTriangle> {
        if technique != Technique::SolidAngle {
            return None;
        }
        let view = SphericalTriangle::new(p, self.vertices())?;
        let omega = view.solid_angle();
        (omega > MIN_SPHERICAL_SOLID_ANGLE && omega < MAX_SPHERICAL_SOLID_ANGLE).then_some(view)
    }

    /// Draws a point for receiver p; None when the sample carries no light (edge-on).
    #[inline]
    pub fn sample(&self, p: Vec3, technique: Technique, u: [f32; 2]) -> Option<TriangleSample> {
        if let Some(view) = self.spherical_at(p, technique) {
            // A degenerate spherical sample is dropped rather than redrawn by area, so that
            // pdf_solid_angle always describes the technique that was used.
            return view.sample(u).map(|s| TriangleSample {
                point: s.point,
                wi: s.direction,
                jacobian: 1.0,
                p_x: s.pdf,
                spherical: true,
            });
        }
        let point = self.sample_area(u);
        let d = point - p;
        let dist2 = d.length_squared();
        let wi = d / dist2.sqrt();
        let cos_light = self.normal.dot(wi).abs();
        (dist2 > 0.0 && cos_light > 0.0).then(|| TriangleSample {
            point,
            wi,
            jacobian: cos_light / dist2,
            p_x: 1.0 / self.area,
            spherical: false,
        })
    }

    /// The solid-angle density with which `sample` (same technique) produces the direction from
    /// p toward `point` on this triangle: 1/Ω, or r²/(A·cosθ') where area sampling applies.
    pub fn pdf_solid_angle(&self, p: Vec3, technique: Technique, point: Vec3) -> f32 {
        if let Some(view) = self.spherical_at(p, technique) {
            return view.pdf();
        }
        let d = point - p;
        let dist2 = d.length_squared();
        let cos_light = self.normal.dot(d).abs() / dist2.sqrt();
        if cos_light > 0.0 {
            dist2 / (self.area * cos_light)
        } else {
            0.0
        }
    }

    /// A point uniform over the triangle: pdf 1/A in area measure.
    #[inline]
    pub fn sample_area(&self, u: [f32; 2]) -> Vec3 {
        let (b1, b2) = warp::uniform_triangle(u);
        self.p0 + b1 * self.e1 + b2 * self.e2
    }

    /// Barycentrics (b1, b2) of a point x on the triangle's plane, x = p0 + b1·e1 + b2·e2:
    /// b1 = ((x − p0) × e2)·n / ((e1 × e2)·n), b2 = (e1 × (x − p0))·n / ((e1 × e2)·n).
    #[inline]
    pub fn barycentrics(&self, x: Vec3) -> (f32, f32) {
        let d = x - self.p0;
        let inv = 1.0 / self.e1.cross(self.e2).dot(self.normal);
        (
            d.cross(self.e2).dot(self.normal) * inv,
            self.e1.cross(d).dot(self.normal) * inv,
        )
    }

    /// Radiance leaving the light toward unit direction `w` (the mean radiance when textured).
    #[inline]
    pub fn emitted(&self, w: Vec3) -> Vec3 {
        if emits_toward(self.normal, self.two_sided, w) {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_is_pi_area_luminance_doubled_when_two_sided() {
        let mut l = TriangleLight {
            p0: Vec3::ZERO,
            e1: Vec3::X * 2.0,
            e2: Vec3::Y,
            normal: Vec3::Z,
            area: 1.0,
            radiance: Vec3::new(1.0, 1.0, 1.0),
            two_sided: false,
            textured: false,
            triangle: 0,
        };
        assert!((l.power() - std::f64::consts::PI).abs() < 1e-6);
        l.two_sided = true;
        assert!((l.power() - 2.0 * std::f64::consts::PI).abs() < 1e-6);
        assert_eq!(l.emitted(-Vec3::Z), l.radiance);
        l.two_sided = false;
        assert_eq!(l.emitted(-Vec3::Z), Vec3::ZERO);
        assert_eq!(l.emitted(Vec3::Z), l.radiance);
    }

    #[test]
    fn barycentrics_invert_the_parametrisation() {
        let l = TriangleLight {
            p0: Vec3::new(1.0, -2.0, 0.5),
            e1: Vec3::new(2.0, 0.5, -1.0),
            e2: Vec3::new(-0.5, 1.5, 2.0),
            normal: Vec3::new(2.0, 0.5, -1.0)
                .cross(Vec3::new(-0.5, 1.5, 2.0))
                .normalize(),
            area: 0.0,
            radiance: Vec3::ONE,
            two_sided: false,
            textured: true,
            triangle: 0,
        };
        for (b1, b2) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.2, 0.7), (0.45, 0.1)] {
            let (c1, c2) = l.barycentrics(l.p0 + b1 * l.e1 + b2 * l.e2);
            assert!(
                (c1 - b1).abs() < 1e-5 && (c2 - b2).abs() < 1e-5,
                "{b1},{b2}: {c1},{c2}"
            );
        }
    }
}
