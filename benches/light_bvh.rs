//! Light BVH speed: build over 50,000 and 1,000,000 random triangle lights
//! (and the tree's size per light), and the `bvh` selector's build over the
//! emitters of `manylights gen city` with as many lights (what `render`
//! prints as "light build");
//! `sample` and `pmf` per call on 50,000.

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
mod common;
use common::generated_city;
use glam::Vec3;
use manylights::lights::Lights;
use manylights::select::light_tree::{LightBounds, LightBvh};
use manylights::select::BvhSelector;
use rand_core::Rng;
use rand_pcg::Pcg32;
use std::hint::black_box;
use std::time::Duration;

struct Rand(Pcg32);

impl Rand {
    fn f32(&mut self) -> f32 {
        (self.0.next_u32() >> 8) as f32 / 16_777_216.0
    }
    fn f64(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 / 9_007_199_254_740_992.0
    }
    fn point(&mut self, half: f32) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32()) * (2.0 * half) - half
    }
}

/// Triangles in [−1, 1]³, sizes over 2.5 decades, random orientation, a
/// quarter two-sided, powers over six decades.
fn random_lights(count: usize, seed: u64) -> Vec<LightBounds> {
    let mut rng = Rand(Pcg32::new(seed, 3));
    let mut lights = Vec::with_capacity(count);
    while lights.len() < count {
        let centre = rng.point(1.0);
        let size = 10f32.powf(rng.f32() * 2.5 - 3.0);
        let v = [0; 3].map(|_| centre + rng.point(size));
        let normal = (v[1] - v[0]).cross(v[2] - v[0]);
        let two_sided = rng.f32() < 0.25;
        let Some(w) = normal.try_normalize() else {
            continue;
        };
        let power = 10f32.powf(rng.f32() * 6.0 - 3.0);
        lights.push(LightBounds {
            lo: v[0].min(v[1]).min(v[2]),
            hi: v[0].max(v[1]).max(v[2]),
            phi: 0.5 * normal.length() * power * if two_sided { 2.0 } else { 1.0 },
            w,
            cos_theta_o: 1.0,
            cos_theta_e: 0.0,
            two_sided,
        });
    }
    lights
}

fn build(c: &mut Criterion) {
    let mut group = c.benchmark_group("build");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    for count in [50_000, 1_000_000] {
        let lights = random_lights(count, 1);
        let (tree, _) = LightBvh::build(&lights);
        println!(
            "{count} lights: {} nodes, {:.1} bytes/light",
            tree.node_count(),
            tree.bytes() as f64 / tree.len() as f64
        );
        group.bench_function(format!("{count}"), |b| {
            b.iter(|| black_box(LightBvh::build(black_box(&lights))))
        });
    }
    for count in [50_000, 1_000_000] {
        let scene = generated_city(count);
        let lights = Lights::from_scene(&scene);
        group.bench_function(format!("city{count}"), |b| {
            b.iter_batched(
                || lights.clone(),
                |mut lights| black_box(BvhSelector::build(&mut lights)),
                BatchSize::LargeInput,
            )
        });
    }
    group.finish();
}

fn query(c: &mut Criterion) {
    let (bvh, _) = LightBvh::build(&random_lights(50_000, 2));
    let mut rng = Rand(Pcg32::new(7, 9));
    let queries: Vec<(Vec3, Vec3, f64)> = (0..4096)
        .map(|_| {
            let n = rng.point(1.0).normalize_or(Vec3::Z);
            (rng.point(1.2), n, rng.f64())
        })
        .collect();
    let picks: Vec<(Vec3, Vec3, usize)> = queries
        .iter()
        .filter_map(|&(p, n, u)| bvh.sample(p, n, u).map(|(light, _)| (p, n, light)))
        .collect();
    let mut group = c.benchmark_group("query_50000");
    let mut i = 0;
    group.bench_function("sample", |b| {
        b.iter_batched(
            || {
                i = (i + 1) % queries.len();
                queries[i]
            },
            |(p, n, u)| black_box(bvh.sample(p, n, u)),
            BatchSize::SmallInput,
        )
    });
    let mut i = 0;
    group.bench_function("pmf", |b| {
        b.iter_batched(
            || {
                i = (i + 1) % picks.len();
                picks[i]
            },
            |(p, n, light)| black_box(bvh.pmf(p, n, light)),
            BatchSize::SmallInput,
        )
    });
    group.finish();
}

criterion_group!(benches, build, query);
criterion_main!(benches);
