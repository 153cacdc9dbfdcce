//! The "mismatched" robustness set of the diagnosis benchmark: recordings from a generator
//! written apart from the simulator, whose chamber, body and noise break the assumptions the
//! diagnosis and the matched set share, with one hidden effect each (or none), diagnosed
//! from the CSV alone.
//!
//! The matched set draws its recordings from `rlg-simulate`: the noise the diagnosis' own
//! noise model describes (white + a Gauss–Markov bank 100…10⁴ s), one thermal lag, the same
//! profiles. A diagnosis tuned there can owe its calibration to that agreement. Here only
//! the physics the diagnosis names (`rlg_physics` terms, evaluated on this generator's
//! temperatures) is shared; everything else is drawn per case, each condition independently,
//! from a ChaCha8 stream seeded by the master seed with `set_stream(case)`:
//!
//! - **Profiles.** Ramp cycles at 0.3, 1 or 3 °C/min (2–3 cycles, holds filling the record),
//!   day/night sines (period 6–24 h, 24–36 h records) and 15 °C staircases (soaks
//!   1.5–3 h) over a range lo ∈ [−40, 20] °C, hi ∈ [lo + 25, 70] °C; 10–36 h at 1 s. Real
//!   campaigns use all three, and slow ramps, sines and steps excite the rate terms very
//!   differently from the simulator's 0.5–2 °C/min cycles.
//! - **Chamber control.** The air lags the setpoint (τ 120–600 s); with probability 0.3 the
//!   controller hunts (±0.05–0.3 °C, 8–20 min) and overshoots at the end of every ramp or
//!   step (0.3–1.5 °C). Real chambers do both; the simulator's air is a clean lag.
//! - **Two-node body.** A case node lagging the air (300–1500 s) and a core node lagging
//!   the case (800–4000 s), the sensor on one of them; self-heating of 1–6 °C rises with
//!   τ 1500–5000 s after power-on. With probability 0.3 the record starts 2–8 h after
//!   power-on (warm, no transient), as when a gyro is left running between runs. The bias
//!   physics is driven by the sensor's node, so a case with nothing hidden is clean for a
//!   model driven by the reading: the second node changes only the temperature's shape
//!   (curvature at the ends of ramps, a second time constant), which a one-lag simulator
//!   never produces.
//! - **Temperature reading.** Node temperature plus white noise σ 0–0.01 °C (probability
//!   0.5) before rounding to 0.01 °C: real sensors dither and their dT/dt is noisier.
//! - **Base bias.** Earth rate (latitude 20–60°, axis up or down) and the paper's Eq. (11)
//!   polynomial and rate terms with coefficients varied by ±30 % — the model the diagnosis
//!   is given (`PhysicsModel::paper()`).
//! - **Gyro noise** (levels around the paper's ARW 2.5e-4 °/√h and BI 5e-4 °/h, each
//!   0.5–2×): white Gaussian or (p 0.4) Student-t with 3 degrees of freedom at the same
//!   variance (heavy tails from readout glitches); angle quantisation 0.02–0.2″ (p 0.5; the
//!   counted angle's quantum); rate random walk (p 0.4; Allan deviation at 10⁴ s 0.3–1.5×
//!   the bias-instability floor), which the diagnosis' noise model lacks; a 1/f-like bias
//!   (p 0.5: 12–20 Gauss–Markov processes of equal variance, correlation times over four
//!   decades from 30–300 s) or a 3–6 process bank over 1–3 decades — correlation times the
//!   diagnosis' 100…10⁴ s bank does not span; isolated spikes (p 0.3; 1–5 samples of
//!   20–100× the 1 s σ).
//! - **Hidden effect.** One of the ten library families at a detectability D drawn in
//!   3…10; nothing (clean); or one of two effects outside the library, whose right verdict
//!   is `unexplained_structure`: a bias step at a time unrelated to temperature (uniform in
//!   the middle 60 % of the record) and a term a·(dT/dt)², dT/dt in °C/min.
//! - **More effects outside the library** (`--outside-kinds`): after the clean cases, a
//!   transient bump in time (a Gaussian of σ 20 min–2 h centred in the middle 60 % of the
//!   record), a random telegraph (the bias switching between 0 and a level at the times of
//!   a Poisson process of 3–8 switches per record, at least two) and a bump at one
//!   temperature (a Gaussian in the node's temperature, σ 4–12 % of its range, centred in
//!   its middle 60 %). None is a library shape; each is `unexplained_structure`.
//! - **Other forms** (`--other-shapes`, [`Shape`]): warm-up, aging, mode hop, backscatter,
//!   periodic, hysteresis and gradient lag hidden in a form the term library does not have
//!   (two exponentials or a power law from power-on; logarithmic or square-root aging; a
//!   relay whose step settles over 1–10 min; a ripple in temperature or time with its
//!   second harmonic; a loop that bends into saturation in three steps; a gradient built
//!   through two lags), at the same drawn D on the same conditions. The diagnosis scans
//!   the library's exact shapes; a real gyro's effects need not have them.
//! - **Effects elsewhere** (`--effect-elsewhere`): each library mechanism of the bias
//!   (or its other form) driven by the body's other node, not the sensor's: the core when
//!   the sensor is on the case, the case when it is on the core, at the same drawn D on the
//!   same conditions. A real gyro's mechanisms live in the laser block and its readout,
//!   its sensor somewhere else on the body; the base bias stays on the sensor's node, as
//!   the model the diagnosis is given is fitted to the sensor's temperature.
//! - **A data logger's artefacts** (`--logger`, `logger.rs`): one per case on the finished
//!   recording, drawn from a stream of its own so the case is otherwise its default twin:
//!   1–4 dropouts of 5–60 min, 20–80 gaps of up to 5–60 s, means of 2, 5 or 10 s, Unix time
//!   stamps in ms from a clock ±50 ppm off with 2–50 ms of jitter, or 2–10 temperature
//!   readings at a digital sensor's error values (85 °C, −127 °C). None is gyro physics; the
//!   right verdict is the twin's. D is the record's before the artefact.
//! - **A coarse reading** (`--coarse-reading`, `beside.rs`): the temperature read at the
//!   quantum of a 9- to 12-bit sensor (0.5, 0.25, 0.125 or 0.0625 °C) beside the hidden
//!   effect, its D taken on that reading. The reading's quantum is an artefact; the hidden
//!   effect should still be found, at any rank beside a `temp_quantization` finding.
//! - **A noise level in time** (`--noise-in-time`, `beside.rs`): on the clean cases, the
//!   white noise's σ drifting to, stepping to or passing through 0.5…2.5× its level over
//!   the run, unrelated to temperature. It is not `heteroscedastic`.
//!
//! D is the matched set's (see the parent module's doc): D² = ēᵀ(Σ⁻¹ −
//! Σ⁻¹X(XᵀΣ⁻¹X)⁻¹XᵀΣ⁻¹)ē, ē the effect's means on the diagnosis' 100 s blocks, X its baseline
//! columns, Σ the exact covariance of this generator's block means (dense, the random walk
//! makes it non-stationary; spikes left out). `heteroscedastic` has its D on the 1 Hz
//! log-variance with this generator's noise (`NoiseDraw::scale_detectability`: the angle
//! count's and the bank's share of a sample's variance, which the term does not scale, and
//! the Student-t's lesser information), where the matched set's assumes the white noise is
//! all of it; `sensor_lag` and `temp_quantization`, which have no amplitude, reach theirs
//! through the noise level.
//!
//! Measures: false alarms on clean recordings and the calibration of the p-values against
//! α, per condition; top-1 accuracy by D; outside-library effects named as a library
//! mechanism. See [`mismatch_report_markdown`].

