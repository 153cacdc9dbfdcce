//! Thermal-chamber RLG simulator: a scenario (chamber profile, thermal constants, physics
//! terms, noise) and a seed give a recording and its ground truth.
//!
//! Deterministic: one ChaCha8 stream consumed sequentially, fixed output formats, so the same
//! scenario and seed give byte-identical files on every machine.

pub mod figure;
pub mod noise;
pub mod scenario;
pub mod shipped;
pub mod thermal;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub use noise::{NoiseGen, NoiseParams};
pub use scenario::{Scenario, ScenarioError, Segment};
pub use thermal::{Thermal, ThermalParams, ThermalSample};

use rlg_io::recording::{write_atomic, Recording, RecordingError};
use rlg_physics::{Drive, Role, TermStep};

/// Ground truth of one run, written beside the recording as `<name>.truth.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// The scenario as run (every term with its parameters, the noise parameters).
    pub scenario: Scenario,
    /// RNG seed.
    pub seed: u64,
    /// Gauss–Markov correlation times of the bias-instability bank, s.
    pub gm_tau_s: Vec<f64>,
    /// Common steady-state σ of the Gauss–Markov processes, °/h.
    pub gm_sigma_dph: f64,
    /// True body/cavity temperature T_c at each recorded sample, °C.
    pub body_c: Vec<f64>,
    /// dT_c/dt at each recorded sample, °C/s.
    pub dbody_c_per_s: Vec<f64>,
    /// Noise-free bias (sum of the bias terms), °/h.
    pub bias_dph: Vec<f64>,
}

/// A simulated recording and its truth.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// What the gyro and its sensor would have recorded.
    pub recording: Recording,
    /// What really happened.
    pub truth: Truth,
}

/// Runs `scenario` with `seed`. Samples start at power-on and are `sample_period_s` apart.
pub fn simulate(scenario: &Scenario, seed: u64) -> Result<Simulation, ScenarioError> {
    scenario.validate()?;
    let dt = scenario.sample_period_s;
    let pieces = scenario.pieces();
    let duration = scenario.duration();
    let mut thermal = Thermal::new(&scenario.thermal, scenario.start_c);
    let mut noise = NoiseGen::new(&scenario.noise, seed);
    let (gm_tau_s, gm_sigma_dph) = scenario.noise.gauss_markov_bank();

    // Warm the chamber up to power-on with the gyro off (integer steps, no float drift).
    let n_off = (scenario.power_on_s / dt).round() as u64;
    for k in 1..=n_off {
        let t = k as f64 * dt;
        thermal.step(
            scenario::setpoint_at(&pieces, scenario.start_c, t),
            false,
            dt,
        );
    }
    let n = ((duration - n_off as f64 * dt) / dt).floor() as usize + 1;
    let mut rec = Recording {
        time_s: Vec::with_capacity(n),
        rate_dph: Vec::with_capacity(n),
        temp_c: Vec::with_capacity(n),
        chamber_c: Some(Vec::with_capacity(n)),
        comments: vec![
            format!(" rlg simulate: scenario `{}`, seed {seed}", scenario.name),
            format!(" host-trainer {}", env!("CARGO_PKG_VERSION")),
        ],
        ..Default::default()
    };
    let (mut body_c, mut dbody, mut bias_v) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut steps: Vec<TermStep> = Vec::new();
    for i in 0..n {
        let t = (n_off as usize + i) as f64 * dt;
        let sp = scenario::setpoint_at(&pieces, scenario.start_c, t);
        // The first recorded sample is the power-on instant: the thermal state as it was,
        // before self-heating starts.
        let th = if i == 0 {
            thermal.current(false)
        } else {
            thermal.step(sp, true, dt)
        };
        let d = Drive {
            t_s: t,
            temp_c: th.body_c,
            dtemp_c_per_s: th.dbody_c_per_s,
        };
        if i == 0 {
            steps = scenario
                .terms
                .iter()
                .map(|term| TermStep::new(term, &d))
                .collect();
        }
        let (mut bias, mut sensor, mut scale) = (0.0, th.body_c, 1.0);
        for st in &mut steps {
            match st.term().role() {
                Role::Bias => bias += st.step(&d, sensor),
                Role::Sensor => sensor = st.step(&d, sensor),
                Role::NoiseScale => scale *= st.step(&d, sensor),
            }
        }
        let noisy = bias + noise.step(dt, scale);
        let out = noise.quantise(noisy, dt);
        rec.time_s.push(t);
        rec.rate_dph.push(out);
        rec.temp_c.push(sensor);
        if let Some(c) = rec.chamber_c.as_mut() {
            c.push(th.air_c);
        }
        body_c.push(th.body_c);
        dbody.push(th.dbody_c_per_s);
        bias_v.push(bias);
    }
    let truth = Truth {
        scenario: scenario.clone(),
        seed,
        gm_tau_s,
        gm_sigma_dph,
        body_c,
        dbody_c_per_s: dbody,
        bias_dph: bias_v,
    };
    Ok(Simulation {
        recording: rec,
        truth,
    })
}

/// The sidecar path of a recording: `rec.csv` → `rec.truth.json`.
pub fn truth_path(csv_path: &Path) -> PathBuf {
    let stem = csv_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    csv_path.with_file_name(format!("{stem}.truth.json"))
}

/// Writes the recording to `csv_path` and the truth to its sidecar, both atomically.
pub fn write_simulation(sim: &Simulation, csv_path: &Path) -> Result<(), RecordingError> {
    sim.recording.write_csv(csv_path)?;
    let tp = truth_path(csv_path);
    let json = serde_json::to_vec(&sim.truth).map_err(|e| RecordingError::Io {
        path: tp.display().to_string(),
        source: std::io::Error::other(e),
    })?;
    write_atomic(&tp, &json)
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod calibration_tests;
