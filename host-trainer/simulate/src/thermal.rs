//! Chamber and gyro thermal model: air follows the setpoint, the body follows the air plus
//! self-heating, both through first-order lags discretised exactly.

use serde::{Deserialize, Serialize};

use rlg_physics::FirstOrderLag;

/// Thermal constants.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalParams {
    /// Chamber air lag behind the setpoint, s.
    pub air_tau_s: f64,
    /// Gyro body lag behind (air + self-heating), s.
    pub body_tau_s: f64,
    /// Settled body − air with the gyro on, at 0 °C air, °C.
    pub self_heating_c: f64,
    /// Change of the self-heating per °C of air temperature, °C/°C.
    #[serde(default)]
    pub self_heating_per_c: f64,
}

impl ThermalParams {
    /// Checks the time constants (≥ 0) and finiteness.
    pub fn validate(&self) -> Result<(), String> {
        let ok = self.air_tau_s >= 0.0
            && self.body_tau_s >= 0.0
            && [
                self.air_tau_s,
                self.body_tau_s,
                self.self_heating_c,
                self.self_heating_per_c,
            ]
            .iter()
            .all(|v| v.is_finite());
        if ok {
            Ok(())
        } else {
            Err(format!(
                "thermal constants must be finite with τ ≥ 0: {self:?}"
            ))
        }
    }

    /// Settled body − air at air temperature `air_c` with the gyro on, °C.
    pub fn self_heating_at(&self, air_c: f64) -> f64 {
        self.self_heating_c + self.self_heating_per_c * air_c
    }
}

/// Running thermal state.
#[derive(Clone, Debug)]
pub struct Thermal {
    params: ThermalParams,
    air: FirstOrderLag,
    body: FirstOrderLag,
}

/// Temperatures at one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThermalSample {
    /// Chamber air, °C.
    pub air_c: f64,
    /// Gyro body/cavity T_c, °C.
    pub body_c: f64,
    /// dT_c/dt, °C/s (exact for the lag: (input − T_c)/τ).
    pub dbody_c_per_s: f64,
}

impl Thermal {
    /// Settled at `start_c` with the gyro off (body = air = setpoint).
    pub fn new(params: &ThermalParams, start_c: f64) -> Self {
        Self {
            params: params.clone(),
            air: FirstOrderLag::new(start_c),
            body: FirstOrderLag::new(start_c),
        }
    }

    /// dT_c/dt of the body at `body_c` driven by `input_c` (air plus self-heating), °C/s:
    /// (input − T_c)/τ, exact for the lag; 0 without one.
    fn body_rate(&self, input_c: f64, body_c: f64) -> f64 {
        if self.params.body_tau_s > 0.0 {
            (input_c - body_c) / self.params.body_tau_s
        } else {
            0.0
        }
    }

    /// The present state without advancing, the gyro powered when `on`.
    pub fn current(&self, on: bool) -> ThermalSample {
        let air = self.air.y;
        let heat = if on {
            self.params.self_heating_at(air)
        } else {
            0.0
        };
        let body = self.body.y;
        let d = self.body_rate(air + heat, body);
        ThermalSample {
            air_c: air,
            body_c: body,
            dbody_c_per_s: d,
        }
    }

    /// Advances by `dt_s` to setpoint `setpoint_c`, the gyro powered when `on`.
    pub fn step(&mut self, setpoint_c: f64, on: bool, dt_s: f64) -> ThermalSample {
        let air = self.air.step(setpoint_c, dt_s, self.params.air_tau_s);
        let heat = if on {
            self.params.self_heating_at(air)
        } else {
            0.0
        };
        let u = air + heat;
        let body = self.body.step(u, dt_s, self.params.body_tau_s);
        let d = self.body_rate(u, body);
        ThermalSample {
            air_c: air,
            body_c: body,
            dbody_c_per_s: d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A long soak settles the body at air + self-heating (the Table 1 offsets' model), and
    /// on a long ramp of rate r the body lags by (τ_air + τ_body)·r (two cascaded lags),
    /// less the self-heating slope's share, with dT/dt → r·(1 + self_heating_per_c).
    #[test]
    fn soak_and_ramp_match_closed_forms() {
        let p = ThermalParams {
            air_tau_s: 300.0,
            body_tau_s: 1200.0,
            self_heating_c: 4.8,
            self_heating_per_c: -0.0137,
        };
        let mut th = Thermal::new(&p, -40.0);
        let mut s = th.step(-40.0, true, 1.0);
        for _ in 0..40_000 {
            s = th.step(-40.0, true, 1.0);
        }
        assert!((s.body_c - (-40.0 + 4.8 + 0.0137 * 40.0)).abs() < 1e-9);
        let r = 1.0 / 60.0;
        let mut sp = -40.0;
        for _ in 0..30_000 {
            sp += r;
            s = th.step(sp, true, 1.0);
        }
        let k = 1.0 + p.self_heating_per_c;
        // Air lags by τ_a·r; body input = k·air + c lags τ_b·k·r more.
        let air = sp - 300.0 * r;
        let body = k * air + 4.8 - 1200.0 * k * r;
        assert!((s.air_c - air).abs() < 1e-6, "{} {}", s.air_c, air);
        assert!((s.body_c - body).abs() < 1e-6, "{} {}", s.body_c, body);
        assert!((s.dbody_c_per_s - k * r).abs() < 1e-9);
    }
}
