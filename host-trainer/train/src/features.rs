//! Training features computed exactly as the board computes them.
//!
//! The temperature is rounded to f32 and fed, sample by sample, through
//! `compensator_core::RateEstimator` built from `RateFilter::from_tau_s` and the recursive
//! features of `compensator_core::features::FeatureBank` — the very code and gains the board
//! runs — so every feature the model is trained on (T, dT/dt, lead-corrected T, lagged
//! gradient, play operator, time since power-on) is bit-identical to the one it sees in
//! flight. The f32 values are returned widened to f64.
//!
//! Gaps in the sample times that are a whole number of periods are bridged as the board does
//! when it rejects samples (`Compensator::update` with a temperature fault, once per missing
//! period): the estimator and the features skip the period, and from
//! `SensorLimits::DEFAULT.max_skipped` consecutive missing periods on the estimator restarts
//! (a new warm-up) and the lag and play states clear.

use compensator_core::features::FeatureBank;
use compensator_core::{Feature, RateEstimator, RateFilter, SensorLimits};

/// Why features could not be computed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FeatureError {
    /// `temp_c` and `time_s` differ in length, or are empty.
    #[error(
        "{temps} temperatures but {times} time stamps (need at least one of each, equal counts)"
    )]
    Length {
        /// Number of temperatures.
        temps: usize,
        /// Number of time stamps.
        times: usize,
    },
    /// A temperature or time stamp is NaN or infinite.
    #[error("non-finite {what} at sample {index}")]
    NonFinite {
        /// "temp_c" or "time_s".
        what: &'static str,
        /// 0-based sample.
        index: usize,
    },
    /// τ or the sample period is not a positive finite number, or gives an unstable filter.
    #[error("dT/dt filter with tau = {tau_s} s at dt = {dt_s} s is not usable (both must be positive and finite)")]
    Filter {
        /// Time constant, s.
        tau_s: f64,
        /// Sample period, s.
        dt_s: f64,
    },
    /// Two samples are not a whole number (≥ 1) of periods apart.
    #[error("samples {index} and {} are {step_s} s apart, not a whole number of {dt_s} s periods", index + 1)]
    Sampling {
        /// 0-based index of the earlier sample.
        index: usize,
        /// Their separation, s.
        step_s: f64,
        /// The expected period, s.
        dt_s: f64,
    },
    /// Two samples are further apart than [`MAX_GAP_PERIODS`] periods (a clock error rather
    /// than a pause: bridging it would replay every missing period).
    #[error("samples {index} and {} are {periods} periods apart (more than {MAX_GAP_PERIODS}); split the recording at the gap", index + 1)]
    Gap {
        /// 0-based index of the earlier sample.
        index: usize,
        /// Periods between the two samples.
        periods: f64,
    },
    /// Block averaging asked for blocks of 0 samples or more samples than exist.
    #[error("cannot average {len} samples in blocks of {block}")]
    Block {
        /// Samples available.
        len: usize,
        /// Requested block length.
        block: usize,
    },
}

/// The longest gap bridged between two samples, periods (≈ 116 days at 1 Hz).
pub const MAX_GAP_PERIODS: f64 = 1e7;

/// The dT/dt filter the trainer and the board share, for `rate_tau_s` at period `dt_s`.
pub fn rate_filter(rate_tau_s: f64, dt_s: f64) -> Result<RateFilter, FeatureError> {
    let f = RateFilter::from_tau_s(rate_tau_s as f32, dt_s as f32);
    if !(rate_tau_s > 0.0
        && rate_tau_s.is_finite()
        && dt_s > 0.0
        && dt_s.is_finite()
        && f.is_stable())
    {
        return Err(FeatureError::Filter {
            tau_s: rate_tau_s,
            dt_s,
        });
    }
    Ok(f)
}

/// Rows of features stored in one flat allocation: 16 bytes a sample for two features,
/// where one vector per row costs 56 (a 10⁷-sample record: 160 MB instead of 560 MB).
/// `rows[k]` is row k as a slice.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeatureRows {
    dim: usize,
    n: usize,
    data: Vec<f64>,
}

impl FeatureRows {
    /// Empty rows of `dim` values, room for `n`.
    pub fn with_capacity(dim: usize, n: usize) -> Self {
        FeatureRows {
            dim,
            n: 0,
            data: Vec::with_capacity(dim * n),
        }
    }