mod beside;
mod curve;
mod detect;
mod gen;
mod hidden;
mod logger;
mod noise;
mod report;
mod score;
mod shapes;
#[cfg(test)]
mod tests;
mod thermal;

pub use beside::{CoarseReading, NoiseInTime, TimeForm};
pub use curve::detection_png;
pub use gen::{build_case, build_case_in, Case, Conditions, Variant};
pub use hidden::Hidden;
pub use logger::Logger;
pub use report::{
    calibration_markdown, calibration_png, calibration_png_of, clean_results,
    mismatch_report_markdown,
};
pub use shapes::Shape;

use std::path::Path;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::{BenchError, CaseResult};
use rlg_diagnose::candidates::Family;
use rlg_diagnose::prepare::PhysicsModel;
use rlg_diagnose::{diagnose, Options};
use rlg_io::recording::{write_atomic, Recording};

/// Uniform in [lo, hi).
fn uni(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// Log-uniform in [lo, hi).
fn log_uni(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo * (hi / lo).powf(rng.random::<f64>())
}

/// What a case of the plan hides.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    /// A library family.
    Library(Family),
    /// A bias step in time (outside the library).
    Step,
    /// a·(dT/dt)² (outside the library).
    RateSquared,
    /// A transient bump in time (outside the library; `--outside-kinds`).
    BumpInTime,
    /// A random telegraph in time (outside the library; `--outside-kinds`).
    Telegraph,
    /// A bump at one temperature (outside the library; `--outside-kinds`).
    BumpInTemperature,
    /// Nothing.
    Clean,
}

