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
mod tests {
    use super::*;
    use rand_core::Rng;
    use rand_pcg::Pcg32;
    use std::f64::consts::PI;

    fn uniform(rng: &mut Pcg32) -> f32 {
        (rng.next_u32() >> 8) as f32 / 16_777_216.0
    }

    fn uv(rng: &mut Pcg32) -> [f32; 2] {
        [uniform(rng), uniform(rng)]
    }

    fn dv(x: Vec3) -> DVec3 {
        x.as_dvec3()
    }

    /// Planar barycentrics of `x` (assumed in the plane) with respect to `v`, in f64.
    fn planar_barycentrics(x: Vec3, v: [Vec3; 3]) -> [f64; 3] {
        let (a, b, c, x) = (dv(v[0]), dv(v[1]), dv(v[2]), dv(x));
        let n = (b - a).cross(c - a);
        let nn = n.length_squared();
        let l1 = (x - a).cross(c - a).dot(n) / nn;
        let l2 = (b - a).cross(x - a).dot(n) / nn;
        [1.0 - l1 - l2, l1, l2]
    }

    /// Vector integral ∫_Δ ω dω over the spherical triangle, from Lambert's polygon formula:
    /// ½ Σ Θ_i Γ_i with Θ_i the arc length of edge i and Γ_i its unit great-circle normal,
    /// oriented so that Γ_i points into the triangle. Projected solid angle on n is `n·` this.
    fn lambert_vector(p: Vec3, v: [Vec3; 3]) -> DVec3 {
        let d = v.map(|x| (dv(x) - dv(p)).normalize());
        let orient = d[0].dot(d[1].cross(d[2])).signum();
        let mut sum = DVec3::ZERO;
        for i in 0..3 {
            let (a, b) = (d[i], d[(i + 1) % 3]);
            let cross = a.cross(b);
            let theta = cross.length().atan2(a.dot(b));
            sum += theta * cross.normalize();
        }
        0.5 * orient * sum
    }

    /// Triangle with vertices on the axes at distance r; from the origin it covers an octant.
    fn octant(r: f32) -> [Vec3; 3] {
        [Vec3::X * r, Vec3::Y * r, Vec3::Z * r]
    }

    /// Equilateral-ish triangle of circumradius `radius` in the plane z = 0 around `centre`.
    fn flat_triangle(centre: Vec3, radius: f32) -> [Vec3; 3] {
        [0.0f32, 2.0, 4.0].map(|k| {
            let phi = k * std::f32::consts::FRAC_PI_3 + 0.3;
            centre + radius * Vec3::new(phi.cos(), phi.sin(), 0.0)
        })
    }

