//! Uniform solid-angle sampling of a planar triangle as seen from a point.
//!
//! The triangle `(v0, v1, v2)` seen from `p` projects onto the unit sphere around `p` as the
//! spherical triangle with vertices `A, B, C` (unit directions to `v0, v1, v2`). Its area is the
//! solid angle `Ω` (steradians), evaluated with the formula of Van Oosterom & Strackee (1983).
//!
//! [`sample_spherical_triangle`] implements the inversion of J. Arvo, "Stratified Sampling of
//! Spherical Triangles", SIGGRAPH 1995: `u0` picks the sub-triangle `(A, B, C')` of area
//! `u0·Ω` (with `C'` on the arc `AC`), and `u1` picks a point on the arc `BC'` uniformly in the
//! cosine of its angle from `B`. The resulting direction `ω` has density
//!
//! ```text
//! pdf(ω) = 1 / Ω     with respect to solid angle (per steradian) at p,
//! ```
//!
//! The map `u ↦ ω` is continuous; `u0` is exactly the fraction of `Ω` swept by `(A, B, C')` and
//! `u1` the fraction of `1 − cos|BC'|` covered along the arc, so stratified or low-discrepancy
//! `u` stays stratified on the sphere.
//!
//! All spherical trigonometry runs in `f64` on the vertex offsets `v_i − p` and edges
//! `v_j − v_i`, which are exact in `f64` for `f32` inputs of comparable magnitude (within a
//! factor of about 2^29); only the results are rounded to `f32`.

use glam::{DVec3, Vec3};

/// A direction drawn uniformly in the solid angle of a triangle seen from a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphericalSample {
    /// Unit direction from `p` towards the triangle.
    pub direction: Vec3,
    /// Point where the ray `p + t·direction` meets the triangle (inside it, up to `f32` rounding).
    pub point: Vec3,
    /// Density of `direction` per steradian: `1/Ω`, bit-identical to [`spherical_pdf`].
    pub pdf: f32,
}

/// Solid angle (sr) subtended at `p` by the triangle `(v0, v1, v2)`.
///
/// Van Oosterom & Strackee (1983): with `a, b, c` the unit directions from `p` to the vertices,
///
/// ```text
/// tan(Ω/2) = |a·(b×c)| / (1 + a·b + b·c + c·a),   i.e.  Ω = 2·atan2(|a·(b×c)|, 1 + a·b + b·c + c·a).
/// ```
///
/// The triple product is taken as `(v0 − p)·((v1 − v0)×(v2 − v0)) / (|v0 − p||v1 − p||v2 − p|)`,
/// which avoids the cancellation of `b×c` for small or distant triangles. Computed in `f64` and
/// rounded to `f32`. Returns 0 for a degenerate triangle, for `p` in the triangle's plane or at a
/// vertex, and for non-finite input.
pub fn solid_angle(p: Vec3, v: [Vec3; 3]) -> f32 {
    SphericalTriangle::new(p, v).map_or(0.0, |view| view.omega as f32)
}

/// Density `1/Ω` (per steradian) of [`sample_spherical_triangle`], for MIS weights.
///
/// Returns 0 when `Ω` is 0, or so small that `1/Ω` overflows `f32`; exactly in those cases the
/// sampler returns `None`.
pub fn spherical_pdf(p: Vec3, v: [Vec3; 3]) -> f32 {
    pdf_from_solid_angle(solid_angle(p, v))
}

/// Draws a direction uniformly within the solid angle of the triangle `(v0, v1, v2)` seen from `p`.
///
/// Arvo (1995), with `A, B, C` the unit directions to `v0, v1, v2`, `α` the interior angle at
/// `A`, `c` the arc length `AB` and `Â = u0·Ω`:
///
/// ```text
/// s = sin(Â − α),  t = cos(Â − α),  u = t − cos α,  v = s + sin α·cos c,
/// q = cos|AC'| = ((v·t − u·s)·cos α − v) / ((v·s + u·t)·sin α),
/// C' = q·A + √(1 − q²)·unit(C − (C·A)·A),
/// z = cos|Bω| = 1 − u1·(1 − C'·B),
/// ω = z·B + √(1 − z²)·unit(C' − (C'·B)·B).
/// ```
///
/// `u` and `v` are evaluated in their cancellation-free forms
/// `u = 2·sin(Â/2)·sin(α − Â/2)` and `v = 2·sin(Â/2)·cos(α − Â/2) − sin α·|A − B|²/2`.
///
/// The hit point comes from the barycentrics of `ω` with respect to the vertex offsets
/// (Cramer's rule), clamped into the triangle; `direction` is then re-derived from that point, so
/// `point` lies on the ray and inside the triangle even where the ray grazes the plane. `u` is
/// clamped to `[0, 1]²`.
///
/// Returns `None` when `Ω` is 0 (see [`solid_angle`]), when `1/Ω` overflows `f32`, or when the
/// computation degenerates to a non-finite value.
pub fn sample_spherical_triangle(p: Vec3, v: [Vec3; 3], u: [f32; 2]) -> Option<SphericalSample> {
    SphericalTriangle::new(p, v)?.sample(u)
}

