//! One mismatched case: its conditions, its hidden effect set to the drawn detectability,
//! and the recording the diagnosis reads.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Serialize;

use super::beside::{CoarseReading, NoiseInTime};
use super::detect::Metric;
use super::hidden::{hetero_d, library_term, mean_effect, Hidden};
use super::logger::Logger;
use super::noise::{describe_noise, NoiseDraw, PAPER_ARW, PAPER_BI};
use super::shapes::Shape;
use super::thermal::{self, describe_body, describe_chamber, Body, Chamber, Profile, Trajectory};
use super::{log_uni, uni, Kind};
use crate::diagnose::cases::scale_amplitude;
use crate::diagnose::detectability::amplitude_at;
use crate::diagnose::BenchError;
use rlg_diagnose::candidates::Family;
use rlg_diagnose::prepare::{prepare, PhysicsModel, Prepared};
use rlg_eval::paper::eq11;
use rlg_io::recording::Recording;
use rlg_physics::{contribution, Axis, Role, Term};
use std::borrow::Cow;

/// Sample period, s.
pub(super) const DT_S: f64 = 1.0;

/// Quantum of every temperature reading, °C; a hidden `temp_quantization` replaces it.
pub(super) const READ_QUANTUM_C: f64 = 0.01;

/// Draws per case before giving up on meeting the detectability.
const TRIES: usize = 40;

/// Everything drawn for one case but the hidden effect.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conditions {
    /// Chamber programme and control.
    pub chamber: Chamber,
    /// Gyro body.
    pub body: Body,
    /// σ of the temperature reading's white noise before rounding, °C.
    pub temp_noise_c: f64,
    /// The base bias: Earth rate and the paper's Eq. (11) terms, coefficients varied.
    pub bias: Vec<Term>,
    /// Gyro noise.
    pub noise: NoiseDraw,
    /// Seed of the reading's noise.
    pub seed_temp: u64,
    /// Seed of the gyro noise.
    pub seed_noise: u64,
}

impl Conditions {
    fn draw(rng: &mut ChaCha8Rng) -> Conditions {
        let chamber = Chamber::draw(rng);
        let body = Body::draw(rng);
        let temp_noise_c = if uni(rng, 0.0, 1.0) < 0.5 {
            uni(rng, 0.0, 0.01)
        } else {
            0.0
        };
        let mut v = |x: f64| x * (1.0 + 0.3 * (2.0 * uni(rng, 0.0, 1.0) - 1.0));
        let bias = vec![
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
            Term::EarthRate {
                latitude_deg: uni(rng, 20.0, 60.0),
                axis: if uni(rng, 0.0, 1.0) < 0.5 {
                    Axis::Up
                } else {
                    Axis::Down
                },
            },
        ];
        let n = (chamber.duration_s / DT_S).round() as usize;
        let noise = NoiseDraw::draw(rng, n);
        Conditions {
            chamber,
            body,
            temp_noise_c,
            bias,
            noise,
            seed_temp: rng.random(),
            seed_noise: rng.random(),
        }
    }

    /// The conditions present, by name ([`CONDITION_TAGS`]), for the per-condition counts
    /// of the report.
    pub(super) fn tags(&self) -> Vec<String> {
        let n = &self.noise;
        let rate = match &self.chamber.profile {
            Profile::Ramp { rate_c_per_min, .. } => Some(*rate_c_per_min),
            _ => None,
        };
        let on = [
            rate.is_some_and(|r| r < 0.5),
            rate.is_some_and(|r| (0.5..2.0).contains(&r)),
            rate.is_some_and(|r| r >= 2.0),
            matches!(self.chamber.profile, Profile::Sine { .. }),
            matches!(self.chamber.profile, Profile::Staircase { .. }),
            self.chamber.hunting.is_some(),
            self.body.warm_s > 0.0,
            self.body.sensor_on_core,
            self.temp_noise_c > 0.0,
            n.student_t,
            n.quantum_arcsec > 0.0,
            n.rrw_dph_per_rt_h > 0.0,
            n.one_over_f,
            !n.spikes.is_empty(),
        ];
        CONDITION_TAGS
            .iter()
            .zip(on)
            .filter(|(_, on)| *on)
            .map(|(t, _)| t.to_string())
            .collect()
    }
}

