//! From a diagnosis to the board: each missing mechanism the diagnosis names becomes the
//! recursive compensation feature that carries its physics (`compensator_core::features`),
//! the LS-SVM is retrained on the augmented inputs, and both models are judged on data that
//! neither the diagnosis nor the training saw: a later recording of the same gyro
//! ([`train_and_score_on`]), or the later cycles of one recording ([`train_and_score`]).
//!
//! | mechanism (diagnosis) | feature on the board | role | why |
//! |---|---|---|---|
//! | `sensor_lag` τ | `temp_lead_c(tau_s=τ)`: T + τ·dT/dt | replaces T in the kernel | the body leads the late sensor by τ·dT/dt |
//! | `gradient_lag` τ | `temp_grad_lag_c_per_s(tau_s=τ)`: G, τ·dG/dt = −G + dT/dt | linear term | the bias is gain·G, a history [T, dT/dt] does not hold |
//! | `hysteresis` w | `temp_play_c(width_mc=1000·w)`: play operator p of width w | linear term | the bias is ∝ T − p, and the branch persists through holds, where dT/dt is 0 |
//! | `warmup` τ | `warmup_decay(tau_s=τ)`: e^(−t_on/τ) | linear term | the bias is amplitude·e^(−t/τ) from power-on |
//!
//! A physics term enters as a linear term beside the kernel (the partially linear LS-SVM,
//! `lssvm::solve::solve_partially_linear`), as the library defines it: linear in its
//! amplitude. As a kernel input instead, it would let the model move jointly through inputs
//! the single training cycle never visited (a warm-up state next to a hot ramp), and the
//! held-out cycles would pay for it.
//!
//! The other mechanisms get no feature, for a stated reason: `backscatter` and `mode_hop` are
//! functions of T, already an input (a narrower kernel may be needed, which the
//! cross-validation chooses); `periodic` and `aging` run in absolute time, which the board
//! cannot know from its inputs and which would not repeat after calibration;
//! `heteroscedastic` changes the noise, not the bias; `temp_quantization` is in the reading,
//! which the board shares: its remedy is to de-quantise the reading before the dT/dt
//! estimator, not a bias feature (not done here).
//!
//! Each model is judged with the same protocol ([`Protocol`]): σ and c by blocked
//! cross-validation on the training part's 100 s means, an LS-SVM on those means (exact, or fixed-size within the
//! board table's capacity), and the held-out 100 s stability of the compensated output (f64
//! on the host features clamped to the trained range as the board clamps them; the board's
//! f32 path for up to five features). The augmented model is adopted only when its
//! cross-validated error is lower than the base model's: the held-out data never decide.

use compensator_core::{Compensator, Feature, SensorLimits};
use indicatif::ProgressBar;

use rlg_diagnose::{Diagnosis, Finding};
use rlg_eval::metrics::stability::bias_stability_gapless_dph;
use rlg_io::recording::Recording;
use rlg_physics::{Mechanism, Term};
use rlg_train::dataset::{self, RecordingSelection};
use rlg_train::export;
use rlg_train::features;
use rlg_train::lssvm::sparse::train_fixed_size_partially_linear;
use rlg_train::lssvm::tune::{tune_partially_linear, CvPoint, Grid, Tuned, Validation};
use rlg_train::lssvm::Lssvm;
use rlg_train::model::{ModelFile, Provenance};
use rlg_train::protocol;

/// The paper's inputs, the base every augmentation starts from.
pub const BASE: [Feature; 2] = [Feature::TempC, Feature::TempRateCPerS];

/// How a feature enters the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// It replaces the temperature as a kernel input.
    ReplacesTemperature,
    /// It is a linear term beside the kernel.
    Linear,
}

/// What the close loop does with one finding.
#[derive(Clone, Debug, PartialEq)]
pub struct Suggestion {
    /// The diagnosed mechanism.
    pub mechanism: Mechanism,
    /// The feature that carries it, if any.
    pub feature: Option<Feature>,
    /// How it enters the model.
    pub role: Role,
    /// Why this feature, or why none.
    pub reason: String,
}

