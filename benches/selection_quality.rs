//! How close each selector's choice is to the oracle's, without Monte Carlo noise: at shading
//! points where camera rays hit a surface without emission (the pixels the lit-surface MSE
//! counts: a point on an emitter sees its own triangle at cos θ = 0, where the oracle's
//! polygon formula is singular and dwarfed every other point), the chi-square divergence of
//! the selector's pmf p_l from the oracle's q_l (each light's exact unshadowed contribution,
//! normalised),
//!     χ² = Σ_l q_l² / p_l − 1,
//! which is the relative variance of an estimate that picks one light with p_l and then knows
//! that light's unshadowed contribution exactly (0 for the oracle itself). Pixel error scales
//! with W²·χ², W the point's total unshadowed contribution, and relative pixel error with χ²
//! itself, so the table gives the W²-weighted mean, the plain mean (which a few bad points
//! dominate, as they dominate relMSE), the median and the largest χ², and counts points where a
//! contributing light has p_l = 0 (bias).
//!
//! The last column adds visibility, which the oracle ignores as every selector here does: with
//! V_l one shadow ray from the point to light l's centroid and S = Σ V_l w_l the shadowed
//! total (w_l the oracle's unnormalised weight, W = Σ w_l), picking l with p_l and knowing V_l w_l
//! exactly has variance Σ (V_l w_l)² / p_l − S², the oracle's W·S − S²; the column is the ratio
//! of their sums over the points. It is the light choice's own excess with shadows, not a
//! render's: MIS's BSDF sample and the point on the light are left out, and a thousand points
//! miss rare fireflies. Measured at 3c1b9f2 against renders (`bench --spp 1`, lit MSE): raising
//! the inside floor to 0.3 moved it 2.96 → 2.91 on the town and 9.76 → 9.30 on the 50k city
//! while the renders went −3% and +1%; doubling two-sided lights' Φ moved it to 3.24 and 15.9
//! while the renders went −5% and +16%. A change is judged by `bench`, not by this column.
//!
//! Scenes: `scenes/town.glb` and the generated 50k city (seed 1, as `manylights gen city`).
//! Run: `cargo bench --bench selection_quality` (about 15 s on 2 cores; prints a table, times
//! nothing).

mod common;
use common::{generated_city, shading_points, shipped};
use manylights::accel::Accel;
use manylights::lights::{Light, Lights};
use manylights::scene::Scene;
use manylights::select::{oracle, LightSelector, SelectorKind, ShadingContext};
use rayon::prelude::*;

/// Camera rays per image side (columns; rows follow the 4:3 frame).
const GRID: u32 = 40;

/// What one selector leaves at the shading points: χ² over them, the points where a
/// contributing light has p_l = 0, and its shadowed variance summed over them.
struct Divergence {
    weighted_mean: f64,
    mean: f64,
    median: f64,
    max: f64,
    missed: usize,
    shadowed: f64,
}

/// One selector at one point: χ², whether a contributing light has p_l = 0, and the shadowed
/// variance Σ (V_l w_l)² / p_l − S².
struct AtPoint {
    chi2: f64,
    lost: bool,
    shadowed: f64,
}

/// Whether light `light` is seen from the receiver: one shadow ray to its centroid (lights
/// other than triangles count as seen).
fn visible(accel: &Accel, ctx: &ShadingContext, light: &Light) -> bool {
    let Light::Triangle(t) = light else {
        return true;
    };
    let centroid = t.p0 + (t.e1 + t.e2) / 3.0;
    !accel.segment_occluded(ctx.p, ctx.n, centroid, t.side_toward(ctx.p - centroid))
}

