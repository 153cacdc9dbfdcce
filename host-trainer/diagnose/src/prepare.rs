//! From a recording and a physics model to the series the diagnosis fits: the driving series
//! (recorded temperature, dT/dt from the board's estimator), 100 s block means, and the
//! baseline model's columns (each linear parameter's unit contribution, computed by the
//! shared physics library).

use std::borrow::Cow;
use std::path::Path;

use serde::de::IgnoredAny;
use serde::{Deserialize, Serialize};

use super::DiagnoseError;
use compensator_core::physics::lead;
use rlg_eval::metrics::block_means;
use rlg_io::faults::{sensor_faults, FaultLimits, SensorFaults};
use rlg_io::recording::Recording;
use rlg_physics::{contribution, Mechanism, Role, Term};

/// Length of the averaging blocks, s (the paper's 100 s means).
pub const BLOCK_S: f64 = 100.0;

/// A physics model: the terms with initial parameters (TOML `[[terms]]`, as in scenarios;
/// `rlg terms` lists the kinds).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhysicsModel {
    /// Short name.
    #[serde(default)]
    pub name: String,
    /// The terms.
    pub terms: Vec<Term>,
}

/// The paper's model: Earth rate, cubic static polynomial and the rate terms of Eq. (11).
pub const PAPER_MODEL_TOML: &str = include_str!("../../models/paper.toml");

/// What a model file may hold: a model's keys, and the other keys of a scenario file
/// (`rlg simulate`'s input), which are ignored so that a scenario serves as the model of the
/// physics it simulates. Any other key stays an error that names it. The ignored keys are
/// checked against the scenario's fields by a test.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    #[serde(default)]
    name: String,
    terms: Vec<Term>,
    #[serde(default, rename = "sample_period_s")]
    _sample_period_s: IgnoredAny,
    #[serde(default, rename = "power_on_s")]
    _power_on_s: IgnoredAny,
    #[serde(default, rename = "duration_s")]
    _duration_s: IgnoredAny,
    #[serde(default, rename = "start_c")]
    _start_c: IgnoredAny,
    #[serde(default, rename = "thermal")]
    _thermal: IgnoredAny,
    #[serde(default, rename = "profile")]
    _profile: IgnoredAny,
    #[serde(default, rename = "noise")]
    _noise: IgnoredAny,
}

impl PhysicsModel {
    /// Reads a model file (`--model`): a model, or a scenario whose `[[terms]]` are taken
    /// (see [`PhysicsModel::from_toml`]). Errors name the path.
    pub fn read(path: &Path) -> Result<Self, DiagnoseError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| DiagnoseError::Model {
            origin: origin.clone(),
            message: format!("cannot read the file: {e}"),
        })?;
        Self::from_toml(&text, &origin)
    }

    /// Parses a model from TOML text; `origin` names it in errors. The text is a model
    /// (`name`, `[[terms]]`) or a scenario file, of which only `name` and `[[terms]]` are
    /// read; a key that is neither a model's nor a scenario's is refused by name.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, DiagnoseError> {
        let f: ModelFile = toml::from_str(text).map_err(|e| DiagnoseError::Model {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        let m = PhysicsModel {
            name: f.name,
            terms: f.terms,
        };
        for t in &m.terms {
            t.validate().map_err(|message| DiagnoseError::Model {
                origin: origin.to_string(),
                message,
            })?;
        }
        Ok(m)
    }

    /// The paper's model (see [`PAPER_MODEL_TOML`]).
    pub fn paper() -> Self {
        // The embedded file is checked by a unit test, so this cannot fail at run time.
        Self::from_toml(PAPER_MODEL_TOML, "models/paper.toml").unwrap_or(PhysicsModel {
            name: "paper".into(),
            terms: Vec::new(),
        })
    }

    /// Whether the model holds a term of this mechanism.
    pub fn has(&self, m: Mechanism) -> bool {
        self.terms.iter().any(|t| t.mechanism() == m)
    }
}

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
    /// regressor noise pulls the fitted lag low, most where it is longest (measured at ten
    /// times the benchmark's detectability: −3 % on average, down to −14 %; +1 % without
    /// quantisation). The slope's noise is 6× lower.
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

/// The quantum of a temperature reading, °C, read from the recorded values: the 5th
/// percentile of the non-zero sample-to-sample changes, kept only if at least 95 % of all
/// non-zero changes are whole multiples of it (within 5 %) and it is above 1e-4 °C (the
/// CSV's resolution). `None`: the reading shows no quantum (a continuous or dithered sensor).
pub fn read_quantum(temp_c: &[f64]) -> Option<f64> {
    let mut d: Vec<f64> = temp_c
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|v| *v > 5e-5)
        .collect();
    if d.len() < 20 {
        return None;
    }
    d.sort_by(f64::total_cmp);
    let q = d[d.len() / 20];
    if q < 1e-4 {
        return None;
    }
    let whole = d
        .iter()
        .filter(|v| {
            let r = *v / q;
            (r - r.round()).abs() < 0.05
        })
        .count();
    // Rounded to the CSV's 1e-4 °C so that the same quantum reads the same on every record.
    (whole as f64 >= 0.95 * d.len() as f64).then(|| (q * 1e4).round() / 1e4)
}

