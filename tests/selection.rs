//! Uniform and power-proportional selection are both unbiased: on the many-light town scene
//! they converge to the same image. Compared on the image mean and on 4×4 blocks of pixels
//! (means of many samples, so close to normal), each within 5σ of the combined standard error.

use std::path::Path;

use manylights::accel::Accel;
use manylights::film::Film;
use manylights::integrator::{render, Estimator, RenderOptions, Strategy};
use manylights::lights::Lights;
use manylights::scene::{load_gltf, Scene};
use manylights::select::{LightSelector, SelectorKind};

const SIZE: u32 = 32;
const BLOCK: u32 = 8;

fn render_with(
    scene: &Scene,
    accel: &Accel,
    lights: &Lights,
    kind: SelectorKind,
    seed: u64,
) -> Film {
    let selector = LightSelector::new(kind, lights).unwrap();
    let estimator = Estimator {
        scene,
        accel,
        lights,
        selector: Some(&selector),
        strategy: Strategy::LightArea,
        k: 4,
        n: 1,
    };
    let opts = RenderOptions {
        width: SIZE,
        height: SIZE,
        spp: 1024,
        seed,
    };
    render(&estimator, scene.camera.as_ref().unwrap(), &opts).0
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

#[test]
fn uniform_and_power_converge_to_the_same_image() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/town.glb");
    let scene = load_gltf(&path, &Default::default()).unwrap();
    let accel = Accel::build(&scene);
    let lights = Lights::from_scene(&scene);
    let uniform = render_with(&scene, &accel, &lights, SelectorKind::Uniform, 1);
    let power = render_with(&scene, &accel, &lights, SelectorKind::Power, 2);

    let blocks = SIZE / BLOCK;
    let (mut total_u, mut total_p, mut var_total) = (0.0, 0.0, 0.0);
    for by in 0..blocks {
        for bx in 0..blocks {
            let (mu, vu) = block(&uniform, bx, by);
            let (mp, vp) = block(&power, bx, by);
            let sigma = (vu + vp).sqrt();
            assert!(sigma > 0.0);
            assert!(
                (mu - mp).abs() < 5.0 * sigma,
                "block ({bx},{by}): uniform {mu} vs power {mp}, σ {sigma}"
            );
            total_u += mu;
            total_p += mp;
            var_total += vu + vp;
        }
    }
    let n = (blocks * blocks) as f64;
    let sigma = var_total.sqrt() / n;
    let (mu, mp) = (total_u / n, total_p / n);
    assert!(
        (mu - mp).abs() < 5.0 * sigma,
        "image mean: uniform {mu} vs power {mp}, σ {sigma}"
    );
    // Power selection should also be the better estimator here (lights span 5 decades).
    let var = |f: &Film| {
        f.pixels
            .iter()
            .map(|p| p.variance_of_mean().element_sum())
            .sum::<f64>()
    };
    println!("image mean uniform {mu:.5} power {mp:.5} σ {sigma:.2e}; variance ratio uniform/power {:.2}", var(&uniform) / var(&power));
}
