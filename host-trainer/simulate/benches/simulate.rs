//! Simulating a 7-day 1 Hz chamber campaign (604 801 samples, every noise process on) must
//! take under 2 s. Run: `cargo bench -p rlg-simulate --bench simulate`.

use criterion::{criterion_group, criterion_main, Criterion};
use rlg_physics::{Axis, Term};
use rlg_simulate::{simulate, NoiseParams, Scenario, Segment, ThermalParams};

/// Budget for the 7-day campaign, s.
const SEVEN_DAY_BUDGET_S: f64 = 2.0;

fn seven_day_campaign() -> Scenario {
    Scenario {
        name: "seven-day".into(),
        sample_period_s: 1.0,
        power_on_s: 0.0,
        duration_s: Some(7.0 * 86_400.0),
        start_c: 10.0,
        thermal: ThermalParams {
            air_tau_s: 300.0,
            body_tau_s: 1200.0,
            self_heating_c: 4.8,
            self_heating_per_c: -0.0138,
        },
        profile: vec![Segment::Repeat {
            count: 22,
            segments: vec![
                Segment::Hold {
                    duration_s: 10_800.0,
                },
                Segment::Ramp {
                    to_c: 65.0,
                    rate_c_per_min: 1.0,
                },
                Segment::Hold {
                    duration_s: 10_800.0,
                },
                Segment::Ramp {
                    to_c: 10.0,
                    rate_c_per_min: 1.0,
                },
            ],
        }],
        terms: vec![
            Term::EarthRate {
                latitude_deg: 28.2,
                axis: Axis::Down,
            },
            Term::StaticPoly {
                center_c: 0.0,
                scale_c: 1.0,
                coeffs_dph: vec![-0.0096, 7.1445e-4, -2.6387e-5, 2.1772e-7],
            },
            Term::RateTerms {
                linear: 2.1572,
                cubic: -4.2769e3,
                temp_linear: 1.9163e-5,
            },
            Term::GradientLag {
                tau_s: 600.0,
                gain: 0.3,
            },
            Term::Hysteresis {
                width_c: 4.0,
                height_dph: 5e-4,
                node_lag_s: 0.0,
            },
            Term::ModeHop {
                temp_c: 45.0,
                step_dph: 1e-3,
                hysteresis_c: 3.0,
                node_lag_s: 0.0,
            },
            Term::Backscatter {
                period_c: 7.0,
                amplitude_dph: 3e-4,
                phase_rad: 0.0,
                node_lag_s: 0.0,
            },
            Term::Warmup {
                amplitude_dph: 5e-3,
                tau_s: 900.0,
                t_on_s: 0.0,
            },
            Term::Aging {
                rate_dph_per_day: 2e-4,
            },
            Term::SensorLag { tau_s: 5.0 },
            Term::TempQuantization { step_c: 0.01 },
            Term::Heteroscedastic {
                k: 0.3,
                ref_c: 20.0,
            },
        ],
        noise: NoiseParams {
            arw_dph_rt_h: 2.5e-4,
            bias_instability_dph: 5e-4,
            rrw_dph_per_rt_h: 5e-5,
            angle_quantum_arcsec: 0.01,
            ..Default::default()
        },
    }
}

fn bench(c: &mut Criterion) {
    let s = seven_day_campaign();
    // One timed run up front so the figure is printed even with criterion's output filtered.
    let t = std::time::Instant::now();
    let sim = simulate(&s, 1).expect("valid scenario");
    let secs = t.elapsed().as_secs_f64();
    println!(
        "7-day 1 Hz campaign: {} samples simulated in {secs:.3} s (budget {SEVEN_DAY_BUDGET_S} s)",
        sim.recording.len()
    );
    assert!(
        secs < SEVEN_DAY_BUDGET_S,
        "7-day simulation took {secs:.3} s"
    );
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10);
    g.bench_function("seven_day_1hz", |b| {
        b.iter(|| simulate(&s, 1).expect("valid scenario"))
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
