//! Alias table benchmarks: construction over 1,000,000 log-uniform weights and
//! sampling throughput on that table (random u, so bins are hit at random as
//! in light selection; the 24 MB table does not fit in cache), and on a
//! 1,000-entry table that does, to separate arithmetic from memory latency.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use manylights::sampling::alias::AliasTable;
use rand_core::{Rng, SeedableRng};
use rand_pcg::Pcg64;

const ENTRIES: usize = 1_000_000;
const DRAWS: usize = 1_000_000;

/// Uniform in [0, 1) from the top 53 bits of a u64.
fn uniform(rng: &mut Pcg64) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Weights log-uniform over [1e-12, 1e12].
fn log_uniform_weights(n: usize, rng: &mut Pcg64) -> Vec<f64> {
    (0..n)
        .map(|_| 10f64.powf(-12.0 + 24.0 * uniform(rng)))
        .collect()
}

fn build(c: &mut Criterion) {
    let mut rng = Pcg64::seed_from_u64(1);
    let weights = log_uniform_weights(ENTRIES, &mut rng);
    let mut group = c.benchmark_group("alias_build");
    group.sample_size(20);
    group.throughput(Throughput::Elements(ENTRIES as u64));
    group.bench_function("1M_log_uniform", |b| {
        b.iter(|| AliasTable::new(black_box(&weights)))
    });
    group.finish();
}

fn sample(c: &mut Criterion) {
    for entries in [ENTRIES, 1_000] {
        let mut rng = Pcg64::seed_from_u64(2);
        let weights = log_uniform_weights(entries, &mut rng);
        let table = AliasTable::new(&weights).expect("valid weights");
        let us: Vec<f64> = (0..DRAWS).map(|_| uniform(&mut rng)).collect();
        let mut group = c.benchmark_group(format!("alias_sample_{entries}_entries"));
        group.sample_size(20);
        group.throughput(Throughput::Elements(DRAWS as u64));
        group.bench_function("sample", |b| {
            b.iter(|| {
                us.iter()
                    .map(|&u| table.sample(black_box(u)))
                    .fold(0usize, usize::wrapping_add)
            })
        });
        group.bench_function("sample_with_pmf", |b| {
            b.iter(|| {
                us.iter()
                    .map(|&u| table.sample_with_pmf(black_box(u)).1)
                    .sum::<f64>()
            })
        });
        group.finish();
    }
}

criterion_group!(benches, build, sample);
criterion_main!(benches);