/// `1/Ω`, or 0 if `Ω` is 0 or its reciprocal is not a finite `f32`.
fn pdf_from_solid_angle(omega: f32) -> f32 {
    let pdf = omega.recip();
    if omega > 0.0 && pdf.is_finite() {
        pdf
    } else {
        0.0
    }
}

/// Unit vector along `x`, or zero when `x` is zero.
fn unit_or_zero(x: DVec3) -> DVec3 {
    let length = x.length();
    if length > 0.0 {
        x * length.recip()
    } else {
        DVec3::ZERO
    }
}

/// The triangle as seen from `p`, in `f64`: set up once, then its solid angle, density and
/// samples all come from the same Ω (so a caller's threshold test and the sample agree).
pub struct SphericalTriangle {
    origin: DVec3,
    vertex: [DVec3; 3],
    /// Offsets `v_i − p`.
    offset: [DVec3; 3],
    /// Lengths `|v_i − p|`.
    length: [f64; 3],
    /// Unit directions `offset_i / |offset_i|` (the spherical vertices A, B, C).
    dir: [DVec3; 3],
    /// `|A·(B×C)|`.
    unit_triple: f64,
    /// `det(offset_0, offset_1, offset_2)`, non-zero.
    triple: f64,
    /// Solid angle, in `(0, 2π]`.
    omega: f64,
}