/// Reconstructs a temperature rounded to multiples of `step_c`: where the reading changes
/// from one level to the next, the true temperature crossed the boundary between them half
/// a sample earlier; the reconstruction interpolates linearly between those crossings. Where
/// a level is left the way it was entered (the temperature turned inside it, e.g. a hold),
/// the crossings bound an excursion into that level: the reconstruction rises to the level's
/// centre within the shorter of half the excursion and the time the last crossing took, and
/// stays there. Before the first and after the last crossing it holds the reading.
///
/// Written here because it is the inverse of the physics library's own quantiser; a general
/// interpolation crate would not know where the boundaries are.
pub fn dequantise(temp_c: &[f64], step_c: f64) -> Vec<f64> {
    let n = temp_c.len();
    let mut out = temp_c.to_vec();
    if n < 2 || step_c.is_nan() || step_c <= 0.0 {
        return out;
    }
    // Knots (sample position, temperature) at each crossing.
    let mut knots: Vec<(f64, f64)> = Vec::new();
    for i in 1..n {
        let (a, b) = (temp_c[i - 1], temp_c[i]);
        if (b - a).abs() > 0.5 * step_c {
            let x = i as f64 - 0.5;
            // A jump over several levels in one sample: crossings spread over the sample.
            knots.push((x, 0.5 * (a + b)));
        }
    }
    if knots.is_empty() {
        return out;
    }
    // Excursions: consecutive crossings of the same boundary; add the level's centre.
    let mut full: Vec<(f64, f64)> = Vec::with_capacity(knots.len() * 2);
    for k in 0..knots.len() {
        full.push(knots[k]);
        if let Some(&(x1, v1)) = knots.get(k + 1) {
            let (x0, v0) = knots[k];
            if (v1 - v0).abs() < 0.5 * step_c {
                let level = temp_c[(x0.ceil() as usize).min(n - 1)];
                let prev = if k > 0 { x0 - knots[k - 1].0 } else { x1 - x0 };
                let ramp = (0.5 * (x1 - x0)).min(prev.max(1.0));
                full.push((x0 + ramp, level));
                if x1 - ramp > x0 + ramp {
                    full.push((x1 - ramp, level));
                }
            }
        }
    }
    let mut k = 0;
    for (i, o) in out.iter_mut().enumerate() {
        let x = i as f64;
        if x < full[0].0 || x > full[full.len() - 1].0 {
            continue;
        }
        while k + 1 < full.len() && full[k + 1].0 < x {
            k += 1;
        }
        let (x0, v0) = full[k];
        let (x1, v1) = full.get(k + 1).copied().unwrap_or(full[k]);
        *o = if x1 > x0 {
            v0 + (v1 - v0) * (x - x0) / (x1 - x0)
        } else {
            v0
        };
    }
    out
}

/// Half-width of the least-squares slope that un-lags the temperature, s.
const UNLAG_HALF_WIDTH_S: f64 = 45.0;

/// The runs of samples with no gap between them, as inclusive index ranges: a gap is a step
/// longer than 1.5 sample periods (the reader's rule, `rlg_io` reports them). A window of
/// samples that spans a gap would mix times far apart as if they were `dt_s` apart.
fn gapless_runs(t_s: &[f64], dt_s: f64) -> Vec<(usize, usize)> {
    let n = t_s.len();
    let mut runs = Vec::new();
    let mut lo = 0;
    for i in 1..n {
        if t_s[i] - t_s[i - 1] > 1.5 * dt_s {
            runs.push((lo, i - 1));
            lo = i;
        }
    }
    if n > 0 {
        runs.push((lo, n - 1));
    }
    runs
}

/// Least-squares slope of `x` (samples `dt_s` apart, time stamps `t_s`) over a window of
/// ±`half_width_s` around each sample, truncated at the ends and at gaps (one-sided next to
/// them); 0 for a single sample. O(n) by prefix sums. (The Savitzky–Golay first derivative
/// of order 1 and 2; a dozen lines, so not a crate.)
fn local_slope(x: &[f64], t_s: &[f64], dt_s: f64, half_width_s: f64) -> Vec<f64> {
    let n = x.len();
    let h = ((half_width_s / dt_s).round() as usize).max(1);
    let x0 = x.first().copied().unwrap_or(0.0);
    // Prefix sums of (x − x₀) and i·(x − x₀); x₀ keeps the sums small.
    let (mut s, mut si) = (vec![0.0; n + 1], vec![0.0; n + 1]);
    for (i, v) in x.iter().enumerate() {
        s[i + 1] = s[i] + (v - x0);
        si[i + 1] = si[i] + i as f64 * (v - x0);
    }
    let mut out = Vec::with_capacity(n);
    for (lo, hi) in gapless_runs(&t_s[..n], dt_s) {
        out.extend((lo..=hi).map(|i| {
            let (a, b) = (i.saturating_sub(h).max(lo), (i + h).min(hi));
            let m = (b - a + 1) as f64;
            if m < 2.0 {
                return 0.0;
            }
            let kbar = 0.5 * (a + b) as f64;
            let sx = s[b + 1] - s[a];
            let sxi = si[b + 1] - si[a];
            // Σ(k − k̄)² over m consecutive integers.
            let skk = m * (m * m - 1.0) / 12.0;
            (sxi - kbar * sx) / skk / dt_s
        }));
    }
    out
}

