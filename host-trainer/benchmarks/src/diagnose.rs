//! The concealed-effect benchmark: recordings from the simulator with one hidden term each
//! (or none), concealed and set to a chosen detectability, diagnosed from the CSV alone and
//! scored from the truth sidecar alone.
//!
//! Detectability of a hidden effect e(t) (°/h) on a recording: the part of its 100 s means ē
//! (over the diagnosis' blocks) orthogonal to the baseline model's columns X (offset, T, T²,
//! T³, Ṫ, Ṫ³, T·Ṫ on the recorded drive, the diagnosis' own design), measured in the metric
//! of the simulated noise's exact block-mean covariance Σ (from its parameters,
//! [`block_mean_autocov`]): D² = ēᵀ(Σ⁻¹ − Σ⁻¹X(XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹)ē. D is the signal-to-noise
//! ratio of the best test for that one effect with its shape and the noise known, i.e. what no
//! diagnosis can beat. An earlier definition, ‖P⊥ē‖/σ₁₀₀ with σ₁₀₀ the marginal σ of one
//! 100 s mean, ignored that the bias-instability bank makes neighbouring means correlated
//! (correlation times up to 10⁴ s): on the benchmark's recordings it was 1.0–2.6× the
//! detectability above (median per term from 1.06 for backscatter to 2.38 for aging, whose
//! 3…5 read as 7…11); it is still reported (`detectability_marginal`). For a bias term e is its contribution; for
//! `sensor_lag`, e is the true baseline driven by the body temperature minus the same
//! baseline driven by the lagged reading; for `temp_quantization` minus the same baseline
//! driven by the rounded reading (its dT/dt by the diagnosis' estimator). Concealment: the
//! peak of e is below half the 1 s noise σ.
//!
//! `heteroscedastic` changes no mean: its detectability is that of the best test for its
//! exact shape on the 1 Hz samples, D² = ½·Σ(gᵢ − ḡ)² with gᵢ = 2·ln(1 + k·xᵢ) the
//! log-variance it adds ([`heteroscedastic_detectability`]); concealed when the change of
//! the noise σ at its peak, σ_w·k·x_max, is below half the 1 s σ.

use std::path::{Path, PathBuf};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use rlg_diagnose::candidates::Family;
use rlg_diagnose::linalg::{dot, Basis};
use rlg_diagnose::locate::{iou, peak_mask};
use rlg_diagnose::noise::{block_mean_autocov, GlsWhitener};
use rlg_diagnose::prepare::{baseline_columns, estimate_rate, prepare, PhysicsModel, Prepared};
use rlg_diagnose::variance::{heldout_variance, heteroscedastic_detectability, log_scale};
use rlg_diagnose::{diagnose, heldout_metrics, Diagnosis, Options, Verdict};
use rlg_eval::paper::{self, eq11};
use rlg_io::recording::Recording;
use rlg_physics::{contribution, Axis, Mechanism, Term};
use rlg_simulate::{
    simulate, truth_path, write_simulation, NoiseParams, Scenario, Segment, ThermalParams, Truth,
};

/// Benchmark size and seed.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Master seed.
    pub seed: u64,
    /// Recordings per hidden term.
    pub per_term: usize,
    /// Recordings with nothing hidden.
    pub nulls: usize,
    /// Keep the recordings and sidecars in the output directory.
    pub keep: bool,
    /// False-alarm probability of the diagnosis' significance test.
    pub alpha: f64,
    /// Run only these hidden terms (None: nothing-hidden cases); empty: every case. Each
    /// case keeps its number, so a subset reproduces the full run's recordings.
    pub only: Vec<Option<Family>>,
}

impl BenchOptions {
    /// The full benchmark: 20 per term, 100 without a hidden term.
    pub fn full(seed: u64) -> Self {
        Self {
            seed,
            per_term: 20,
            nulls: 100,
            keep: false,
            alpha: Options::default().alpha,
            only: Vec::new(),
        }
    }

    /// A quick run for tests: 2 per term, 8 without.
    pub fn quick(seed: u64) -> Self {
        Self {
            seed,
            per_term: 2,
            nulls: 8,
            keep: false,
            alpha: Options::default().alpha,
            only: Vec::new(),
        }
    }
}

/// What a case hid, or what the diagnosis said of it: a mechanism of the term library,
/// nothing, or structure no library term explains. In JSON and in the report its name: the
/// mechanism's, `none` or `unexplained`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Label {
    /// A mechanism of the term library.
    Mechanism(Mechanism),
    /// Nothing hidden; or the diagnosis found the recording consistent with the model.
    None,
    /// The diagnosis found structure but no library term for it.
    Unexplained,
}

impl Label {
    /// The label's name.
    pub fn name(self) -> &'static str {
        match self {
            Label::Mechanism(m) => m.name(),
            Label::None => "none",
            Label::Unexplained => "unexplained",
        }
    }

    /// The label of a name, `None` for a name that is none of them.
    pub fn from_name(name: &str) -> Option<Label> {
        match name {
            "none" => Some(Label::None),
            "unexplained" => Some(Label::Unexplained),
            _ => Mechanism::from_name(name).map(Label::Mechanism),
        }
    }

    /// The diagnosis' label: its first finding's mechanism, or its verdict.
    pub fn of(d: &Diagnosis) -> Label {
        match (d.verdict, d.findings.first()) {
            (Verdict::MissingPhysics, Some(f)) => Label::Mechanism(f.mechanism),
            (Verdict::UnexplainedStructure, _) => Label::Unexplained,
            (Verdict::Consistent, _) | (Verdict::MissingPhysics, None) => Label::None,
        }
    }
}

