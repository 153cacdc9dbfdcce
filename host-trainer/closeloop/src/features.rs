//! Findings to board features: which recursive feature carries each mechanism, and the
//! inputs a diagnosis adds to the paper's [T, dT/dt].

use compensator_core::Feature;

use rlg_diagnose::{Diagnosis, Finding};
use rlg_physics::{Mechanism, Term};

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