/// Half-width of the centred difference that estimates dT/dt, s.
pub const RATE_HALF_WIDTH_S: f64 = 30.0;

/// dT/dt by a centred difference over ±30 s (one-sided at the ends and next to gaps), °C/s.
///
/// Not the board's causal α-β estimator (`compensator_core::RateEstimator`): on the body's
/// curved temperature at the ends of each ramp that estimator lags by an amount ∝ d²T/dt²,
/// and through the rate terms (2.16 °/h per °C/s) this lag is itself a model mismatch — on a
/// simulated recording with nothing hidden it scored ΔBIC −30 as a "sensor lag". The
/// diagnosis tests the physics, which is written in the true dT/dt; the centred difference
/// has no phase lag, and with 0.01 °C readings its noise is 0.01/60/√6 ≈ 7e-5 °C/s per
/// sample, 0.2 % of a 1 °C/min ramp, before the 100 s averaging.
pub fn estimate_rate(temp_c: &[f64], t_s: &[f64], dt_s: f64) -> Result<Vec<f64>, DiagnoseError> {
    let n = temp_c.len();
    if let Some(i) = temp_c.iter().chain(t_s).position(|v| !v.is_finite()) {
        return Err(DiagnoseError::NonFinite {
            index: i % n.max(1),
        });
    }
    let runs = gapless_runs(&t_s[..n], dt_s);
    // The mean step; across gaps it would count the gaps' time, so the period given.
    let dt = if runs.len() > 1 {
        dt_s
    } else if n > 1 {
        (t_s[n - 1] - t_s[0]) / (n - 1) as f64
    } else {
        1.0
    };
    let h = ((RATE_HALF_WIDTH_S / dt).round() as usize).max(1);
    let mut out = Vec::with_capacity(n);
    for (lo, hi) in runs {
        // Never across a gap: a difference over it is the chord of what the gap hides.
        out.extend((lo..=hi).map(|i| {
            let (a, b) = (i.saturating_sub(h).max(lo), (i + h).min(hi));
            if b > a {
                (temp_c[b] - temp_c[a]) / (t_s[b] - t_s[a])
            } else {
                0.0
            }
        }));
    }
    Ok(out)
}

/// The sample period of time stamps: the mean step, unless gaps make it differ from the
/// median step by more than 1 % (a long gap would otherwise pass for a slow sample rate and
/// the blocks would span hours).
fn sample_period(time_s: &[f64]) -> f64 {
    let n = time_s.len();
    let mean_step = (time_s[n - 1] - time_s[0]) / (n - 1) as f64;
    let mut steps: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let median_step = steps[steps.len() / 2];
    if (mean_step / median_step - 1.0).abs() > 0.01 {
        median_step
    } else {
        mean_step
    }
}

/// The recording prepared for fitting.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// Sample period, s.
    pub dt_s: f64,
    /// Samples per block.
    pub block: usize,
    /// The drive (starting after the estimator's warm-up), whole blocks only.
    pub drive: DriveSeries,
    /// Recorded rate over the same samples, °/h.
    pub rate_dph: Vec<f64>,
    /// The drive over the whole recording (the estimator's warm-up included).
    pub full_drive: DriveSeries,
    /// The samples of `full_drive` that `drive` holds.
    pub range: std::ops::Range<usize>,
    /// Block means of the rate, °/h.
    pub y_b: Vec<f64>,
    /// Block means of time (s), temperature (°C), dT/dt (°C/s).
    pub t_b: Vec<f64>,
    /// °C.
    pub temp_b: Vec<f64>,
    /// °C/s.
    pub dtemp_b: Vec<f64>,
    /// Temperature samples dropped as sensor faults before anything else
    /// ([`rlg_io::faults::sensor_faults`]).
    pub faults: SensorFaults,
    /// Set when the record was sampled in bursts and each burst reduced to its mean
    /// ([`find_bursts`]).
    pub bursts: Option<Bursts>,
}

impl Prepared {
    /// Number of blocks.
    pub fn nb(&self) -> usize {
        self.y_b.len()
    }

    /// The drive un-lagged by `tau_s` (see [`DriveSeries::unlagged`]), computed over the
    /// whole recording so the estimator's warm-up falls outside the fitted samples.
    pub fn drive_unlagged(&self, tau_s: f64) -> Result<DriveSeries, DiagnoseError> {
        Ok(self.fitted_part(self.full_drive.unlagged(tau_s, self.dt_s)?))
    }

