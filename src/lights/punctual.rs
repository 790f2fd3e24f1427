//! Delta lights from KHR_lights_punctual: point and spot lights (radiant intensity I, W/sr) and
//! directional lights (irradiance E, W/m², at infinity). Each is sampled exactly: one direction,
//! no pdf, so their N in the K×N estimator is 1.
//!
//! glTF gives luminous intensity (cd) and illuminance (lx); [`from_punctual`] divides them by
//! the luminous efficacy 683 lm/W ([`crate::scene::LUMINOUS_EFFICACY`]) unless the scene says its
//! values are already radiometric. A Blender light of Φ watts exported in the default lighting
//! mode has I = Φ/(4π)·683 cd, so it comes back as Φ/(4π) W/sr: Φ watts again.

use glam::Vec3;

use crate::color::luminance;
use crate::scene::{PunctualKind, PunctualLight, PunctualUnits};

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

/// Converts a scene's punctual light, its intensity in `units`, to W/sr or W/m²;
/// `scene_radius` sizes directional lights' power.
pub fn from_punctual(l: &PunctualLight, scene_radius: f32, units: PunctualUnits) -> super::Light {
    let intensity = l.intensity * units.to_radiometric();
    match l.kind {
        PunctualKind::Point => super::Light::Point(PointLight {
            position: l.position,
            intensity,
            spot: None,
        }),
        PunctualKind::Spot {
            cos_inner,
            cos_outer,
        } => super::Light::Point(PointLight {
            position: l.position,
            intensity,
            spot: Some((l.direction, cos_inner, cos_outer)),
        }),
        PunctualKind::Directional => super::Light::Directional(DirectionalLight {
            direction: l.direction,
            irradiance: intensity,
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
    fn photometric_units_divide_by_the_luminous_efficacy() {
        // A Blender point light of 100 W exported in the default lighting mode: 100/(4π)·683 cd.
        let cd = 100.0 / (4.0 * std::f32::consts::PI) * 683.0;
        let l = PunctualLight {
            kind: PunctualKind::Point,
            position: Vec3::ZERO,
            direction: -Vec3::Z,
            intensity: Vec3::splat(cd),
        };
        let super::super::Light::Point(p) = from_punctual(&l, 1.0, PunctualUnits::Photometric)
        else {
            panic!("a point light")
        };
        assert!((p.power() - 100.0).abs() < 1e-3, "{} W", p.power());
        let super::super::Light::Point(raw) = from_punctual(&l, 1.0, PunctualUnits::Radiometric)
        else {
            panic!("a point light")
        };
        assert_eq!(raw.intensity, Vec3::splat(cd));
        // A sun of 3 W/m² written as 3·683 lx.
        let sun = PunctualLight {
            kind: PunctualKind::Directional,
            intensity: Vec3::splat(3.0 * 683.0),
            ..l
        };
        let super::super::Light::Directional(d) =
            from_punctual(&sun, 1.0, PunctualUnits::Photometric)
        else {
            panic!("a directional light")
        };
        assert!((d.irradiance - Vec3::splat(3.0)).abs().max_element() < 1e-5);
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
