//! Delta lights from KHR_lights_punctual: point and spot lights (radiant intensity I, W/sr) and
//! directional lights (irradiance E, W/m², at infinity). Each is sampled exactly: one direction,
//! no pdf, so their N in the K×N estimator is 1.

use glam::Vec3;

use super::luminance;
use crate::scene::{PunctualKind, PunctualLight};

/// What a delta light delivers to a point: direction toward the light, distance (infinite for
/// directional lights) and the incident quantity that multiplies f·cosθ (I·falloff/r², or E).
#[derive(Clone, Copy, Debug)]
pub struct DeltaSample {
    pub wi: Vec3,
    pub dist: f32,
    pub li: Vec3,
}

/// A point or spot light at `position`.
#[derive(Clone, Debug)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Vec3,
    /// Spot cone: unit direction the light travels, and (cos inner, cos outer); None for a point.
    pub spot: Option<(Vec3, f32, f32)>,
}

impl PointLight {
    /// glTF's spot attenuation: t = clamp((cosθ − cos outer)/(cos inner − cos outer), 0, 1), t².
    fn falloff(&self, from_light: Vec3) -> f32 {
        match self.spot {
            None => 1.0,
            Some((axis, cos_inner, cos_outer)) => {
                let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
                let t = ((axis.dot(from_light) - cos_outer) * scale).clamp(0.0, 1.0);
                t * t
            }
        }
    }

    /// I·falloff/r² arriving at p.
    pub fn sample(&self, p: Vec3) -> Option<DeltaSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        if dist2 <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        Some(DeltaSample {
            wi,
            dist,
            li: self.intensity * (self.falloff(-wi) / dist2),
        })
    }

    /// Φ = 4π·luminance(I) for a point; for a spot, the falloff integrated approximately as
    /// 2π·(1 − (cos inner + cos outer)/2)·luminance(I) (used only for selection).
    pub fn power(&self) -> f64 {
        let solid_angle = match self.spot {
            None => 4.0 * std::f64::consts::PI,
            Some((_, ci, co)) => 2.0 * std::f64::consts::PI * (1.0 - 0.5 * (ci + co) as f64),
        };
        solid_angle * luminance(self.intensity) as f64
    }
}

/// A directional light: parallel light of irradiance E travelling along `direction`.
#[derive(Clone, Debug)]
pub struct DirectionalLight {
    pub direction: Vec3,
    pub irradiance: Vec3,
    /// Radius of the scene's bounding sphere: the light's power is E over that disk.
    pub scene_radius: f32,
}

impl DirectionalLight {
    pub fn sample(&self) -> DeltaSample {
        DeltaSample {
            wi: -self.direction,
            dist: f32::INFINITY,
            li: self.irradiance,
        }
    }

    /// Φ = π·R²·luminance(E): the power crossing the scene's bounding sphere.
    pub fn power(&self) -> f64 {
        std::f64::consts::PI
            * (self.scene_radius as f64).powi(2)
            * luminance(self.irradiance) as f64
    }
}

/// Converts a scene's punctual light; `scene_radius` sizes directional lights' power.
pub fn from_punctual(l: &PunctualLight, scene_radius: f32) -> super::Light {
    match l.kind {
        PunctualKind::Point => super::Light::Point(PointLight {
            position: l.position,
            intensity: l.intensity,
            spot: None,
        }),
        PunctualKind::Spot {
            cos_inner,
            cos_outer,
        } => super::Light::Point(PointLight {
            position: l.position,
            intensity: l.intensity,
            spot: Some((l.direction, cos_inner, cos_outer)),
        }),
        PunctualKind::Directional => super::Light::Directional(DirectionalLight {
            direction: l.direction,
            irradiance: l.intensity,
            scene_radius,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_light_follows_the_inverse_square_law() {
        let l = PointLight {
            position: Vec3::new(0.0, 2.0, 0.0),
            intensity: Vec3::splat(8.0),
            spot: None,
        };
        let s = l.sample(Vec3::ZERO).unwrap();
        assert_eq!(s.wi, Vec3::Y);
        assert_eq!(s.li, Vec3::splat(2.0));
        assert!((l.power() - 4.0 * std::f64::consts::PI * 8.0).abs() < 1e-4);
    }

    #[test]
    fn spot_falloff_is_full_inside_inner_and_zero_outside_outer() {
        let axis = -Vec3::Y;
        let (ci, co) = (0.3f32.cos(), 0.5f32.cos());
        let l = PointLight {
            position: Vec3::Y,
            intensity: Vec3::ONE,
            spot: Some((axis, ci, co)),
        };
        assert_eq!(l.sample(Vec3::ZERO).unwrap().li, Vec3::ONE);
        let outside = Vec3::new(0.6f32.tan(), 0.0, 0.0);
        assert_eq!(l.sample(outside).unwrap().li, Vec3::ZERO);
        let between = Vec3::new(0.4f32.tan(), 0.0, 0.0);
        let li = l.sample(between).unwrap().li.x;
        assert!(li > 0.0 && li < 1.0 / between.length_squared().max(1.0));
    }
}
