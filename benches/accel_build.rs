//! Build time of the geometry BVH (`Accel::build`, every thread, wall time as the render's
//! `bvh build` line reports it): the shipped town (12k triangles, obvhs's thorough build), the
//! generated city with 50,000 emitters (97k triangles, one part) and, with
//! `MANYLIGHTS_BENCH_1M=1`, the city with 1,000,000 emitters (1.95M triangles, built in 17 parts
//! and joined). Each build writes fresh memory, as in the program (the benches use its
//! allocator).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
mod common;
use common::{generated_city, shipped};
use manylights::accel::Accel;

fn build(c: &mut Criterion) {
    let mut group = c.benchmark_group("accel_build");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(15));
    let mut scenes = vec![
        ("town", shipped("town")),
        ("city50k", generated_city(50_000)),
    ];
    if std::env::var_os("MANYLIGHTS_BENCH_1M").is_some() {
        scenes.push(("city1m", generated_city(1_000_000)));
    }
    for (name, scene) in &scenes {
        group.bench_function(*name, |b| {
            b.iter(|| black_box(Accel::build(black_box(scene))))
        });
    }
    group.finish();
}

criterion_group!(benches, build);
criterion_main!(benches);