impl Kind {
    /// Its name: the family's, `step`, `rate_squared` or `none`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Library(f) => f.name(),
            Kind::Step => "step",
            Kind::RateSquared => "rate_squared",
            Kind::BumpInTime => "bump_in_time",
            Kind::Telegraph => "telegraph",
            Kind::BumpInTemperature => "bump_in_temperature",
            Kind::Clean => "none",
        }
    }

    /// The kind of a name.
    pub fn from_name(name: &str) -> Option<Kind> {
        match name {
            "step" => Some(Kind::Step),
            "rate_squared" => Some(Kind::RateSquared),
            "bump_in_time" => Some(Kind::BumpInTime),
            "telegraph" => Some(Kind::Telegraph),
            "bump_in_temperature" => Some(Kind::BumpInTemperature),
            "none" => Some(Kind::Clean),
            n => Family::from_name(n).map(Kind::Library),
        }
    }

    /// Whether its effect lies outside the term library.
    pub fn outside(self) -> bool {
        matches!(
            self,
            Kind::Step
                | Kind::RateSquared
                | Kind::BumpInTime
                | Kind::Telegraph
                | Kind::BumpInTemperature
        )
    }

    /// The effects outside the library that only `--outside-kinds` adds to the plan.
    pub const MORE_OUTSIDE: [Kind; 3] =
        [Kind::BumpInTime, Kind::Telegraph, Kind::BumpInTemperature];
}

impl Serialize for Kind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Size, seed and α of a mismatched run.
#[derive(Clone, Debug, PartialEq)]
pub struct MismatchOptions {
    /// Master seed.
    pub seed: u64,
    /// Recordings per library family.
    pub per_family: usize,
    /// Recordings per outside-library effect.
    pub per_outside: usize,
    /// Recordings with nothing hidden.
    pub clean: usize,
    /// Keep the recordings, their truth files and their diagnoses' reports.
    pub keep: bool,
    /// False-alarm probability of the diagnosis' significance test.
    pub alpha: f64,
    /// Run only these kinds; empty: every case. Each case keeps its number.
    pub only: Vec<Kind>,
    /// Which variant of the set: mechanisms in other forms, driven by the other node.
    pub variant: Variant,
    /// Samples cut from the start of each recording before it is diagnosed
    /// ([`super::cut_start`]).
    pub shift: usize,
    /// The diagnosis' [`Options::phases`].
    pub phases: usize,
}

impl MismatchOptions {
    /// The full set: 12 per family and per outside effect, 60 clean.
    pub fn full(seed: u64) -> Self {
        Self {
            seed,
            per_family: 12,
            per_outside: 12,
            clean: 60,
            keep: false,
            alpha: Options::default().alpha,
            only: Vec::new(),
            variant: Variant::default(),
            shift: 0,
            phases: Options::default().phases,
        }
    }

