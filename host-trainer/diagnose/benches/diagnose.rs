//! Diagnosing one day of 1 Hz data (the paper's dynamic test, 86 400 samples, with a hidden
//! hysteresis besides the scenario's own backscatter ripple) against the paper's model must
//! take under 30 s on 2 cores.
//! Run: `cargo bench -p rlg-diagnose --bench diagnose`.

use criterion::{criterion_group, criterion_main, Criterion};
use rlg_diagnose::{diagnose, Options, PhysicsModel};
use rlg_physics::Term;
use rlg_simulate::{simulate, Scenario};

/// Budget for one day at 1 Hz, s.
const ONE_DAY_BUDGET_S: f64 = 30.0;

fn one_day() -> Scenario {
    let mut s = rlg_simulate::shipped::dynamic().expect("scenario is valid");
    s.duration_s = Some(86_400.0);
    s.terms.push(Term::Hysteresis {
        width_c: 6.0,
        height_dph: 0.003,
        node_lag_s: 0.0,
    });
    s
}

fn bench(c: &mut Criterion) {
    let rec = simulate(&one_day(), 1).expect("valid scenario").recording;
    let model = PhysicsModel::paper();
    let opts = Options::default();
    // One timed run up front so the figure is printed even with criterion's output filtered.
    let t = std::time::Instant::now();
    let d = diagnose(&rec, &model, &opts).expect("diagnoses");
    let secs = t.elapsed().as_secs_f64();
    println!(
        "1-day 1 Hz recording ({} samples) diagnosed in {secs:.2} s (budget {ONE_DAY_BUDGET_S} s): {:?}, {}",
        rec.len(),
        d.verdict,
        d.findings.first().map_or("no finding", |f| f.mechanism.name())
    );
    assert!(secs < ONE_DAY_BUDGET_S, "diagnosis took {secs:.2} s");
    let mut g = c.benchmark_group("diagnose");
    g.sample_size(10);
    g.bench_function("one_day_1hz", |b| {
        b.iter(|| diagnose(&rec, &model, &opts).expect("diagnoses"))
    });
    g.finish();
}

// No plots: criterion's plotters backend needs a system font and panics without one, after
// the figures are printed but with a failing exit status.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
