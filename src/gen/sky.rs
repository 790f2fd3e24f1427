//! An analytic sun-and-sky environment map and an outdoor scene to light with it.
//!
//! * [`sun_and_sky`]: an equirectangular map (the convention of `environment`: +Y up,
//!   row 0 at the zenith, u = 1/2 toward −Z) of a smooth blue-to-white sky gradient with a
//!   circumsolar glow, a dim ground below the horizon, and a small, very bright sun disc.
//! * [`outdoor`]: boxes of several materials on a ground plane, with one small lamp panel, seen
//!   from a camera looking down −Z; rendered with `--env` of the sky.

use glam::Vec3;

use super::gltf_write::{look_at_rotation, GltfBuilder, GltfMaterial, NodeTransform};
use super::mesh::{add_object, QuadMesh};
use crate::image::RgbImage;
use crate::sampling::warp::equirectangular_direction;

/// Unit direction toward the sun: 35° above the horizon, to the right of −Z (toward +X).
pub fn sun_direction() -> Vec3 {
    let (elevation, azimuth) = (35f32.to_radians(), 40f32.to_radians());
    Vec3::new(
        elevation.cos() * azimuth.sin(),
        elevation.sin(),
        -elevation.cos() * azimuth.cos(),
    )
}

/// Angular radius of the sun disc (about 7 times the real sun's, so that it covers a few texels
/// of a 256×128 map).
pub const SUN_RADIUS_DEGREES: f32 = 2.0;

/// Radiance of the sun disc: its irradiance on a surface facing it, L·π·sin²(2°) ≈ 7.7, is about
/// five times the sky's.
pub const SUN_RADIANCE: [f32; 3] = [2000.0, 1900.0, 1750.0];

/// Sky radiance toward unit direction `w` (sun excluded): zenith blue fading to a pale horizon,
/// a glow around the sun, a dim brown ground below the horizon.
fn sky(w: Vec3) -> Vec3 {
    if w.y < 0.0 {
        return Vec3::new(0.12, 0.1, 0.08);
    }
    let zenith = Vec3::new(0.15, 0.3, 0.75);
    let horizon = Vec3::new(0.8, 0.85, 0.95);
    let t = w.y.sqrt();
    let glow = (-(1.0 - w.dot(sun_direction())) * 12.0).exp();
    horizon.lerp(zenith, t) + Vec3::new(1.0, 0.9, 0.7) * glow
}

/// The map: each texel is the mean of 4×4 directions inside it, the sun's share counted by
/// the same sub-samples (so its edge is antialiased).
pub fn sun_and_sky(width: usize, height: usize) -> RgbImage {
    const SUB: usize = 4;
    let cos_sun = SUN_RADIUS_DEGREES.to_radians().cos();
    let sun = sun_direction();
    let mut pixels = Vec::with_capacity(width * height);
    for j in 0..height {
        for i in 0..width {
            let mut sum = Vec3::ZERO;
            for a in 0..SUB {
                for b in 0..SUB {
                    let u = (i as f64 + (a as f64 + 0.5) / SUB as f64) / width as f64;
                    let v = (j as f64 + (b as f64 + 0.5) / SUB as f64) / height as f64;
                    let w = equirectangular_direction(u, v).as_vec3();
                    sum += if w.dot(sun) >= cos_sun {
                        Vec3::from_array(SUN_RADIANCE)
                    } else {
                        sky(w)
                    };
                }
            }
            pixels.push((sum / (SUB * SUB) as f32).to_array());
        }
    }
    RgbImage {
        width,
        height,
        pixels,
    }
}

