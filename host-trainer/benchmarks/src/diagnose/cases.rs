//! The benchmark's cases: a chamber profile, a gyro (base physics, noise) and a hidden term
//! concealed at a chosen detectability, each from its own seeded draw.

use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::detectability::{
    amplitude_at, case_detectability, effect, noise_scale_peak, noise_sigmas,
};
use super::BenchError;
use rlg_diagnose::candidates::Family;
use rlg_diagnose::prepare::{prepare, PhysicsModel};
use rlg_eval::paper::{self, eq11};
use rlg_physics::{Axis, Term};
use rlg_simulate::{simulate, NoiseParams, Scenario, Segment, ThermalParams};

pub(super) fn u(rng: &mut ChaCha8Rng) -> f64 {
    rng.random::<f64>()
}

pub(super) fn log_u(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo * (hi / lo).powf(u(rng))
}

/// A random chamber profile: static steps or 0.5/1/2 °C/min cycles over one of three ranges.
pub(super) fn profile(rng: &mut ChaCha8Rng) -> (String, f64, Vec<Segment>) {
    let ranges = [(10.0, 65.0), (-20.0, 40.0), (-40.0, 60.0)];
    let (lo, hi) = ranges[(u(rng) * 3.0) as usize % 3];
    let kind = (u(rng) * 4.0) as usize % 4;
    if kind == 0 {
        let steps = 6;
        let segs = (0..steps)
            .map(|k| Segment::Soak {
                setpoint_c: lo + (hi - lo) * k as f64 / (steps - 1) as f64,
                duration_s: 7200.0,
            })
            .collect();
        return (format!("steps {lo}..{hi} °C"), lo, segs);
    }
    let rate = [0.5, 1.0, 2.0][kind - 1];
    let cycles = if rate < 1.0 { 2 } else { 3 };
    let cyc = Segment::Repeat {
        count: cycles,
        segments: vec![
            Segment::Hold { duration_s: 3600.0 },
            Segment::Ramp {
                to_c: hi,
                rate_c_per_min: rate,
            },
            Segment::Hold { duration_s: 3600.0 },
            Segment::Ramp {
                to_c: lo,
                rate_c_per_min: rate,
            },
        ],
    };
    (
        format!("{cycles}×{rate} °C/min {lo}..{hi} °C"),
        lo,
        vec![cyc, Segment::Hold { duration_s: 3600.0 }],
    )
}

/// Base scenario: the paper's thermal constants and Eq. (11) with coefficients varied by ±30 %.
pub(super) fn base_scenario(
    rng: &mut ChaCha8Rng,
    name: String,
    start_c: f64,
    profile: Vec<Segment>,
    noise_scale: f64,
) -> Scenario {
    let mut v = |x: f64| x * (1.0 + 0.3 * (2.0 * u(rng) - 1.0));
    Scenario {
        name,
        sample_period_s: 1.0,
        power_on_s: 0.0,
        duration_s: None,
        start_c,
        thermal: ThermalParams {
            air_tau_s: 300.0,
            body_tau_s: 1200.0,
            self_heating_c: 4.818,
            self_heating_per_c: -0.01375,
        },
        profile,
        terms: vec![
            Term::EarthRate {
                latitude_deg: paper::LATITUDE_DEG,
                axis: Axis::Down,
            },
            Term::StaticPoly {
                center_c: 0.0,
                scale_c: 1.0,
                coeffs_dph: eq11::STATIC_POLY_DPH.iter().map(|&c| v(c)).collect(),
            },
            Term::RateTerms {
                linear: v(eq11::RATE_LINEAR),
                cubic: v(eq11::RATE_CUBIC),
                temp_linear: v(eq11::TEMP_RATE),
            },
            Term::TempQuantization {
                step_c: BASE_QUANTUM_C,
            },
        ],
        noise: NoiseParams {
            arw_dph_rt_h: 2.5e-4 * noise_scale,
            bias_instability_dph: 5e-4 * noise_scale,
            ..Default::default()
        },
    }
}

/// The temperature reading's quantum of every benchmark gyro, °C; a hidden
/// `temp_quantization` replaces it with a coarser one.
pub(super) const BASE_QUANTUM_C: f64 = 0.01;

