//! Exact LS-SVM training (Eq. 9 by `solve`, low-rank-preconditioned CG from 1000 samples on)
//! at n = 1000, 2000, 5000, its closed-form LOO and the kernel matrix alone, with faer
//! sequential and on the rayon pool; and the fixed-size reduction of 10⁵ and 10⁶ raw samples
//! to 64 support vectors.
//!
//! Run: `cargo bench -p rlg-benchmarks --bench lssvm`. The comparison against numpy / scipy /
//! scikit-learn on the same data is `host-trainer/benchmarks/reference/run.sh`.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use rlg_benchmarks::lssvm::{bench_data, campaign, train_scale};
use rlg_repro::pipeline::{C, DYNAMIC_SEED, SIGMA};
use rlg_train::lssvm::solve::solve_with_loo;
use rlg_train::lssvm::{kernel_matrix, solve};

fn exact(cr: &mut Criterion) {
    let mut g = cr.benchmark_group("exact");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    for n in [1000usize, 2000, 5000] {
        let (z, y) = bench_data(n).expect("reference data");
        for (name, par) in [("seq", faer::Par::Seq), ("rayon", faer::Par::rayon(0))] {
            faer::set_global_parallelism(par);
            g.bench_with_input(BenchmarkId::new(format!("solve/{name}"), n), &n, |b, _| {
                b.iter(|| solve(&z, &y, SIGMA, C).expect("solve"))
            });
            g.bench_with_input(BenchmarkId::new(format!("loo/{name}"), n), &n, |b, _| {
                b.iter(|| solve_with_loo(&z, &y, SIGMA, C).expect("loo"))
            });
        }
        g.bench_with_input(BenchmarkId::new("kernel", n), &n, |b, _| {
            b.iter(|| kernel_matrix(&z, SIGMA))
        });
    }
    g.finish();
}

fn fixed_size(cr: &mut Criterion) {
    let mut g = cr.benchmark_group("fixed_size_64");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    for n in [100_000usize, 1_000_000] {
        let rec = campaign(n, DYNAMIC_SEED).expect("campaign");
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| train_scale(&rec, 64, SIGMA, C).expect("train"))
        });
    }
    g.finish();
}

// No plots: criterion's plotters backend needs a system font and panics without one, after
// the figures are printed but with a failing exit status.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = exact, fixed_size
}
criterion_main!(benches);
