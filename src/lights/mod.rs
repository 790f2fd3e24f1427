//! Lights: one per emissive triangle, with its power for selection and area sampling.

use glam::Vec3;

use crate::sampling::warp;
use crate::scene::Scene;

/// Rec.709 luminance of linear RGB.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Whether a surface with unit front normal `n` emits toward direction `w` (pointing away from
/// the surface): always when two-sided, else only from the counter-clockwise front face.
#[inline]
pub fn emits_toward(n: Vec3, two_sided: bool, w: Vec3) -> bool {
    let c = n.dot(w);
    c > 0.0 || (two_sided && c < 0.0)
}

/// An emissive triangle of constant radiance: p(b1, b2) = p0 + b1·e1 + b2·e2.
#[derive(Clone, Debug)]
pub struct TriangleLight {
    pub p0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    /// Unit normal of the front face.
    pub normal: Vec3,
    pub area: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻².
    pub radiance: Vec3,
    pub two_sided: bool,
}

impl TriangleLight {
    /// Emitted power used for selection: Φ = π·A·luminance(L), doubled when two-sided (f64).
    pub fn power(&self) -> f64 {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        std::f64::consts::PI * self.area as f64 * luminance(self.radiance) as f64 * sides
    }

    /// A point uniform over the triangle: pdf 1/A in area measure.
    #[inline]
    pub fn sample_area(&self, u: [f32; 2]) -> Vec3 {
        let (b1, b2) = warp::uniform_triangle(u);
        self.p0 + b1 * self.e1 + b2 * self.e2
    }

    /// Radiance leaving the light toward unit direction `w`.
    #[inline]
    pub fn emitted(&self, w: Vec3) -> Vec3 {
        if emits_toward(self.normal, self.two_sided, w) {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }
}

/// All lights of a scene.
#[derive(Clone, Debug, Default)]
pub struct Lights {
    pub lights: Vec<TriangleLight>,
}

impl Lights {
    /// One light per triangle whose material emits.
    pub fn from_scene(scene: &Scene) -> Lights {
        let lights = scene
            .triangles
            .iter()
            .filter_map(|t| {
                let m = &scene.materials[t.material as usize];
                m.is_emissive().then(|| {
                    let [p0, p1, p2] = t.positions;
                    TriangleLight {
                        p0,
                        e1: p1 - p0,
                        e2: p2 - p0,
                        normal: t.geometric_normal(),
                        area: t.area(),
                        radiance: m.emission,
                        two_sided: m.double_sided,
                    }
                })
            })
            .collect();
        Lights { lights }
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Φ of every light (f64).
    pub fn powers(&self) -> Vec<f64> {
        self.lights.iter().map(TriangleLight::power).collect()
    }

    /// Total emitted power Σ Φ, summed in f64.
    pub fn total_power(&self) -> f64 {
        self.lights.iter().map(TriangleLight::power).sum()
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
        };
        assert!((l.power() - std::f64::consts::PI).abs() < 1e-6);
        l.two_sided = true;
        assert!((l.power() - 2.0 * std::f64::consts::PI).abs() < 1e-6);
        assert_eq!(l.emitted(-Vec3::Z), l.radiance);
        l.two_sided = false;
        assert_eq!(l.emitted(-Vec3::Z), Vec3::ZERO);
        assert_eq!(l.emitted(Vec3::Z), l.radiance);
    }
}
