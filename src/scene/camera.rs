//! Cameras, glTF convention: a camera looks down its local −Z with +Y up.
//!
//! Pixel (i, j), row 0 at the top, with sub-pixel offset (u, v) ∈ [0,1)² has screen coordinates
//! sx = 2(i+u)/W − 1, sy = 1 − 2(j+v)/H. A perspective (pinhole) camera shoots from its position
//! along the camera-space direction (sx·tan(yfov/2)·W/H, sy·tan(yfov/2), −1); an orthographic one
//! shoots along −Z from the point (sx·ymag·W/H, sy·ymag, 0) of its plane (glTF's xmag, ymag are
//! the half-width and half-height of the view). Pixels are square: the horizontal extent always
//! follows W/H; the file's aspect ratio (xmag/ymag for orthographic cameras) only picks H from W.

use glam::{Mat4, Vec3};

/// How a camera maps screen coordinates to rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Pinhole; vertical field of view in radians.
    Perspective { yfov: f32 },
    /// Parallel rays; half the view's height in metres.
    Orthographic { ymag: f32 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub name: String,
    pub position: Vec3,
    /// Unit world-space axes of the camera frame.
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub projection: Projection,
    /// Width / height from the file, if it gives one.
    pub aspect_ratio: Option<f32>,
}

impl Camera {
    /// Where a camera-less scene is viewed from, as printed in notes: the direction from the
    /// bounds' centre to the eye.
    pub const FRAMING_DIRECTION_TEXT: &'static str =
        "from +Z (glTF's front, Blender's −Y) turned 30° toward +X and raised 25°, the bounding \
         sphere filling the narrower field of view of 45° vertical";

    /// A perspective camera placed by a node's world matrix (scale is ignored; axes are
    /// re-orthonormalised).
    pub fn from_world_matrix(
        name: String,
        world: &Mat4,
        yfov: f32,
        aspect_ratio: Option<f32>,
    ) -> Option<Camera> {
        let valid = yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI;
        let camera = Camera::placed(name, world, Projection::Perspective { yfov }, aspect_ratio)?;
        valid.then_some(camera)
    }

    /// An orthographic camera placed by a node's world matrix, viewing `2·xmag × 2·ymag` metres
    /// (glTF's sign-free magnifications: a negative value is taken by its magnitude).
    pub fn orthographic(name: String, world: &Mat4, xmag: f32, ymag: f32) -> Option<Camera> {
        let (xmag, ymag) = (xmag.abs(), ymag.abs());
        let valid = xmag.is_normal() && ymag.is_normal() && (xmag / ymag).is_normal();
        let projection = Projection::Orthographic { ymag };
        let camera = Camera::placed(name, world, projection, Some(xmag / ymag))?;
        valid.then_some(camera)
    }

    fn placed(
        name: String,
        world: &Mat4,
        projection: Projection,
        aspect_ratio: Option<f32>,
    ) -> Option<Camera> {
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        let up_hint = world.transform_vector3(Vec3::Y);
        let right = forward.cross(up_hint).normalize_or_zero();
        let up = right.cross(forward);
        let valid = position.is_finite() && forward != Vec3::ZERO && right != Vec3::ZERO;
        valid.then_some(Camera {
            name,
            position,
            right,
            up,
            forward,
            projection,
            aspect_ratio,
        })
    }