    /// The fitted samples of a drive over the whole recording, cut in place: a month's
    /// drive is 60 MB, and a copy would double it while both live.
    pub fn fitted_part(&self, mut full: DriveSeries) -> DriveSeries {
        let r = self.range.clone();
        for v in [&mut full.t_s, &mut full.temp_c, &mut full.dtemp_c_per_s] {
            v.truncate(r.end);
            v.drain(..r.start);
        }
        full
    }

    /// The drive de-quantised at `step_c` (see [`DriveSeries::dequantised`]), computed over
    /// the whole recording.
    pub fn drive_dequantised(&self, step_c: f64) -> Result<DriveSeries, DiagnoseError> {
        Ok(self.fitted_part(self.full_drive.dequantised(step_c, self.dt_s)?))
    }

    /// Block means of a per-sample series.
    pub fn blocks(&self, x: &[f64]) -> Vec<f64> {
        block_means(x, self.block)
    }

    /// Block means of [`baseline_columns`] on `drive`, one column at a time: a month's
    /// record then holds one 20 MB per-sample column, not one per linear parameter.
    pub fn baseline_blocks(&self, model: &PhysicsModel, drive: &DriveSeries) -> Vec<Vec<f64>> {
        baseline_specs(model)
            .iter()
            .map(|(_, unit)| self.blocks(&baseline_values(unit.as_ref(), drive)))
            .collect()
    }

    /// The recorded rate less `beta` times [`baseline_columns`] on `drive`, per sample, the
    /// columns computed one at a time (the bits of the sum over all of them at once).
    pub fn baseline_residual(
        &self,
        model: &PhysicsModel,
        drive: &DriveSeries,
        beta: &[f64],
    ) -> Vec<f64> {
        let mut fit = vec![0.0; self.rate_dph.len()];
        for ((_, unit), b) in baseline_specs(model).iter().zip(beta) {
            if *b != 0.0 {
                let c = baseline_values(unit.as_ref(), drive);
                fit.iter_mut().zip(&c).for_each(|(o, v)| *o += b * v);
            }
        }
        self.rate_dph.iter().zip(&fit).map(|(a, f)| a - f).collect()
    }
}

/// Most samples a diagnosis takes (46 days at 1 Hz): its per-sample series then stay within
/// about 1.2 GB (measured at 45 days; 30 days take 0.8 GB).
pub const MAX_SAMPLES: usize = 4_000_000;

/// Minimum number of 100 s blocks for a diagnosis (about 5.5 h).
pub const MIN_BLOCKS: usize = 200;

/// Most blocks a diagnosis works on (4.6 days of 100 s blocks). A longer record is averaged
/// over longer blocks, whole multiples of [`BLOCK_S`], so that the work on block means (the
/// scan, the bootstrap, the noise fit) and the periodic grid, whose resolution follows the
/// record's length, stay bounded: time and memory then grow with the record only through the
/// per-sample columns. Slow effects keep their power (a 30-day record in 700 s blocks still
/// has 3 700 of them); effects faster than a block were already beyond 100 s means.
pub const MAX_BLOCKS: usize = 4000;

/// A record sampled in bursts (a logger that wakes every few minutes for a few seconds at
/// tens of Hz, as MEMS thermal logs are made): how many, and their typical shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bursts {
    /// Number of bursts.
    pub count: usize,
    /// Median samples per burst.
    pub samples: usize,
    /// Median duration of a burst, s.
    pub length_s: f64,
    /// Median time from one burst's start to the next's, s.
    pub period_s: f64,
}

impl Bursts {
    /// The note the diagnosis gives.
    pub fn describe(&self) -> String {
        format!(
            "the record is sampled in bursts ({} of about {} samples over {:.1} s, one every \
             {:.0} s): each burst is reduced to its mean (time, rate, temperature) and the \
             diagnosis runs on the burst means; the noise-scale test, which needs several \
             samples within a block, is not run",
            self.count, self.samples, self.length_s, self.period_s
        )
    }
}