/// A model's inputs: the features and which of them are linear terms.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Inputs {
    /// The features, in table order.
    pub features: Vec<Feature>,
    /// Per feature, whether it is a linear term (else a kernel input).
    pub linear: Vec<bool>,
}

impl Inputs {
    /// The paper's [T, dT/dt], both kernel inputs.
    pub fn base() -> Inputs {
        Inputs {
            features: BASE.to_vec(),
            linear: vec![false; BASE.len()],
        }
    }

    /// The base inputs with `s` applied (a suggestion without a feature changes nothing).
    pub fn with(mut self, s: &Suggestion) -> Inputs {
        let Some(f) = s.feature else {
            return self;
        };
        if self.features.contains(&f) {
            return self;
        }
        match s.role {
            Role::ReplacesTemperature => {
                if let Some(d) = self.features.iter().position(|x| *x == Feature::TempC) {
                    self.features[d] = f;
                }
            }
            Role::Linear => {
                self.features.push(f);
                self.linear.push(true);
            }
        }
        self
    }

    /// `Display` forms, with ` (linear)` marking linear terms.
    pub fn describe(&self) -> Vec<String> {
        self.features
            .iter()
            .zip(&self.linear)
            .map(|(f, l)| {
                if *l {
                    format!("{f} (linear)")
                } else {
                    f.to_string()
                }
            })
            .collect()
    }
}

/// Rounds a positive parameter to the feature's integer unit (s or m°C), at least 1.
fn unit(v: f64) -> Option<u32> {
    (v.is_finite() && v > 0.0).then(|| v.round().clamp(1.0, f64::from(u32::MAX)) as u32)
}

/// The feature for a mechanism with its parameters (names of the physics library).
pub fn feature_for(mechanism: Mechanism, param: impl Fn(&str) -> Option<f64>) -> Suggestion {
    let s = |feature: Option<Feature>, reason: &str| Suggestion {
        mechanism,
        role: if mechanism == Mechanism::SensorLag {
            Role::ReplacesTemperature
        } else {
            Role::Linear
        },
        feature,
        reason: reason.to_string(),
    };
    // Each mechanism is either carried by a recursive board feature (the parameter it takes,
    // that parameter's scale to the feature's integer unit, the feature, why it is needed) or
    // not (why not).
    type Carrier = (&'static str, f64, fn(u32) -> Feature, &'static str);
    let carrier: Result<Carrier, &str> = match mechanism {
        Mechanism::SensorLag => Ok((
            "tau_s",
            1.0,
            |tau_s| Feature::TempLeadC { tau_s },
            "the body leads the late sensor reading by τ·dT/dt",
        )),
        Mechanism::GradientLag => Ok((
            "tau_s",
            1.0,
            |tau_s| Feature::TempGradLagCPerS { tau_s },
            "the bias follows the gradient lagged by τ, a history [T, dT/dt] does not hold",
        )),
        Mechanism::Hysteresis => Ok((
            "width_c",
            1000.0,
            |width_mc| Feature::TempPlayC { width_mc },
            "the heating or cooling branch persists through holds, where dT/dt is 0",
        )),
        Mechanism::Warmup => Ok((
            "tau_s",
            1.0,
            |tau_s| Feature::WarmupDecay { tau_s },
            "the transient decays as e^(−t/τ) from power-on",
        )),
        Mechanism::Backscatter | Mechanism::ModeHop => Err(
            "a function of T, already an input; cross-validation chooses the kernel width it needs",
        ),
        Mechanism::Periodic | Mechanism::Aging => Err(
            "runs in absolute time, which the board's inputs do not carry and which would not repeat after calibration",
        ),
        Mechanism::Heteroscedastic => Err("changes the noise, not the bias: nothing to compensate"),
        Mechanism::TempQuantization => Err(
            "the board reads the same rounded temperature: de-quantise the reading before the dT/dt estimator (not a bias feature)",
        ),
        Mechanism::EarthRate | Mechanism::StaticPoly | Mechanism::RateTerms => {
            Err("part of the paper's model, which [T, dT/dt] already carries")
        }
    };
    // A term driven by another node of the body (`node_lag_s`): the board's inputs carry
    // the sensor's temperature only, so say what the suggestion leaves out.
    let node = matches!(
        mechanism,
        Mechanism::Hysteresis | Mechanism::ModeHop | Mechanism::Backscatter
    )
    .then(|| param("node_lag_s"))
    .flatten()
    .filter(|v| *v != 0.0);
    if let Some(lag) = node {
        let side = if lag > 0.0 { "behind" } else { "ahead of" };
        let missing = format!(
            "driven by a node {:.0} s {side} the sensor, a temperature the board's inputs do \
             not carry (no lagged-temperature feature yet)",
            lag.abs()
        );
        if mechanism != Mechanism::Hysteresis {
            return s(None, &missing);
        }
        if let Ok((name, scale, feature, why)) = carrier {
            if let Some(u) = param(name).and_then(|v| unit(scale * v)) {
                return s(
                    Some(feature(u)),
                    &format!("{why}; on the sensor's T, but {missing}"),
                );
            }
        }
    }
    match carrier {
        Ok((name, scale, feature, why)) => match param(name).and_then(|v| unit(scale * v)) {
            Some(u) => s(Some(feature(u)), why),
            None => s(None, &format!("{mechanism} without a usable {name}")),
        },
        Err(why) => s(None, why),
    }
}

