//! Shared by the benches: the scenes they measure (a shipped one, the generated city) and
//! shading points where a scene's camera sees its surfaces.

// Every bench is a crate of its own and uses only some of these.
#![allow(dead_code)]

use std::path::Path;

use manylights::accel::Accel;
use manylights::gen::generate::city;
use manylights::scene::{load_gltf, load_gltf_bytes, Scene};
use manylights::select::{Lobe, ShadingContext};

/// The program's allocator (`manylights::alloc`), so that builds are measured as the program
/// runs them.
#[global_allocator]
static ALLOCATOR: manylights::alloc::HugePageAllocator = manylights::alloc::HugePageAllocator;

/// `scenes/NAME.glb` of this repository.
pub fn shipped(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.glb"));
    load_gltf(&path, &Default::default()).expect("shipped scene loads")
}

/// The generated city with `lights` emitters, as `manylights gen city --lights N` writes it.
pub fn generated_city(lights: usize) -> Scene {
    let bytes = city(lights, 1).to_glb_bytes();
    let path = Path::new("city.glb");
    load_gltf_bytes(&bytes, path, Path::new("."), &Default::default())
        .expect("generated city loads")
}

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
                    lobe: Lobe::NONE,
                });
            }
        }
    }
    points
}