    /// Appends one row (the iterator must give `dim` values).
    pub fn push_row(&mut self, row: impl IntoIterator<Item = f64>) {
        let before = self.data.len();
        self.data.extend(row);
        assert_eq!(
            self.data.len() - before,
            self.dim,
            "row of the wrong length"
        );
        self.n += 1;
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether there is no row.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Values per row.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The rows in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[f64]> + '_ {
        (0..self.n).map(move |k| &self[k])
    }

    /// The last row.
    pub fn last(&self) -> Option<&[f64]> {
        self.n.checked_sub(1).map(|k| &self[k])
    }
}

/// Rows of inputs, whether one vector per row or one block ([`FeatureRows`]): what training
/// reads, so a long record need not be held as 10⁷ separate vectors (56 bytes a row for two
/// features, against 16 in a block).
pub trait RowSet {
    /// Number of rows.
    fn n_rows(&self) -> usize;
    /// Row `i`.
    fn row(&self, i: usize) -> &[f64];
}

impl RowSet for [Vec<f64>] {
    fn n_rows(&self) -> usize {
        self.len()
    }
    fn row(&self, i: usize) -> &[f64] {
        &self[i]
    }
}

impl RowSet for Vec<Vec<f64>> {
    fn n_rows(&self) -> usize {
        self.len()
    }
    fn row(&self, i: usize) -> &[f64] {
        &self[i]
    }
}

impl RowSet for FeatureRows {
    fn n_rows(&self) -> usize {
        self.n
    }
    fn row(&self, i: usize) -> &[f64] {
        &self[i]
    }
}

impl std::ops::Index<usize> for FeatureRows {
    type Output = [f64];
    fn index(&self, k: usize) -> &[f64] {
        assert!(k < self.n, "row {k} of {}", self.n);
        &self.data[k * self.dim..(k + 1) * self.dim]
    }
}

/// A feature matrix, one row per sample.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureSeries {
    /// Which feature each column holds.
    pub features: Vec<Feature>,
    /// One row per input sample; each value is the f32 the board would compute, widened.
    pub rows: FeatureRows,
    /// Whether the estimator was still warming up at each sample (exclude from training).
    pub warming_up: Vec<bool>,
}

impl FeatureSeries {
    /// Feature names with their parameters (`Feature`'s `Display`, e.g.
    /// `temp_lead_c(tau_s=120)`), in column order.
    pub fn names(&self) -> Vec<String> {
        self.features.iter().map(|f| f.to_string()).collect()
    }
}

/// Runs the board's feature pipeline over a temperature series sampled every `dt_s` seconds.
///
/// `time_s` must advance by whole multiples of `dt_s` (within 1 % of a period); missing
/// periods are bridged as described in the module doc.
pub fn compute(
    features: &[Feature],
    temp_c: &[f64],
    time_s: &[f64],
    rate_tau_s: f64,
    dt_s: f64,
) -> Result<FeatureSeries, FeatureError> {
    if temp_c.is_empty() || temp_c.len() != time_s.len() {
        return Err(FeatureError::Length {
            temps: temp_c.len(),
            times: time_s.len(),
        });
    }
    let filter = rate_filter(rate_tau_s, dt_s)?;
    if let Some(i) = temp_c.iter().position(|v| !v.is_finite()) {
        return Err(FeatureError::NonFinite {
            what: "temp_c",
            index: i,
        });
    }
    if let Some(i) = time_s.iter().position(|v| !v.is_finite()) {
        return Err(FeatureError::NonFinite {
            what: "time_s",
            index: i,
        });
    }
    let max_skipped = SensorLimits::DEFAULT.max_skipped;
    let mut est = RateEstimator::new(filter);
    // One bank per feature: each feature's state is its own, so a one-feature bank runs the
    // board's arithmetic for that column (the board runs them side by side in one bank).
    let mut banks: Vec<FeatureBank<1>> = features
        .iter()
        .map(|f| FeatureBank::new([*f], filter.dt_s))
        .collect();
    let mut rows = FeatureRows::with_capacity(features.len(), temp_c.len());
    let mut warming_up = Vec::with_capacity(temp_c.len());
    for (k, &t) in temp_c.iter().enumerate() {
        if k > 0 {
            let step_s = time_s[k] - time_s[k - 1];
            let periods = (step_s / dt_s).round();
            if periods < 1.0 || (step_s / dt_s - periods).abs() > 0.01 {
                return Err(FeatureError::Sampling {
                    index: k - 1,
                    step_s,
                    dt_s,
                });
            }
            if periods > MAX_GAP_PERIODS {
                return Err(FeatureError::Gap {
                    index: k - 1,
                    periods,
                });
            }
            // The board's path for a period without an accepted temperature.
            let missing = periods as u64 - 1;
            for skipped in 1..=missing {
                if skipped >= u64::from(max_skipped) {
                    est.reset();
                    let e = est.estimate();
                    for b in &mut banks {
                        b.skip(&e);
                        b.reset();
                    }
                } else {
                    let e = est.skip();
                    banks.iter_mut().for_each(|b| b.skip(&e));
                }
            }
        }
        let t32 = t as f32;
        let e = est.update(t32);
        rows.push_row(banks.iter_mut().map(|b| f64::from(b.update(t32, &e)[0])));
        warming_up.push(e.warming_up);
    }
    Ok(FeatureSeries {
        features: features.to_vec(),
        rows,
        warming_up,
    })
}