    /// A perspective camera that frames the box `lo..hi` for an image of aspect `width/height`
    /// (used when a file has no camera): see [`Camera::FRAMING_DIRECTION_TEXT`]. The eye is at
    /// the distance where the bounding sphere of radius r touches the narrower half-angle α:
    /// d = r / sin α.
    pub fn framing(lo: Vec3, hi: Vec3, aspect: f32) -> Camera {
        let center = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        let yfov = 45f32.to_radians();
        let aspect = if aspect.is_normal() { aspect } else { 1.0 };
        let half_x = ((0.5 * yfov).tan() * aspect).atan();
        let half = half_x.min(0.5 * yfov);
        let distance = radius / half.sin();
        let (azimuth, elevation) = (30f32.to_radians(), 25f32.to_radians());
        let toward_eye = Vec3::new(
            azimuth.sin() * elevation.cos(),
            elevation.sin(),
            azimuth.cos() * elevation.cos(),
        );
        let eye = center + distance * toward_eye;
        let right = Vec3::Y.cross(toward_eye).normalize();
        let up = toward_eye.cross(right);
        let world = Mat4::from_cols(
            right.extend(0.0),
            up.extend(0.0),
            toward_eye.extend(0.0),
            eye.extend(1.0),
        );
        Camera::from_world_matrix("framing (no camera in file)".into(), &world, yfov, None)
            .expect("a look-at matrix with a non-vertical view gives a valid camera")
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

    /// The world-space ray (origin, unit direction) through image position (x, y) in pixels
    /// (x right, y down); see [`CameraRays::ray`], which a loop over many rays should use.
    #[inline]
    pub fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> (Vec3, Vec3) {
        self.rays(width, height).ray(x, y)
    }

    /// The rays of a `width` × `height` image, with tan(yfov/2) (or ymag) and W/H computed once.
    pub fn rays(&self, width: u32, height: u32) -> CameraRays {
        let (half_height, perspective) = match self.projection {
            Projection::Perspective { yfov } => ((0.5 * yfov).tan(), true),
            Projection::Orthographic { ymag } => (ymag, false),
        };
        CameraRays {
            position: self.position,
            right: self.right,
            up: self.up,
            forward: self.forward,
            width: width as f32,
            height: height as f32,
            aspect: width as f32 / height as f32,
            half_height,
            perspective,
        }
    }

    /// One line describing the camera (kind, place, view), for summaries.
    pub fn describe(&self) -> String {
        let view = match self.projection {
            Projection::Perspective { yfov } => {
                format!("perspective, yfov {:.2}°", yfov.to_degrees())
            }
            Projection::Orthographic { ymag } => {
                format!("orthographic, {:.4} m high", 2.0 * ymag)
            }
        };
        let (p, f) = (self.position, self.forward);
        format!(
            "'{}' at [{:.3}, {:.3}, {:.3}] looking [{:.3}, {:.3}, {:.3}], {view}, aspect {}",
            self.name,
            p.x,
            p.y,
            p.z,
            f.x,
            f.y,
            f.z,
            self.aspect_ratio
                .map_or("from --width/--height".into(), |a| format!("{a:.4}"))
        )
    }
}

/// A camera's rays for one image size: the per-image factors of the screen mapping
/// (see the module doc) computed once, each ray the same f32 operations on the same values as
/// computing them per ray.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    position: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    width: f32,
    height: f32,
    /// W/H.
    aspect: f32,
    /// tan(yfov/2) for a perspective camera, ymag for an orthographic one.
    half_height: f32,
    perspective: bool,
}

