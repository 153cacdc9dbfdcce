//! The paper's Eq. (11): the stepwise-regression bias model, coefficients verbatim.
//!
//! B = −0.00960 + 7.1445e-4·T − 2.6387e-5·T² + 2.1772e-7·T³ + 2.1572·Ṫ − 4.2769e3·Ṫ³
//!     + 1.9163e-5·T·Ṫ,   B in °/h, T body temperature in °C, Ṫ = dT/dt in **°C/s**.
//!
//! The paper does not state the unit of dT/dt; °C/s is the only reading that gives a
//! physical bias. For the 1 °C/min ramps of its dynamic test (Ṫ = ±1/60 °C/s) the Ṫ terms
//! contribute ±0.0162 °/h (0.032 °/h between up- and down-ramps) and the T terms vary by
//! 0.011 °/h over 10 … 65 °C — the 0.01–0.04 °/h scale of its Figs. 3–5 and of its raw
//! 100 s stability (0.0102 °/h). Read in °C/min, the Ṫ³ term alone would be −4277 °/h at
//! 1 °C/min. The cubic in Ṫ peaks at |Ṫ| = √(2.1572/(3·4276.9)) = 0.0130 °C/s (0.78 °C/min),
//! so it must not be used beyond the ~1 °C/min range it was fitted on.
//! The constant −0.00960 °/h is the room-temperature calibration term, so B is the bias
//! deviation relative to the calibrated bias (Earth rate excluded).

use crate::paper::eq11::{RATE_CUBIC, RATE_LINEAR, STATIC_POLY_DPH, TEMP_RATE};

/// Constant term, °/h (room-temperature calibration).
pub const INTERCEPT_DPH: f64 = STATIC_POLY_DPH[0];

/// The six retained terms of Eq. (11), named as in [`super::stepwise::PAPER_TERMS`], with
/// their coefficients in °/h per unit of the term (T in °C, dT/dt in °C/s).
pub const TERMS: [(&str, f64); 6] = [
    ("T", STATIC_POLY_DPH[1]),
    ("T^2", STATIC_POLY_DPH[2]),
    ("T^3", STATIC_POLY_DPH[3]),
    ("dT/dt", RATE_LINEAR),
    ("(dT/dt)^3", RATE_CUBIC),
    ("T*dT/dt", TEMP_RATE),
];

/// Eq. (11): bias in °/h at body temperature `temp_c` (°C) and rate `dtdt_c_per_s` (°C/s).
pub fn bias_dph(temp_c: f64, dtdt_c_per_s: f64) -> f64 {
    let (t, r) = (temp_c, dtdt_c_per_s);
    let v = [t, t * t, t * t * t, r, r * r * r, t * r];
    INTERCEPT_DPH + TERMS.iter().zip(v).map(|((_, c), x)| c * x).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::baselines::stepwise::{paper_candidates, LinearFit, PAPER_TERMS};

    /// Hand-evaluated: T = 25 °C, Ṫ = 0 → −0.0096 + 0.01786125 − 0.016491875 + 0.003401875
    /// = −0.00482875 °/h; Ṫ = 1/60 °C/s adds 2.1572/60 − 4276.9/216000 + 1.9163e-5·25/60
    /// = 0.0359533 − 0.0198005 + 0.0000080 = 0.0161609 °/h.
    #[test]
    fn matches_hand_evaluation() {
        assert!((bias_dph(25.0, 0.0) - -0.00482875).abs() < 1e-12);
        let d = bias_dph(25.0, 1.0 / 60.0) - bias_dph(25.0, 0.0);
        assert!((d - 0.0161609).abs() < 1e-7, "{d}");
    }

    /// The unit decision: with Ṫ in °C/s the variation over 10 … 65 °C and ±1 °C/min is of
    /// the paper's 0.01–0.04 °/h order; in °C/min it would be thousands of °/h.
    #[test]
    fn dtdt_unit_is_celsius_per_second() {
        let temps: Vec<f64> = (0..=550).map(|i| 10.0 + 0.1 * i as f64).collect();
        let range = |rates: &[f64]| {
            let v: Vec<f64> = temps
                .iter()
                .flat_map(|&t| rates.iter().map(move |&r| bias_dph(t, r)))
                .collect();
            v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
        };
        let temp_only = range(&[0.0]);
        let ramp_split = bias_dph(37.5, 1.0 / 60.0) - bias_dph(37.5, -1.0 / 60.0);
        assert!((0.005..0.04).contains(&temp_only), "{temp_only}");
        assert!((0.01..0.04).contains(&ramp_split), "{ramp_split}");
        assert!(range(&[-1.0, 1.0]) > 1000.0);
    }

    /// The term names are the stepwise builder's, and a LinearFit holding Eq. (11) predicts
    /// the same values as [`bias_dph`] from the paper's candidate columns.
    #[test]
    fn terms_agree_with_stepwise_candidates() {
        let t = [10.0, 30.0, 65.0];
        let r = [0.01, -0.005, 1.0 / 60.0];
        let fit = LinearFit {
            terms: TERMS.iter().map(|(n, _)| n.to_string()).collect(),
            intercept: INTERCEPT_DPH,
            intercept_std_err: 0.0,
            coefficients: TERMS.iter().map(|(_, c)| *c).collect(),
            std_errors: vec![0.0; 6],
            residuals: vec![],
            rss: 0.0,
            dof: 0,
        };
        assert!(TERMS.iter().all(|(n, _)| PAPER_TERMS.contains(n)));
        let p = fit.predict(&paper_candidates(&t, &r).unwrap()).unwrap();
        for i in 0..3 {
            assert!((p[i] - bias_dph(t[i], r[i])).abs() < 1e-15);
        }
    }
}