/// [`feature_for`] a diagnosis finding.
pub fn suggest(f: &Finding) -> Suggestion {
    feature_for(f.mechanism, |p| f.parameters.get(p).copied())
}

/// [`feature_for`] a true term (for the oracle comparison on simulated data).
pub fn suggest_from_term(t: &Term) -> Suggestion {
    let params = t.parameters();
    feature_for(t.mechanism(), |p| {
        params.iter().find(|(n, _)| n == p).map(|(_, v)| *v)
    })
}

/// The base inputs with the feature of every finding that has one (each feature once).
pub fn augmented_features(d: &Diagnosis) -> (Inputs, Vec<Suggestion>) {
    let suggestions: Vec<Suggestion> = d.findings.iter().map(suggest).collect();
    let inputs = suggestions.iter().fold(Inputs::base(), Inputs::with);
    (inputs, suggestions)
}

/// How the close loop trains and judges a feature set.
#[derive(Clone, Debug, PartialEq)]
pub struct Protocol {
    /// σ × c search grid.
    pub grid: Grid,
    /// Cross-validation of σ and c, and of whether an augmentation helps.
    pub validation: Validation,
    /// Support vectors (fixed-size LS-SVM), or exact with `None`.
    pub budget: Option<usize>,
    /// An augmented model is adopted only when its CV RMS is below the base model's by this
    /// fraction.
    pub adopt_margin: f64,
}

impl Default for Protocol {
    /// The project's cross-validation ([`protocol::CV`], as the paper reproduction and the
    /// default table use), the board table's capacity, a 2 % margin. (Contiguous folds,
    /// `Validation::Contiguous`, were measured on the benchmark too: they choose smoother
    /// models and adopt fewer augmentations, with the same median outcome.)
    fn default() -> Self {
        Protocol {
            grid: Grid::default(),
            validation: protocol::CV,
            budget: Some(protocol::SUPPORT_VECTORS),
            adopt_margin: 0.02,
        }
    }
}

impl Protocol {
    /// Whether `aug` is adopted over `base`: cross-validated, never by the held-out data.
    pub fn adopts(&self, base: &Scored, aug: &Scored) -> bool {
        aug.inputs != base.inputs && aug.cv_rms_dph < (1.0 - self.adopt_margin) * base.cv_rms_dph
    }
}

