//! Pinhole perspective camera (glTF convention: looks down its local −Z, +Y up).
//!
//! Pixel (i, j), row 0 at the top, with sub-pixel offset (u, v) ∈ [0,1)² maps to the camera-space
//! direction ((2(i+u)/W − 1)·tan(yfov/2)·W/H, (1 − 2(j+v)/H)·tan(yfov/2), −1). Pixels are square:
//! the aspect ratio used for rays is always W/H; the file's aspect ratio only picks H from W.

use glam::{Mat4, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    pub position: Vec3,
    /// Unit world-space axes of the camera frame.
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    /// Vertical field of view, radians.
    pub yfov: f32,
    /// Width / height from the file, if it gives one.
    pub aspect_ratio: Option<f32>,
}

impl Camera {
    /// A camera placed by a node's world matrix (scale is ignored; axes are re-orthonormalised).
    pub fn from_world_matrix(
        name: String,
        world: &Mat4,
        yfov: f32,
        aspect_ratio: Option<f32>,
    ) -> Option<Camera> {
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        let up_hint = world.transform_vector3(Vec3::Y);
        let right = forward.cross(up_hint).normalize_or_zero();
        let up = right.cross(forward);
        let valid = position.is_finite()
            && forward != Vec3::ZERO
            && right != Vec3::ZERO
            && yfov.is_finite()
            && yfov > 0.0
            && yfov < std::f32::consts::PI;
        valid.then_some(Camera {
            name,
            position,
            right,
            up,
            forward,
            yfov,
            aspect_ratio,
        })
    }

    /// A camera that frames the box `lo..hi` from its +Z side (used when a file has no camera).
    pub fn framing(lo: Vec3, hi: Vec3) -> Camera {
        let center = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        let yfov = 45f32.to_radians();
        let distance = radius / (0.5 * yfov).sin();
        let position = center + Vec3::new(0.0, 0.0, distance);
        let world = Mat4::from_translation(position);
        Camera::from_world_matrix("framing (no camera in file)".into(), &world, yfov, None)
            .expect("a translation-only matrix gives a valid camera")
    }

    /// Image size from the requested width and optional height: H = round(W / aspect) where the
    /// file gives an aspect ratio (clamped to 1..=16384), else square.
    pub fn resolution(&self, width: u32, height: Option<u32>) -> (u32, u32) {
        const MAX_HEIGHT: f32 = 16384.0;
        let h = height.unwrap_or_else(|| {
            let aspect = self
                .aspect_ratio
                .filter(|a| a.is_finite() && *a > 0.0)
                .unwrap_or(1.0);
            (width as f32 / aspect).round().clamp(1.0, MAX_HEIGHT) as u32
        });
        (width, h)
    }

    /// Unit world-space direction through image position (x, y) in pixels (x right, y down).
    #[inline]
    pub fn direction(&self, x: f32, y: f32, width: u32, height: u32) -> Vec3 {
        let tan_half = (0.5 * self.yfov).tan();
        let aspect = width as f32 / height as f32;
        let sx = (2.0 * x / width as f32 - 1.0) * tan_half * aspect;
        let sy = (1.0 - 2.0 * y / height as f32) * tan_half;
        (self.right * sx + self.up * sy + self.forward).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_forward_and_corners_span_the_fov() {
        let cam = Camera::from_world_matrix("c".into(), &Mat4::IDENTITY, 1.0, None).unwrap();
        let d = cam.direction(50.0, 50.0, 100, 100);
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        let top = cam.direction(50.0, 0.0, 100, 100);
        assert!(
            (top.y.atan2(-top.z) - 0.5).abs() < 1e-5,
            "top edge is yfov/2 above the axis"
        );
        let right = cam.direction(200.0, 50.0, 200, 100);
        assert!((right.x / -right.z - 2.0 * 0.5f32.tan()).abs() < 1e-5);
    }

    #[test]
    fn resolution_follows_the_file_aspect_ratio() {
        let cam = Camera::from_world_matrix("c".into(), &Mat4::IDENTITY, 1.0, Some(1.5)).unwrap();
        assert_eq!(cam.resolution(300, None), (300, 200));
        assert_eq!(cam.resolution(300, Some(10)), (300, 10));
        let thin = Camera {
            aspect_ratio: Some(1e-9),
            ..cam
        };
        assert_eq!(thin.resolution(300, None), (300, 16384));
    }
}
