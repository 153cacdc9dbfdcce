//! Conditions put beside a case's hidden effect by two variants of the set, each drawn from a
//! stream of its own so that the case is otherwise its default twin:
//!
//! * a coarse temperature reading ([`CoarseReading`]): real chamber rigs read the gyro's
//!   body through sensors of 9 to 12 bits (0.5 … 0.0625 °C), and the reading's quantum is an
//!   artefact the diagnosis should name as such and then go on to the physics beside it;
//! * a white-noise level that changes in time and not with temperature
//!   ([`NoiseInTime`]): a laser current or a readout drifting over the run, or a
//!   disturbance that starts part way; it is not `heteroscedastic`, a noise level that
//!   follows the temperature.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::uni;

/// A reading rounded to a sensor's coarse quantum, °C.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CoarseReading {
    /// The quantum, °C.
    pub quantum_c: f64,
}

impl CoarseReading {
    /// The quanta of 12-, 11-, 10- and 9-bit digital temperature sensors, °C.
    const QUANTA_C: [f64; 4] = [0.0625, 0.125, 0.25, 0.5];

    /// Case `id`'s quantum, from its own stream.
    pub(super) fn draw(seed: u64, id: usize) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xc0a5_e0c0_a5e0_c0a5);
        rng.set_stream(id as u64);
        let n = Self::QUANTA_C.len();
        let k = (uni(&mut rng, 0.0, n as f64) as usize).min(n - 1);
        Self {
            quantum_c: Self::QUANTA_C[k],
        }
    }
}

/// How the white noise's σ moves in time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeForm {
    /// Linear from 1 at the start to the ratio at the end.
    Drift,
    /// 1 until a time, the ratio after it.
    Step,
    /// 1, then the ratio over a middle stretch of the run, then 1 again.
    Episode,
}

/// A white-noise level that changes in time, not with temperature.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NoiseInTime {
    /// Its form.
    pub form: TimeForm,
    /// σ at its most changed over σ at the start (0.5 … 0.67 or 1.5 … 2.5).
    pub ratio: f64,
    /// Where the step or the episode starts, as a share of the run.
    pub from: f64,
    /// Where the episode ends, as a share of the run.
    pub to: f64,
}

impl NoiseInTime {
    /// Case `id`'s change, from its own stream.
    pub(super) fn draw(seed: u64, id: usize) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7e17_0a5e_7e17_0a5e);
        rng.set_stream(id as u64);
        let form = match (uni(&mut rng, 0.0, 3.0) as usize).min(2) {
            0 => TimeForm::Drift,
            1 => TimeForm::Step,
            _ => TimeForm::Episode,
        };
        let up = uni(&mut rng, 1.5, 2.5);
        let ratio = if uni(&mut rng, 0.0, 1.0) < 0.3 {
            1.0 / up.min(2.0)
        } else {
            up
        };
        let from = uni(&mut rng, 0.2, 0.6);
        let to = from + uni(&mut rng, 0.15, 0.35);
        Self {
            form,
            ratio,
            from,
            to,
        }
    }

    /// The white noise's multiplier at each time of `t_s`.
    pub(super) fn scale(&self, t_s: &[f64]) -> Vec<f64> {
        let (t0, t1) = match (t_s.first(), t_s.last()) {
            (Some(&a), Some(&b)) if b > a => (a, b),
            _ => return vec![1.0; t_s.len()],
        };
        t_s.iter()
            .map(|t| {
                let x = (t - t0) / (t1 - t0);
                match self.form {
                    TimeForm::Drift => 1.0 + (self.ratio - 1.0) * x,
                    TimeForm::Step if x >= self.from => self.ratio,
                    TimeForm::Episode if (self.from..self.to).contains(&x) => self.ratio,
                    _ => 1.0,
                }
            })
            .collect()
    }

    /// One phrase for the case's description.
    pub(super) fn describe(&self) -> String {
        match self.form {
            TimeForm::Drift => format!("white σ drifting to {:.2}× over the run", self.ratio),
            TimeForm::Step => format!(
                "white σ {:.2}× from {:.0} % of the run",
                self.ratio,
                100.0 * self.from
            ),
            TimeForm::Episode => format!(
                "white σ {:.2}× from {:.0} to {:.0} % of the run",
                self.ratio,
                100.0 * self.from,
                100.0 * self.to
            ),
        }
    }
}
