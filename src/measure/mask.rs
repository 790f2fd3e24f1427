//! The lit-surface mask: the pixels where light selection matters. A pixel is lit surface when
//! every primary ray of the reference hit a surface without emission (no emitter and no
//! background seen through any part of the pixel): there the error is the light-sampling
//! noise, while elsewhere it is dominated by the anti-aliasing of directly seen emitters and
//! background, which no light selector changes.
//!
//! References store the per-pixel fraction of such primary rays as their `surface` channel.
//! For a reference without one, [`primary_surface_fractions`] recomputes it by a primary
//! visibility pass: G × G rays per pixel through the centres of a regular grid of sub-pixel
//! cells, closest hits only, no shading.

use glam::Vec3;
use rayon::prelude::*;

use super::SceneSetup;
use crate::accel::Accel;

/// Sub-pixel grid of the recomputing pass: 8 × 8 rays per pixel.
pub const RECOMPUTE_GRID: u32 = 8;

/// One flag per pixel: lit surface when its fraction is 1.
pub fn lit_mask(surface_fractions: &[f32]) -> Vec<bool> {
    surface_fractions.iter().map(|&f| f >= 1.0).collect()
}

/// Per pixel, the fraction of `grid` × `grid` primary rays (through the cell centres) whose
/// closest hit is a triangle whose material has no emission.
pub fn primary_surface_fractions(setup: &SceneSetup, grid: u32) -> Vec<f32> {
    let accel = Accel::build(&setup.scene);
    let (w, h) = (setup.width, setup.height);
    let camera = &setup.camera;
    let scene = &setup.scene;
    let rays = (grid * grid) as f32;
    let surface = |(origin, dir): (Vec3, Vec3)| {
        accel
            .closest_hit(origin, dir, f32::INFINITY)
            .is_some_and(|hit| {
                let tri = &scene.triangles[hit.triangle as usize];
                !scene.materials[tri.material as usize].is_emissive()
            })
    };
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut hits = 0u32;
            for sy in 0..grid {
                for sx in 0..grid {
                    let u = x as f32 + (sx as f32 + 0.5) / grid as f32;
                    let v = y as f32 + (sy as f32 + 0.5) / grid as f32;
                    hits += surface(camera.ray(u, v, w, h)) as u32;
                }
            }
            hits as f32 / rays
        })
        .collect()
}
