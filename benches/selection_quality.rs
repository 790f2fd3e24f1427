//! How close each selector's choice is to the oracle's, without Monte Carlo noise: at shading
//! points where camera rays hit a surface without emission (the pixels the lit-surface MSE
//! counts: a point on an emitter sees its own triangle at cos θ = 0, where the oracle's
//! polygon formula is singular and dwarfed every other point), the chi-square divergence of the selector's pmf p_l
//! from the oracle's q_l (each light's exact unshadowed contribution, normalised),
//!     χ² = Σ_l q_l² / p_l − 1,
//! which is the relative variance of an estimate that picks one light with p_l and then knows
//! that light's unshadowed contribution exactly (0 for the oracle itself). Pixel error scales
//! with W²·χ², W the point's total unshadowed contribution, and relative pixel error with χ²
//! itself, so the table gives the W²-weighted mean, the plain mean (which a few bad points
//! dominate, as they dominate relMSE), the median and the largest χ², and counts points where a
//! contributing light has p_l = 0 (bias).
//!
//! Scenes: `scenes/town.glb` and the generated 50k city (seed 1, as `manylights gen city`).
//! Run: `cargo bench --bench selection_quality` (about 30 s; prints a table, times nothing).

mod common;
use common::{generated_city, shading_points, shipped};
use manylights::accel::Accel;
use manylights::lights::Lights;
use manylights::scene::Scene;
use manylights::select::{oracle, LightSelector, SelectorKind, ShadingContext};

/// Camera rays per image side (columns; rows follow the 4:3 frame).
const GRID: u32 = 40;

/// χ² over the shading points, and the points where a contributing light has p_l = 0.
struct Divergence {
    weighted_mean: f64,
    mean: f64,
    median: f64,
    max: f64,
    missed: usize,
}

fn divergence(scene: &Scene, points: &[ShadingContext], kind: SelectorKind) -> Divergence {
    let mut lights = Lights::from_scene(scene);
    let selector = LightSelector::build(kind, &mut lights).expect("the scene has lights");
    let (mut weighted, mut weight_sum, mut missed) = (0.0, 0.0, 0);
    let mut all = Vec::with_capacity(points.len());
    for ctx in points {
        let weights: Vec<f64> = lights
            .lights
            .iter()
            .map(|l| oracle::weight(l, ctx))
            .collect();
        let total: f64 = weights.iter().sum();
        if total <= 0.0 {
            continue;
        }
        let mut chi2 = -1.0;
        let mut lost = false;
        for (light, &w) in weights.iter().enumerate().filter(|(_, &w)| w > 0.0) {
            let p = selector.pmf(&lights, ctx, light);
            let q = w / total;
            if p > 0.0 {
                chi2 += q * q / p;
            } else {
                lost = true;
            }
        }
        missed += usize::from(lost);
        weighted += total * total * chi2;
        weight_sum += total * total;
        all.push(chi2);
    }
    all.sort_by(f64::total_cmp);
    Divergence {
        weighted_mean: weighted / weight_sum,
        mean: all.iter().sum::<f64>() / all.len() as f64,
        median: all.get(all.len() / 2).copied().unwrap_or(f64::NAN),
        max: all.last().copied().unwrap_or(f64::NAN),
        missed,
    }
}

fn main() {
    let town = shipped("town");
    let city = generated_city(50_000);
    println!(
        "scene     selector  points  W²-weighted χ²     mean χ²  median χ²      max χ²  \
         points with a contributing light at p = 0"
    );
    for (name, scene) in [("town", &town), ("city50k", &city)] {
        let accel = Accel::build(scene);
        let points = shading_points(scene, &accel, GRID, GRID * 3 / 4, true);
        for kind in [
            SelectorKind::Uniform,
            SelectorKind::Power,
            SelectorKind::Bvh,
        ] {
            let d = divergence(scene, &points, kind);
            println!(
                "{name:<9} {:<9} {:>6}  {:>14.3}  {:>10.3}  {:>9.3}  {:>10.1}  {}",
                format!("{kind:?}").to_lowercase(),
                points.len(),
                d.weighted_mean,
                d.mean,
                d.median,
                d.max,
                d.missed
            );
        }
    }
}