/// Averages rows and targets over consecutive blocks of `block` samples (the paper averages
/// 100 1 Hz points per training sample). A trailing partial block is dropped.
pub fn block_average(
    rows: &[Vec<f64>],
    y: &[f64],
    block: usize,
) -> Result<(Vec<Vec<f64>>, Vec<f64>), FeatureError> {
    if block == 0 || rows.len() < block || rows.len() != y.len() {
        return Err(FeatureError::Block {
            len: rows.len().min(y.len()),
            block,
        });
    }
    let dim = rows[0].len();
    let n = rows.len() / block;
    let mut out_x = Vec::with_capacity(n);
    let mut out_y = Vec::with_capacity(n);
    for b in 0..n {
        let r = &rows[b * block..(b + 1) * block];
        let mean: Vec<f64> = (0..dim)
            .map(|d| r.iter().map(|v| v[d]).sum::<f64>() / block as f64)
            .collect();
        out_x.push(mean);
        out_y.push(y[b * block..(b + 1) * block].iter().sum::<f64>() / block as f64);
    }
    Ok((out_x, out_y))
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOTH: [Feature; 2] = [Feature::TempC, Feature::TempRateCPerS];

    #[test]
    fn features_equal_a_direct_run_of_the_board_estimator() {
        let temp: Vec<f64> = (0..900)
            .map(|k| 20.0 + 10.0 * (k as f64 / 200.0).sin())
            .collect();
        let time: Vec<f64> = (0..900).map(f64::from).collect();
        let s = compute(&BOTH, &temp, &time, 60.0, 1.0).unwrap();
        let mut est = RateEstimator::new(RateFilter::from_tau_s(60.0, 1.0));
        for (k, &t) in temp.iter().enumerate() {
            let e = est.update(t as f32);
            assert_eq!(s.rows[k][0], f64::from(t as f32));
            assert_eq!(s.rows[k][1].to_bits(), f64::from(e.rate_c_per_s).to_bits());
            assert_eq!(
                s.warming_up[k],
                k + 1 < 300,
                "warm-up ends with the 300th sample (5τ)"
            );
        }
    }

    #[test]
    fn ramp_rate_is_recovered_after_warm_up() {
        // A type-2 tracker follows a ramp without steady-state error (compensator_core::rate).
        let time: Vec<f64> = (0..2000).map(f64::from).collect();
        let temp: Vec<f64> = time.iter().map(|t| 15.0 + 0.01 * t).collect();
        let s = compute(&BOTH, &temp, &time, 60.0, 1.0).unwrap();
        let last = s.rows.last().unwrap();
        assert!((last[1] - 0.01).abs() < 1e-5, "{}", last[1]);
        assert!(!s.warming_up[1999]);
    }

    #[test]
    fn gaps_are_bridged_like_rejected_samples() {
        let temp: Vec<f64> = (0..10).map(|k| k as f64 * 0.1).collect();
        let time = vec![0.0, 1.0, 2.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 100.0];
        let s = compute(&BOTH, &temp, &time, 60.0, 1.0).unwrap();
        let mut est = RateEstimator::new(RateFilter::from_tau_s(60.0, 1.0));
        for (k, &t) in temp.iter().enumerate().take(9) {
            if k == 3 {
                est.skip();
            }
            assert_eq!(s.rows[k][1], f64::from(est.update(t as f32).rate_c_per_s));
        }
        // 90 missing periods exceed max_skipped: a restart, slope 0 again.
        assert_eq!(s.rows[9][1], 0.0);
        assert!(compute(
            &BOTH,
            &temp,
            &[0.0, 1.0, 1.5, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
            60.0,
            1.0
        )
        .is_err());
    }

    /// Every recursive feature, through gaps short and long, equals a joint five-feature
    /// `FeatureBank` (as the board holds it) driven by `Compensator::update`'s rule for a
    /// period without an accepted temperature, bit for bit. (The board's outputs themselves are
    /// compared bit for bit in QEMU by the tests crate.)
    #[test]
    fn recursive_features_equal_a_joint_bank_through_gaps() {
        const F: [Feature; 5] = [
            Feature::TempC,
            Feature::TempLeadC { tau_s: 120 },
            Feature::TempGradLagCPerS { tau_s: 300 },
            Feature::TempPlayC { width_mc: 2000 },
            Feature::TimeOnS,
        ];
        // A triangle wave with gaps of 3 and of 200 missing periods (the latter restarts).
        let mut time = Vec::new();
        let mut t = 0.0;
        for k in 0..3000 {
            time.push(t);
            t += match k {
                1000 => 4.0,
                2000 => 201.0,
                _ => 1.0,
            };
        }
        let temp: Vec<f64> = time
            .iter()
            .map(|t| 20.0 + 15.0 * (2.0 * ((t / 1600.0f64).fract() - 0.5)).abs())
            .collect();
        let s = compute(&F, &temp, &time, 60.0, 1.0).unwrap();

        let filter = RateFilter::from_tau_s(60.0, 1.0);
        let mut rate = RateEstimator::new(filter);
        let mut bank = FeatureBank::new(F, filter.dt_s);
        let max_skipped = SensorLimits::DEFAULT.max_skipped;
        for (k, &tc) in temp.iter().enumerate() {
            if k > 0 {
                let mut skipped = 0u32;
                for _ in 1..(time[k] - time[k - 1]) as usize {
                    skipped += 1;
                    if skipped >= max_skipped {
                        rate.reset();
                        bank.skip(&rate.estimate());
                        bank.reset();
                    } else {
                        let e = rate.skip();
                        bank.skip(&e);
                    }
                }
            }
            let e = rate.update(tc as f32);
            let want = bank.update(tc as f32, &e);
            for (d, v) in want.iter().enumerate() {
                assert_eq!(
                    s.rows[k][d].to_bits(),
                    f64::from(*v).to_bits(),
                    "sample {k}, feature {d}"
                );
            }
        }
        // The long gap restarted the estimator: the lag and play states cleared, time ran on.
        assert_eq!(s.rows[2001][4], 2000.0 + 1.0 + 3.0 + 200.0);
        assert!(s.warming_up[2001] && !s.warming_up[1999]);
    }

    #[test]
    fn block_average_matches_hand_means() {
        let rows: Vec<Vec<f64>> = (0..7).map(|k| vec![k as f64, 2.0 * k as f64]).collect();
        let y: Vec<f64> = (0..7).map(|k| 10.0 + k as f64).collect();
        let (x, yb) = block_average(&rows, &y, 3).unwrap();
        assert_eq!(x, vec![vec![1.0, 2.0], vec![4.0, 8.0]]);
        assert_eq!(yb, vec![11.0, 14.0]);
        assert!(block_average(&rows, &y, 0).is_err());
        assert!(block_average(&rows, &y, 8).is_err());
    }

    #[test]
    fn bad_filter_and_data_are_errors() {
        assert!(matches!(
            rate_filter(0.0, 1.0),
            Err(FeatureError::Filter { .. })
        ));
        assert!(matches!(
            rate_filter(60.0, f64::NAN),
            Err(FeatureError::Filter { .. })
        ));
        assert!(matches!(
            compute(&BOTH, &[1.0, f64::NAN], &[0.0, 1.0], 60.0, 1.0),
            Err(FeatureError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            compute(&BOTH, &[], &[], 60.0, 1.0),
            Err(FeatureError::Length { .. })
        ));
    }
}
