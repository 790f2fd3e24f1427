//! Whole-path costs on the shipped many-light scene (12,000 emissive triangles): BVH build,
//! light + selector build per selector, the cost of one light choice per selector at real
//! shading points, and one frame at 128×128, 1 spp, K = N = 1.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
mod common;
use common::{shading_points, shipped};
use manylights::accel::Accel;
use manylights::integrator::{render, PreparedScene, RenderOptions, Strategy};
use manylights::lights::Lights;
use manylights::sampling::rng::PixelRng;
use manylights::select::{LightSelector, SelectorKind};

const SELECTORS: [SelectorKind; 4] = [
    SelectorKind::Uniform,
    SelectorKind::Power,
    SelectorKind::Bvh,
    SelectorKind::Oracle,
];

fn town_benches(c: &mut Criterion) {
    let scene = shipped("town");
    c.bench_function("town/bvh_build", |b| b.iter(|| Accel::build(&scene)));
    for kind in [SelectorKind::Power, SelectorKind::Bvh] {
        c.bench_function(&format!("town/light_build/{kind:?}"), |b| {
            b.iter(|| {
                let mut lights = Lights::from_scene(&scene);
                LightSelector::build(kind, &mut lights)
            })
        });
    }
    let accel = Accel::build(&scene);
    let points = shading_points(&scene, &accel, 32, 32, false);
    for kind in SELECTORS {
        let mut lights = Lights::from_scene(&scene);
        let selector = LightSelector::build(kind, &mut lights).expect("town has lights");
        let mut rng = PixelRng::new(1, 2);
        let mut i = 0;
        c.bench_function(&format!("town/select_sample/{kind:?}"), |b| {
            b.iter(|| {
                i = (i + 1) % points.len();
                black_box(selector.sample(&lights, &points[i], rng.next_f64()))
            })
        });
        c.bench_function(&format!("town/select_pmf/{kind:?}"), |b| {
            b.iter(|| {
                i = (i + 1) % points.len();
                black_box(selector.pmf(&lights, &points[i], i % lights.len()))
            })
        });
    }
    let camera = scene.camera.clone().expect("town has a camera");
    let opts = RenderOptions::new(128, 128, 1, 0);
    for kind in [SelectorKind::Power, SelectorKind::Bvh] {
        let prepared = PreparedScene::new(scene.clone(), kind);
        let estimator = prepared.estimator(Strategy::LightArea, 1, 1);
        c.bench_function(&format!("town/frame_128x128_1spp/{kind:?}"), |b| {
            b.iter(|| render(&estimator, &camera, &opts))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = town_benches
}
criterion_main!(benches);