/// One feature set trained on the training part and judged on the rest.
#[derive(Clone, Debug)]
pub struct Scored {
    /// The inputs.
    pub inputs: Inputs,
    /// σ, c and the CV evidence.
    pub tuned: Tuned,
    /// The σ of the model: the tuned one, or the best-scoring one the board's f32 budget
    /// allows.
    pub sigma: f64,
    /// The c of the model (as σ).
    pub c: f64,
    /// The cross-validated RMS of the model at that (σ, c), °/h (what adoption compares).
    pub cv_rms_dph: f64,
    /// Largest |board f32 − model f64| over the trained range, °/h.
    pub board_deviation_dph: f64,
    /// The model (LS-SVM on the training part's 100 s means, exact or within the budget).
    pub model: ModelFile,
    /// TRAINING rms on those means, °/h.
    pub train_rms_dph: f64,
    /// HELD-OUT 100 s stability of the output compensated in f64 on the host features, °/h.
    pub test_b100_dph: f64,
    /// First held-out sample (the training part is the samples before it).
    pub test_from: usize,
    /// The f64 model's correction at each held-out sample, °/h (what `test_b100_dph`
    /// subtracts from the recorded rate).
    pub test_correction_dph: Vec<f64>,
    /// The same through the board's f32 `Compensator` (up to five features), °/h.
    pub board_b100_dph: Option<f64>,
}

/// A model trained and its (σ, c) chosen, not yet judged.
struct Fitted {
    tuned: Tuned,
    point: CvPoint,
    model: ModelFile,
    board_deviation_dph: f64,
    dt_s: f64,
}

/// Trains on the samples of `rec` up to `train_to_s` with `inputs`; `provenance` names the
/// recording and the command in the model file. With a budget, the model is the fixed-size
/// LS-SVM of at most that many support vectors (the board table's capacity), with the σ and
/// c cross-validated for the exact one.
fn fit(
    rec: &Recording,
    train_to_s: f64,
    inputs: &Inputs,
    protocol: &Protocol,
    provenance: &Provenance,
) -> anyhow::Result<Fitted> {
    let (grid, budget) = (&protocol.grid, protocol.budget);
    let (feats, linear) = (&inputs.features, &inputs.linear);
    let sel = RecordingSelection {
        from_s: None,
        to_s: Some(train_to_s),
        block: protocol::TRAIN_BLOCK,
        rate_tau_s: protocol::RATE_TAU_S,
    };
    let data = dataset::from_recording_with(rec, &sel, feats)?;
    let tuned = tune_partially_linear(
        &data.features,
        &data.x,
        &data.y_dph,
        linear,
        &protocol.validation,
        grid,
        &ProgressBar::hidden(),
    )?;
    let train = |sigma: f64, c: f64| -> anyhow::Result<ModelFile> {
        let lssvm = match budget {
            Some(m) if data.x.len() > m => train_fixed_size_partially_linear(
                &data.features,
                &data.x,
                &data.y_dph,
                sigma,
                c,
                m,
                linear,
            )?,
            _ => Lssvm::train_partially_linear(
                &data.features,
                &data.x,
                &data.y_dph,
                sigma,
                c,
                linear,
            )?,
        };
        Ok(ModelFile::from_trained(
            lssvm,
            &data.x,
            &data.y_dph,
            protocol::RATE_TAU_S,
            data.dt_s,
            None,
            provenance.clone(),
        )?)
    };
    // The board must evaluate the model within its f32 budget: large cancelling
    // coefficients (a large c on a wide kernel) lose it. The chosen (σ, c) is the tuned one
    // if the board can evaluate it, else the best-scoring evaluated point it can.
    let mut candidates: Vec<CvPoint> = std::iter::once(CvPoint {
        sigma: tuned.sigma,
        c: tuned.c,
        cv_rms_dph: tuned.cv_rms_dph,
    })
    .chain(tuned.curve.iter().chain(&tuned.refined).copied())
    .filter(|p| p.cv_rms_dph.is_finite())
    .collect();
    candidates[1..].sort_by(|a, b| a.cv_rms_dph.total_cmp(&b.cv_rms_dph));
    let mut chosen = None;
    for p in candidates {
        let Ok(model) = train(p.sigma, p.c) else {
            continue;
        };
        let dev = export::f32_deviation_dph(&model)?;
        if dev <= export::F32_BUDGET_DPH {
            chosen = Some((p, model, dev));
            break;
        }
    }
    let (point, model, board_deviation_dph) = chosen.ok_or_else(|| {
        anyhow::anyhow!(
            "no (sigma, c) of the grid gives a model the board evaluates within {:.0e} °/h",
            export::F32_BUDGET_DPH
        )
    })?;
    Ok(Fitted {
        tuned,
        point,
        model,
        board_deviation_dph,
        dt_s: data.dt_s,
    })
}