    /// Point `foot + h·dir` where Ω of `tri` reaches `target`, by bisection on `h`.
    fn at_solid_angle(tri: [Vec3; 3], foot: Vec3, dir: Vec3, target: f32) -> Vec3 {
        let (mut lo, mut hi) = (1e-6f32, 1e6f32);
        for _ in 0..200 {
            let mid = (lo * hi).sqrt();
            if solid_angle(foot + dir * mid, tri) > target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        foot + dir * lo
    }

    /// Point above the centroid of `tri` (in z = 0) where Ω reaches `target`.
    fn height_for_solid_angle(tri: [Vec3; 3], target: f32) -> Vec3 {
        at_solid_angle(tri, (tri[0] + tri[1] + tri[2]) / 3.0, Vec3::Z, target)
    }

    struct Case {
        name: &'static str,
        p: Vec3,
        v: [Vec3; 3],
    }

    fn cases() -> Vec<Case> {
        let big = flat_triangle(Vec3::ZERO, 1.0);
        let sliver = [
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.02, 0.0),
            Vec3::new(0.9, -0.01, 0.0),
        ];
        vec![
            Case {
                name: "octant",
                p: Vec3::ZERO,
                v: octant(2.0),
            },
            Case {
                name: "near",
                p: Vec3::new(0.1, 0.2, 0.15),
                v: [
                    Vec3::new(-0.5, -0.4, 0.0),
                    Vec3::new(0.7, -0.2, 0.1),
                    Vec3::new(0.0, 0.8, -0.05),
                ],
            },
            Case {
                name: "far",
                p: Vec3::new(3.0, -40.0, 25.0),
                v: [
                    Vec3::new(-0.5, -0.4, 0.0),
                    Vec3::new(0.7, -0.2, 0.1),
                    Vec3::new(0.0, 0.8, -0.05),
                ],
            },
            Case {
                name: "large ~2 sr",
                p: height_for_solid_angle(big, 2.0),
                v: big,
            },
            Case {
                name: "small ~1e-3 sr",
                p: height_for_solid_angle(big, 1e-3),
                v: big,
            },
            Case {
                name: "obtuse",
                p: Vec3::new(0.3, 0.5, 0.6),
                v: [
                    Vec3::new(-1.5, 0.0, 0.0),
                    Vec3::new(1.5, 0.0, 0.0),
                    Vec3::new(0.2, 0.25, 0.0),
                ],
            },
            Case {
                name: "sliver, sharp at v0",
                p: Vec3::new(0.2, 0.3, 0.4),
                v: [
                    Vec3::new(-1.0, 0.0, 0.0),
                    Vec3::new(1.0, 0.01, 0.0),
                    Vec3::new(1.0, -0.01, 0.0),
                ],
            },
            Case {
                name: "sliver, sharp at v1",
                p: Vec3::new(0.2, 0.3, 0.4),
                v: [
                    Vec3::new(1.0, 0.01, 0.0),
                    Vec3::new(-1.0, 0.0, 0.0),
                    Vec3::new(1.0, -0.01, 0.0),
                ],
            },
            Case {
                name: "sliver, flat at v0",
                p: Vec3::new(-0.3, 0.2, 0.5),
                v: [
                    Vec3::new(0.0, 0.005, 0.0),
                    Vec3::new(1.0, 0.0, 0.0),
                    Vec3::new(-1.0, 0.0, 0.0),
                ],
            },
            Case {
                name: "threshold 3e-4 sr",
                p: height_for_solid_angle(big, 3e-4),
                v: big,
            },
            Case {
                name: "threshold 6.2 sr",
                p: height_for_solid_angle(big, 6.2),
                v: big,
            },
            Case {
                name: "threshold 3e-4 sr, oblique sliver",
                p: at_solid_angle(
                    sliver,
                    Vec3::ZERO,
                    Vec3::new(0.3, -0.5, 0.2).normalize(),
                    3e-4,
                ),
                v: sliver,
            },
            Case {
                name: "threshold 6.2 sr, off-centre",
                p: at_solid_angle(big, 0.8 * big[1] + 0.1 * big[2], Vec3::Z, 6.2),
                v: big,
            },
            Case {
                name: "edge-on, p beside the plane",
                p: Vec3::new(2.0, 0.1, 0.02),
                v: big,
            },
        ]
    }

    #[test]
    fn solid_angle_of_octant_is_pi_over_2() {
        for r in [1e-3, 0.5, 1.0, 7.0, 1e4] {
            let omega = solid_angle(Vec3::ZERO, octant(r));
            assert!(
                (f64::from(omega) - PI / 2.0).abs() < 1e-6,
                "r = {r}: {omega}"
            );
        }
    }