/// The conditions a case may have, in the report's order.
pub(super) const CONDITION_TAGS: [&str; 14] = [
    "ramps 0.3 °C/min",
    "ramps 1 °C/min",
    "ramps 3 °C/min",
    "day/night sine",
    "15 °C staircase",
    "PID hunting + overshoot",
    "warm start",
    "sensor on the core",
    "temperature reading noise",
    "Student-t white noise",
    "angle quantisation",
    "rate random walk",
    "1/f-like bank",
    "spikes",
];

/// The temperature column: the sensor node (lagged for a hidden `sensor_lag`) plus the
/// reading's white noise, rounded to 0.01 °C (to the coarse quantum of a hidden
/// `temp_quantization`, or of a `coarse` sensor).
pub(super) fn reading(
    tr: &Trajectory,
    c: &Conditions,
    hidden: &Hidden,
    coarse: Option<CoarseReading>,
) -> Vec<f64> {
    let read_q = coarse.map_or(READ_QUANTUM_C, |r| r.quantum_c);
    let (src, q) = match hidden {
        Hidden::Library {
            term: t @ Term::SensorLag { .. },
        } => (
            contribution(t, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s),
            read_q,
        ),
        Hidden::Library {
            term: Term::TempQuantization { step_c },
        } => (tr.node_c.clone(), *step_c),
        _ => (tr.node_c.clone(), read_q),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(c.seed_temp);
    src.iter()
        .map(|x| {
            let z: f64 = StandardNormal.sample(&mut rng);
            ((x + c.temp_noise_c * z) / q).round() * q
        })
        .collect()
}

/// A case ready to diagnose.
#[derive(Clone, Debug)]
pub struct Case {
    /// Case number.
    pub id: usize,
    /// What the plan put here.
    pub kind: Kind,
    /// The conditions drawn.
    pub conditions: Conditions,
    /// The hidden effect at its amplitude.
    pub hidden: Hidden,
    /// The drawn detectability (0 for a clean case).
    pub target_d: f64,
    /// The detectability reached.
    pub d: f64,
    /// ‖P⊥ē‖/σ₁₀₀ of the mean effect (the heteroscedastic: its D).
    pub marginal: f64,
    /// Share of the mean effect's block energy inside the baseline's span.
    pub energy_in_span: f64,
    /// Peak of the effect over the 1 s noise σ.
    pub peak_over_sigma1: f64,
    /// The hidden mechanism is driven by the body's other node ([`Variant::effect_elsewhere`]).
    pub effect_elsewhere: bool,
    /// The data logger's artefact on the recording ([`Variant::logger`]).
    pub logger: Option<Logger>,
    /// The second hidden effect ([`Variant::second_effect`]): its term at its amplitude, on
    /// the sensor's node, and its D alone (against the baseline, as the first's).
    pub second: Option<(Term, f64)>,
    /// The reading's coarse quantum ([`Variant::coarse_reading`]; not with a hidden
    /// `temp_quantization`, which is one).
    pub coarse: Option<CoarseReading>,
    /// The white noise's level changing in time ([`Variant::noise_in_time`]).
    pub noise_in_time: Option<NoiseInTime>,
    /// Chamber and body history.
    pub trajectory: Trajectory,
    /// What the diagnosis reads.
    pub recording: Recording,
}

impl Case {
    /// One line on every condition and the hidden effect.
    pub fn describe(&self) -> String {
        let c = &self.conditions;
        let tn = if c.temp_noise_c > 0.0 {
            format!("T noise {:.4} °C", c.temp_noise_c)
        } else {
            "no T noise".into()
        };
        let node = match (self.effect_elsewhere, c.body.sensor_on_core) {
            (false, _) => "",
            (true, true) => " on the case",
            (true, false) => " on the core",
        };
        let mut logger = self
            .logger
            .as_ref()
            .map_or(String::new(), |l| format!("; {}", l.describe()));
        if let Some(r) = self.coarse {
            logger.push_str(&format!("; reading quantum {} °C", r.quantum_c));
        }
        if let Some(n) = self.noise_in_time {
            logger.push_str(&format!("; {}", n.describe()));
        }
        format!(
            "{}; {}; {tn}; {}{logger}; hidden: {}{node}",
            describe_chamber(&c.chamber),
            describe_body(&c.body),
            describe_noise(&c.noise),
            self.hidden.describe()
        )
    }

    /// The conditions present, by name, the logger's included (see [`Conditions::tags`]).
    pub(super) fn tags(&self) -> Vec<String> {
        let mut t = self.conditions.tags();
        t.extend(self.logger.as_ref().map(|l| l.tag().to_string()));
        t.extend(self.coarse.map(|_| BESIDE_TAGS[0].to_string()));
        t.extend(self.noise_in_time.map(|_| BESIDE_TAGS[1].to_string()));
        t
    }
}

/// The conditions of [`CoarseReading`] and [`NoiseInTime`], in the report's order.
pub(super) const BESIDE_TAGS: [&str; 2] = ["coarse reading", "noise level in time"];

/// A recording of the trajectory with the given rate and temperature columns.
pub(super) fn recording(id: usize, tr: &Trajectory, rate: Vec<f64>, temp: Vec<f64>) -> Recording {
    Recording {
        time_s: tr.t_s.clone(),
        rate_dph: rate,
        temp_c: temp,
        chamber_c: Some(tr.air_c.clone()),
        comments: vec![format!(
            " rlg benchmark-diagnose --set mismatched: case {id}"
        )],
        ..Default::default()
    }
}

/// Builds case `id` of the plan's `kind` (see the module doc of `mismatch`): its own seeded
/// draw; the hidden effect set to a detectability drawn in 3…10 (linear amplitudes by one
/// ratio, the heteroscedastic `k` by bisection, sensor terms through the noise level).
pub fn build_case(
    id: usize,
    kind: Kind,
    seed: u64,
    model: &PhysicsModel,
) -> Result<Case, BenchError> {
    build_case_in(id, kind, seed, model, Variant::default())
}

/// How a case departs from the default set; each keeps the default case's conditions and
/// drawn D (unless the two differ in having a D on a draw, which is then drawn again).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Variant {
    /// Each library family that has one hidden in a form other than its term ([`Shape`]).
    pub other_shapes: bool,
    /// A hidden mechanism of the bias driven by the body's other node, not the sensor's
    /// (the core when the sensor is on the case, the case when it is on the core).
    pub effect_elsewhere: bool,
    /// One artefact of a chamber's data logger on the finished recording ([`Logger`]).
    pub logger: bool,
    /// Beside a library term of the bias, a second one of another mechanism at a D of its
    /// own ([`Case::second`]): is each found when there are two?
    pub second_effect: bool,
    /// The temperature read through a sensor of 9 to 12 bits ([`CoarseReading`]): is the
    /// hidden effect found beside the reading's artefact?
    pub coarse_reading: bool,
    /// On the clean cases, a white-noise level that changes in time, not with temperature
    /// ([`NoiseInTime`]): is it told from `heteroscedastic`?
    pub noise_in_time: bool,
    /// After the clean cases, further effects outside the library ([`Kind::MORE_OUTSIDE`]):
    /// is structure of other kinds called `unexplained`?
    pub outside_kinds: bool,
}

