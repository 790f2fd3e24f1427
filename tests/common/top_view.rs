//! The camera of the lit-plane tests: a pinhole straight above the plane z = 0 looking down −z,
//! and the exact value of one of its pixels, written from the pinhole geometry here rather than
//! taken from the crate's `Camera::ray`.
//!
//! Pixel coordinates (i + u, j + v) of a size × size image see the plane point
//!     (x, y) = h · tan(fov / 2) · (2(i + u)/size − 1, 1 − 2(j + v)/size),
//! h the camera's height and fov its vertical field of view; the box-filtered pixel is the mean
//! of the plane's exitant radiance over (u, v) ∈ [0, 1)², here by a q × q midpoint rule.

use glam::{Mat4, Vec3};
use manylights::scene::Camera;

/// A square image of the plane z = 0 seen from straight above.
pub struct TopView {
    /// The camera's height above the plane.
    pub height: f32,
    /// Vertical field of view in degrees.
    pub yfov_deg: f32,
    /// Pixels per side.
    pub size: u32,
}

impl TopView {
    /// The camera at (0, 0, height), looking down −z (a glTF camera's own axis).
    pub fn camera(&self) -> Camera {
        Camera::from_world_matrix(
            "top".into(),
            &Mat4::from_translation(Vec3::new(0.0, 0.0, self.height)),
            self.yfov_deg.to_radians(),
            None,
        )
        .unwrap()
    }

    /// The box filter's average of `radiance(x, y)` (the plane's exitant radiance) over pixel
    /// (i, j)'s footprint, with q × q midpoint samples.
    pub fn pixel(&self, i: u32, j: u32, q: u32, radiance: impl Fn(f64, f64) -> f64) -> f64 {
        let t = (0.5 * self.yfov_deg.to_radians() as f64).tan();
        let h = self.height as f64;
        let size = self.size as f64;
        let mut sum = 0.0;
        for a in 0..q {
            for b in 0..q {
                let u = (a as f64 + 0.5) / q as f64;
                let v = (b as f64 + 0.5) / q as f64;
                let sx = (2.0 * (i as f64 + u) / size - 1.0) * t;
                let sy = (1.0 - 2.0 * (j as f64 + v) / size) * t;
                sum += radiance(h * sx, h * sy);
            }
        }
        sum / (q * q) as f64
    }
}