impl CameraRays {
    /// The world-space ray (origin, unit direction) through image position (x, y) in pixels
    /// (x right, y down).
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> (Vec3, Vec3) {
        let sx = (2.0 * x / self.width - 1.0) * self.half_height * self.aspect;
        let sy = (1.0 - 2.0 * y / self.height) * self.half_height;
        if self.perspective {
            let dir = (self.right * sx + self.up * sy + self.forward).normalize();
            (self.position, dir)
        } else {
            (self.position + self.right * sx + self.up * sy, self.forward)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn direction(cam: &Camera, x: f32, y: f32, w: u32, h: u32) -> Vec3 {
        let (origin, dir) = cam.ray(x, y, w, h);
        assert_eq!(origin, cam.position);
        dir
    }

    #[test]
    fn centre_pixel_looks_forward_and_corners_span_the_fov() {
        let cam = Camera::from_world_matrix("c".into(), &Mat4::IDENTITY, 1.0, None).unwrap();
        let d = direction(&cam, 50.0, 50.0, 100, 100);
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        let top = direction(&cam, 50.0, 0.0, 100, 100);
        assert!(
            (top.y.atan2(-top.z) - 0.5).abs() < 1e-5,
            "top edge is yfov/2 above the axis"
        );
        let right = direction(&cam, 200.0, 50.0, 200, 100);
        assert!((right.x / -right.z - 2.0 * 0.5f32.tan()).abs() < 1e-5);
    }

    /// The per-image factors computed once give, bit for bit, the rays of the screen mapping
    /// evaluated in full for each ray, for both projections.
    #[test]
    fn rays_of_an_image_equal_the_mapping_per_ray() {
        let world = Mat4::from_translation(Vec3::new(1.0, -2.0, 0.5))
            * Mat4::from_rotation_y(0.7)
            * Mat4::from_rotation_x(-0.3);
        let perspective = Camera::from_world_matrix("p".into(), &world, 0.9, None).unwrap();
        let orthographic = Camera::orthographic("o".into(), &world, 3.0, 1.25).unwrap();
        let (w, h) = (317u32, 211u32);
        for cam in [perspective, orthographic] {
            let rays = cam.rays(w, h);
            for (x, y) in [
                (0.0f32, 0.0f32),
                (158.37, 105.5),
                (316.999, 210.01),
                (3.25, 199.9),
            ] {
                let aspect = w as f32 / h as f32;
                let expected = match cam.projection {
                    Projection::Perspective { yfov } => {
                        let t = (0.5 * yfov).tan();
                        let sx = (2.0 * x / w as f32 - 1.0) * t * aspect;
                        let sy = (1.0 - 2.0 * y / h as f32) * t;
                        let d = (cam.right * sx + cam.up * sy + cam.forward).normalize();
                        (cam.position, d)
                    }
                    Projection::Orthographic { ymag } => {
                        let sx = (2.0 * x / w as f32 - 1.0) * ymag * aspect;
                        let sy = (1.0 - 2.0 * y / h as f32) * ymag;
                        (cam.position + cam.right * sx + cam.up * sy, cam.forward)
                    }
                };
                let (o, d) = rays.ray(x, y);
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!((bits(o), bits(d)), (bits(expected.0), bits(expected.1)));
            }
        }
    }

    /// An orthographic camera at (1, 2, 3) looking down −X (turned +90° about Y): every ray
    /// travels along −X, and pixel positions map linearly onto the 2·xmag × 2·ymag view.
    #[test]
    fn orthographic_rays_are_parallel_and_span_the_magnifications() {
        let world = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
            * Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let cam = Camera::orthographic("o".into(), &world, 4.0, -2.0).unwrap();
        assert_eq!(cam.aspect_ratio, Some(2.0));
        let (w, h) = cam.resolution(200, None);
        assert_eq!((w, h), (200, 100));
        // Camera right is world −Z, camera up is world +Y.
        let cases = [
            ((100.0, 50.0), Vec3::new(1.0, 2.0, 3.0)),
            ((0.0, 0.0), Vec3::new(1.0, 4.0, 7.0)),
            ((200.0, 100.0), Vec3::new(1.0, 0.0, -1.0)),
            ((150.0, 25.0), Vec3::new(1.0, 3.0, 1.0)),
        ];
        for ((x, y), expected) in cases {
            let (origin, dir) = cam.ray(x, y, w, h);
            assert!((dir - Vec3::NEG_X).length() < 1e-6, "{dir}");
            assert!((origin - expected).length() < 1e-5, "({x}, {y}): {origin}");
        }
        assert!(Camera::orthographic("z".into(), &world, 0.0, 1.0).is_none());
    }

    /// The framing camera sees the whole bounding sphere: every box corner projects inside the
    /// image, and the sphere touches the narrower side.
    #[test]
    fn framing_keeps_the_box_inside_the_image() {
        let (lo, hi) = (Vec3::new(-3.0, 0.0, -1.0), Vec3::new(5.0, 2.0, 1.0));
        for aspect in [0.5f32, 1.0, 16.0 / 9.0] {
            let cam = Camera::framing(lo, hi, aspect);
            let Projection::Perspective { yfov } = cam.projection else {
                panic!("perspective")
            };
            let t = (0.5 * yfov).tan();
            let centre = 0.5 * (lo + hi);
            assert!((cam.forward - (centre - cam.position).normalize()).length() < 1e-5);
            assert!(cam.position.y > centre.y && cam.position.z > centre.z);
            for k in 0..8 {
                let c = Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                let v = c - cam.position;
                let depth = v.dot(cam.forward);
                let (sx, sy) = (v.dot(cam.right) / depth, v.dot(cam.up) / depth);
                assert!(
                    sx.abs() <= t * aspect && sy.abs() <= t,
                    "{aspect}: corner {c}"
                );
            }
        }
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