impl Variant {
    /// The set's name with the variant's departures, for a caption: "mismatched set, two
    /// effects, coarse reading".
    pub fn describe(&self) -> String {
        let parts = [
            (self.other_shapes, "other shapes"),
            (self.effect_elsewhere, "effect elsewhere"),
            (self.logger, "logger artefacts"),
            (self.second_effect, "two effects"),
            (self.coarse_reading, "coarse reading"),
            (self.noise_in_time, "noise level in time"),
            (self.outside_kinds, "more effects outside the library"),
        ];
        let mut s = String::from("mismatched set");
        for (_, name) in parts.iter().filter(|p| p.0) {
            s.push_str(", ");
            s.push_str(name);
        }
        s
    }
}

/// What a hidden effect is driven by: the sensor's node, or with `elsewhere` the body's
/// other node for a library mechanism of the bias (the step in time and the (dT/dt)² term
/// outside the library stay on the sensor's node; sensor and noise terms act through the
/// reading and the noise).
fn effect_drive<'a>(tr: &'a Trajectory, hidden: &Hidden, elsewhere: bool) -> Cow<'a, Trajectory> {
    let moves = match hidden {
        Hidden::Library { term } => term.role() == Role::Bias,
        Hidden::Shaped { .. } => true,
        _ => false,
    };
    if elsewhere && moves {
        Cow::Owned(tr.at_other_node())
    } else {
        Cow::Borrowed(tr)
    }
}