/// Trains on the samples up to `train_to_s` with `inputs` and scores the rest of the same
/// recording (see [`train_and_score_on`]).
pub fn train_and_score(
    rec: &Recording,
    train_to_s: f64,
    inputs: &Inputs,
    protocol: &Protocol,
    provenance: &Provenance,
) -> anyhow::Result<Scored> {
    let fitted = fit(rec, train_to_s, inputs, protocol, provenance)?;
    let split = rec.time_s.partition_point(|t| *t <= train_to_s);
    judge(fitted, inputs, rec, split)
}

/// Trains on all of `calibration` with `inputs` and scores all of `test`: a later recording
/// of the same gyro, which the training (and any diagnosis of `calibration`) never saw.
pub fn train_and_score_on(
    calibration: &Recording,
    test: &Recording,
    inputs: &Inputs,
    protocol: &Protocol,
    provenance: &Provenance,
) -> anyhow::Result<Scored> {
    let end = calibration.time_s.last().copied().unwrap_or(f64::NAN);
    let fitted = fit(calibration, end, inputs, protocol, provenance)?;
    judge(fitted, inputs, test, 0)
}

/// Scores a fitted model on the samples of `rec` from `split` on.
fn judge(fitted: Fitted, inputs: &Inputs, rec: &Recording, split: usize) -> anyhow::Result<Scored> {
    let Fitted {
        tuned,
        point,
        model,
        board_deviation_dph,
        dt_s,
    } = fitted;
    let feats = &inputs.features;
    let (sigma, c, cv_rms_dph) = (point.sigma, point.c, point.cv_rms_dph);
    let series = features::compute(feats, &rec.temp_c, &rec.time_s, protocol::RATE_TAU_S, dt_s)?;
    anyhow::ensure!(
        rec.len() >= split + 2 * protocol::TRAIN_BLOCK,
        "less than two 100 s windows after the training part"
    );
    // Inputs clamped into the trained range, as the board clamps them.
    let test_correction_dph: Vec<f64> = (split..rec.len())
        .map(|k| {
            let x: Vec<f64> = series.rows[k]
                .iter()
                .zip(model.input_lo.iter().zip(&model.input_hi))
                .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
                .collect();
            model.correction_dph(&x)
        })
        .collect();
    let host: Vec<f64> = rec.rate_dph[split..]
        .iter()
        .zip(&test_correction_dph)
        .map(|(r, c)| r - c)
        .collect();
    let test_b100_dph =
        bias_stability_gapless_dph(&rec.time_s[split..], &host, protocol::TRAIN_BLOCK)
            .unwrap_or(f64::NAN);
    let board_b100_dph = match feats.len() {
        2 => board_b100::<2>(rec, split, &model)?,
        3 => board_b100::<3>(rec, split, &model)?,
        4 => board_b100::<4>(rec, split, &model)?,
        5 => board_b100::<5>(rec, split, &model)?,
        _ => None,
    };
    Ok(Scored {
        inputs: inputs.clone(),
        sigma,
        c,
        cv_rms_dph,
        board_deviation_dph,
        train_rms_dph: model.training.rms_dph,
        tuned,
        model,
        test_b100_dph,
        test_from: split,
        test_correction_dph,
        board_b100_dph,
    })
}