/// A hidden term of `family` with random non-linear parameters and unit amplitude.
pub(super) fn hidden_term(f: Family, rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> Term {
    let sign = if u(rng) < 0.5 { -1.0 } else { 1.0 };
    let range = hi - lo;
    match f {
        Family::SensorLag => Term::SensorLag {
            tau_s: log_u(rng, 60.0, 600.0),
        },
        Family::GradientLag => Term::GradientLag {
            tau_s: log_u(rng, 200.0, 3000.0),
            gain: sign,
        },
        Family::Hysteresis => Term::Hysteresis {
            width_c: (3.0 + 12.0 * u(rng)).min(range / 3.0),
            height_dph: sign,
            node_lag_s: 0.0,
        },
        Family::Warmup => Term::Warmup {
            amplitude_dph: sign,
            tau_s: log_u(rng, 1200.0, 7200.0),
            t_on_s: 0.0,
        },
        Family::ModeHop => Term::ModeHop {
            temp_c: lo + 5.0 + range * (0.3 + 0.4 * u(rng)),
            step_dph: sign,
            hysteresis_c: 0.5 + 2.5 * u(rng),
            node_lag_s: 0.0,
        },
        Family::Backscatter => Term::Backscatter {
            period_c: (4.0 + 11.0 * u(rng)).min(range / 3.0),
            amplitude_dph: 1.0,
            phase_rad: std::f64::consts::TAU * u(rng),
            node_lag_s: 0.0,
        },
        Family::Periodic => Term::Periodic {
            period_s: log_u(rng, 1500.0, 10_000.0),
            amplitude_dph: 1.0,
            phase_rad: std::f64::consts::TAU * u(rng),
            windows_s: Vec::new(),
        },
        Family::Aging => Term::Aging {
            rate_dph_per_day: sign,
        },
        Family::Heteroscedastic => Term::Heteroscedastic {
            k: 1.0,
            ref_c: lo + range * (0.2 + 0.6 * u(rng)),
        },
        Family::TempQuantization => Term::TempQuantization {
            step_c: (log_u(rng, 0.05, 0.5) * 1e4).round() / 1e4,
        },
    }
}

/// Scales a bias term's amplitude by `k`.
pub(super) fn scale_amplitude(t: &Term, k: f64) -> Term {
    let mut t = t.clone();
    match &mut t {
        Term::GradientLag { gain, .. } => *gain *= k,
        Term::Hysteresis { height_dph, .. } => *height_dph *= k,
        Term::Warmup { amplitude_dph, .. }
        | Term::Backscatter { amplitude_dph, .. }
        | Term::Periodic { amplitude_dph, .. } => *amplitude_dph *= k,
        Term::ModeHop { step_dph, .. } => *step_dph *= k,
        Term::Aging { rate_dph_per_day } => *rate_dph_per_day *= k,
        Term::Heteroscedastic { k: kk, .. } => *kk *= k,
        _ => {}
    }
    t
}

/// Puts `hidden` into a scenario's terms: a sensor lag first (the physics library rounds the
/// lagged reading), a reading quantum in place of the base one, any other term last.
pub(super) fn insert_hidden(terms: &mut Vec<Term>, hidden: Term) {
    match hidden {
        Term::SensorLag { .. } => terms.insert(0, hidden),
        Term::TempQuantization { .. } => {
            match terms
                .iter_mut()
                .find(|t| matches!(t, Term::TempQuantization { .. }))
            {
                Some(t) => *t = hidden,
                None => terms.push(hidden),
            }
        }
        _ => terms.push(hidden),
    }
}

pub(super) struct Case {
    pub(super) profile: String,
    pub(super) scenario: Scenario,
    pub(super) hidden: Option<Term>,
}

/// Builds case `id`: a profile, a noise level and (for `family`) a hidden term concealed at
/// detectability `target`. Tries up to 40 draws for one that meets the concealment bound.
pub(super) fn build_case(
    id: usize,
    family: Option<Family>,
    seed: u64,
    model: &PhysicsModel,
) -> Result<Case, BenchError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id as u64);
    let target = 3.0 + 7.0 * u(&mut rng);
    let mut last = None;
    for _try in 0..40 {
        let (pname, start, segs) = profile(&mut rng);
        let (lo, hi) = match &segs[0] {
            Segment::Repeat { segments, .. } => match segments[1] {
                Segment::Ramp { to_c, .. } => (start, to_c),
                _ => (start, start),
            },
            _ => (
                start,
                start
                    + 100.0_f64.min(match segs.last() {
                        Some(Segment::Soak { setpoint_c, .. }) => setpoint_c - start,
                        _ => 0.0,
                    }),
            ),
        };
        let noise_scale = log_u(&mut rng, 0.5, 2.0);
        let mut sc = base_scenario(&mut rng, format!("bench-{id}"), start, segs, noise_scale);
        let Some(f) = family else {
            return Ok(Case {
                profile: pname,
                scenario: sc,
                hidden: None,
            });
        };
        let unit = hidden_term(f, &mut rng, lo, hi);
        // Noise-free run for the drive.
        let mut quiet = sc.clone();
        quiet.noise = NoiseParams::default();
        let sim = simulate(&quiet, 0)?;
        let mut rec_sc = quiet.clone();
        if matches!(unit, Term::SensorLag { .. } | Term::TempQuantization { .. }) {
            insert_hidden(&mut rec_sc.terms, unit.clone());
        }
        let rec = simulate(&rec_sc, 0)?.recording;
        let prep = prepare(&rec)?;
        let e = effect(&unit, &sim.truth);
        let mut truth_noisy = sim.truth.clone();
        truth_noisy.scenario.noise = sc.noise.clone();
        let Some(d_unit) = case_detectability(&unit, &truth_noisy, &prep, model) else {
            continue;
        };
        let peak_unit = e.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let (s1, _) = noise_sigmas(&sc.noise);
        if d_unit.is_nan() || d_unit <= 0.0 {
            continue;
        }
        let hidden = match unit {
            Term::Heteroscedastic { .. } => {
                let body = &sim.truth.body_c[prep.range.clone()];
                let d_of = |k: f64| {
                    case_detectability(&scale_amplitude(&unit, k), &truth_noisy, &prep, model)
                        .unwrap_or(0.0)
                };
                let Some(k) = amplitude_at(target, d_of) else {
                    continue;
                };
                let t = scale_amplitude(&unit, k);
                last = Some((pname.clone(), sc.clone(), t.clone()));
                if noise_scale_peak(&t, body, &sc.noise) < 0.5 * s1 {
                    t
                } else {
                    continue;
                }
            }
            Term::SensorLag { .. } | Term::TempQuantization { .. } => {
                // No amplitude: the noise level sets D (D scales as 1/k when every noise
                // amplitude is scaled by k).
                let k = d_unit / target;
                sc.noise.arw_dph_rt_h *= k;
                sc.noise.bias_instability_dph *= k;
                if !(0.1..=5.0).contains(&(noise_scale * k)) {
                    continue;
                }
                let (s1k, _) = noise_sigmas(&sc.noise);
                last = Some((pname.clone(), sc.clone(), unit.clone()));
                if peak_unit < 0.5 * s1k {
                    unit
                } else {
                    continue;
                }
            }
            _ => {
                let a = target / d_unit;
                let t = scale_amplitude(&unit, a);
                last = Some((pname.clone(), sc.clone(), t.clone()));
                if a * peak_unit < 0.5 * s1 {
                    t
                } else {
                    continue;
                }
            }
        };
        insert_hidden(&mut sc.terms, hidden.clone());
        return Ok(Case {
            profile: pname,
            scenario: sc,
            hidden: Some(hidden),
        });
    }
    // No draw met the bound: keep the last one, its peak ratio is reported.
    let (pname, mut sc, t) = last.ok_or_else(|| BenchError::Truth {
        path: format!("case {id}"),
        message: "no usable draw".into(),
    })?;
    insert_hidden(&mut sc.terms, t.clone());
    Ok(Case {
        profile: pname,
        scenario: sc,
        hidden: Some(t),
    })
}

