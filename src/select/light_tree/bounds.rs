//! Light bounds and their importance: the box, power Φ, normal cone (axis w,
//! half-angle θo) and emission spread θe of a set of emitters, their union, and
//! the upper bound [`LightBounds::importance`] on what the set can send to a
//! receiver at p with normal n (pbrt-v4 `LightBounds::Importance`: the box seen
//! as a bounding sphere, angles combined through (cos, sin) pairs, no trig).

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

    /// Conservative bound on Φ·cos θ'/d² times the receiver's cosine, at a
    /// receiver point `p` with unit normal `n` (`Vec3::ZERO`: no receiver term).
    ///
    /// With c the box centre, θb the half-angle of the cone from p around the
    /// box's bounding sphere (π when p is inside it):
    /// - emitter: θw = ∠(w, p − c) (|cos| when two-sided), θx = max(0, θw − θo),
    ///   θp = max(0, θx − θb); 0 if cos θp ≤ cos θe, else the factor cos θp;
    /// - receiver: θi = ∠(n, c − p); factor cos(max(0, θi − θb)), 0 when that
    ///   angle reaches 90° (the whole sphere behind the tangent plane);
    /// - d² = max(|p − c|², (|hi − lo|/2)²).
    ///
    /// Cosines near a threshold are given a margin of `COS_SLACK` so that f32
    /// rounding never rejects a node that can reach p's upper hemisphere. The
    /// result is finite and ≥ 0 (clamped to f32::MAX), and positive results
    /// are at least f32::MIN_POSITIVE.
    #[inline(always)]
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        self.importance_with_radius(p, n, bounding_radius)
    }

    /// [`importance`](Self::importance) with the bounding sphere's radius
    /// given by `radius(centre, half_diagonal_sq)`: [`bounding_radius`] or a
    /// value precomputed by it.
    #[inline(always)]
    pub(super) fn importance_with_radius(
        &self,
        p: Vec3,
        n: Vec3,
        radius: impl FnOnce(Vec3, f32) -> f32,
    ) -> f32 {
        let (centre, half_diagonal_sq) = self.centre_and_half_diagonal_sq();
        let valid = self.phi > 0.0 && centre.is_finite() && p.is_finite() && n.is_finite();
        if !valid {
            return 0.0;
        }
        let radius = radius(centre, half_diagonal_sq);
        let to_p = p - centre;
        let dist_sq = to_p.length_squared();
        let sphere = Subtended::new(to_p, dist_sq, radius);
        let emitted = self.emitter_factor(sphere);
        if emitted == 0.0 {
            return 0.0;
        }
        let received = receiver_factor(n, sphere);
        let inv_d_sq = dist_sq.max(half_diagonal_sq).max(f32::MIN_POSITIVE).recip();
        let value = f64::from(self.phi) * f64::from(emitted * received) * f64::from(inv_d_sq);
        if value > 0.0 {
            (value.min(f64::from(f32::MAX)) as f32).max(f32::MIN_POSITIVE)
        } else {
            0.0
        }
    }

    /// The box's centre and its half diagonal squared.
    #[inline(always)]
    pub(super) fn centre_and_half_diagonal_sq(&self) -> (Vec3, f32) {
        let centre = (self.lo + self.hi) * 0.5;
        (centre, ((self.hi - self.lo) * 0.5).length_squared())
    }

    /// cos θp, or 0 when θp ≥ θe (with slack) so no emitter faces p.
    #[inline(always)]
    pub(super) fn emitter_factor(&self, sphere: Option<Subtended>) -> f32 {
        let Some(s) = sphere else {
            return 1.0; // p inside the sphere: θb = π, θp = 0
        };
        let x = if self.cos_theta_o <= -1.0 || self.w == Vec3::ZERO {
            (1.0, 0.0)
        } else {
            let cos_w = self.w.dot(s.dir);
            let cos_w = if self.two_sided { cos_w.abs() } else { cos_w };
            let sin_w = self.w.cross(s.dir).length();
            angle_minus((cos_w, sin_w), (self.cos_theta_o, sin_of(self.cos_theta_o)))
        };
        let (cos_p, _) = angle_minus(x, (s.cos_b, s.sin_b));
        if cos_p <= self.cos_theta_e - COS_SLACK {
            0.0
        } else {
            cos_p.max(COS_SLACK)
        }
    }
}

/// Receiver factor cos(max(0, θi − θb)), or 0 when that angle is ≥ 90° (with
/// slack): the node's bounding sphere lies wholly behind the tangent plane.
#[inline(always)]
pub(super) fn receiver_factor(n: Vec3, sphere: Option<Subtended>) -> f32 {
    let Some(s) = sphere else { return 1.0 };
    if n == Vec3::ZERO {
        return 1.0;
    }
    let to_centre = -s.dir;
    let (cos_i, sin_i) = (n.dot(to_centre), n.cross(to_centre).length());
    let (cos, _) = angle_minus((cos_i, sin_i), (s.cos_b, s.sin_b));
    if cos <= -COS_SLACK {
        0.0
    } else {
        cos.max(COS_SLACK)
    }
}

/// The cone of directions from the receiver that holds a node's bounding
/// sphere: `dir` is the unit vector from the sphere's centre to p, and
/// (`cos_b`, `sin_b`) its half-angle θb, sin θb = r/|p − c|.
#[derive(Clone, Copy, Debug)]
pub(super) struct Subtended {
    pub(super) dir: Vec3,
    pub(super) cos_b: f32,
    pub(super) sin_b: f32,
}

impl Subtended {
    /// `None` when p is inside the sphere (θb = π).
    #[inline(always)]
    pub(super) fn new(to_p: Vec3, dist_sq: f32, radius: f32) -> Option<Subtended> {
        (dist_sq > radius * radius).then(|| {
            let dist = dist_sq.sqrt();
            let inv_dist = dist.recip();
            Subtended {
                dir: to_p * inv_dist,
                cos_b: ((dist - radius) * (dist + radius)).sqrt() * inv_dist,
                sin_b: radius * inv_dist,
            }
        })
    }
}

/// Radius of a sphere about the f32 centre that surely holds the box: the half
/// diagonal enlarged for the rounding of the centre and of the half diagonal.
pub(super) fn bounding_radius(centre: Vec3, half_diagonal_sq: f32) -> f32 {
    let eps = f32::EPSILON;
    half_diagonal_sq.sqrt() * (1.0 + 8.0 * eps) + 4.0 * eps * centre.abs().max_element()
}

/// (cos, sin) of max(0, α − β) from those of α, β ∈ [0, π].
pub(super) fn angle_minus((cos_a, sin_a): (f32, f32), (cos_b, sin_b): (f32, f32)) -> (f32, f32) {
    if cos_a >= cos_b {
        return (1.0, 0.0);
    }
    (
        cos_a * cos_b + sin_a * sin_b,
        (sin_a * cos_b - cos_a * sin_b).max(0.0),
    )
}

/// sin θ from cos θ for θ ∈ [0, π], written (1 − c)(1 + c) to stay accurate
/// near c = ±1.
pub(super) fn sin_of(cos: f32) -> f32 {
    ((1.0 - cos) * (1.0 + cos)).max(0.0).sqrt()
}

/// cos(α + β) from cos α, cos β and sin β, α, β ∈ [0, π]; −1 once α + β ≥ π.
pub(super) fn cos_sum(cos_a: f32, cos_b: f32, sin_b: f32) -> f32 {
    if cos_a + cos_b <= 0.0 {
        return -1.0;
    }
    (cos_a * cos_b - sin_of(cos_a) * sin_b).max(-1.0)
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
