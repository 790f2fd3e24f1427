//! Whole-path costs on the shipped many-light scene: BVH build, light build (lights + alias
//! table), and one frame at 128×128, 1 spp, K = N = 1, power selection.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use manylights::accel::Accel;
use manylights::integrator::{render, Estimator, RenderOptions, Strategy};
use manylights::lights::Lights;
use manylights::scene::load_gltf;
use manylights::select::{LightSelector, SelectorKind};

fn town(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/town.glb");
    let scene = load_gltf(&path, &Default::default()).expect("scenes/town.glb loads");
    c.bench_function("town/bvh_build", |b| b.iter(|| Accel::build(&scene)));
    c.bench_function("town/light_build", |b| {
        b.iter(|| {
            let lights = Lights::from_scene(&scene);
            LightSelector::new(SelectorKind::Power, &lights)
        })
    });
    let accel = Accel::build(&scene);
    let lights = Lights::from_scene(&scene);
    let selector = LightSelector::new(SelectorKind::Power, &lights);
    let estimator = Estimator {
        scene: &scene,
        accel: &accel,
        lights: &lights,
        selector: selector.as_ref(),
        strategy: Strategy::LightArea,
        k: 1,
        n: 1,
    };
    let camera = scene.camera.clone().expect("town has a camera");
    let opts = RenderOptions {
        width: 128,
        height: 128,
        spp: 1,
        seed: 0,
    };
    c.bench_function("town/frame_128x128_1spp", |b| {
        b.iter(|| render(&estimator, &camera, &opts))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = town
}
criterion_main!(benches);
