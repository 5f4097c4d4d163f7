//! Overhead of each strategy over `FixedNoise` for one update of a 15-state filter with a
//! 3-D (position) and a 6-D (position + velocity) measurement.
//!
//! Run: `cargo bench -p adaptive --bench strategy_overhead`

#![allow(non_snake_case)]

use std::hint::black_box;

use adaptive::{AnyStrategy, STRATEGY_NAMES};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use estimator_core::linear::LinearMeasurement;
use estimator_core::{ErrorStateFilter, FixedNoise, NoiseStrategy};
use nalgebra::{SMatrix, SVector};

fn filter<A: NoiseStrategy>(a: A) -> ErrorStateFilter<SVector<f64, 15>, A> {
    let P = SMatrix::<f64, 15, 15>::from_fn(|r, c| if r == c { 1.0 } else { 0.01 });
    ErrorStateFilter::new(SVector::zeros(), P, a).unwrap()
}

fn bench_m<const M: usize>(c: &mut Criterion) {
    let H = SMatrix::<f64, M, 15>::from_fn(|r, col| if r == col { 1.0 } else { 0.0 });
    let sensor = LinearMeasurement::new(H);
    let R = SMatrix::<f64, M, M>::identity();
    let zs: Vec<SVector<f64, M>> = (0..64)
        .map(|k| SVector::<f64, M>::from_fn(|i, _| ((k * 7 + i * 3) % 11) as f64 * 0.1 - 0.5))
        .collect();
    let mut group = c.benchmark_group(format!("update_15_states_m{M}"));
    {
        // The generic FixedNoise (zero-sized) as the baseline.
        let mut f = filter(FixedNoise);
        let mut k = 0;
        group.bench_function(BenchmarkId::new("FixedNoise", M), |b| {
            b.iter(|| {
                k = (k + 1) % zs.len();
                black_box(f.update(&sensor, &zs[k], &R).unwrap().nis)
            })
        });
    }
    for name in STRATEGY_NAMES {
        let mut f = filter(name.parse::<AnyStrategy>().unwrap());
        let mut k = 0;
        group.bench_function(BenchmarkId::new(name, M), |b| {
            b.iter(|| {
                k = (k + 1) % zs.len();
                black_box(f.update(&sensor, &zs[k], &R).unwrap().nis)
            })
        });
    }
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_m::<3>(c);
    bench_m::<6>(c);
}

criterion_group!(strategy_overhead, benches);
criterion_main!(strategy_overhead);