    #[test]
    fn solid_angle_of_small_far_triangle_matches_area_cos_over_d2() {
        let v = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.02, 0.0, 0.0),
            Vec3::new(0.005, 0.03, 0.0),
        ];
        let centroid = (dv(v[0]) + dv(v[1]) + dv(v[2])) / 3.0;
        let area = 0.5 * (dv(v[1]) - dv(v[0])).cross(dv(v[2]) - dv(v[0])).length();
        for (dir, d) in [
            (DVec3::Z, 5.0),
            (DVec3::new(0.3, -0.4, 0.8).normalize(), 10.0),
            (DVec3::new(-0.9, 0.1, 0.2).normalize(), 3.0),
        ] {
            let p = (centroid + d * dir).as_vec3();
            let to_p = dv(p) - centroid;
            let expected = area * to_p.normalize().z.abs() / to_p.length_squared();
            let omega = f64::from(solid_angle(p, v));
            assert!(
                (omega / expected - 1.0).abs() < 1e-3,
                "{omega} vs {expected}"
            );
        }
    }

    #[test]
    fn solid_angle_ignores_vertex_order_and_orientation() {
        for case in cases() {
            let [a, b, c] = case.v;
            let reference = solid_angle(case.p, case.v);
            for perm in [
                [a, b, c],
                [b, c, a],
                [c, a, b],
                [a, c, b],
                [c, b, a],
                [b, a, c],
            ] {
                let omega = solid_angle(case.p, perm);
                assert!(
                    (omega - reference).abs() <= 1e-6 * reference,
                    "{}: {omega} vs {reference}",
                    case.name
                );
            }
            // Reflecting p through the plane flips the orientation as seen from p.
            let n = (dv(b) - dv(a)).cross(dv(c) - dv(a)).normalize();
            let mirrored = dv(case.p) - 2.0 * (dv(case.p) - dv(a)).dot(n) * n;
            let omega = solid_angle(mirrored.as_vec3(), case.v);
            assert!(
                (omega - reference).abs() <= 1e-4 * reference,
                "{} mirrored: {omega} vs {reference}",
                case.name
            );
        }
    }

    #[test]
    fn solid_angle_is_zero_in_plane_or_degenerate() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        for p in [
            Vec3::new(0.2, 0.2, 0.0),
            Vec3::new(3.0, -1.0, 0.0),
            Vec3::ZERO,
            Vec3::new(0.5, 0.0, 0.0),
        ] {
            assert_eq!(solid_angle(p, tri), 0.0, "{p}");
            assert_eq!(spherical_pdf(p, tri), 0.0);
            assert!(sample_spherical_triangle(p, tri, [0.5, 0.5]).is_none());
        }
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let point = [Vec3::ONE; 3];
        for v in [line, point] {
            assert_eq!(solid_angle(Vec3::Z, v), 0.0);
            assert!(sample_spherical_triangle(Vec3::Z, v, [0.5, 0.5]).is_none());
        }
        // A tilted plane: p is only in it up to f32 rounding.
        let tilted = [
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::new(1.3, -0.7, 0.9),
            Vec3::new(-0.4, 1.1, 2.0),
        ];
        let p = tilted[0] + 0.3 * (tilted[1] - tilted[0]) + 0.25 * (tilted[2] - tilted[0]);
        let outside = tilted[0] + 1.5 * (tilted[1] - tilted[0]) + 0.25 * (tilted[2] - tilted[0]);
        assert!(solid_angle(outside, tilted) < 1e-5);
        let omega = solid_angle(p, tilted);
        println!("p in a tilted plane (up to f32 rounding): Ω = {omega:e}");
        assert!(
            !(1e-5..=2.0 * std::f32::consts::PI - 1e-4).contains(&omega),
            "{omega}"
        );
    }

    #[test]
    fn pdf_is_reciprocal_of_solid_angle() {
        let mut rng = Pcg32::new(11, 3);
        for case in cases() {
            let omega = solid_angle(case.p, case.v);
            let pdf = spherical_pdf(case.p, case.v);
            assert_eq!(pdf, 1.0 / omega, "{}", case.name);
            for _ in 0..100 {
                let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng)).unwrap();
                assert_eq!(s.pdf, pdf, "{}", case.name);
            }
        }
    }

    /// Largest barycentric violation and distance from the ray, and |1 − |direction||.
    fn check_samples(case: &Case, n: usize, seed: u64) -> (f64, f64) {
        let mut rng = Pcg32::new(seed, 7);
        let mut worst_bary = 0.0f64;
        let mut worst_ray = 0.0f64;
        let scale = case
            .v
            .iter()
            .map(|x| (dv(*x) - dv(case.p)).length())
            .fold(0.0, f64::max);
        for _ in 0..n {
            let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng))
                .unwrap_or_else(|| panic!("{}: no sample", case.name));
            assert!(s.direction.is_finite() && s.point.is_finite());
            assert!(
                (f64::from(s.direction.length()) - 1.0).abs() < 1e-6,
                "{}: |direction| = {}",
                case.name,
                s.direction.length()
            );
            let l = planar_barycentrics(s.point, case.v);
            worst_bary = worst_bary.max(-l[0]).max(-l[1]).max(-l[2]);
            worst_bary = worst_bary.max(l[0] + l[1] + l[2] - 1.0);
            let off = dv(s.point) - dv(case.p);
            let miss = off.cross(dv(s.direction)).length() / scale;
            worst_ray = worst_ray.max(miss);
            assert!(off.dot(dv(s.direction)) > 0.0, "{}: behind p", case.name);
        }
        (worst_bary, worst_ray)
    }

    #[test]
    fn samples_lie_inside_the_triangle_and_on_the_ray() {
        for (k, case) in cases().iter().enumerate() {
            let (bary, ray) = check_samples(case, 20_000, 100 + k as u64);
            println!(
                "{:32} max barycentric violation {bary:.2e}, ray miss {ray:.2e}",
                case.name
            );
            assert!(bary <= 1e-5, "{}: barycentric violation {bary}", case.name);
            assert!(ray <= 1e-6, "{}: off the ray by {ray}", case.name);
        }
    }

    #[test]
    fn extreme_u_give_vertices_and_edges() {
        for case in cases() {
            let omega = solid_angle(case.p, case.v);
            for u in [
                [0.0, 0.0],
                [1.0, 0.0],
                [0.0, 1.0],
                [1.0, 1.0],
                [0.5, 1.0],
                [1.0, 0.5],
            ] {
                let s = sample_spherical_triangle(case.p, case.v, u).unwrap();
                let l = planar_barycentrics(s.point, case.v);
                let tol = 1e-4;
                // u1 = 0 is the vertex B = v1; u0 = 0 collapses C' onto A; u0 = 1 puts C' at C.
                if u[1] == 0.0 {
                    assert!(l[1] > 1.0 - tol, "{} {u:?}: {l:?}", case.name);
                } else if u[0] == 0.0 {
                    assert!(l[2] < tol, "{} {u:?}: {l:?}", case.name);
                } else if u[0] == 1.0 && u[1] == 1.0 {
                    assert!(l[2] > 1.0 - tol, "{} {u:?}: {l:?}", case.name);
                } else if u[0] == 1.0 {
                    assert!(l[0] < tol, "{} {u:?}: {l:?}", case.name);
                } else {
                    // u1 = 1: on the arc AC, cutting off a fraction u0 of Ω.
                    assert!(l[1] < tol, "{} {u:?}: {l:?}", case.name);
                    let fraction = solid_angle(case.p, [case.v[0], case.v[1], s.point]) / omega;
                    assert!((fraction - u[0]).abs() < 1e-4, "{}: {fraction}", case.name);
                }
            }
        }
    }

    /// Mean of `ω/pdf` against the Lambert vector; returns the worst |error|/σ over the axes
    /// (and along the plane normal) and the largest relative error of the cos-weighted integral.
    fn unbiasedness(case: &Case, n: usize, seed: u64) -> (f64, f64) {
        let normal = {
            let [a, b, c] = case.v.map(dv);
            let n = (b - a).cross(c - a).normalize();
            if n.dot(dv(case.p) - a) >= 0.0 {
                n
            } else {
                -n
            }
        };
        let axes = [DVec3::X, DVec3::Y, DVec3::Z, normal];
        let reference = lambert_vector(case.p, case.v);
        let mut rng = Pcg32::new(seed, 5);
        let mut sum = [0.0f64; 4];
        let mut sum_sq = [0.0f64; 4];
        for _ in 0..n {
            let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng)).unwrap();
            let w = dv(s.direction);
            for (k, axis) in axes.iter().enumerate() {
                let f = w.dot(*axis) / f64::from(s.pdf);
                sum[k] += f;
                sum_sq[k] += f * f;
            }
        }
        let nf = n as f64;
        let mut worst_sigma = 0.0f64;
        let mut cos_rel = 0.0;
        for (k, axis) in axes.iter().enumerate() {
            let mean = sum[k] / nf;
            let var = (sum_sq[k] / nf - mean * mean).max(0.0) * nf / (nf - 1.0);
            let expected = reference.dot(*axis);
            // Floor of f32 rounding of the direction so near-constant integrands do not give σ = 0.
            let sigma = (var / nf).sqrt() + 1e-7 * expected.abs();
            worst_sigma = worst_sigma.max((mean - expected).abs() / sigma);
            if k == 3 {
                cos_rel = (mean / expected - 1.0).abs();
            }
        }
        (worst_sigma, cos_rel)
    }

    #[test]
    fn estimator_is_unbiased_against_lamberts_formula() {
        for (k, case) in cases().iter().enumerate() {
            let omega = solid_angle(case.p, case.v);
            let (sigmas, cos_rel) = unbiasedness(case, 200_000, 1000 + k as u64);
            println!(
                "{:32} Ω = {omega:.4e}: worst deviation {sigmas:.2} σ, cos-weighted rel. error {cos_rel:.2e}",
                case.name
            );
            assert!(sigmas < 5.0, "{}: {sigmas} σ", case.name);
        }
    }

    #[test]
    fn lamberts_formula_matches_octant() {
        // Projected solid angle of the octant on each axis is a quarter disc: π/4.
        let l = lambert_vector(Vec3::ZERO, octant(3.0));
        assert!((l - DVec3::splat(PI / 4.0)).length() < 1e-12, "{l}");
    }

    /// Barycentric corners `(λ1, λ2)` of the 4^levels cells of repeated midpoint subdivision.
    fn subdivide(levels: u32) -> Vec<[[f64; 2]; 3]> {
        let mut cells = vec![[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]];
        for _ in 0..levels {
            cells = cells
                .iter()
                .flat_map(|&[a, b, c]| {
                    let mid = |x: [f64; 2], y: [f64; 2]| [0.5 * (x[0] + y[0]), 0.5 * (x[1] + y[1])];
                    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [bc, ca, ab]]
                })
                .collect();
        }
        cells
    }

    /// Smallest local barycentric of the point `x = (λ1, λ2)` in `cell` (≥ 0 inside).
    fn inside_margin(cell: &[[f64; 2]; 3], x: [f64; 2]) -> f64 {
        let [a, b, c] = *cell;
        let (e1, e2, r) = (
            [b[0] - a[0], b[1] - a[1]],
            [c[0] - a[0], c[1] - a[1]],
            [x[0] - a[0], x[1] - a[1]],
        );
        let det = e1[0] * e2[1] - e1[1] * e2[0];
        let s = (r[0] * e2[1] - r[1] * e2[0]) / det;
        let t = (e1[0] * r[1] - e1[1] * r[0]) / det;
        s.min(t).min(1.0 - s - t)
    }

    #[test]
    fn chi_square_against_uniform_solid_angle() {
        const SAMPLES: usize = 200_000;
        let cells = subdivide(3);
        assert_eq!(cells.len(), 64);
        let all = cases();
        for name in ["near", "obtuse", "large ~2 sr", "threshold 6.2 sr"] {
            let case = all.iter().find(|c| c.name == name).unwrap();
            let [v0, v1, v2] = case.v.map(dv);
            let at = |x: [f64; 2]| (v0 + x[0] * (v1 - v0) + x[1] * (v2 - v0)).as_vec3();
            let omega = f64::from(solid_angle(case.p, case.v));
            let expected: Vec<f64> = cells
                .iter()
                .map(|cell| f64::from(solid_angle(case.p, cell.map(at))) / omega)
                .collect();
            let total: f64 = expected.iter().sum();
            assert!((total - 1.0).abs() < 1e-4, "{name}: cells sum to {total}");
            let mut counts = vec![0usize; cells.len()];
            let mut rng = Pcg32::new(4242, 9);
            for _ in 0..SAMPLES {
                let s = sample_spherical_triangle(case.p, case.v, uv(&mut rng)).unwrap();
                let l = planar_barycentrics(s.point, case.v);
                let x = [l[1], l[2]];
                let best = (0..cells.len())
                    .max_by(|&i, &j| {
                        inside_margin(&cells[i], x).total_cmp(&inside_margin(&cells[j], x))
                    })
                    .unwrap();
                counts[best] += 1;
            }
            let n = SAMPLES as f64;
            let chi2: f64 = counts
                .iter()
                .zip(&expected)
                .map(|(&o, &p)| (o as f64 - n * p).powi(2) / (n * p))
                .sum();
            let dof = (cells.len() - 1) as f64;
            let bound = dof + 5.0 * (2.0 * dof).sqrt();
            let min_expected = expected.iter().fold(f64::INFINITY, |m, &p| m.min(n * p));
            println!(
                "{name:24} χ² = {chi2:.1} (dof {dof}, bound {bound:.1}), smallest expected count {min_expected:.0}"
            );
            assert!(chi2 < bound, "{name}: χ² = {chi2} ≥ {bound}");
        }
    }

    #[test]
    fn stratification_is_preserved() {
        for case in cases() {
            let mut worst = 0.0f32;
            let omega = solid_angle(case.p, case.v);
            let b = (dv(case.v[1]) - dv(case.p)).normalize();
            for u1 in [0.25f32, 0.5, 0.9] {
                let mut previous = -1.0f32;
                for k in 0..=64 {
                    let u0 = k as f32 / 64.0;
                    let s = sample_spherical_triangle(case.p, case.v, [u0, u1]).unwrap();
                    // C' is where the line from v1 through the point meets the edge v0 v2.
                    let l = planar_barycentrics(s.point, case.v);
                    let w0 = l[0] / (l[0] + l[2]);
                    let [v0, v2] = [case.v[0], case.v[2]].map(dv);
                    let c_prime = (v0 + (1.0 - w0) * (v2 - v0)).as_vec3();
                    let fraction = solid_angle(case.p, [case.v[0], case.v[1], c_prime]) / omega;
                    assert!(
                        (fraction - u0).abs() < 1e-4,
                        "{} u = ({u0}, {u1}): fraction {fraction}",
                        case.name
                    );
                    worst = worst.max((fraction - u0).abs());
                    assert!(fraction >= previous - 1e-6, "{}: not monotone", case.name);
                    previous = fraction;
                    // Along B C', u1 is the fraction of 1 − cos of the arc length.
                    let cp = (dv(c_prime) - dv(case.p)).normalize();
                    let w = (dv(s.point) - dv(case.p)).normalize();
                    let arc = 0.5 * (cp - b).length_squared();
                    if arc > 1e-9 {
                        let along = 0.5 * (w - b).length_squared() / arc;
                        assert!(
                            (along - f64::from(u1)).abs() < 1e-4,
                            "{} u = ({u0}, {u1}): along {along}",
                            case.name
                        );
                    }
                }
            }
            println!("{:36} max |fraction − u0| = {worst:.2e}", case.name);
        }
    }

    /// Barycentric violation of Arvo's direction before clamping, i.e. the accuracy of the
    /// spherical trigonometry itself (the public result is clamped into the triangle).
    #[test]
    fn raw_arvo_directions_fall_inside() {
        for (k, case) in cases().iter().enumerate() {
            let view = SphericalTriangle::new(case.p, case.v).unwrap();
            let [d0, d1, d2] = view.offset;
            let mut rng = Pcg32::new(500 + k as u64, 3);
            let mut worst = 0.0f64;
            for _ in 0..50_000 {
                // A quarter of the samples sit on the edges u1 = 1 (arc AC) or u0 = 1 (arc BC).
                let mut u = uv(&mut rng).map(f64::from);
                match rng.next_u32() % 8 {
                    0 => u[1] = 1.0,
                    1 => u[0] = 1.0,
                    _ => {}
                }
                let w = view.arvo_direction(u).unwrap();
                let x = [d1.cross(d2), d2.cross(d0), d0.cross(d1)].map(|m| w.dot(m) / view.triple);
                let sum = x[0] + x[1] + x[2];
                worst = x.iter().fold(worst, |m, &x_i| m.max(-x_i / sum));
            }
            println!("{:36} raw barycentric violation {worst:.2e}", case.name);
            assert!(worst < 1e-6, "{}: {worst}", case.name);
        }
    }

    #[test]
    fn grazing_and_tiny_configurations_stay_inside() {
        let big = flat_triangle(Vec3::ZERO, 1.0);
        let feet = [
            Vec3::ZERO,
            0.98 * big[0],
            0.5 * (big[1] + big[2]),
            1.5 * big[2],
        ];
        let mut rng = Pcg32::new(77, 2);
        let mut some = 0;
        for foot in feet {
            for h in [1e-2f32, 1e-4, 1e-6, -1e-6, 1e3, 1e5] {
                let case = Case {
                    name: "grazing or tiny",
                    p: foot + Vec3::Z * h,
                    v: big,
                };
                for _ in 0..2000 {
                    let Some(s) = sample_spherical_triangle(case.p, case.v, uv(&mut rng)) else {
                        continue;
                    };
                    some += 1;
                    let l = planar_barycentrics(s.point, case.v);
                    assert!(l.iter().all(|&x| x >= -1e-5), "{foot} {h}: {l:?}");
                    assert!((s.direction.length() - 1.0).abs() < 1e-6);
                }
            }
        }
        assert!(some > 40_000, "{some}");
    }

    #[test]
    fn never_nan_on_hostile_input() {
        let mut rng = Pcg32::new(99, 1);
        let specials = [
            0.0,
            -0.0,
            1e-30,
            -1e-30,
            1e30,
            -1e30,
            1.0,
            f32::MAX,
            f32::MIN_POSITIVE,
            f32::NAN,
            f32::INFINITY,
        ];
        let pick = |rng: &mut Pcg32| -> f32 {
            let r = rng.next_u32();
            if r.is_multiple_of(4) {
                specials[(r as usize / 4) % specials.len()]
            } else {
                let e = (r % 13) as i32 - 6;
                (uniform(rng) * 2.0 - 1.0) * 10f32.powi(e)
            }
        };
        let mut produced = 0;
        for _ in 0..200_000 {
            let vec = |rng: &mut Pcg32| Vec3::new(pick(rng), pick(rng), pick(rng));
            let p = vec(&mut rng);
            let mut v = [vec(&mut rng), vec(&mut rng), vec(&mut rng)];
            // Sometimes make the triangle collinear or doubled, or put p on a vertex.
            match rng.next_u32() % 8 {
                0 => v[2] = v[0] + 0.5 * (v[1] - v[0]),
                1 => v[1] = p,
                2 => v[2] = v[0],
                _ => {}
            }
            let u = [
                [uniform(&mut rng), uniform(&mut rng)],
                [0.0, 0.0],
                [1.0, 1.0],
                [f32::NAN, 0.5],
            ][(rng.next_u32() % 4) as usize];
            let omega = solid_angle(p, v);
            let pdf = spherical_pdf(p, v);
            assert!(omega.is_finite() && omega >= 0.0);
            assert!(omega <= 2.0 * std::f32::consts::PI + 1e-5);
            assert!(pdf.is_finite() && pdf >= 0.0);
            if let Some(s) = sample_spherical_triangle(p, v, u) {
                assert!(s.direction.is_finite() && s.point.is_finite(), "{p} {v:?}");
                assert!(s.pdf > 0.0 && s.pdf == pdf);
                produced += 1;
            }
        }
        assert!(produced > 10_000, "{produced}");
    }

    #[test]
    #[ignore = "timing; run with --ignored --nocapture"]
    fn timing() {
        use std::hint::black_box;
        let mut rng = Pcg32::new(5, 5);
        let configs: Vec<(Vec3, [Vec3; 3])> = (0..1024)
            .map(|_| {
                let mut r = || Vec3::new(uniform(&mut rng), uniform(&mut rng), uniform(&mut rng));
                let p = r() * 4.0 - Vec3::splat(2.0) + Vec3::Z * 3.0;
                (p, [r(), r(), r()])
            })
            .collect();
        let us: Vec<[f32; 2]> = (0..4096).map(|_| uv(&mut rng)).collect();
        let rounds = 2_000_000;
        for label in ["solid_angle", "sample_spherical_triangle"] {
            let start = std::time::Instant::now();
            let mut acc = 0.0f32;
            for i in 0..rounds {
                let (p, v) = configs[i % configs.len()];
                if label == "solid_angle" {
                    acc += solid_angle(black_box(p), black_box(v));
                } else if let Some(s) =
                    sample_spherical_triangle(black_box(p), black_box(v), us[i % us.len()])
                {
                    acc += s.point.x;
                }
            }
            black_box(acc);
            let ns = start.elapsed().as_nanos() as f64 / rounds as f64;
            println!("{label}: {ns:.1} ns per call");
        }
    }
}
