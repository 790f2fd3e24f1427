//! Warps from [0,1)² to triangles and hemispheres, each with the PDF of what it produces.

use glam::{DVec3, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Barycentric weights (b1, b2) of vertices 1 and 2, uniform over a triangle (density 1/A in
/// area measure), by the square-root map (b1, b2) = (√u1·(1 − u2), √u1·u2).
#[inline]
pub fn uniform_triangle(u: [f32; 2]) -> (f32, f32) {
    let s = u[0].sqrt();
    (s * (1.0 - u[1]), s * u[1])
}

/// Direction uniform on the hemisphere z > 0 in local coordinates; pdf 1/(2π) per steradian.
#[inline]
pub fn uniform_hemisphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_HEMISPHERE_PDF: f32 = 0.5 * FRAC_1_PI;

/// Cosine-weighted direction on the hemisphere z > 0 (Malley's method over Shirley's
/// concentric disk map); pdf cosθ/π per steradian.
#[inline]
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let (x, y) = concentric_disk(u);
    Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Shirley & Chiu's concentric map from the square to the unit disk (area preserving).
#[inline]
fn concentric_disk(u: [f32; 2]) -> (f32, f32) {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    // θ = φ with φ = π/4 · b/a, or θ = π/2 − φ with φ = π/4 · a/b: either way |φ| ≤ π/4, and
    // cos θ, sin θ are cos φ, sin φ or the reverse.
    if a.abs() > b.abs() {
        let (cos, sin) = cos_sin_within_quarter(0.25 * PI * (b / a));
        (a * cos, a * sin)
    } else {
        let (cos, sin) = cos_sin_within_quarter(0.25 * PI * (a / b));
        (b * sin, b * cos)
    }
}

/// (cos φ, sin φ) for |φ| ≤ π/4 from their Taylor polynomials to degrees 8 and 9, whose
/// truncation errors there are below 2.6e-8 and 1.9e-9 (under half an f32 ulp of cos φ ≥ 0.7),
/// in Horner form: a dozen multiplications and additions in place of a call to libm's sincosf.
#[inline]
fn cos_sin_within_quarter(phi: f32) -> (f32, f32) {
    let x2 = phi * phi;
    let step = |c: f32, rest: f32| 1.0 - x2 * c * rest;
    let [c0, c1, c2, c3] = COS_STEPS;
    let [s0, s1, s2, s3] = SIN_STEPS;
    let cos = step(c0, step(c1, step(c2, step(c3, 1.0))));
    let sin = phi * step(s0, step(s1, step(s2, step(s3, 1.0))));
    (cos, sin)
}

/// The Horner steps of cos φ = 1 − φ²/2·(1 − φ²/12·(1 − φ²/30·(1 − φ²/56))): each
/// 1 − φ²·c·(rest), innermost last (the innermost rest is 1, an exact product).
pub(crate) const COS_STEPS: [f32; 4] = [1.0 / 2.0, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0];
/// The same for sin φ = φ·(1 − φ²/6·(1 − φ²/20·(1 − φ²/42·(1 − φ²/72)))).
pub(crate) const SIN_STEPS: [f32; 4] = [1.0 / 6.0, 1.0 / 20.0, 1.0 / 42.0, 1.0 / 72.0];

/// An orthonormal frame around a unit vector n (Duff et al. 2017, branchless).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    #[inline]
    pub fn new(n: Vec3) -> Frame {
        let sign = 1f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            t: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// The equirectangular (latitude-longitude) convention of environment maps: texture
/// coordinates (u, v) ∈ [0, 1]² to a unit direction, θ = π·v from +Y, φ = 2π·u,
/// d = (−sinθ·sinφ, cosθ, sinθ·cosφ): row 0 at the zenith, the image centre toward −Z.
#[inline]
pub fn equirectangular_direction(u: f64, v: f64) -> DVec3 {
    use std::f64::consts::PI;
    let (sin_phi, cos_phi) = (2.0 * PI * u).sin_cos();
    let (sin_theta, cos_theta) = (PI * v).sin_cos();
    DVec3::new(-sin_theta * sin_phi, cos_theta, sin_theta * cos_phi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng::PixelRng;

    /// Mean of f over `n` warped samples, with its standard error.
    fn mean_and_sigma(n: usize, mut f: impl FnMut([f32; 2]) -> f64) -> (f64, f64) {
        let mut rng = PixelRng::new(42, 7);
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let y = f(rng.next_2d());
            s += y;
            s2 += y * y;
        }
        let mean = s / n as f64;
        (mean, ((s2 / n as f64 - mean * mean) / n as f64).sqrt())
    }

    #[test]
    fn hemisphere_warps_match_their_pdfs() {
        // E[cosθ] = 1/2 under the uniform pdf, 2/3 under the cosine pdf.
        let (m, s) = mean_and_sigma(200_000, |u| uniform_hemisphere(u).z as f64);
        assert!((m - 0.5).abs() < 5.0 * s, "{m} ± {s}");
        let (m, s) = mean_and_sigma(200_000, |u| cosine_hemisphere(u).z as f64);
        assert!((m - 2.0 / 3.0).abs() < 5.0 * s, "{m} ± {s}");
        // The estimator ∫ cos dω = π through either pdf.
        let (m, s) = mean_and_sigma(200_000, |u| {
            (uniform_hemisphere(u).z / UNIFORM_HEMISPHERE_PDF) as f64
        });
        assert!((m - std::f64::consts::PI).abs() < 5.0 * s);
    }

    /// The polynomial cosine and sine against f64's over [−π/4, π/4], within 1.5e-7 (about one
    /// f32 ulp of 1; the truncation errors are below 2.6e-8, the rest is f32 rounding), and the
    /// concentric map against the polar form it stands for, r·(cos θ, sin θ).
    #[test]
    fn the_quarter_turn_polynomials_match_f64_sin_and_cos() {
        let steps = 100_000;
        for i in 0..=steps {
            let phi = (-0.25 * PI) + 0.5 * PI * i as f32 / steps as f32;
            let (cos, sin) = cos_sin_within_quarter(phi);
            let x = f64::from(phi);
            assert!(
                (f64::from(cos) - x.cos()).abs() < 1.5e-7,
                "cos {phi}: {cos}"
            );
            assert!(
                (f64::from(sin) - x.sin()).abs() < 1.5e-7,
                "sin {phi}: {sin}"
            );
        }
        let mut rng = PixelRng::new(3, 9);
        for _ in 0..100_000 {
            let u = rng.next_2d();
            let (x, y) = concentric_disk(u);
            let (a, b) = (2.0 * f64::from(u[0]) - 1.0, 2.0 * f64::from(u[1]) - 1.0);
            let (r, theta) = if a.abs() > b.abs() {
                (a, std::f64::consts::FRAC_PI_4 * (b / a))
            } else {
                (
                    b,
                    std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / b),
                )
            };
            assert!(
                (f64::from(x) - r * theta.cos()).abs() < 3e-7,
                "{u:?}: x {x}"
            );
            assert!(
                (f64::from(y) - r * theta.sin()).abs() < 3e-7,
                "{u:?}: y {y}"
            );
        }
    }

    #[test]
    fn triangle_warp_is_uniform() {
        // Over the triangle (0,0),(1,0),(0,1) with b = (b1, b2): E[b1] = E[b2] = 1/3,
        // and the share with b1 + b2 < 1/2 (a sub-triangle of 1/4 the area) is 1/4.
        let (m, s) = mean_and_sigma(200_000, |u| uniform_triangle(u).0 as f64);
        assert!((m - 1.0 / 3.0).abs() < 5.0 * s);
        let (m, s) = mean_and_sigma(200_000, |u| {
            let (a, b) = uniform_triangle(u);
            assert!(a >= 0.0 && b >= 0.0 && a + b <= 1.0);
            ((a + b) < 0.5) as u8 as f64
        });
        assert!((m - 0.25).abs() < 5.0 * s);
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.81).normalize(),
        ] {
            let f = Frame::new(n);
            assert!((f.t.dot(f.b)).abs() < 1e-6 && (f.t.dot(n)).abs() < 1e-6);
            assert!((f.t.cross(f.b) - n).length() < 1e-5);
        }
    }
}
