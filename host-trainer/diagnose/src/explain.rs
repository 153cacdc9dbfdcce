//! The plain-words explanation of a finding.

use super::candidates::Family;
use super::{Figures, Finding};

/// Plain-words explanation of `finding` (its own `explanation` aside), a term of family `f`
/// significant below the ΔBIC threshold `thr` on means of `block_s`; `before` are the model's
/// held-out figures.
pub(super) fn explain(
    f: Family,
    finding: &Finding,
    (thr, block_s): (f64, f64),
    before: &Figures,
) -> String {
    let (p, u, dbic) = (&finding.parameters, &finding.uncertainty, finding.delta_bic);
    let (after, where_) = (&finding.improved, &finding.where_);
    let pu = |k: &str| {
        format!(
            "{k} = {:.4} ± {:.2}",
            p.get(k).copied().unwrap_or(f64::NAN),
            u.get(k).copied().unwrap_or(f64::NAN)
        )
    };
    let mech = match f {
        Family::SensorLag => format!("the temperature sensor lags the gyro body ({}); the model, driven by the late reading, misplaces every temperature-dependent bias during ramps", pu("tau_s")),
        Family::GradientLag => format!("a bias follows the rate of temperature change through a thermal lag ({}, {} °/h per °C/s): it persists after each ramp ends", pu("tau_s"), pu("gain")),
        Family::Hysteresis => format!("the bias differs between heating and cooling at the same temperature ({}, {} °/h)", pu("width_c"), pu("height_dph")),
        Family::Warmup => format!("a transient decays after power-on ({} °/h, {})", pu("amplitude_dph"), pu("tau_s")),
        Family::ModeHop => format!("the bias steps by {} °/h when the temperature crosses {} °C ({} °C switching hysteresis)", pu("step_dph"), pu("temp_c"), pu("hysteresis_c")),
        Family::Backscatter => format!("a ripple periodic in temperature ({}, {} °/h), as backscatter/lock-in varies with cavity length", pu("period_c"), pu("amplitude_dph")),
        Family::Periodic => format!("a ripple periodic in time ({}, {} °/h), an external disturbance", pu("period_s"), pu("amplitude_dph")),
        Family::Aging => format!("the bias drifts linearly in time ({} °/h per day)", pu("rate_dph_per_day")),
        Family::Heteroscedastic => format!("the 1 Hz white noise grows away from {} °C as 1 + k·((T − ref)/30)² ({}); the mean model is unchanged, so the RMS and 100 s stability below are too, and the BIC adds the held-out gain of the block log-variance model", pu("ref_c"), pu("k")),
        Family::TempQuantization => format!("the temperature reading is rounded to {} °C, read from the recorded values; driven by the staircase, the model sees false temperature steps and dT/dt spikes, which the reconstructed (de-quantised) temperature removes", pu("step_c")),
    };
    // A term of another node of the body (`node_lag_s`, zero on the reading's own node): the
    // engineer needs to know the model's temperature input is not where the effect lives.
    let mech = match p.get("node_lag_s").copied().filter(|l| *l != 0.0) {
        Some(l) if l > 0.0 => format!(
            "{mech}, on a node of the body lagging the temperature reading by {l:.0} s (a \
             first-order lag of the reading)"
        ),
        Some(l) => format!(
            "{mech}, on a node of the body leading the temperature reading by {:.0} s (T + {:.0} \
             s·dT/dt, the node the reading lags)",
            -l, -l
        ),
        None => mech,
    };
    let wh = match where_.first() {
        Some(w) => format!(
            " The effect is largest in {} span(s), the first {:.0}–{:.0} s ({}, {:.1}–{:.1} °C).",
            where_.len(),
            w.t_start_s,
            w.t_end_s,
            w.phase,
            w.temp_lo_c,
            w.temp_hi_c
        ),
        None => String::new(),
    };
    format!(
        "{}: {mech}. Adding it changes the BIC of the whitened {block_s:.0} s means by {dbic:.1} (significance threshold {thr:.1} from the noise-model bootstrap); on held-out data the 100 s stability goes from {:.2e} to {:.2e} °/h and the BIC from {:.1} to {:.1}.{wh}",
        f.name(),
        before.b100_dph,
        after.b100_dph,
        before.bic,
        after.bic
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    fn words(lag: Option<f64>) -> String {
        let mut p = BTreeMap::from([
            ("period_c".to_string(), 25.0),
            ("amplitude_dph".to_string(), 2e-3),
        ]);
        if let Some(l) = lag {
            p.insert("node_lag_s".to_string(), l);
        }
        let fig = Figures {
            rms_dph: 1e-2,
            b100_dph: 1e-3,
            bic: -100.0,
        };
        let finding = Finding {
            mechanism: Family::Backscatter.mechanism(),
            parameters: p,
            uncertainty: BTreeMap::new(),
            where_: Vec::new(),
            delta_bic: -9.0,
            improved: fig.clone(),
            explanation: String::new(),
            close_alternatives: Vec::new(),
        };
        explain(Family::Backscatter, &finding, (-3.0, 100.0), &fig)
    }

    /// The text says when the finding lives on another node than the reading's, and which
    /// way: the JSON's `node_lag_s` alone was easy to miss.
    #[test]
    fn a_finding_on_another_node_says_so() {
        assert!(!words(None).contains("node of the body"));
        assert!(!words(Some(0.0)).contains("node of the body"));
        let behind = words(Some(800.0));
        assert!(
            behind.contains("lagging the temperature reading by 800 s"),
            "{behind}"
        );
        let ahead = words(Some(-400.0));
        assert!(
            ahead.contains("leading the temperature reading by 400 s"),
            "{ahead}"
        );
    }
}