/// The runs of a record sampled in bursts, or `None` for a record sampled throughout (gaps
/// and all). Runs are split at steps over [`BURST_GAP`] times the median step (not the
/// reader's 1.5: a logger's time stamps jitter within a burst, and a burst split in two would
/// be two means a fraction of a second apart). A record is taken as burst-sampled when it has at least [`MIN_BLOCKS`] runs, its median
/// run lasts under half a block ([`BLOCK_S`]) and runs start at least twice their length
/// apart: in 100 s blocks of consecutive samples each block would then span many bursts
/// and hours (a day of 5 s bursts at 1 Hz every 2 min gave 38 blocks, too few to diagnose).
/// A record with dropouts has runs of hours and stays as it is.
pub fn find_bursts(time_s: &[f64]) -> Option<(Vec<std::ops::Range<usize>>, Bursts)> {
    let n = time_s.len();
    if n < 3 {
        return None;
    }
    let median = |mut v: Vec<f64>| -> f64 {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let step = median(time_s.windows(2).map(|w| w[1] - w[0]).collect());
    let mut runs = Vec::new();
    let mut start = 0;
    for i in 1..n {
        if time_s[i] - time_s[i - 1] > BURST_GAP * step {
            runs.push(start..i);
            start = i;
        }
    }
    runs.push(start..n);
    if runs.len() < MIN_BLOCKS {
        return None;
    }
    let length_s = median(
        runs.iter()
            .map(|r| time_s[r.end - 1] - time_s[r.start] + step)
            .collect(),
    );
    let period_s = median(
        runs.windows(2)
            .map(|w| time_s[w[1].start] - time_s[w[0].start])
            .collect(),
    );
    if length_s >= 0.5 * BLOCK_S || period_s < 2.0 * length_s {
        return None;
    }
    let mut sizes: Vec<usize> = runs.iter().map(|r| r.len()).collect();
    sizes.sort_unstable();
    let b = Bursts {
        count: runs.len(),
        samples: sizes[sizes.len() / 2],
        length_s,
        period_s,
    };
    Some((runs, b))
}

/// A step between bursts is at least this many median steps.
const BURST_GAP: f64 = 10.0;

/// The recording of one sample per run of `runs`: the means of its time, rate, temperature
/// and chamber temperature. Columns this crate does not interpret are not carried.
fn burst_means(rec: &Recording, runs: &[std::ops::Range<usize>]) -> Recording {
    let mean = |v: &[f64]| -> Vec<f64> {
        runs.iter()
            .map(|r| v[r.clone()].iter().sum::<f64>() / r.len() as f64)
            .collect()
    };
    Recording {
        time_s: mean(&rec.time_s),
        rate_dph: mean(&rec.rate_dph),
        temp_c: mean(&rec.temp_c),
        chamber_c: rec.chamber_c.as_deref().map(mean),
        extra: Vec::new(),
        comments: rec.comments.clone(),
    }
}

/// Samples per block for `n` samples `dt_s` apart: [`BLOCK_S`], or the smallest whole
/// multiple of it that keeps the record within [`MAX_BLOCKS`] blocks.
pub fn block_samples(n: usize, dt_s: f64) -> usize {
    let base = (BLOCK_S / dt_s).round().max(1.0) as usize;
    let k = n.div_ceil(base * MAX_BLOCKS).max(1);
    base * k
}

/// Prepares a recording: computes dT/dt by a centred difference, drops the first 30 s and any
/// partial last block. A recording given by value lends its series to the result instead of
/// being copied (a month at 1 Hz: 80 MB less while the diagnosis runs).
pub fn prepare<'a>(rec: impl Into<Cow<'a, Recording>>) -> Result<Prepared, DiagnoseError> {
    prepare_shifted(rec, 0)
}

/// [`prepare`] with the 100 s blocks starting `shift` samples later (of the record as
/// prepared: after faults are dropped and bursts averaged); the samples before the first
/// block are still used for dT/dt.
pub fn prepare_shifted<'a>(
    rec: impl Into<Cow<'a, Recording>>,
    shift: usize,
) -> Result<Prepared, DiagnoseError> {
    let mut rec = rec.into();
    if rec.len() < 3 {
        return Err(DiagnoseError::TooShort {
            blocks: 0,
            min: MIN_BLOCKS,
        });
    }
    let (bad, faults) = sensor_faults(
        &rec.time_s,
        &rec.temp_c,
        sample_period(&rec.time_s),
        &FaultLimits::BOARD,
    );
    if faults.total() > 0 {
        // Dropped, so that they become gaps, which every step bridges.
        rec = Cow::Owned(rec.without(&bad));
    }
    let bursts = find_bursts(&rec.time_s).map(|(runs, b)| {
        rec = Cow::Owned(burst_means(&rec, &runs));
        b
    });
    let n = rec.len();
    if n < 3 {
        return Err(DiagnoseError::TooShort {
            blocks: 0,
            min: MIN_BLOCKS,
        });
    }
    let dt_s = sample_period(&rec.time_s);
    if n > MAX_SAMPLES {
        return Err(DiagnoseError::TooLong {
            samples: n,
            max: MAX_SAMPLES,
            days: n as f64 * dt_s / 86_400.0,
        });
    }
    let rate_all = estimate_rate(&rec.temp_c, &rec.time_s, dt_s)?;
    let block = block_samples(n, dt_s);
    // The first and last ±30 s have one-sided differences; the start is dropped (the end is
    // usually cut by the partial last block).
    let skip = ((RATE_HALF_WIDTH_S / dt_s).ceil() as usize + shift).min(n);
    let usable = (n - skip) / block * block;
    let nb = usable / block;
    if nb < MIN_BLOCKS {
        return Err(DiagnoseError::TooShort {
            blocks: nb,
            min: MIN_BLOCKS,
        });
    }
    let r = skip..skip + usable;
    let drive = DriveSeries {
        t_s: rec.time_s[r.clone()].to_vec(),
        temp_c: rec.temp_c[r.clone()].to_vec(),
        dtemp_c_per_s: rate_all[r.clone()].to_vec(),
    };
    let (t_s, temp_c, mut rate_dph) = match rec {
        Cow::Owned(x) => (x.time_s, x.temp_c, x.rate_dph),
        Cow::Borrowed(x) => (x.time_s.clone(), x.temp_c.clone(), x.rate_dph.clone()),
    };
    rate_dph.truncate(r.end);
    rate_dph.drain(..r.start);
    let full_drive = DriveSeries {
        t_s,
        temp_c,
        dtemp_c_per_s: rate_all,
    };
    Ok(Prepared {
        faults,
        bursts,
        full_drive,
        range: r,
        dt_s,
        block,
        y_b: block_means(&rate_dph, block),
        t_b: block_means(&drive.t_s, block),
        temp_b: block_means(&drive.temp_c, block),
        dtemp_b: block_means(&drive.dtemp_c_per_s, block),
        drive,
        rate_dph,
    })
}