    /// A quick run: 2 per family and per outside effect, 8 clean.
    pub fn quick(seed: u64) -> Self {
        Self {
            per_family: 2,
            per_outside: 2,
            clean: 8,
            ..Self::full(seed)
        }
    }

    /// The numbered plan: each family's cases in `Family::ALL` order, the steps, the
    /// (dT/dt)² terms, the clean cases; with [`Variant::outside_kinds`] then the further
    /// effects outside the library ([`Kind::MORE_OUTSIDE`]), so the cases before them keep
    /// their numbers.
    pub fn plan(&self) -> Vec<(usize, Kind)> {
        let mut plan: Vec<Kind> = Vec::new();
        for f in Family::ALL {
            plan.extend(std::iter::repeat_n(Kind::Library(f), self.per_family));
        }
        plan.extend(std::iter::repeat_n(Kind::Step, self.per_outside));
        plan.extend(std::iter::repeat_n(Kind::RateSquared, self.per_outside));
        plan.extend(std::iter::repeat_n(Kind::Clean, self.clean));
        if self.variant.outside_kinds {
            for k in Kind::MORE_OUTSIDE {
                plan.extend(std::iter::repeat_n(k, self.per_outside));
            }
        }
        plan.into_iter()
            .enumerate()
            .filter(|(_, k)| self.only.is_empty() || self.only.contains(k))
            .collect()
    }
}

/// One scored mismatched case.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MismatchResult {
    /// What it hid.
    pub kind: Kind,
    /// The conditions present (for the per-condition counts).
    pub conditions: Vec<String>,
    /// The form of a library mechanism hidden in another form ([`Shape::form`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub form: Option<&'static str>,
    /// The scored outcome (`profile` describes every condition drawn).
    pub result: CaseResult,
    /// With a second hidden effect ([`Variant::second_effect`]): which of the two were found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub two: Option<TwoFound>,
    /// With a coarse reading ([`Variant::coarse_reading`]): what was found beside it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coarse: Option<CoarseFound>,
    /// With a noise level in time ([`Variant::noise_in_time`]): the change, and whether
    /// some finding is `heteroscedastic`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_in_time: Option<(NoiseInTime, bool)>,
}

/// What was found on a case read at a coarse quantum.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CoarseFound {
    /// The reading's quantum, °C.
    pub quantum_c: f64,
    /// The hidden effect's D (0 for a clean case).
    pub d: f64,
    /// Some finding names the hidden effect's mechanism (whatever its rank).
    pub effect_found: bool,
    /// The first finding names it.
    pub effect_first: bool,
    /// Some finding is `temp_quantization`.
    pub artefact_named: bool,
    /// Some finding names a mechanism that is neither the hidden one nor the reading's
    /// quantum.
    pub other_named: bool,
}

impl CoarseFound {
    /// The outcome on `case`'s diagnosis `d` (`None` without a coarse reading).
    fn of(case: &Case, d: &rlg_diagnose::Diagnosis) -> Option<CoarseFound> {
        let r = case.coarse?;
        let hidden = match &case.hidden {
            Hidden::Library { term } => Some(term.mechanism()),
            Hidden::Shaped { shape } => Some(shape.family().mechanism()),
            _ => None,
        };
        let quantum = Family::TempQuantization.mechanism();
        Some(CoarseFound {
            quantum_c: r.quantum_c,
            d: case.d,
            effect_found: hidden.is_some_and(|m| d.findings.iter().any(|f| f.mechanism == m)),
            effect_first: hidden
                .is_some_and(|m| d.findings.first().is_some_and(|f| f.mechanism == m)),
            artefact_named: d.findings.iter().any(|f| f.mechanism == quantum),
            other_named: d
                .findings
                .iter()
                .any(|f| f.mechanism != quantum && Some(f.mechanism) != hidden),
        })
    }
}

/// Which effects of a case with two were found: each counts when some finding names its
/// mechanism, whatever its rank.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TwoFound {
    /// The first effect's D and whether a finding names it.
    pub first: (f64, bool),
    /// The second's.
    pub second: (f64, bool),
    /// The second's mechanism.
    pub second_mechanism: String,
}

