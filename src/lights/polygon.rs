//! Lambert's polygon formula: the projected solid angle ∫ max(0, n·ω) dω of a triangle seen from
//! a point, the part above the point's tangent plane only. A constant-radiance emitter of
//! radiance L then gives irradiance E = L · (projected solid angle).
//!
//! The triangle is clipped against the plane through p with normal n (Sutherland–Hodgman), and
//! for the clipped polygon's unit vertex directions u_i:
//!     Ω⊥ = ½ |Σ_i Θ_i (n · Γ_i)|,  Θ_i = ∠(u_i, u_{i+1}),  Γ_i = (u_i × u_{i+1}) / |u_i × u_{i+1}|.
//! Everything in f64; angles by atan2 so that tiny, distant triangles keep their precision.

use glam::{DVec3, Vec3};

/// Projected solid angle of triangle `v` above the tangent plane of unit normal `n` at `p`.
pub fn projected_solid_angle(p: Vec3, n: Vec3, v: [Vec3; 3]) -> f64 {
    let n = n.as_dvec3();
    let rel = v.map(|x| x.as_dvec3() - p.as_dvec3());
    let mut clipped = [DVec3::ZERO; 4];
    let mut count = 0;
    for i in 0..3 {
        let (a, b) = (rel[i], rel[(i + 1) % 3]);
        let (da, db) = (n.dot(a), n.dot(b));
        if da > 0.0 {
            clipped[count] = a;
            count += 1;
        }
        if (da > 0.0) != (db > 0.0) && da != db {
            let t = da / (da - db);
            let x = a + (b - a) * t;
            // A point exactly on the tangent plane adds nothing but a horizon vertex.
            clipped[count] = x;
            count += 1;
        }
    }
    if count < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..count {
        let (a, b) = (clipped[i], clipped[(i + 1) % count]);
        let (la, lb) = (a.length(), b.length());
        if la == 0.0 || lb == 0.0 {
            continue;
        }
        let (ua, ub) = (a / la, b / lb);
        let cross = ua.cross(ub);
        let sin = cross.length();
        if sin == 0.0 {
            continue;
        }
        let theta = sin.atan2(ua.dot(ub));
        sum += theta * n.dot(cross / sin);
    }
    0.5 * sum.abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{rng::PixelRng, warp};
    use std::f64::consts::PI;

    #[test]
    fn a_huge_triangle_overhead_covers_the_hemisphere() {
        let v = [
            Vec3::new(-1e5, -1e5, 1.0),
            Vec3::new(1e5, -1e5, 1.0),
            Vec3::new(0.0, 1e5, 1.0),
        ];
        let e = projected_solid_angle(Vec3::ZERO, Vec3::Z, v);
        assert!((e - PI).abs() < 1e-3, "{e}");
    }

    #[test]
    fn a_small_distant_triangle_is_area_cos_cos_over_d2() {
        let d = 1e3f32;
        let s = 1e-2f32;
        let v = [
            Vec3::new(0.0, 0.0, d),
            Vec3::new(s, 0.0, d),
            Vec3::new(0.0, s, d),
        ];
        let e = projected_solid_angle(Vec3::ZERO, Vec3::Z, v);
        let expected = 0.5 * (s as f64).powi(2) / (d as f64).powi(2);
        assert!((e / expected - 1.0).abs() < 1e-4, "{e} vs {expected}");
    }

    #[test]
    fn clipping_at_the_horizon_matches_cosine_sampling() {
        // A triangle straddling the receiver's tangent plane: Monte Carlo with cosine-weighted
        // directions estimates Ω⊥ = π · P(direction hits the triangle).
        let v = [
            Vec3::new(-1.0, 1.0, -0.5),
            Vec3::new(1.5, 1.0, 0.8),
            Vec3::new(0.2, 1.2, 2.0),
        ];
        let exact = projected_solid_angle(Vec3::ZERO, Vec3::Z, v);
        let mut rng = PixelRng::new(5, 5);
        let count = 400_000;
        let e1 = v[1] - v[0];
        let e2 = v[2] - v[0];
        let hits = (0..count)
            .filter(|_| {
                let w = warp::cosine_hemisphere(rng.next_2d());
                // Möller–Trumbore from the origin.
                let q = w.cross(e2);
                let det = e1.dot(q);
                let s = -v[0];
                let (b1, b2) = (s.dot(q) / det, w.dot(s.cross(e1)) / det);
                let t = e2.dot(s.cross(e1)) / det;
                b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && t > 0.0
            })
            .count();
        let p = hits as f64 / count as f64;
        let sigma = PI * (p * (1.0 - p) / count as f64).sqrt();
        assert!(
            (PI * p - exact).abs() < 5.0 * sigma,
            "MC {} vs {exact} (σ {sigma})",
            PI * p
        );
    }

    #[test]
    fn nothing_below_the_plane_counts() {
        let v = [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(0.0, 1.0, -1.0),
        ];
        assert_eq!(projected_solid_angle(Vec3::ZERO, Vec3::Z, v), 0.0);
    }
}
