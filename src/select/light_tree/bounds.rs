//! Light bounds: the box, power Φ, normal cone (axis w, half-angle θo) and
//! emission spread θe of a set of emitters, their union (pbrt-v4's
//! `DirectionCone` union for the cones), and the bounding sphere of a box that
//! the importance in [`super::lanes`] sees.

use glam::{DVec3, Vec3};
use std::f64::consts::PI;

use super::*;

/// Bounds of one emitter or a group: what the importance function needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// Lower corner of the axis-aligned box of the emitter(s).
    pub lo: Vec3,
    /// Upper corner of the axis-aligned box of the emitter(s).
    pub hi: Vec3,
    /// Emitted power Φ ≥ 0 (already including ×2 for two-sided emitters).
    pub phi: f32,
    /// Unit axis of the normal cone.
    pub w: Vec3,
    /// cos θo, θo the normal cone's half-angle (1 for a flat one-sided
    /// triangle, −1 for a point light).
    pub cos_theta_o: f32,
    /// cos θe, θe the emission spread beyond θo (0 for area emitters: 90°).
    pub cos_theta_e: f32,
    /// Whether the emitter(s) also emit on the side opposite to their normal.
    pub two_sided: bool,
}

impl LightBounds {
    /// Bounds of both: box union, Φ summed, the smallest cone holding both
    /// normal cones (pbrt's `DirectionCone` union), the larger θe, and two-sided
    /// if either is.
    pub fn union(&self, other: &LightBounds) -> LightBounds {
        let (w, cos_theta_o) = cone_union((self.w, self.cos_theta_o), (other.w, other.cos_theta_o));
        LightBounds {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
            phi: (self.phi + other.phi).min(f32::MAX),
            w,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(other.cos_theta_e),
            two_sided: self.two_sided || other.two_sided,
        }
    }

    /// The box's centre and its half diagonal squared.
    #[inline(always)]
    pub(super) fn centre_and_half_diagonal_sq(&self) -> (Vec3, f32) {
        let centre = (self.lo + self.hi) * 0.5;
        (centre, ((self.hi - self.lo) * 0.5).length_squared())
    }
}

/// Radius of a sphere about the f32 centre that surely holds the box: the half
/// diagonal enlarged for the rounding of the centre and of the half diagonal.
pub(super) fn bounding_radius(centre: Vec3, half_diagonal_sq: f32) -> f32 {
    let eps = f32::EPSILON;
    half_diagonal_sq.sqrt() * (1.0 + 8.0 * eps) + 4.0 * eps * centre.abs().max_element()
}

/// Angle between two vectors, accurate at small and large angles.
pub(super) fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// The largest f32 not above `c` (so a cone never narrows), at least −1.
pub(super) fn cos_down(c: f64) -> f32 {
    let f = c as f32;
    let f = if f64::from(f) > c { f.next_down() } else { f };
    f.max(-1.0)
}

/// Whether the cone holds every direction (or has no usable axis).
pub(super) fn is_whole_sphere((w, cos): (Vec3, f32)) -> bool {
    cos <= -1.0 || w.length_squared() == 0.0 || !w.is_finite()
}

/// Smallest cone holding two cones (w, cos θ), following pbrt-v4's
/// `DirectionCone` union: if one holds the other it is the result; otherwise
/// the half-angle is (θa + θd + θb)/2, θd = ∠(wa, wb), and the axis is wa
/// turned towards wb by that minus θa. Computed in f64, widened by
/// `ANGLE_SLACK` and with the cosine rounded down.
pub(super) fn cone_union(a: (Vec3, f32), b: (Vec3, f32)) -> (Vec3, f32) {
    if is_whole_sphere(a) || is_whole_sphere(b) {
        return (a.0, -1.0);
    }
    // Equal cones (common: a facade's lights share a normal) need no arccosines: θd = 0, so
    // the test below returns `a`.
    if a == b {
        return a;
    }
    let (wa, wb) = (a.0.as_dvec3().normalize(), b.0.as_dvec3().normalize());
    let theta_a = f64::from(a.1).clamp(-1.0, 1.0).acos();
    let theta_b = f64::from(b.1).clamp(-1.0, 1.0).acos();
    let theta_d = angle_between(wa, wb);
    if (theta_d + theta_b).min(PI) <= theta_a {
        return a;
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return b;
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    let spread = theta_o + ANGLE_SLACK;
    let Some(pivot) = wa.cross(wb).try_normalize() else {
        return (a.0, -1.0);
    };
    if spread >= PI {
        return (a.0, -1.0);
    }
    let (sin_r, cos_r) = (theta_o - theta_a).sin_cos();
    let w = wa * cos_r + pivot.cross(wa) * sin_r;
    (w.as_vec3().normalize(), cos_down(spread.cos()))
}