impl std::fmt::Display for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Label {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Label {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Label::from_name(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("`{name}` is not a label")))
    }
}

/// The scored outcome of one recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseResult {
    /// Case number.
    pub id: usize,
    /// Profile description.
    pub profile: String,
    /// The hidden mechanism, `none` when nothing is hidden.
    pub truth: Label,
    /// Detectability D (see the module doc), from the truth.
    pub detectability: f64,
    /// The earlier definition, ‖P⊥ē‖/σ₁₀₀ (orthogonal part over the marginal σ of a 100 s
    /// mean): it ignores the noise's correlation, so it overstates slow effects and
    /// understates fast ones (see the module doc).
    #[serde(default)]
    pub detectability_marginal: f64,
    /// Peak of the hidden effect over the 1 s noise σ (concealed when < 0.5).
    pub peak_over_sigma1: f64,
    /// Share of the effect's 100 s-mean energy inside the baseline's span.
    pub energy_in_span: f64,
    /// The diagnosis' top mechanism, or its verdict when it names none.
    pub predicted: Label,
    /// Key parameter within tolerance (only for correct identifications).
    pub param_ok: Option<bool>,
    /// Relative error of the key parameter.
    pub param_rel_err: Option<f64>,
    /// Key parameter: (true, found, reported 1σ uncertainty).
    pub param: Option<(f64, f64, f64)>,
    /// Time IoU of the finding's spans with the truth's (only for correct identifications).
    pub iou: Option<f64>,
    /// Held-out gain of the diagnosed model over the true model's (correct identifications).
    pub gain_fraction: Option<f64>,
    /// Diagnosis wall time, s.
    pub seconds: f64,
    /// Best candidate's ΔBIC and its bootstrap threshold (the evidence of the verdict).
    pub best_delta_bic: (Label, f64, f64),
    /// Bootstrap p-values behind the verdict: the best candidate's, the reported finding's
    /// (if any) and the generic structure test's. With them [`CaseResult::predicted_at`]
    /// gives the verdict at any α up to the one the benchmark ran at.
    #[serde(default)]
    pub p_values: PValues,
    /// The α the diagnosis ran at.
    #[serde(default)]
    pub alpha: f64,
}

/// See [`CaseResult::p_values`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PValues {
    /// The most significant candidate's p-value.
    pub best: f64,
    /// The finding's p-value (None: no finding).
    pub finding: Option<f64>,
    /// The generic structure test's p-value.
    pub structure: f64,
    /// The true family's p-value had it been the only family tested (None: nothing hidden).
    #[serde(default)]
    pub true_family_alone: Option<f64>,
}

impl CaseResult {
    /// The verdict the diagnosis would give at a smaller false-alarm probability `alpha`
    /// (for `alpha` ≥ the run's α, the run's verdict). Exact up to the bootstrap's
    /// resolution: candidates are significant in the order of their ΔBIC, so at a smaller α
    /// the finding is the run's finding if its p-value is at most α, and otherwise there is
    /// none (every candidate before it failed its held-out check).
    pub fn predicted_at(&self, alpha: f64) -> Label {
        if alpha >= self.alpha {
            return self.predicted;
        }
        let p = &self.p_values;
        if p.finding.is_some_and(|v| v <= alpha) {
            self.predicted
        } else if p.best <= alpha || p.structure <= alpha {
            Label::Unexplained
        } else {
            Label::None
        }
    }
}