/// Each selector of `kinds` at `points`, and the oracle's shadowed variance W·S − S² summed
/// over them.
fn divergences(
    scene: &Scene,
    accel: &Accel,
    points: &[ShadingContext],
    kinds: &[SelectorKind],
) -> (Vec<Divergence>, f64) {
    let mut lights = Lights::from_scene(scene);
    // The tree renumbers the lights into its leaf order and the other selectors keep the order
    // they are given, so built after the tree they all index the same lights.
    let tree = LightSelector::build(SelectorKind::Bvh, &mut lights).expect("the scene has lights");
    let selectors: Vec<LightSelector> = kinds
        .iter()
        .map(|&kind| match kind {
            SelectorKind::Bvh => tree.clone(),
            _ => LightSelector::build(kind, &mut lights).expect("the scene has lights"),
        })
        .collect();
    let per_point: Vec<Option<(Vec<AtPoint>, f64, f64)>> = points
        .par_iter()
        .map(|ctx| {
            let weights: Vec<f64> = lights
                .lights
                .iter()
                .map(|l| oracle::weight(l, ctx))
                .collect();
            let total: f64 = weights.iter().sum();
            if total <= 0.0 {
                return None;
            }
            let seen: Vec<(usize, f64, f64)> = weights
                .iter()
                .enumerate()
                .filter(|(_, &w)| w > 0.0)
                .map(|(l, &w)| {
                    let v = if visible(accel, ctx, &lights.lights[l]) {
                        w
                    } else {
                        0.0
                    };
                    (l, w, v)
                })
                .collect();
            let shadowed_total: f64 = seen.iter().map(|&(_, _, v)| v).sum();
            let at = selectors
                .iter()
                .map(|selector| {
                    let mut at = AtPoint {
                        chi2: -1.0,
                        lost: false,
                        shadowed: -shadowed_total * shadowed_total,
                    };
                    for &(light, w, v) in &seen {
                        let p = selector.pmf(&lights, ctx, light);
                        if p > 0.0 {
                            let q = w / total;
                            at.chi2 += q * q / p;
                            at.shadowed += v * v / p;
                        } else {
                            at.lost = true;
                        }
                    }
                    at
                })
                .collect();
            let oracle = total * shadowed_total - shadowed_total * shadowed_total;
            Some((at, total, oracle))
        })
        .collect();
    let oracle_shadowed = per_point.iter().flatten().map(|(_, _, o)| o).sum();
    let divergences = (0..kinds.len())
        .map(|s| {
            let (mut weighted, mut weight_sum, mut missed, mut shadowed) = (0.0, 0.0, 0, 0.0);
            let mut all = Vec::with_capacity(points.len());
            for (at, total, _) in per_point.iter().flatten() {
                let at = &at[s];
                missed += usize::from(at.lost);
                weighted += total * total * at.chi2;
                weight_sum += total * total;
                shadowed += at.shadowed;
                all.push(at.chi2);
            }
            all.sort_by(f64::total_cmp);
            Divergence {
                weighted_mean: weighted / weight_sum,
                mean: all.iter().sum::<f64>() / all.len() as f64,
                median: all.get(all.len() / 2).copied().unwrap_or(f64::NAN),
                max: all.last().copied().unwrap_or(f64::NAN),
                missed,
                shadowed,
            }
        })
        .collect();
    (divergences, oracle_shadowed)
}

fn main() {
    let town = shipped("town");
    let city = generated_city(50_000);
    println!(
        "scene     selector  points  W²-weighted χ²     mean χ²  median χ²      max χ²  \
         points with a contributing light at p = 0  shadowed variance / oracle's"
    );
    let kinds = [
        SelectorKind::Uniform,
        SelectorKind::Power,
        SelectorKind::Bvh,
    ];
    for (name, scene) in [("town", &town), ("city50k", &city)] {
        let accel = Accel::build(scene);
        let points = shading_points(scene, &accel, GRID, GRID * 3 / 4, true);
        let (divergences, oracle_shadowed) = divergences(scene, &accel, &points, &kinds);
        for (kind, d) in kinds.iter().zip(divergences) {
            println!(
                "{name:<9} {:<9} {:>6}  {:>14.3}  {:>10.3}  {:>9.3}  {:>10.1}  {:>43}  {:>28.3}",
                format!("{kind:?}").to_lowercase(),
                points.len(),
                d.weighted_mean,
                d.mean,
                d.median,
                d.max,
                d.missed,
                d.shadowed / oracle_shadowed
            );
        }
    }
}
