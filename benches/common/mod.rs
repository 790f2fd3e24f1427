//! Shared by the benches: shading points where a scene's camera sees its surfaces.

use manylights::accel::Accel;
use manylights::scene::Scene;
use manylights::select::ShadingContext;

/// Shading points where camera rays through the pixel centres of a `width` × `height` grid hit
/// the scene, each with its geometric normal turned toward the camera; with `lit_only`, only
/// hits on surfaces without emission (the pixels of the lit-surface MSE).
pub fn shading_points(
    scene: &Scene,
    accel: &Accel,
    width: u32,
    height: u32,
    lit_only: bool,
) -> Vec<ShadingContext> {
    let camera = scene.camera.as_ref().expect("the scene has a camera");
    let mut points = Vec::new();
    for j in 0..height {
        for i in 0..width {
            let (origin, dir) = camera.ray(i as f32 + 0.5, j as f32 + 0.5, width, height);
            if let Some(hit) = accel.closest_hit(origin, dir, f32::INFINITY) {
                let triangle = &scene.triangles[hit.triangle as usize];
                if lit_only && scene.materials[triangle.material as usize].is_emissive() {
                    continue;
                }
                let n = triangle.geometric_normal();
                let n = if n.dot(dir) > 0.0 { -n } else { n };
                points.push(ShadingContext {
                    p: origin + dir * hit.t,
                    n,
                });
            }
        }
    }
    points
}