/// One column of a design: a linear parameter's unit contribution per sample.
#[derive(Clone, Debug)]
pub struct Column {
    /// Which term and parameter, e.g. `static_poly.coeffs_dph[2]`.
    pub name: String,
    /// °/h per unit of the parameter, per sample.
    pub values: Vec<f64>,
}

/// The baseline model's columns evaluated on `drive`, each a linear parameter of the model:
/// a constant (Earth rate and any offset), each `static_poly` coefficient, the three rate
/// terms, and the amplitude of any other bias term at its given non-linear parameters.
/// Sensor terms of the model (a `sensor_lag`) are applied to the drive by the caller.
pub fn baseline_columns(model: &PhysicsModel, drive: &DriveSeries) -> Vec<Column> {
    baseline_specs(model)
        .into_iter()
        .map(|(name, unit)| Column {
            values: baseline_values(unit.as_ref(), drive),
            name,
        })
        .collect()
}

/// The linear parameters of [`baseline_columns`], in its order: each column's name and its
/// unit-amplitude term (`None`: the offset, a column of ones).
pub fn baseline_specs(model: &PhysicsModel) -> Vec<(String, Option<Term>)> {
    let mut specs = vec![("offset".to_string(), None)];
    for term in &model.terms {
        match term {
            Term::EarthRate { .. } => {}
            Term::StaticPoly {
                center_c,
                scale_c,
                coeffs_dph,
            } => {
                // The constant is the offset column; one column per higher power.
                for k in 1..coeffs_dph.len() {
                    let mut unit = vec![0.0; coeffs_dph.len()];
                    unit[k] = 1.0;
                    let u = Term::StaticPoly {
                        center_c: *center_c,
                        scale_c: *scale_c,
                        coeffs_dph: unit,
                    };
                    specs.push((format!("static_poly.coeffs_dph[{k}]"), Some(u)));
                }
            }
            Term::RateTerms { .. } => {
                for (name, (a, b, c)) in [
                    ("linear", (1.0, 0.0, 0.0)),
                    ("cubic", (0.0, 1.0, 0.0)),
                    ("temp_linear", (0.0, 0.0, 1.0)),
                ] {
                    let u = Term::RateTerms {
                        linear: a,
                        cubic: b,
                        temp_linear: c,
                    };
                    specs.push((format!("rate_terms.{name}"), Some(u)));
                }
            }
            other if other.role() == Role::Bias => {
                if let Some(u) = other.unit_amplitude() {
                    specs.push((format!("{}.amplitude", other.name()), Some(u)));
                }
            }
            _ => {}
        }
    }
    specs
}

/// One column of [`baseline_columns`] on `drive`, from its [`baseline_specs`] entry: one
/// column at a time, so that a caller combining columns over a long record holds one, not
/// all of them.
pub fn baseline_values(unit: Option<&Term>, drive: &DriveSeries) -> Vec<f64> {
    let (t, x, r) = (&drive.t_s, &drive.temp_c, &drive.dtemp_c_per_s);
    match unit {
        None => vec![1.0; t.len()],
        Some(u) => contribution(u, t, x, r),
    }
}