impl SphericalTriangle {
    /// `None` when the solid angle is 0 or not finite.
    pub fn new(p: Vec3, v: [Vec3; 3]) -> Option<Self> {
        let origin = p.as_dvec3();
        let vertex = v.map(Vec3::as_dvec3);
        let offset = vertex.map(|x| x - origin);
        let length = offset.map(DVec3::length);
        if !length.iter().all(|l| *l > 0.0 && l.is_finite()) {
            return None;
        }
        let dir = [0, 1, 2].map(|i| offset[i] * length[i].recip());
        let normal = (vertex[1] - vertex[0]).cross(vertex[2] - vertex[0]);
        let triple = offset[0].dot(normal);
        if triple == 0.0 || !triple.is_finite() {
            return None;
        }
        let [a, b, c] = dir;
        let unit_triple = triple.abs() / (length[0] * length[1] * length[2]);
        let omega = 2.0 * unit_triple.atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a));
        (omega > 0.0 && omega.is_finite()).then_some(Self {
            origin,
            vertex,
            offset,
            length,
            dir,
            unit_triple,
            triple,
            omega,
        })
    }

    /// Ω in steradians, rounded to `f32` (what [`solid_angle`] returns).
    pub fn solid_angle(&self) -> f32 {
        self.omega as f32
    }

    /// `1/Ω` per steradian (what [`spherical_pdf`] returns).
    pub fn pdf(&self) -> f32 {
        pdf_from_solid_angle(self.solid_angle())
    }

    /// The sample of [`sample_spherical_triangle`] for this view.
    pub fn sample(&self, u: [f32; 2]) -> Option<SphericalSample> {
        let pdf = self.pdf();
        if pdf == 0.0 {
            return None;
        }
        let w = self.arvo_direction([f64::from(u[0]), f64::from(u[1])])?;
        let bary = self.barycentrics(w)?;
        let [v0, v1, v2] = self.vertex;
        let point = v0 + bary[1] * (v1 - v0) + bary[2] * (v2 - v0);
        let offset = point - self.origin;
        let length = offset.length();
        if !(length > 0.0 && length.is_finite()) {
            return None;
        }
        Some(SphericalSample {
            direction: (offset * length.recip()).as_vec3(),
            point: point.as_vec3(),
            pdf,
        })
    }

    /// Arvo's map from `u ∈ [0, 1]²` to a unit direction inside the spherical triangle.
    fn arvo_direction(&self, u: [f64; 2]) -> Option<DVec3> {
        let [a, b, _] = self.dir;
        let d0 = self.offset[0];
        let [l0, l1, l2] = self.length;
        // A×B and A×C (normals of the great circles AB and AC), through edges to avoid
        // cancellation: d0×d1 = d0×(v1 − v0) and d0×d2 = d0×(v2 − v0).
        let n_ac = d0.cross(self.vertex[2] - self.vertex[0]);
        let a_cross_b = d0.cross(self.vertex[1] - self.vertex[0]) * (l0 * l1).recip();
        let a_cross_c = n_ac * (l0 * l2).recip();
        // Interior angle α at A: cos α ∝ (A×B)·(A×C), sin α ∝ |(A×B)×(A×C)| = |A·(B×C)|.
        let cos_raw = a_cross_b.dot(a_cross_c);
        // Both terms are at most 1 in magnitude, so squaring cannot overflow.
        let norm = (cos_raw * cos_raw + self.unit_triple * self.unit_triple).sqrt();
        if !norm.is_normal() {
            return None;
        }
        let inv_norm = norm.recip();
        let (sin_alpha, cos_alpha) = (self.unit_triple * inv_norm, cos_raw * inv_norm);
        let one_minus_cos_c = 0.5 * (a - b).length_squared();

        // Trigonometry of Â/2 and α − Â/2 by angle addition; Â − α = Â/2 − (α − Â/2).
        let area = u[0].clamp(0.0, 1.0) * self.omega;
        let (sin_half, cos_half) = (0.5 * area).sin_cos();
        let sin_d = sin_alpha * cos_half - cos_alpha * sin_half;
        let cos_d = cos_alpha * cos_half + sin_alpha * sin_half;
        let s = sin_half * cos_d - cos_half * sin_d;
        let t = cos_half * cos_d + sin_half * sin_d;
        let uu = 2.0 * sin_half * sin_d;
        let vv = 2.0 * sin_half * cos_d - sin_alpha * one_minus_cos_c;
        let q = ((vv * t - uu * s) * cos_alpha - vv) / ((vv * s + uu * t) * sin_alpha);
        if !q.is_finite() {
            return None;
        }
        let q = q.clamp(-1.0, 1.0);
        // Tangent at A towards C: (a×c)×a = c − (c·a)·a.
        let tangent_ac = unit_or_zero(n_ac.cross(d0));
        let c_prime = q * a + ((1.0 - q) * (1.0 + q)).sqrt() * tangent_ac;

        // 1 − C'·B and the tangent at B towards C', both free of cancellation near B.
        let delta = c_prime - b;
        let one_minus_cos_bc = 0.5 * delta.length_squared();
        let one_minus_z = u[1].clamp(0.0, 1.0) * one_minus_cos_bc;
        let z = 1.0 - one_minus_z;
        let sin_theta = (one_minus_z * (2.0 - one_minus_z)).max(0.0).sqrt();
        let tangent_b = unit_or_zero(delta + one_minus_cos_bc * b);
        let w = z * b + sin_theta * tangent_b;
        w.is_finite().then_some(w)
    }

    /// Barycentrics `(λ0, λ1, λ2)` of the point where the ray from `p` along `w` meets the
    /// triangle's plane, clamped into the triangle.
    ///
    /// Writing `w = Σ x_i·d_i` with `d_i = v_i − p`, Cramer's rule gives
    /// `x_i = w·(d_j×d_k) / det(d0, d1, d2)`, and `λ_i = x_i / Σ x_j`.
    fn barycentrics(&self, w: DVec3) -> Option<[f64; 3]> {
        let [v0, v1, v2] = self.vertex;
        let [d0, d1, d2] = self.offset;
        // d_j×d_k through an edge, to avoid cancellation: d1×d2 = d1×(v2 − v1), etc.
        let m = [d1.cross(v2 - v1), d2.cross(v0 - v2), d0.cross(v1 - v0)];
        let sign = self.triple.signum();
        let x = m.map(|m_i| (sign * w.dot(m_i)).max(0.0));
        let sum = x[0] + x[1] + x[2];
        if !(sum > 0.0 && sum.is_finite()) {
            return None;
        }
        let inv_sum = sum.recip();
        Some(x.map(|x_i| x_i * inv_sum))
    }
}

#[cfg(test)]
mod tests;