/// Why the benchmark failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// Simulation failed.
    #[error(transparent)]
    Scenario(#[from] rlg_simulate::ScenarioError),
    /// Reading or writing a recording failed.
    #[error(transparent)]
    Recording(#[from] rlg_io::recording::RecordingError),
    /// Diagnosis failed.
    #[error(transparent)]
    Diagnose(#[from] rlg_diagnose::DiagnoseError),
    /// The truth sidecar could not be read.
    #[error("{path}: {message}")]
    Truth {
        /// File.
        path: String,
        /// What went wrong.
        message: String,
    },
}

fn u(rng: &mut ChaCha8Rng) -> f64 {
    rng.random::<f64>()
}

fn log_u(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo * (hi / lo).powf(u(rng))
}

/// A random chamber profile: static steps or 0.5/1/2 °C/min cycles over one of three ranges.
fn profile(rng: &mut ChaCha8Rng) -> (String, f64, Vec<Segment>) {
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
fn base_scenario(
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
const BASE_QUANTUM_C: f64 = 0.01;

/// σ of a 1 s sample and of a 100 s mean of the simulated noise, °/h.
fn noise_sigmas(p: &NoiseParams) -> (f64, f64) {
    let w = p.arw_dph_rt_h * 60.0;
    let (taus, s) = p.gauss_markov_bank();
    let window = 100.0;
    let gm100: f64 = taus
        .iter()
        .map(|t| {
            let x = window / t;
            s * s * 2.0 / x * (1.0 - (1.0 - (-x).exp()) / x)
        })
        .sum();
    let gm1: f64 = taus.len() as f64 * s * s;
    ((w * w + gm1).sqrt(), (w * w / window + gm100).sqrt())
}

/// The hidden effect (°/h per sample of the recording) of `hidden` under `truth`.
fn effect(hidden: &Term, truth: &Truth) -> Vec<f64> {
    let t: Vec<f64> = (0..truth.body_c.len())
        .map(|i| i as f64 * truth.scenario.sample_period_s + truth.scenario.power_on_s)
        .collect();
    match hidden {
        Term::SensorLag { tau_s } => {
            let lagged = contribution(hidden, &t, &truth.body_c, &truth.dbody_c_per_s);
            let dl: Vec<f64> = truth
                .body_c
                .iter()
                .zip(&lagged)
                .map(|(c, s)| (c - s) / tau_s)
                .collect();
            let base: Vec<&Term> = truth
                .scenario
                .terms
                .iter()
                .filter(|x| matches!(x, Term::StaticPoly { .. } | Term::RateTerms { .. }))
                .collect();
            let mut e = vec![0.0; t.len()];
            for b in base {
                let a = contribution(b, &t, &truth.body_c, &truth.dbody_c_per_s);
                let l = contribution(b, &t, &lagged, &dl);
                e.iter_mut()
                    .zip(a.iter().zip(&l))
                    .for_each(|(o, (x, y))| *o += x - y);
            }
            e
        }
        Term::TempQuantization { .. } => {
            let read = contribution(hidden, &t, &truth.body_c, &truth.dbody_c_per_s);
            let rate = estimate_rate(&read, &t, truth.scenario.sample_period_s)
                .unwrap_or_else(|_| vec![0.0; t.len()]);
            let mut e = vec![0.0; t.len()];
            for b in truth
                .scenario
                .terms
                .iter()
                .filter(|x| matches!(x, Term::StaticPoly { .. } | Term::RateTerms { .. }))
            {
                let a = contribution(b, &t, &truth.body_c, &truth.dbody_c_per_s);
                let l = contribution(b, &t, &read, &rate);
                e.iter_mut()
                    .zip(a.iter().zip(&l))
                    .for_each(|(o, (x, y))| *o += x - y);
            }
            e
        }
        // A noise scale adds nothing to the mean.
        Term::Heteroscedastic { .. } => vec![0.0; t.len()],
        _ => contribution(hidden, &t, &truth.body_c, &truth.dbody_c_per_s),
    }
}

/// Detectability of `hidden` on the recording `prep` of `truth` (see the module doc): the
/// mean effect's in the metric of the noise's block-mean covariance, or the noise scale's
/// on the 1 Hz samples.
fn case_detectability(
    hidden: &Term,
    truth: &Truth,
    prep: &Prepared,
    model: &PhysicsModel,
) -> Option<f64> {
    match hidden {
        Term::Heteroscedastic { k, ref_c } => Some(heteroscedastic_detectability(
            &truth.body_c[prep.range.clone()],
            *k,
            *ref_c,
        )),
        _ => detectability(prep, model, &effect(hidden, truth), &truth.scenario.noise),
    }
}

/// The largest change of the 1 s noise σ a `heteroscedastic` term makes, °/h.
fn noise_scale_peak(hidden: &Term, body_c: &[f64], noise: &NoiseParams) -> f64 {
    match hidden {
        Term::Heteroscedastic { k, ref_c } => {
            let xmax = body_c
                .iter()
                .map(|t| ((t - ref_c) / 30.0).powi(2))
                .fold(0.0f64, f64::max);
            noise.arw_dph_rt_h * 60.0 * (k * xmax).abs()
        }
        _ => 0.0,
    }
}

/// (‖P⊥ē‖, ‖ē‖², P⊥ē) on the diagnosis' blocks of `prep`.
fn orthogonal_part(prep: &Prepared, model: &PhysicsModel, e: &[f64]) -> (f64, f64, Vec<f64>) {
    let eb = prep.blocks(&e[prep.range.clone()]);
    let cols: Vec<Vec<f64>> = baseline_columns(model, &prep.drive)
        .iter()
        .map(|c| prep.blocks(&c.values))
        .collect();
    let r = Basis::new(&cols).residual(&eb);
    (dot(&r, &r).sqrt(), dot(&eb, &eb), r)
}

/// Detectability of the effect `e` on the blocks of `prep` under the noise `noise`: the
/// norm of its part orthogonal to the baseline's span in the metric of the noise covariance
/// of the 100 s means, D² = ēᵀ(Σ⁻¹ − Σ⁻¹X(XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹)ē — the signal-to-noise ratio of
/// the best test for that exact effect (known shape, known noise). None when the recording
/// is too long for the exact factor.
fn detectability(
    prep: &Prepared,
    model: &PhysicsModel,
    e: &[f64],
    noise: &NoiseParams,
) -> Option<f64> {
    let g = GlsWhitener::new(&block_mean_autocov(noise, prep.nb(), prep.block, prep.dt_s))?;
    let eb = g.whiten(&prep.blocks(&e[prep.range.clone()]));
    let cols: Vec<Vec<f64>> = baseline_columns(model, &prep.drive)
        .iter()
        .map(|c| g.whiten(&prep.blocks(&c.values)))
        .collect();
    let r = Basis::new(&cols).residual(&eb);
    Some(dot(&r, &r).sqrt())
}

/// A hidden term of `family` with random non-linear parameters and unit amplitude.
fn hidden_term(f: Family, rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> Term {
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
        },
        Family::Backscatter => Term::Backscatter {
            period_c: (4.0 + 11.0 * u(rng)).min(range / 3.0),
            amplitude_dph: 1.0,
            phase_rad: std::f64::consts::TAU * u(rng),
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
fn scale_amplitude(t: &Term, k: f64) -> Term {
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
fn insert_hidden(terms: &mut Vec<Term>, hidden: Term) {
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

struct Case {
    profile: String,
    scenario: Scenario,
    hidden: Option<Term>,
}

/// Builds case `id`: a profile, a noise level and (for `family`) a hidden term concealed at
/// detectability `target`. Tries up to 40 draws for one that meets the concealment bound.
fn build_case(
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
                // D is not linear in k (it is in ln(1 + k·x)): bisection on a log scale.
                let body = &sim.truth.body_c[prep.range.clone()];
                let d_of = |k: f64| {
                    case_detectability(&scale_amplitude(&unit, k), &truth_noisy, &prep, model)
                        .unwrap_or(0.0)
                };
                let (mut a, mut b) = (1e-5, 10.0);
                if d_of(b) < target {
                    continue;
                }
                for _ in 0..60 {
                    let m = (a * b).sqrt();
                    if d_of(m) < target {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let t = scale_amplitude(&unit, (a * b).sqrt());
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

/// Case `id` of the benchmark with master seed `seed` (the same draw and noise seed as
/// [`run_benchmark`] gives it when `family` is the family its plan puts at `id`): the profile
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
    let sims = (0..runs as u64)
        .map(|k| {
            let s = seed.wrapping_add(id as u64) ^ k.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            simulate(&case.scenario, s)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((case.profile, case.hidden, sims))
}

/// The benchmark's case number of the `k`-th case of `family` with `per_term` cases per
/// family (the plan of [`run_benchmark`]: each family's cases in `Family::ALL` order).
pub fn case_id(family: Family, k: usize, per_term: usize) -> usize {
    let pos = Family::ALL.iter().position(|f| *f == family).unwrap_or(0);
    pos * per_term + k
}

/// The recording's hidden term, from its truth sidecar only: the scenario's term that the
/// benchmark adds beyond the base set (a reading quantum other than the base's).
fn hidden_from_truth(truth: &Truth) -> Option<Term> {
    truth
        .scenario
        .terms
        .iter()
        .find(|t| match t {
            Term::TempQuantization { step_c } => (step_c - BASE_QUANTUM_C).abs() > 1e-9,
            _ => Family::from_name(t.name()).is_some(),
        })
        .cloned()
}

fn term_from_finding(d: &Diagnosis) -> Option<Term> {
    d.findings.first()?.term()
}

/// JSON value → TOML value, numbers as f64 (integers kept when they are integers).
///
/// The workspace builds serde_json with `arbitrary_precision`, under which serde_json cannot
/// deserialize internally tagged enums such as [`Term`] (numbers reach the tag buffer as
/// maps: "invalid type: map, expected f64"). The truth sidecar is therefore parsed into a
/// `serde_json::Value` and deserialized through `toml::Value`, which has no such limitation.
fn json_to_toml(v: &serde_json::Value) -> Option<toml::Value> {
    Some(match v {
        serde_json::Value::Null => return None,
        serde_json::Value::Bool(b) => toml::Value::Boolean(*b),
        serde_json::Value::Number(n) => match n.as_i64() {
            Some(i) => toml::Value::Integer(i),
            None => toml::Value::Float(n.as_f64()?),
        },
        serde_json::Value::String(s) => toml::Value::String(s.clone()),
        serde_json::Value::Array(a) => {
            toml::Value::Array(a.iter().filter_map(json_to_toml).collect())
        }
        serde_json::Value::Object(o) => toml::Value::Table(
            o.iter()
                .filter_map(|(k, v)| json_to_toml(v).map(|t| (k.clone(), t)))
                .collect(),
        ),
    })
}

/// Reads a truth sidecar.
pub fn read_truth(path: &Path) -> Result<Truth, BenchError> {
    let bad = |message: String| BenchError::Truth {
        path: path.display().to_string(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    json_to_toml(&v)
        .ok_or_else(|| bad("empty truth".into()))?
        .try_into()
        .map_err(|e: toml::de::Error| bad(e.to_string()))
}

/// Scores one diagnosis from the truth sidecar (and the recording, for the block grid).
fn score(
    id: usize,
    profile: String,
    rec: &Recording,
    truth_file: &Path,
    d: &Diagnosis,
    model: &PhysicsModel,
    seconds: f64,
) -> Result<CaseResult, BenchError> {
    let truth = read_truth(truth_file)?;
    let prep = prepare(rec)?;
    let hidden = hidden_from_truth(&truth);
    let predicted = Label::of(d);
    let (s1, s100) = noise_sigmas(&truth.scenario.noise);
    let mut r = CaseResult {
        id,
        profile,
        truth: hidden
            .as_ref()
            .map_or(Label::None, |t| Label::Mechanism(t.mechanism())),
        detectability: 0.0,
        detectability_marginal: 0.0,
        peak_over_sigma1: 0.0,
        energy_in_span: 0.0,
        predicted,
        param_ok: None,
        param_rel_err: None,
        param: None,
        iou: None,
        gain_fraction: None,
        seconds,
        best_delta_bic: d
            .evidence
            .candidates
            .first()
            .map_or((Label::None, 0.0, 0.0), |c| {
                (
                    Label::Mechanism(c.mechanism),
                    c.delta_bic,
                    d.evidence.delta_bic_threshold,
                )
            }),
        p_values: PValues {
            best: d.evidence.candidates.first().map_or(1.0, |c| c.p_value),
            finding: d.findings.first().and_then(|f| {
                d.evidence
                    .candidates
                    .iter()
                    .find(|c| c.mechanism == f.mechanism)
                    .map(|c| c.p_value)
            }),
            structure: d.evidence.structure_p_value,
            true_family_alone: None,
        },
        alpha: 0.0,
    };
    let Some(h) = hidden else { return Ok(r) };
    r.p_values.true_family_alone = d
        .evidence
        .candidates
        .iter()
        .find(|c| c.mechanism == h.mechanism())
        .map(|c| c.p_value_alone);
    let e = effect(&h, &truth);
    let (dperp, e2, perp) = orthogonal_part(&prep, model, &e);
    r.detectability = case_detectability(&h, &truth, &prep, model).unwrap_or(f64::NAN);
    r.detectability_marginal = dperp / s100;
    r.peak_over_sigma1 = e.iter().fold(0.0f64, |a, v| a.max(v.abs())) / s1;
    r.energy_in_span = if e2 > 0.0 {
        1.0 - dperp * dperp / e2
    } else {
        0.0
    };
    // A noise scale: its effect is on the log-variance, whose constant the noise level takes.
    let perp = match &h {
        Term::Heteroscedastic { k, ref_c } => {
            let body = &truth.body_c[prep.range.clone()];
            r.detectability_marginal = r.detectability;
            r.peak_over_sigma1 = noise_scale_peak(&h, body, &truth.scenario.noise) / s1;
            let g = log_scale(body, *k, *ref_c);
            let m = g.iter().sum::<f64>() / g.len().max(1) as f64;
            let g2 = dot(&g, &g);
            r.energy_in_span = if g2 > 0.0 {
                m * m * g.len() as f64 / g2
            } else {
                0.0
            };
            log_scale(&prep.temp_b, *k, *ref_c)
                .iter()
                .map(|v| v - m)
                .collect()
        }
        _ => perp,
    };
    if r.predicted != r.truth {
        return Ok(r);
    }
    let fam = Family::from_name(h.name()).expect("hidden terms are candidate families");
    let (key, tol) = fam.key_parameter();
    let get = |t: &Term| t.parameters().into_iter().find(|p| p.0 == key).map(|p| p.1);
    let found = &d.findings[0];
    if let (Some(tv), Some(fv)) = (get(&h), found.parameters.get(key)) {
        let rel = ((fv - tv) / tv).abs();
        r.param_rel_err = Some(rel);
        r.param_ok = Some(rel <= tol);
        r.param = Some((
            tv,
            *fv,
            found.uncertainty.get(key).copied().unwrap_or(f64::NAN),
        ));
    }
    // Localisation: blocks whose centre lies in a finding span vs. the truth's orthogonal
    // effect at ≥ half its peak.
    let mask_d: Vec<bool> = prep
        .t_b
        .iter()
        .map(|t| {
            found
                .where_
                .iter()
                .any(|w| *t >= w.t_start_s && *t <= w.t_end_s)
        })
        .collect();
    r.iou = Some(iou(&mask_d, &peak_mask(&perp, 0.5)));
    if matches!(h, Term::Heteroscedastic { .. }) {
        // Held-out gain of the block log-variance model (the mean model is unchanged).
        if let (Some((b0, bt)), Some(t)) = (heldout_variance(&prep, &h), term_from_finding(d)) {
            if let Some((_, bd)) = heldout_variance(&prep, &t) {
                if b0 - bt > 0.0 {
                    r.gain_fraction = Some((b0 - bd) / (b0 - bt));
                }
            }
        }
        return Ok(r);
    }
    let base = heldout_metrics(&prep, model, None)?.rss_b;
    let truem = heldout_metrics(&prep, model, Some(&h))?.rss_b;
    if let Some(t) = term_from_finding(d) {
        let diag = heldout_metrics(&prep, model, Some(&t))?.rss_b;
        if base - truem > 0.0 {
            r.gain_fraction = Some((base - diag) / (base - truem));
        }
    }
    Ok(r)
}

/// Runs the benchmark, writing recordings to `out_dir` (deleted after scoring unless kept).
pub fn run_benchmark(opts: &BenchOptions, out_dir: &Path) -> Result<Vec<CaseResult>, BenchError> {
    std::fs::create_dir_all(out_dir).map_err(|e| BenchError::Truth {
        path: out_dir.display().to_string(),
        message: e.to_string(),
    })?;
    let model = PhysicsModel::paper();
    let mut plan: Vec<Option<Family>> = Vec::new();
    for f in Family::ALL {
        plan.extend(std::iter::repeat_n(Some(f), opts.per_term));
    }
    plan.extend(std::iter::repeat_n(None, opts.nulls));
    let plan: Vec<(usize, Option<Family>)> = plan
        .into_iter()
        .enumerate()
        .filter(|(_, f)| opts.only.is_empty() || opts.only.contains(f))
        .collect();
    plan.into_par_iter()
        .map(|(id, fam)| {
            let case = build_case(id, fam, opts.seed, &model)?;
            let sim = simulate(&case.scenario, opts.seed.wrapping_add(id as u64))?;
            let csv: PathBuf = out_dir.join(format!("case{id:04}.csv"));
            write_simulation(&sim, &csv)?;
            // The diagnosis sees the CSV only.
            let rec = Recording::read_csv(&csv)?;
            let t0 = std::time::Instant::now();
            let dopts = Options {
                alpha: opts.alpha,
                ..Options::default()
            };
            let d = diagnose(&rec, &model, &dopts)?;
            let secs = t0.elapsed().as_secs_f64();
            let r =
                score(id, case.profile, &rec, &truth_path(&csv), &d, &model, secs).map(|mut r| {
                    r.alpha = opts.alpha;
                    r
                });
            if !opts.keep {
                let _ = std::fs::remove_file(&csv);
                let _ = std::fs::remove_file(truth_path(&csv));
            }
            let _ = case.hidden;
            r
        })
        .collect()
}

/// The results as a Markdown report.
pub fn report_markdown(results: &[CaseResult]) -> String {
    use std::fmt::Write as _;
    let mut o = String::new();
    let pct = |a: usize, b: usize| {
        if b == 0 {
            "–".to_string()
        } else {
            format!("{:.0} % ({a}/{b})", 100.0 * a as f64 / b as f64)
        }
    };
    let hidden: Vec<&CaseResult> = results.iter().filter(|r| r.truth != Label::None).collect();
    let nulls: Vec<&CaseResult> = results.iter().filter(|r| r.truth == Label::None).collect();
    let fa = nulls.iter().filter(|r| r.predicted != Label::None).count();
    let fa_mp = nulls
        .iter()
        .filter(|r| matches!(r.predicted, Label::Mechanism(_)))
        .count();
    let _ = writeln!(o, "| measure | result | target |\n|---|---|---|");
    let _ = writeln!(
        o,
        "| false alarms (any verdict but consistent) | {} | ≤ 5 % |",
        pct(fa, nulls.len())
    );
    let _ = writeln!(
        o,
        "| false alarms naming a mechanism | {} | |",
        pct(fa_mp, nulls.len())
    );
    for (name, lo, hi, target) in [
        ("top-1, D 3–5", 3.0, 5.0, "≥ 70 %"),
        ("top-1, D 5–6", 5.0, 6.0, ""),
        ("top-1, D ≥ 6", 6.0, f64::INFINITY, "≥ 90 %"),
    ] {
        let set: Vec<&&CaseResult> = hidden
            .iter()
            .filter(|r| r.detectability >= lo && r.detectability < hi)
            .collect();
        let ok = set.iter().filter(|r| r.predicted == r.truth).count();
        let _ = writeln!(o, "| {name} | {} | {target} |", pct(ok, set.len()));
    }
    let correct: Vec<&&CaseResult> = hidden.iter().filter(|r| r.predicted == r.truth).collect();
    let pok = correct.iter().filter(|r| r.param_ok == Some(true)).count();
    let _ = writeln!(
        o,
        "| key parameter within 20 %/25 % (of correct) | {} | ≥ 80 % |",
        pct(pok, correct.len())
    );
    // What the diagnosis' own 1σ says it should reach: Σ P(|N(0, σᵢ)| ≤ tolᵢ), and how
    // often the truth lies within 1σ and 2σ (68 % and 95 % if the σ are right).
    let with_p: Vec<(f64, f64, f64, f64)> = correct
        .iter()
        .filter_map(|r| {
            let (t, f, u) = r.param?;
            let Label::Mechanism(m) = r.truth else {
                return None;
            };
            let tol = Family::of(m)?.key_parameter().1;
            Some((t, f, u, tol))
        })
        .filter(|(t, _, u, _)| *t != 0.0 && u.is_finite() && *u > 0.0)
        .collect();
    if !with_p.is_empty() {
        let m = with_p.len() as f64;
        let expected: f64 = with_p
            .iter()
            .map(|(t, _, u, tol)| statrs::function::erf::erf(tol * t.abs() / u / 2f64.sqrt()))
            .sum();
        let within = |k: f64| {
            with_p
                .iter()
                .filter(|(t, f, u, _)| (f - t).abs() <= k * u)
                .count() as f64
        };
        let _ = writeln!(
            o,
            "| key parameter: share within tolerance its reported 1σ predicts; truth within 1σ / 2σ | {:.0} %; {:.0} % / {:.0} % | (68 % / 95 %) |",
            100.0 * expected / m,
            100.0 * within(1.0) / m,
            100.0 * within(2.0) / m
        );
    }
    let iok = correct
        .iter()
        .filter(|r| r.iou.is_some_and(|v| v >= 0.5))
        .count();
    let _ = writeln!(
        o,
        "| localisation IoU ≥ 0.5 (of correct) | {} | |",
        pct(iok, correct.len())
    );
    let mut g: Vec<f64> = correct.iter().filter_map(|r| r.gain_fraction).collect();
    g.sort_by(f64::total_cmp);
    let gok = g.iter().filter(|v| **v >= 0.8).count();
    let med = g.get(g.len() / 2).copied().unwrap_or(f64::NAN);
    let _ = writeln!(
        o,
        "| held-out gain ≥ 80 % of the true model's (of correct) | {} (median {med:.2}) | ≥ 80 % |",
        pct(gok, g.len())
    );
    let conc = hidden.iter().filter(|r| r.peak_over_sigma1 < 0.5).count();
    let _ = writeln!(
        o,
        "| concealed (peak < σ₁/2) | {} | all |",
        pct(conc, hidden.len())
    );
    let mut span: Vec<f64> = hidden.iter().map(|r| r.energy_in_span).collect();
    span.sort_by(f64::total_cmp);
    let _ = writeln!(
        o,
        "| median energy share inside the baseline span | {:.2} | > 0.5 |",
        span.get(span.len() / 2).copied().unwrap_or(f64::NAN)
    );
    let mut secs: Vec<f64> = results.iter().map(|r| r.seconds).collect();
    secs.sort_by(f64::total_cmp);
    let _ = writeln!(
        o,
        "| diagnosis time per recording (median / max) | {:.2} s / {:.2} s | |",
        secs.get(secs.len() / 2).copied().unwrap_or(0.0),
        secs.last().copied().unwrap_or(0.0)
    );
    // Operating curve: the verdicts at smaller false-alarm probabilities.
    let run_alpha = results.iter().map(|r| r.alpha).fold(0.0, f64::max);
    let alphas: Vec<f64> = [0.0025, 0.005, 0.01, 0.02, 0.03, 0.05]
        .into_iter()
        .filter(|a| *a <= run_alpha + 1e-12)
        .collect();
    if alphas.len() > 1 {
        let _ = writeln!(
            o,
            "\nOperating curve (verdicts at a smaller α from the bootstrap p-values; the run's α = {:.1} %):\n",
            100.0 * run_alpha
        );
        let _ = writeln!(
            o,
            "| α | false alarms | top-1 D 3–5 | D 5–6 | D ≥ 6 | D 3–5 found if the family were known |\n|---|---|---|---|---|---|"
        );
        for a in alphas {
            let fa = nulls
                .iter()
                .filter(|r| r.predicted_at(a) != Label::None)
                .count();
            let band = |lo: f64, hi: f64| {
                let set: Vec<&&CaseResult> = hidden
                    .iter()
                    .filter(|r| r.detectability >= lo && r.detectability < hi)
                    .collect();
                pct(
                    set.iter().filter(|r| r.predicted_at(a) == r.truth).count(),
                    set.len(),
                )
            };
            let low: Vec<&&CaseResult> = hidden
                .iter()
                .filter(|r| r.detectability >= 3.0 && r.detectability < 5.0)
                .collect();
            let known = low
                .iter()
                .filter(|r| r.p_values.true_family_alone.is_some_and(|p| p <= a))
                .count();
            let _ = writeln!(
                o,
                "| {:.2} % | {} | {} | {} | {} | {} |",
                100.0 * a,
                pct(fa, nulls.len()),
                band(3.0, 5.0),
                band(5.0, 6.0),
                band(6.0, f64::INFINITY),
                pct(known, low.len())
            );
        }
    }
    // Confusion matrix.
    let mut cols: Vec<Label> = Family::ALL
        .iter()
        .map(|f| Label::Mechanism(f.mechanism()))
        .collect();
    cols.push(Label::None);
    cols.push(Label::Unexplained);
    let _ = writeln!(
        o,
        "\nConfusion matrix (rows: hidden term, columns: diagnosis):\n"
    );
    let names: Vec<&str> = cols.iter().map(|c| c.name()).collect();
    let _ = writeln!(o, "| truth \\ diagnosed | {} |", names.join(" | "));
    let _ = writeln!(o, "|---|{}", "---|".repeat(cols.len()));
    for row in cols.iter().take(cols.len() - 1) {
        let rs: Vec<&CaseResult> = results.iter().filter(|r| r.truth == *row).collect();
        if rs.is_empty() {
            continue;
        }
        let cells: Vec<String> = cols
            .iter()
            .map(|c| rs.iter().filter(|r| r.predicted == *c).count().to_string())
            .collect();
        let _ = writeln!(o, "| {row} | {} |", cells.join(" | "));
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The truth sidecar reads back exactly (the TOML route around serde_json's
    /// `arbitrary_precision`), and every generated case is concealed at the detectability it
    /// was built for: D recomputed from the sidecar and the recording lies in 3 … 10 and the
    /// effect's peak stays below half the 1 s noise σ (unless no draw met the bound).
    #[test]
    fn cases_are_concealed_at_their_detectability() {
        let model = PhysicsModel::paper();
        let dir = tempfile::tempdir().expect("temp dir");
        let mut concealed = 0;
        for (id, f) in Family::ALL.into_iter().enumerate() {
            let case = build_case(id, Some(f), 7, &model).expect("case");
            let sim = simulate(&case.scenario, 1).expect("simulates");
            let csv = dir.path().join(format!("c{id}.csv"));
            write_simulation(&sim, &csv).expect("writes");
            let truth = read_truth(&truth_path(&csv)).expect("reads truth");
            assert_eq!(truth, sim.truth);
            let rec = Recording::read_csv(&csv).expect("reads csv");
            let prep = prepare(&rec).expect("prepares");
            let h = hidden_from_truth(&truth).expect("hidden term");
            assert_eq!(h.name(), f.name());
            let e = effect(&h, &truth);
            let d = case_detectability(&h, &truth, &prep, &model).expect("short");
            let (s1, _) = noise_sigmas(&truth.scenario.noise);
            assert!(
                (3.0 - 1e-6..=10.0 + 1e-6).contains(&d),
                "{}: D = {d}",
                f.name()
            );
            let peak = e
                .iter()
                .fold(0.0f64, |a, v| a.max(v.abs()))
                .max(noise_scale_peak(&h, &truth.body_c, &truth.scenario.noise));
            if peak < 0.5 * s1 {
                concealed += 1;
            }
        }
        assert!(
            concealed + 1 >= Family::ALL.len(),
            "{concealed} of {} concealed",
            Family::ALL.len()
        );
    }

    /// A case's second run is the same gyro in the chamber again: the same thermal history
    /// and noise-free bias, its own noise; its first run is the benchmark's recording.
    #[test]
    fn a_case_run_again_differs_in_its_noise_only() {
        let (profile, hidden, runs) = case_runs(42, Some(Family::Hysteresis), 7, 2).expect("runs");
        let (p0, h0, sim) = case_simulation(42, Some(Family::Hysteresis), 7).expect("case");
        assert_eq!((&profile, &hidden), (&p0, &h0));
        assert_eq!(runs[0].recording, sim.recording);
        let (a, b) = (&runs[0], &runs[1]);
        assert_eq!(a.truth.bias_dph, b.truth.bias_dph);
        assert_eq!(a.truth.body_c, b.truth.body_c);
        assert_eq!(a.truth.scenario, b.truth.scenario);
        assert_ne!(a.truth.seed, b.truth.seed);
        let same = a
            .recording
            .rate_dph
            .iter()
            .zip(&b.recording.rate_dph)
            .filter(|(x, y)| x == y)
            .count();
        assert!(same < a.recording.len() / 10, "{same} equal rate samples");
    }

    /// σ of 100 s means from the noise parameters against a long simulation of the noise.
    #[test]
    fn noise_sigmas_match_simulated_noise() {
        let p = NoiseParams {
            arw_dph_rt_h: 2.5e-4,
            bias_instability_dph: 5e-4,
            ..Default::default()
        };
        let mut g = rlg_simulate::NoiseGen::new(&p, 5);
        let x: Vec<f64> = (0..2_000_000).map(|_| g.step(1.0, 1.0)).collect();
        let m = rlg_eval::metrics::block_means(&x, 100);
        let mean = m.iter().sum::<f64>() / m.len() as f64;
        let sd = (m.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m.len() as f64).sqrt();
        let (_, s100) = noise_sigmas(&p);
        assert!((sd / s100 - 1.0).abs() < 0.05, "{sd} vs {s100}");
    }

    /// The quick benchmark end to end (release only: `cargo test --release -p rlg-benchmarks
    /// quick_benchmark -- --ignored`, run by the test command; 48 s on 2 cores). Regression
    /// floors, below the targets (measured 2026-11-23 at seed 1 and α 2 %: 14 of 16 named,
    /// 1 of 8 false alarms): at least 6 of 16 hidden terms named and at most 2 of 8 alarms without
    /// one.
    /// The verdict at a smaller α: the finding survives while its own p-value is within α,
    /// then the verdict falls to `unexplained` (something else still significant) or
    /// `none`; at or above the run's α it is the run's verdict.
    #[test]
    fn verdict_at_a_smaller_alpha() {
        let mut r = CaseResult {
            id: 0,
            profile: String::new(),
            truth: Label::Mechanism(Mechanism::Aging),
            detectability: 4.0,
            detectability_marginal: 0.0,
            peak_over_sigma1: 0.1,
            energy_in_span: 0.8,
            predicted: Label::Mechanism(Mechanism::Aging),
            param_ok: None,
            param_rel_err: None,
            param: None,
            iou: None,
            gain_fraction: None,
            seconds: 0.0,
            best_delta_bic: (Label::None, 0.0, 0.0),
            p_values: PValues {
                best: 0.004,
                finding: Some(0.02),
                structure: 0.3,
                true_family_alone: Some(0.001),
            },
            alpha: 0.05,
        };
        let aging = Label::Mechanism(Mechanism::Aging);
        assert_eq!(r.predicted_at(0.05), aging);
        assert_eq!(r.predicted_at(0.1), aging);
        assert_eq!(r.predicted_at(0.02), aging);
        assert_eq!(r.predicted_at(0.01), Label::Unexplained);
        assert_eq!(r.predicted_at(0.003), Label::None);
        r.p_values.structure = 0.001;
        assert_eq!(r.predicted_at(0.003), Label::Unexplained);
        r.predicted = Label::None;
        r.p_values = PValues {
            best: 0.2,
            finding: None,
            structure: 0.5,
            true_family_alone: None,
        };
        assert_eq!(r.predicted_at(0.01), Label::None);
    }

    #[test]
    #[ignore = "release-mode benchmark"]
    fn quick_benchmark() {
        let dir = tempfile::tempdir().expect("temp dir");
        let r = run_benchmark(&BenchOptions::quick(1), dir.path()).expect("runs");
        let hidden: Vec<_> = r.iter().filter(|c| c.truth != Label::None).collect();
        let ok = hidden.iter().filter(|c| c.truth == c.predicted).count();
        let fa = r
            .iter()
            .filter(|c| c.truth == Label::None && c.predicted != Label::None)
            .count();
        println!("{}", report_markdown(&r));
        // Measured with ten families at α 2 %: 18 of 20 named, 1 of 8 false alarms.
        assert!(ok >= 15, "{ok}/{}", hidden.len());
        assert!(fa <= 2, "{fa} false alarms");
    }
}
