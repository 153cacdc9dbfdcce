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
    /// noise is 6× lower. A reading rounded to `quantum_c` is [`dequantise`]d for the slope:
    /// τ would otherwise carry its rounding into T_c as a lagging sensor of its own, which a
    /// gradient's lag fits better than the sensor's true τ does.
    pub fn unlagged(
        &self,
        tau_s: f64,
        dt_s: f64,
        quantum_c: Option<f64>,
    ) -> Result<DriveSeries, DiagnoseError> {
        let deq = quantum_c.map(|q| self.dequantised_temp(q, dt_s));
        let slope = local_slope(
            deq.as_deref().unwrap_or(&self.temp_c),
            &self.t_s,
            dt_s,
            UNLAG_HALF_WIDTH_S,
        );
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
        let temp = self.dequantised_temp(step_c, dt_s);
        let rate = estimate_rate(&temp, &self.t_s, dt_s)?;
        Ok(DriveSeries {
            t_s: self.t_s.clone(),
            temp_c: temp,
            dtemp_c_per_s: rate,
        })
    }

    /// The recorded temperature [`dequantise`]d at `step_c`, each run between gaps on its
    /// own: across a gap the reading's change is not a crossing half a sample earlier, and
    /// interpolating over it made a steep ramp out of the gap's whole change.
    fn dequantised_temp(&self, step_c: f64, dt_s: f64) -> Vec<f64> {
        let mut temp = Vec::with_capacity(self.temp_c.len());
        for (lo, hi) in gapless_runs(&self.t_s[..self.temp_c.len()], dt_s) {
            temp.extend(dequantise(&self.temp_c[lo..=hi], step_c));
        }
        temp
    }
}

/// Half-width of the least-squares slope that un-lags the temperature, s.
const UNLAG_HALF_WIDTH_S: f64 = 45.0;

#[cfg(test)]
mod tests {
    use super::super::dequantise::read_quantum;
    use super::*;

    /// A body whose temperature steps 15 °C every 3 h through a first-order response
    /// (τ 2 000 s), read at 1 Hz by a sensor 300 s behind it and rounded to 0.01 °C:
    /// what `unlagged` must add to the reading (the body less the unrounded late reading),
    /// and the reading.
    fn lagged_staircase() -> (Vec<f64>, DriveSeries) {
        let (n, dt, tau_body, tau_sensor) = (6 * 3600 * 3, 1.0, 2000.0, 300.0);
        let t_s: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let (mut body, mut sensor) = (vec![0.0; n], vec![0.0; n]);
        let (mut b, mut s) = (20.0_f64, 20.0_f64);
        for i in 0..n {
            let set = 20.0 + 15.0 * ((i / (3 * 3600)) % 4) as f64;
            b += (set - b) * (1.0 - (-dt / tau_body).exp());
            s += (b - s) * (1.0 - (-dt / tau_sensor).exp());
            body[i] = b - s;
            sensor[i] = (s / 0.01).round() * 0.01;
        }
        let rate = estimate_rate(&sensor, &t_s, dt).expect("rate");
        let reading = DriveSeries {
            t_s,
            temp_c: sensor,
            dtemp_c_per_s: rate,
        };
        (body, reading)
    }

    /// What un-lagging a rounded reading adds to it (τ times its slope) has a fraction of
    /// the error that τ times the slope of the rounded steps has (the rounding's own lagging
    /// sensor).
    #[test]
    fn a_rounded_reading_is_unlagged_without_its_rounding() {
        let (lead_true, reading) = lagged_staircase();
        let u = reading
            .unlagged(300.0, 1.0, read_quantum(&reading.temp_c))
            .expect("unlags");
        let raw_slope = local_slope(&reading.temp_c, &reading.t_s, 1.0, UNLAG_HALF_WIDTH_S);
        let n = lead_true.len();
        // Away from the first lag's start, where the reading has no history yet.
        let rms = |f: &dyn Fn(usize) -> f64| {
            let sq: f64 = (600..n).map(|i| (f(i) - lead_true[i]).powi(2)).sum();
            (sq / (n - 600) as f64).sqrt()
        };
        let ours = rms(&|i| u.temp_c[i] - reading.temp_c[i]);
        let rounded = rms(&|i| lead(reading.temp_c[i], 300.0, raw_slope[i]) - reading.temp_c[i]);
        assert!(
            ours < 0.6 * rounded,
            "rms {ours:.2e} against {rounded:.2e} °C"
        );
    }
}