/// [`build_case`] in a [`Variant`].
pub fn build_case_in(
    id: usize,
    kind: Kind,
    seed: u64,
    model: &PhysicsModel,
    variant: Variant,
) -> Result<Case, BenchError> {
    let mut case = draw_case(id, kind, seed, model, variant)?;
    if variant.noise_in_time && kind == Kind::Clean {
        let change = NoiseInTime::draw(seed, id);
        let c = &case.conditions;
        let tr = &case.trajectory;
        let scale = change.scale(&tr.t_s);
        case.recording.rate_dph =
            c.noise
                .generate(&base_bias(c, tr), Some(&scale), DT_S, c.seed_noise);
        case.noise_in_time = Some(change);
    }
    if variant.logger {
        let logger = Logger::draw(seed, id, case.conditions.chamber.duration_s);
        logger.apply(&mut case.recording, seed, id);
        case.logger = Some(logger);
    }
    Ok(case)
}

/// The hidden effect of one draw, at unit amplitude; `(lo, hi)` is the node's 5–95 % range.
fn draw_hidden(
    kind: Kind,
    other_shapes: bool,
    rng: &mut ChaCha8Rng,
    duration_s: f64,
    (lo, hi): (f64, f64),
) -> Hidden {
    let sign = if uni(rng, 0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
    match kind {
        Kind::Clean => Hidden::None,
        Kind::Library(f) => {
            // The form is drawn from a copy of the stream, so that the stream goes on
            // as the library twin's does (its retries included).
            let mut alt = rng.clone();
            let term = library_term(f, rng, lo, hi);
            match other_shapes
                .then(|| Shape::draw(f, &mut alt, lo, hi))
                .flatten()
            {
                Some(shape) => Hidden::Shaped { shape },
                None => Hidden::Library { term },
            }
        }
        Kind::Step => Hidden::Step {
            time_s: (duration_s * uni(rng, 0.2, 0.8)).round(),
            step_dph: sign,
        },
        Kind::RateSquared => Hidden::RateSquared { coeff: sign },
        Kind::BumpInTime => Hidden::BumpInTime {
            centre_s: (duration_s * uni(rng, 0.2, 0.8)).round(),
            width_s: log_uni(rng, 1200.0, 7200.0).round(),
            amplitude_dph: sign,
        },
        Kind::Telegraph => {
            // 3–8 switches on average over the record, exponential dwells (a Poisson
            // process), none closer than 10 min; at least two, so it is not one step.
            let mean = duration_s / uni(rng, 3.0, 8.0);
            let mut switches_s = Vec::new();
            let mut t = duration_s * uni(rng, 0.05, 0.25);
            while t < 0.95 * duration_s {
                switches_s.push(t.round());
                t += (-mean * (1.0 - uni(rng, 0.0, 1.0)).ln()).max(600.0);
            }
            if switches_s.len() < 2 {
                let last = switches_s.last().copied().unwrap_or(0.2 * duration_s);
                switches_s.push(((last + 0.95 * duration_s) / 2.0).round());
            }
            Hidden::Telegraph {
                switches_s,
                level_dph: sign,
            }
        }
        Kind::BumpInTemperature => {
            let range = (hi - lo).max(1.0);
            Hidden::BumpInTemperature {
                centre_c: lo + range * uni(rng, 0.2, 0.8),
                width_c: (range * uni(rng, 0.04, 0.12)).max(0.5),
                amplitude_dph: sign,
            }
        }
    }
}

/// [`build_case_in`] up to the recording as the gyro and its sensor make it.
fn draw_case(
    id: usize,
    kind: Kind,
    seed: u64,
    model: &PhysicsModel,
    variant: Variant,
) -> Result<Case, BenchError> {
    let other_shapes = variant.other_shapes;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id as u64);
    let target = uni(&mut rng, 3.0, 10.0);
    let mut fallback = None;
    for _ in 0..TRIES {
        let mut c = Conditions::draw(&mut rng);
        let tr = thermal::run(&c.chamber, &c.body, DT_S);
        let mut sorted = tr.node_c.clone();
        sorted.sort_by(f64::total_cmp);
        let q = |p: f64| sorted[((p * (sorted.len() - 1) as f64).round()) as usize];
        let (lo, hi) = (q(0.05), q(0.95));
        let unit = draw_hidden(kind, other_shapes, &mut rng, c.chamber.duration_s, (lo, hi));
        let coarse = match &unit {
            Hidden::Library {
                term: Term::TempQuantization { .. },
            } => None,
            _ => variant
                .coarse_reading
                .then(|| CoarseReading::draw(seed, id)),
        };
        let read = reading(&tr, &c, &unit, coarse);
        if kind == Kind::Clean {
            let stats = (0.0, 0.0, 0.0);
            let mut case = assemble(id, kind, c, unit, 0.0, 0.0, stats, tr, read, false);
            case.coarse = coarse;
            return Ok(case);
        }
        let prep = prepare(recording(id, &tr, vec![0.0; tr.t_s.len()], read.clone()))?;
        let Some(metric) = Metric::new(&prep, model, &c.noise)? else {
            continue;
        };
        let s1 = c.noise.sigma1(DT_S);
        match &unit {
            Hidden::Library {
                term: Term::Heteroscedastic { ref_c, .. },
            } => {
                let body = &tr.node_c[prep.range.clone()];
                let d_of = |k: f64| {
                    c.noise
                        .scale_detectability(body, k, *ref_c, prep.dt_s, prep.block)
                };
                let Some(k) = amplitude_at(target, d_of) else {
                    continue;
                };
                let xmax = tr
                    .node_c
                    .iter()
                    .map(|t| ((t - ref_c) / 30.0).powi(2))
                    .fold(0.0, f64::max);
                let h = unit.scaled(k);
                let d = hetero_d(&h, &tr, &prep, &c.noise).unwrap_or(f64::NAN);
                let stats = (d, 0.0, c.noise.white_sigma(DT_S) * k * xmax / s1);
                let mut case = assemble(id, kind, c, h, target, d, stats, tr, read, false);
                case.coarse = coarse;
                return Ok(case);
            }
            Hidden::Library {
                term: Term::SensorLag { .. } | Term::TempQuantization { .. },
            } => {
                // No amplitude: the noise level sets D (D is 1/k when every noise amplitude
                // is k times as large).
                let e = mean_effect(&unit, &tr, &c.bias, &read)?;
                let d_unit = metric.d(&prep, &e);
                if !(d_unit > 0.0 && d_unit.is_finite()) {
                    continue;
                }
                let k = d_unit / target;
                let (marg, span) = metric.marginal(&prep, &e);
                let peak = e.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let levels = [
                    c.noise.arw_dph_rt_h / PAPER_ARW,
                    c.noise.bias_instability_dph / PAPER_BI,
                ];
                let ok = levels.iter().all(|s| (0.1..=5.0).contains(&(s * k)));
                c.noise = c.noise.scaled(k);
                let stats = (marg / k, span, peak / (s1 * k));
                let mut case = assemble(
                    id,
                    kind,
                    c,
                    unit,
                    target,
                    d_unit / k,
                    stats,
                    tr,
                    read,
                    false,
                );
                case.coarse = coarse;
                if ok {
                    return Ok(case);
                }
                // Keep the last draw in case none brings the noise within 0.1–5× the paper's.
                fallback = Some(case);
                continue;
            }
            _ => {}
        }
        // D is linear in the amplitude: one ratio.
        let e = unit.bias_effect(&effect_drive(&tr, &unit, variant.effect_elsewhere));
        let d_unit = metric.d(&prep, &e);
        if !(d_unit > 0.0 && d_unit.is_finite()) {
            continue;
        }
        let a = target / d_unit;
        let (marg, span) = metric.marginal(&prep, &e);
        let peak = a * e.iter().fold(0.0f64, |m, v| m.max(v.abs())) / s1;
        let h = unit.scaled(a);
        let stats = (a * marg, span, peak);
        let second = match (variant.second_effect, kind) {
            (true, Kind::Library(first)) => {
                let second = second_effect(first, (seed, id), &tr, &prep, &metric, (lo, hi));
                c.bias.extend(second.as_ref().map(|s| s.0.clone()));
                second
            }
            _ => None,
        };
        let mut case = assemble(
            id,
            kind,
            c,
            h,
            target,
            a * d_unit,
            stats,
            tr,
            read,
            variant.effect_elsewhere,
        );
        case.second = second;
        case.coarse = coarse;
        return Ok(case);
    }
    fallback.ok_or_else(|| BenchError::Truth {
        path: format!("mismatched case {id}"),
        message: format!("no draw in {TRIES} reached detectability {target:.2}"),
    })
}