/// A 40 m ground plane, five boxes (matte, coloured, glossy) and a small warm lamp panel on the
/// tallest box; the camera at (0, 2.2, 7) looks toward (0, 0.8, 0).
pub fn outdoor() -> GltfBuilder {
    let mut b = GltfBuilder::new();
    let matte = |name: &str, base_color: [f32; 3], roughness: f32| GltfMaterial {
        name: name.to_owned(),
        base_color,
        roughness,
        ..GltfMaterial::default()
    };
    let ground = b.add_material(matte("ground", [0.45, 0.42, 0.38], 0.9));
    let materials = [
        b.add_material(matte("white", [0.75; 3], 0.8)),
        b.add_material(matte("red", [0.7, 0.12, 0.08], 0.7)),
        b.add_material(matte("blue", [0.1, 0.2, 0.65], 0.6)),
        b.add_material(GltfMaterial {
            metallic: 1.0,
            ..matte("gold", [0.95, 0.75, 0.35], 0.25)
        }),
        b.add_material(matte("glossy", [0.3; 3], 0.15)),
    ];
    let lamp = b.add_material(GltfMaterial {
        emissive: [1.0, 0.7, 0.4],
        emissive_strength: 40.0,
        ..matte("lamp", [0.8; 3], 0.8)
    });

    let mut mesh = QuadMesh::default();
    mesh.quad(Vec3::ZERO, Vec3::Z * 20.0, Vec3::X * 20.0);
    add_object(&mut b, "ground", &mesh, ground, NodeTransform::Identity);
    // (centre x, centre z, half size x, height, half size z) per box.
    let boxes = [
        (-2.2, -0.5, 0.6, 1.2, 0.6),
        (-0.6, 0.8, 0.45, 0.9, 0.45),
        (0.9, -0.8, 0.5, 2.0, 0.5),
        (2.4, 0.6, 0.7, 0.7, 0.4),
        (0.2, -2.8, 1.5, 1.4, 0.4),
    ];
    for (k, &(x, z, hx, h, hz)) in boxes.iter().enumerate() {
        let mut cube = QuadMesh::default();
        cube.cuboid(Vec3::new(x - hx, 0.0, z - hz), Vec3::new(x + hx, h, z + hz));
        add_object(
            &mut b,
            &format!("box {k}"),
            &cube,
            materials[k],
            NodeTransform::Identity,
        );
    }
    // The lamp: a 0.4 × 0.3 m panel just in front of the tall box's +Z face, facing +Z.
    let mut panel = QuadMesh::default();
    panel.quad(
        Vec3::new(0.9, 1.4, -0.8 + 0.5 + 0.005),
        Vec3::X * 0.2,
        Vec3::Y * 0.15,
    );
    add_object(&mut b, "lamp", &panel, lamp, NodeTransform::Identity);

    let (eye, target) = ([0.0, 2.2, 7.0], [0.0, 0.8, 0.0]);
    let camera = b.add_perspective_camera("camera", 45f32.to_radians(), Some(1.5), 0.01);
    b.add_node(
        "camera",
        None,
        Some(camera),
        NodeTransform::Trs {
            translation: eye,
            rotation: look_at_rotation(eye, target, [0.0, 1.0, 0.0]),
            scale: [1.0; 3],
        },
    );
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::EnvironmentMap;
    use crate::scene::EnvironmentImage;
    use std::sync::Arc;

    #[test]
    fn the_sun_is_where_the_map_says_and_outshines_the_sky() {
        let image = sun_and_sky(256, 128);
        let map = EnvironmentMap::new(Arc::new(
            EnvironmentImage::from_rgb(&image, 1.0, 0.0).unwrap(),
        ));
        let at_sun = map.radiance(sun_direction());
        assert_eq!(at_sun, Vec3::from_array(SUN_RADIANCE));
        // Irradiance on a surface facing the sun, split into sun disc and the rest of the
        // upper hemisphere, by summing texels (solid angle × cosine at the texel centre).
        let (w, h) = (256, 128);
        let (mut sun, mut rest) = (0.0f64, 0.0f64);
        let n = sun_direction();
        for j in 0..h {
            let theta = |j: usize| std::f64::consts::PI * j as f64 / h as f64;
            let omega =
                2.0 * std::f64::consts::PI / w as f64 * (theta(j).cos() - theta(j + 1).cos());
            for i in 0..w {
                let u = (i as f64 + 0.5) / w as f64;
                let v = (j as f64 + 0.5) / h as f64;
                let d = equirectangular_direction(u, v).as_vec3();
                let cos = d.dot(n).max(0.0) as f64;
                let l = crate::color::luminance(Vec3::from_array(image.pixels[j * w + i])) as f64;
                if d.dot(n) > 0.99 {
                    sun += l * omega * cos;
                } else {
                    rest += l * omega * cos;
                }
            }
        }
        assert!(sun > 2.0 * rest, "sun {sun}, sky {rest}");
    }
}