/// The board's f32 path over the whole record, 100 s stability from `split` on.
fn board_b100<const D: usize>(
    rec: &Recording,
    split: usize,
    model: &ModelFile,
) -> anyhow::Result<Option<f64>> {
    let t = export::to_f32::<D>(model)?;
    let mut comp = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
    anyhow::ensure!(comp.table_ok(), "exported table fails validation");
    let out: Vec<f64> = (0..rec.len())
        .map(|k| {
            f64::from(
                comp.update(rec.temp_c[k] as f32, rec.rate_dph[k] as f32)
                    .rate_dph,
            )
        })
        .collect();
    Ok(bias_stability_gapless_dph(
        &rec.time_s[split..],
        &out[split..],
        protocol::TRAIN_BLOCK,
    ))
}

/// The end of the first temperature cycle, s: the paper's training span.
pub fn first_cycle_end_s(rec: &Recording) -> anyhow::Result<f64> {
    let cycles = rlg_io::cycles::cycle_spans(&rec.time_s, &rec.temp_c);
    anyhow::ensure!(
        cycles.len() >= 2,
        "the recording has {} temperature cycle(s); holding one out needs at least two (or give the training span)",
        cycles.len()
    );
    Ok(cycles[0].1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_library_mechanism_has_a_decision() {
        let p = |name: &str| (name != "node_lag_s").then_some(300.0);
        assert_eq!(
            feature_for(Mechanism::SensorLag, p).feature,
            Some(Feature::TempLeadC { tau_s: 300 })
        );
        assert_eq!(
            feature_for(Mechanism::GradientLag, p).feature,
            Some(Feature::TempGradLagCPerS { tau_s: 300 })
        );
        assert_eq!(
            feature_for(Mechanism::Hysteresis, |_| Some(2.5)).feature,
            Some(Feature::TempPlayC { width_mc: 2500 })
        );
        assert_eq!(
            feature_for(Mechanism::Warmup, p).feature,
            Some(Feature::WarmupDecay { tau_s: 300 })
        );
        for m in [
            Mechanism::Backscatter,
            Mechanism::ModeHop,
            Mechanism::Periodic,
            Mechanism::Aging,
            Mechanism::Heteroscedastic,
            Mechanism::TempQuantization,
            Mechanism::EarthRate,
            Mechanism::StaticPoly,
            Mechanism::RateTerms,
        ] {
            let s = feature_for(m, p);
            assert!(s.feature.is_none() && !s.reason.is_empty(), "{m}");
        }
        assert!(feature_for(Mechanism::SensorLag, |_| Some(f64::NAN))
            .feature
            .is_none());
        assert!(feature_for(Mechanism::Hysteresis, |_| Some(-1.0))
            .feature
            .is_none());
        // Another node's mechanism: the sensor's play with what it leaves out named, and no
        // feature for a hop or a ripple of a lagged node.
        let lagged = |name: &str| Some(if name == "node_lag_s" { 1600.0 } else { 2.5 });
        let h = feature_for(Mechanism::Hysteresis, lagged);
        assert_eq!(h.feature, Some(Feature::TempPlayC { width_mc: 2500 }));
        assert!(h.reason.contains("1600 s behind"), "{}", h.reason);
        let b = feature_for(Mechanism::Backscatter, lagged);
        assert!(
            b.feature.is_none() && b.reason.contains("1600 s behind"),
            "{}",
            b.reason
        );
        // The true term's parameters reach the same mapping.
        let t = Term::Hysteresis {
            width_c: 4.0,
            height_dph: 1e-3,
            node_lag_s: 0.0,
        };
        let s = suggest_from_term(&t);
        assert_eq!(s.feature, Some(Feature::TempPlayC { width_mc: 4000 }));
        // Roles: the play state is a linear term; the lead-corrected T replaces T.
        let i = Inputs::base().with(&s);
        assert_eq!(i.linear, [false, false, true]);
        let lag = Inputs::base().with(&feature_for(Mechanism::SensorLag, p));
        assert_eq!(
            lag.features,
            [Feature::TempLeadC { tau_s: 300 }, Feature::TempRateCPerS]
        );
        assert_eq!(lag.linear, [false, false]);
    }
}