/// The mechanisms of the bias a second effect is drawn from: those with an amplitude.
const SECOND_FAMILIES: [Family; 7] = [
    Family::Warmup,
    Family::Aging,
    Family::ModeHop,
    Family::Backscatter,
    Family::Periodic,
    Family::Hysteresis,
    Family::GradientLag,
];

/// A second library term of the bias beside a case's `first` family: another mechanism of
/// [`SECOND_FAMILIES`], drawn from a stream of its own (so the case is otherwise its
/// single-effect twin) and scaled to a D of its own drawn in 3…10, on the sensor's node.
/// `None` when its D cannot be reached on these conditions.
fn second_effect(
    first: Family,
    (seed, id): (u64, usize),
    tr: &Trajectory,
    prep: &Prepared,
    metric: &Metric,
    (lo, hi): (f64, f64),
) -> Option<(Term, f64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5ec0_0d00_5ec0_0d00);
    rng.set_stream(id as u64);
    let pool: Vec<Family> = SECOND_FAMILIES
        .into_iter()
        .filter(|g| g.mechanism() != first.mechanism())
        .collect();
    let g = pool[(uni(&mut rng, 0.0, pool.len() as f64) as usize).min(pool.len() - 1)];
    let target = uni(&mut rng, 3.0, 10.0);
    let term = library_term(g, &mut rng, lo, hi);
    let e = contribution(&term, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s);
    let d_unit = metric.d(prep, &e);
    (d_unit > 0.0 && d_unit.is_finite()).then(|| (scale_amplitude(&term, target / d_unit), target))
}