impl TwoFound {
    /// The outcome on `case`'s diagnosis `d` (`None` for a case with one effect).
    fn of(case: &Case, d: &rlg_diagnose::Diagnosis) -> Option<TwoFound> {
        let (term, d2) = case.second.as_ref()?;
        let named = |m: rlg_physics::Mechanism| d.findings.iter().any(|f| f.mechanism == m);
        let first = match &case.hidden {
            Hidden::Library { term } => term.mechanism(),
            Hidden::Shaped { shape } => shape.family().mechanism(),
            _ => return None,
        };
        Some(TwoFound {
            first: (case.d, named(first)),
            second: (*d2, named(term.mechanism())),
            second_mechanism: term.name().to_string(),
        })
    }
}

/// The truth file written beside a kept recording (not read by the scoring).
#[derive(Serialize)]
struct TruthFile<'a> {
    kind: Kind,
    description: String,
    target_detectability: f64,
    detectability: f64,
    hidden: &'a Hidden,
    conditions: &'a Conditions,
    #[serde(skip_serializing_if = "Option::is_none")]
    logger: Option<&'a Logger>,
    #[serde(skip_serializing_if = "Option::is_none")]
    second: Option<&'a (rlg_physics::Term, f64)>,
    #[serde(skip_serializing_if = "Option::is_none")]
    coarse: Option<CoarseReading>,
    #[serde(skip_serializing_if = "Option::is_none")]
    noise_in_time: Option<NoiseInTime>,
}

/// Runs the mismatched set, writing each recording to `out_dir` (deleted after scoring
/// unless kept); cases in parallel.
pub fn run_mismatched(
    opts: &MismatchOptions,
    out_dir: &Path,
) -> Result<Vec<MismatchResult>, BenchError> {
    let io = |e: std::io::Error| BenchError::Truth {
        path: out_dir.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(out_dir).map_err(io)?;
    let model = PhysicsModel::paper();
    opts.plan()
        .into_par_iter()
        .map(|(id, kind)| {
            let case = build_case_in(id, kind, opts.seed, &model, opts.variant)?;
            let csv = out_dir.join(format!("mismatched{id:04}.csv"));
            let truth = out_dir.join(format!("mismatched{id:04}.truth.json"));
            case.recording.write_csv(&csv)?;
            let tf = TruthFile {
                kind,
                description: case.describe(),
                target_detectability: case.target_d,
                detectability: case.d,
                hidden: &case.hidden,
                conditions: &case.conditions,
                logger: case.logger.as_ref(),
                second: case.second.as_ref(),
                coarse: case.coarse,
                noise_in_time: case.noise_in_time,
            };
            let json = serde_json::to_vec_pretty(&tf).map_err(|e| BenchError::Truth {
                path: truth.display().to_string(),
                message: e.to_string(),
            })?;
            write_atomic(&truth, &json)?;
            // The diagnosis sees the CSV only.
            let rec = Recording::read_csv(&csv)?;
            let dopts = Options {
                alpha: opts.alpha,
                phases: opts.phases,
                ..Options::default()
            };
            let t0 = std::time::Instant::now();
            let d = diagnose(super::cut_start(&rec, opts.shift), &model, &dopts)?;
            let secs = t0.elapsed().as_secs_f64();
            if opts.keep {
                super::write_report_beside(&csv, &d)?;
            } else {
                let _ = std::fs::remove_file(&csv);
                let _ = std::fs::remove_file(&truth);
            }
            Ok(MismatchResult {
                kind,
                conditions: case.tags(),
                form: match &case.hidden {
                    Hidden::Shaped { shape } => Some(shape.form()),
                    _ => None,
                },
                result: {
                    let mut r = score::score(&case, &d, secs, opts.alpha);
                    r.shift = opts.shift;
                    r
                },
                two: TwoFound::of(&case, &d),
                coarse: CoarseFound::of(&case, &d),
                noise_in_time: case.noise_in_time.map(|n| {
                    let hetero = Family::Heteroscedastic.mechanism();
                    (n, d.findings.iter().any(|f| f.mechanism == hetero))
                }),
            })
        })
        .collect()
}
