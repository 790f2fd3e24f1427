//! Every selector × strategy is unbiased: on a many-light town (2,000 emissive triangles over five
//! decades of radiance, buildings occluding most of them) each configuration converges to the
//! same image as a baseline (power selection, area sampling). Compared on 8×8-pixel blocks
//! (means of thousands of samples, close to normal) and on the image mean, each within 5σ of the
//! combined standard error.

use manylights::film::Film;
use manylights::gen::generate;
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::scene::{load_gltf, CameraChoice, Scene};
use manylights::select::SelectorKind;

const SIZE: u32 = 24;
const BLOCK: u32 = 8;

fn town() -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("town.glb");
    generate::many_lights(4, 2000).write(&path).unwrap();
    load_gltf(&path, &CameraChoice::First).unwrap()
}

fn render_with(scene: &Scene, kind: SelectorKind, strategy: Strategy, k: u32, spp: u32) -> Film {
    let prepared = PreparedScene::new(scene.clone(), kind);
    let estimator = prepared.estimator(strategy, k, 1);
    let opts = RenderOptions::new(SIZE, SIZE, spp, kind as u64 * 7 + 1);
    let (film, stats) = render(&estimator, scene.camera.as_ref().unwrap(), &opts);
    assert_eq!(
        stats.nan_samples + stats.inf_samples,
        0,
        "{kind:?} {strategy:?}"
    );
    film
}

/// (mean, variance of that mean) of the pixels in block (bx, by), channel-averaged.
fn block(film: &Film, bx: u32, by: u32) -> (f64, f64) {
    let (mut m, mut v) = (0.0, 0.0);
    for y in by * BLOCK..(by + 1) * BLOCK {
        for x in bx * BLOCK..(bx + 1) * BLOCK {
            let p = &film.pixels[(y * SIZE + x) as usize];
            m += p.mean.element_sum() / 3.0;
            // Var of the channel average ≤ (σ_r² + σ_g² + σ_b²)/3 (Cauchy–Schwarz): conservative.
            v += p.variance_of_mean().element_sum() / 3.0;
        }
    }
    let count = (BLOCK * BLOCK) as f64;
    (m / count, v / (count * count))
}

/// Asserts that two renders agree block by block and on the whole image, within 5σ.
fn assert_agree(a: &Film, b: &Film, label: &str) {
    let blocks = SIZE / BLOCK;
    let (mut total_a, mut total_b, mut var_total) = (0.0, 0.0, 0.0);
    for by in 0..blocks {
        for bx in 0..blocks {
            let (ma, va) = block(a, bx, by);
            let (mb, vb) = block(b, bx, by);
            let sigma = (va + vb).sqrt();
            assert!(
                (ma - mb).abs() <= 5.0 * sigma,
                "{label}: block ({bx},{by}): {ma} vs baseline {mb}, σ {sigma}"
            );
            total_a += ma;
            total_b += mb;
            var_total += va + vb;
        }
    }
    let n = (blocks * blocks) as f64;
    let sigma = var_total.sqrt() / n;
    let (ma, mb) = (total_a / n, total_b / n);
    assert!(
        (ma - mb).abs() <= 5.0 * sigma,
        "{label}: image mean {ma} vs {mb}, σ {sigma}"
    );
    assert!(ma > 0.0);
    println!("{label}: image mean {ma:.5} vs baseline {mb:.5} (σ {sigma:.2e})");
}

#[test]
fn every_selector_and_strategy_converges_to_the_same_image() {
    let scene = town();
    let baseline = render_with(&scene, SelectorKind::Power, Strategy::LightArea, 4, 2048);
    let configs = [
        (SelectorKind::Uniform, Strategy::LightArea, 4, 512),
        (SelectorKind::Power, Strategy::LightSolidAngle, 4, 512),
        (SelectorKind::Bvh, Strategy::LightArea, 4, 512),
        (SelectorKind::Bvh, Strategy::LightSolidAngle, 4, 512),
        (SelectorKind::Bvh, Strategy::Mis, 4, 512),
        (SelectorKind::Power, Strategy::Mis, 4, 512),
        (SelectorKind::Power, Strategy::Bsdf, 4, 2048),
        (SelectorKind::Oracle, Strategy::LightArea, 1, 128),
        (SelectorKind::Oracle, Strategy::Mis, 1, 64),
    ];
    for (kind, strategy, k, spp) in configs {
        let film = render_with(&scene, kind, strategy, k, spp);
        assert_agree(
            &film,
            &baseline,
            &format!("{kind:?} {strategy:?} K={k} spp={spp}"),
        );
    }
}
