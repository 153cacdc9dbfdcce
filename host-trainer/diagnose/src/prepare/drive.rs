//! The series that drive the model: the recorded temperature and its dT/dt, and the same
//! with the reading's lag or rounding undone where the model says the sensor has them.

use super::dequantise::dequantise;
use super::rate::{estimate_rate, gapless_runs, local_slope};
use crate::DiagnoseError;
use compensator_core::physics::lead;

/// Driving series at the recording's rate.
#[derive(Clone, Debug)]
pub struct DriveSeries {
    /// s.
    pub t_s: Vec<f64>,
    /// Temperature driving the model, °C.
    pub temp_c: Vec<f64>,
    /// dT/dt from the estimator, °C/s.
    pub dtemp_c_per_s: Vec<f64>,
}

impl DriveSeries {
    /// The drive as it would be if the recorded temperature lagged the body by `tau_s`
    /// (τ·dT_s/dt = T_c − T_s, so T_c = T_s + τ·dT_s/dt exactly); dT_c/dt by the same
    /// centred difference over the corrected series.
    ///
    /// The dT_s/dt that τ multiplies is the least-squares slope over ±45 s
    /// ([`local_slope`]), not the ±30 s centred difference: τ amplifies the derivative's
    /// noise, and with 0.01 °C readings the difference of a quantised staircase put
    /// τ·7e-5 °C/s (0.03 °C at τ = 400 s) into T_c and four times that into dT_c/dt. That
    /// regressor noise pulls the fitted lag low, most where it is longest (by several percent
    /// at high signal-to-noise, where without quantisation the fit is unbiased). The slope's
    /// noise is 6× lower.
    pub fn unlagged(&self, tau_s: f64, dt_s: f64) -> Result<DriveSeries, DiagnoseError> {
        let slope = local_slope(&self.temp_c, &self.t_s, dt_s, UNLAG_HALF_WIDTH_S);
        let temp: Vec<f64> = self
            .temp_c
            .iter()
            .zip(&slope)
            .map(|(t, r)| lead(*t, tau_s, *r))
            .collect();
        let rate = estimate_rate(&temp, &self.t_s, dt_s)?;
        Ok(DriveSeries {
            t_s: self.t_s.clone(),
            temp_c: temp,
            dtemp_c_per_s: rate,
        })
    }

    /// The drive as it would be had the temperature not been rounded to multiples of
    /// `step_c`: [`dequantise`] the recorded series (each run between gaps on its own), then
    /// dT/dt by the same centred difference.
    pub fn dequantised(&self, step_c: f64, dt_s: f64) -> Result<DriveSeries, DiagnoseError> {
        // Run by run: across a gap the reading's change is not a crossing half a sample
        // earlier, and interpolating over it made a steep ramp out of the gap's whole change.
        let mut temp = Vec::with_capacity(self.temp_c.len());
        for (lo, hi) in gapless_runs(&self.t_s[..self.temp_c.len()], dt_s) {
            temp.extend(dequantise(&self.temp_c[lo..=hi], step_c));
        }
        let rate = estimate_rate(&temp, &self.t_s, dt_s)?;
        Ok(DriveSeries {
            t_s: self.t_s.clone(),
            temp_c: temp,
            dtemp_c_per_s: rate,
        })
    }
}

/// Half-width of the least-squares slope that un-lags the temperature, s.
const UNLAG_HALF_WIDTH_S: f64 = 45.0;