/// The drive the model sees: the recorded one, de-quantised when the model has a
/// `temp_quantization`, then un-lagged when it has a `sensor_lag` (the physics library applies
/// the lag first and the rounding to the lagged reading, so the diagnosis undoes them in the
/// reverse order).
pub fn model_drive<'a>(
    model: &PhysicsModel,
    prep: &'a Prepared,
) -> Result<Cow<'a, DriveSeries>, DiagnoseError> {
    let tau = model.terms.iter().find_map(|t| match t {
        Term::SensorLag { tau_s } if *tau_s > 0.0 => Some(*tau_s),
        _ => None,
    });
    let step = model.terms.iter().find_map(|t| match t {
        Term::TempQuantization { step_c } if *step_c > 0.0 => Some(*step_c),
        _ => None,
    });
    let dequantised = step
        .map(|q| prep.full_drive.dequantised(q, prep.dt_s))
        .transpose()?;
    let full = match (tau, dequantised) {
        (None, None) => return Ok(Cow::Borrowed(&prep.drive)),
        (None, Some(d)) => d,
        (Some(tau), d) => d
            .as_ref()
            .unwrap_or(&prep.full_drive)
            .unlagged(tau, prep.dt_s)?,
    };
    Ok(Cow::Owned(prep.fitted_part(full)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// The field names a derived `Deserialize` of a struct asks for (its `FIELDS`), read by a
    /// deserializer that records them and stops.
    fn struct_fields<T: serde::de::DeserializeOwned>() -> BTreeSet<&'static str> {
        use serde::de::{Error as _, Visitor};
        struct Probe<'a>(&'a mut &'static [&'static str]);
        impl<'de> serde::Deserializer<'de> for Probe<'_> {
            type Error = serde::de::value::Error;
            fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
                Err(Self::Error::custom("not a struct"))
            }
            fn deserialize_struct<V: Visitor<'de>>(
                self,
                _: &'static str,
                fields: &'static [&'static str],
                _: V,
            ) -> Result<V::Value, Self::Error> {
                *self.0 = fields;
                Err(Self::Error::custom("fields recorded"))
            }
            serde::forward_to_deserialize_any! {
                bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes
                byte_buf option unit unit_struct newtype_struct seq tuple tuple_struct map enum
                identifier ignored_any
            }
        }
        let mut fields: &'static [&'static str] = &[];
        let _ = T::deserialize(Probe(&mut fields));
        fields.iter().copied().collect()
    }

    /// A model file accepts exactly a scenario's keys (of which it reads `name` and `terms`),
    /// so a scenario field added later is not refused in a model file, and no other key is
    /// silently ignored.
    #[test]
    fn model_file_keys_are_the_scenario_keys() {
        let scenario = struct_fields::<rlg_simulate::Scenario>();
        assert!(scenario.contains("terms") && scenario.contains("noise"));
        assert_eq!(struct_fields::<ModelFile>(), scenario);
    }

    /// The shipped dynamic scenario read as a model gives the simulator's terms.
    #[test]
    fn scenario_file_reads_as_its_terms() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/yu2011-dynamic.toml");
        let m = PhysicsModel::read(&path).expect("the scenario reads as a model");
        let sim = rlg_simulate::shipped::dynamic().expect("the shipped scenario is valid");
        assert_eq!(m.terms, sim.terms);
        assert_eq!(m.name, sim.name);
    }

    /// A key that is neither a model's nor a scenario's is refused by name, with the file's
    /// name; so is a file that cannot be read.
    #[test]
    fn unknown_model_key_is_refused_by_name() {
        let text = format!("nosie = 1.0\n{PAPER_MODEL_TOML}");
        let e = PhysicsModel::from_toml(&text, "typo.toml").expect_err("unknown key");
        let msg = e.to_string();
        assert!(
            msg.contains("typo.toml") && msg.contains("`nosie`"),
            "{msg}"
        );
        let dir = tempfile::tempdir().expect("temp dir");
        let missing = dir.path().join("absent.toml");
        let msg = PhysicsModel::read(&missing)
            .expect_err("no file")
            .to_string();
        assert!(msg.contains("absent.toml"), "{msg}");
    }

    /// The least-squares slope is exact on a line everywhere (ends included) and on a
    /// parabola wherever its window is whole (a symmetric window cancels the curvature).
    #[test]
    fn local_slope_is_exact_on_lines_and_centred_parabolas() {
        let dt = 2.0;
        let t: Vec<f64> = (0..300).map(|i| f64::from(i) * dt).collect();
        let line: Vec<f64> = t.iter().map(|t| 3.0 - 0.01 * t).collect();
        for s in local_slope(&line, &t, dt, 45.0) {
            assert!((s + 0.01).abs() < 1e-12, "{s}");
        }
        let par: Vec<f64> = t.iter().map(|t| 1.0 + 0.02 * t + 1e-4 * t * t).collect();
        let s = local_slope(&par, &t, dt, 45.0);
        let h = 23; // 45 s / 2 s, rounded
        for i in h..t.len() - h {
            let want = 0.02 + 2e-4 * t[i];
            assert!((s[i] - want).abs() < 1e-9, "{i}: {} vs {want}", s[i]);
        }
        // A truncated window at the ends is still a least-squares slope, biased only by
        // the curvature: for this parabola by 2e-4·(window centre − t).
        assert!((s[0] - (0.02 + 2e-4 * 0.5 * (h as f64) * dt)).abs() < 1e-9);
        assert_eq!(local_slope(&[5.0], &[0.0], 1.0, 45.0), vec![0.0]);
    }

    /// Next to a gap the slope and dT/dt come from the samples on the same side only: on a
    /// ramp that reverses during a 30 min gap, every estimate is the ramp's own slope, where a
    /// window across the gap took the chord over what the gap hides (0 here) or, for the
    /// slope, divided the jump by the samples' count.
    #[test]
    fn slopes_and_rates_never_span_a_gap() {
        // 1 °C/min up for 1 000 s, a gap of 1 800 s, then 1 °C/min down.
        let mut t: Vec<f64> = (0..1000).map(f64::from).collect();
        t.extend((0..1000).map(|i| 2800.0 + f64::from(i)));
        let temp: Vec<f64> = t
            .iter()
            .map(|&t| {
                if t < 1400.0 {
                    20.0 + t / 60.0
                } else {
                    20.0 + (2800.0 - t) / 60.0
                }
            })
            .collect();
        let want = |t: f64| if t < 1400.0 { 1.0 / 60.0 } else { -1.0 / 60.0 };
        let slope = local_slope(&temp, &t, 1.0, 45.0);
        let rate = estimate_rate(&temp, &t, 1.0).expect("rate");
        for i in 0..t.len() {
            assert!(
                (slope[i] - want(t[i])).abs() < 1e-12,
                "slope at {}: {}",
                t[i],
                slope[i]
            );
            assert!(
                (rate[i] - want(t[i])).abs() < 1e-12,
                "rate at {}: {}",
                t[i],
                rate[i]
            );
        }
        // Without the gap the same code gives the bits it always gave (jitter below 1.5 steps).
        let tj: Vec<f64> = (0..500)
            .map(|i| f64::from(i) + 0.3 * f64::from(i % 3))
            .collect();
        let xj: Vec<f64> = tj.iter().map(|t| (t / 200.0).sin()).collect();
        assert_eq!(gapless_runs(&tj, 1.0), vec![(0, 499)]);
        let rj = estimate_rate(&xj, &tj, 1.0).expect("rate");
        let h = 30;
        for i in [0usize, 17, 250, 499] {
            let (a, b) = (i.saturating_sub(h), (i + h).min(499));
            assert_eq!(rj[i], (xj[b] - xj[a]) / (tj[b] - tj[a]));
        }
    }

    /// A body temperature heating towards 40 °C then cooling at 0.5 °C/min, then resting.
    fn smooth_temperature() -> Vec<f64> {
        (0..20_000)
            .map(|i| {
                let t = f64::from(i);
                if t < 8000.0 {
                    20.0 + 20.0 * (1.0 - (-t / 1200.0).exp())
                } else {
                    let top = 20.0 + 20.0 * (1.0 - (-8000.0f64 / 1200.0).exp());
                    (top - (t - 8000.0) / 120.0).max(-5.0)
                }
            })
            .collect()
    }

    /// The quantum is read from a rounded reading, and none from a continuous one.
    #[test]
    fn quantum_is_read_from_the_reading() {
        let body = smooth_temperature();
        for q in [0.01, 0.0625, 0.25] {
            let r: Vec<f64> = body.iter().map(|t| (t / q).round() * q).collect();
            assert_eq!(read_quantum(&r), Some((q * 1e4_f64).round() / 1e4), "q {q}");
        }
        let noisy: Vec<f64> = body
            .iter()
            .enumerate()
            .map(|(i, t)| t + 0.003 * (i as f64 * 1.7).sin() * (i as f64 * 0.37).cos())
            .collect();
        assert_eq!(read_quantum(&noisy), None);
        assert_eq!(read_quantum(&[1.0; 100]), None);
    }

    /// De-quantising a coarse reading recovers the temperature and its rate: errors a
    /// fraction of the rounding's.
    #[test]
    fn dequantise_recovers_temperature_and_rate() {
        let body = smooth_temperature();
        let t: Vec<f64> = (0..body.len()).map(|i| i as f64).collect();
        let q = 0.25;
        let read: Vec<f64> = body.iter().map(|v| (v / q).round() * q).collect();
        let rec = dequantise(&read, q);
        let rms = |a: &[f64], b: &[f64]| {
            let s: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
            (s / a.len() as f64).sqrt()
        };
        let (e_read, e_rec) = (rms(&read, &body), rms(&rec, &body));
        assert!(e_rec < 0.35 * e_read, "{e_rec} vs {e_read}");
        let rate_true = estimate_rate(&body, &t, 1.0).expect("rate");
        let rate_read = estimate_rate(&read, &t, 1.0).expect("rate");
        let rate_rec = estimate_rate(&rec, &t, 1.0).expect("rate");
        let err = |r: &[f64]| rms(r, &rate_true);
        assert!(
            err(&rate_rec) < 0.35 * err(&rate_read),
            "{} vs {}",
            err(&rate_rec),
            err(&rate_read)
        );
        // Nothing to undo: an unquantised series is returned as it is where it never jumps.
        assert_eq!(dequantise(&[1.0; 10], 0.1), vec![1.0; 10]);
    }
}