/// Case `id` of the benchmark with master seed `seed` (the recording [`run_benchmark`]
/// diagnoses when `family` is the family its plan puts at `id`: it calls this): the profile
/// description, the hidden term and the simulation.
pub fn case_simulation(
    id: usize,
    family: Option<Family>,
    seed: u64,
) -> Result<(String, Option<Term>, rlg_simulate::Simulation), BenchError> {
    let (profile, hidden, mut runs) = case_runs(id, family, seed, 1)?;
    Ok((profile, hidden, runs.remove(0)))
}

/// Case `id` run `runs` times: the same gyro (profile, physics, hidden term, noise levels) in
/// the chamber again, each run with its own noise. Run 0 is [`case_simulation`]'s recording;
/// run k > 0 is seeded apart from every case's run 0.
pub fn case_runs(
    id: usize,
    family: Option<Family>,
    seed: u64,
    runs: usize,
) -> Result<(String, Option<Term>, Vec<rlg_simulate::Simulation>), BenchError> {
    let case = build_case(id, family, seed, &PhysicsModel::paper())?;
    let mut seeds = noise_seeds(id, seed);
    let sims = (0..runs)
        .map(|_| simulate(&case.scenario, seeds.next_u64() >> 11))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((case.profile, case.hidden, sims))
}

/// The noise seeds of case `id`'s runs: their own ChaCha8 stream of the master seed, apart
/// from the stream its draw uses. (Seeds computed as `seed + id` would give case k of seed S
/// the noise of case k + 1 of seed S − 1, so runs at adjacent master seeds would share
/// noise sequences.) Each seed drawn is cut to 53 bits: the truth sidecar carries it, and
/// read back through TOML (integers are i64) or by a reader that holds JSON numbers as
/// doubles, a larger one would not be the same integer.
fn noise_seeds(id: usize, seed: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id as u64 | 1 << 63);
    rng
}

/// The benchmark's case number of the `k`-th case of `family` with `per_term` cases per
/// family (the plan of [`run_benchmark`]: each family's cases in `Family::ALL` order).
pub fn case_id(family: Family, k: usize, per_term: usize) -> usize {
    let pos = Family::ALL.iter().position(|f| *f == family).unwrap_or(0);
    pos * per_term + k
}