/// The base bias on the sensor's node (Earth rate and Eq. (11)'s terms; with two effects,
/// the second's term), °/h per sample.
fn base_bias(c: &Conditions, tr: &Trajectory) -> Vec<f64> {
    let mut out = vec![0.0; tr.t_s.len()];
    for b in &c.bias {
        let v = contribution(b, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s);
        out.iter_mut().zip(&v).for_each(|(o, x)| *o += x);
    }
    out
}

/// The case with its recording: base bias and hidden effect on the sensor node, the noise
/// (its white part scaled by a hidden `heteroscedastic`), the reading.
#[allow(clippy::too_many_arguments)]
fn assemble(
    id: usize,
    kind: Kind,
    c: Conditions,
    hidden: Hidden,
    target_d: f64,
    d: f64,
    (marginal, energy_in_span, peak_over_sigma1): (f64, f64, f64),
    tr: Trajectory,
    read: Vec<f64>,
    elsewhere: bool,
) -> Case {
    let drive = effect_drive(&tr, &hidden, elsewhere);
    let effect_elsewhere = matches!(drive, Cow::Owned(_));
    let mut clean = hidden.bias_effect(&drive);
    drop(drive);
    clean
        .iter_mut()
        .zip(base_bias(&c, &tr))
        .for_each(|(o, x)| *o += x);
    let scale = match &hidden {
        Hidden::Library {
            term: t @ Term::Heteroscedastic { .. },
        } => Some(contribution(t, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s)),
        _ => None,
    };
    let rate = c
        .noise
        .generate(&clean, scale.as_deref(), DT_S, c.seed_noise);
    let recording = recording(id, &tr, rate, read);
    Case {
        id,
        kind,
        conditions: c,
        hidden,
        target_d,
        d,
        marginal,
        energy_in_span,
        peak_over_sigma1,
        effect_elsewhere,
        logger: None,
        second: None,
        coarse: None,
        noise_in_time: None,
        trajectory: tr,
        recording,
    }
}
