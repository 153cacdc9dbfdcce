//! The training span's data: the means every model is trained on, the means σ, c and the
//! polynomial's degree are tuned on, and the cycle each tuning mean starts in (its CV fold).

use rlg_io::recording::Recording;
use rlg_train::dataset::{self, Dataset, RecordingSelection};
use rlg_train::features::FeatureSeries;
use rlg_train::protocol::TRAIN_BLOCK;

use crate::averaging::{averaging_s, Averaging};
use crate::cv::pool_even;
use crate::error::{ensure, CalibrateError};
use crate::options::{Options, MAX_TUNE_MEANS};
use crate::split::Plan;
use crate::stream::cycle_labels;

/// See the module doc.
#[derive(Clone, Debug)]
pub(crate) struct TrainingSets {
    /// Means of `block_s` samples of the training span (pooled with
    /// `--even-temperature`).
    pub data: Dataset,
    /// Means the tuning scores (100 s, longer on a long span).
    pub tune: Dataset,
    /// The cycle each tuning mean starts in.
    pub tune_labels: Vec<usize>,
    /// Seconds per training mean.
    pub block_s: usize,
    /// Seconds per tuning mean.
    pub tune_block_s: usize,
    /// The 1 s noise of the training span's rate, °/h (see [`Averaging::noise_1s_dph`]).
    pub noise_1s_dph: f64,
}

/// The training span of `cal` (up to `plan.train_end_s`) as [`TrainingSets`]; `series` are
/// the board's features of `cal`, `cycles` its temperature cycles. Notes say when the tuning
/// means are longer than 100 s and when the means were pooled.
pub(crate) fn training_sets(
    cal: &Recording,
    series: &FeatureSeries,
    cycles: &[(f64, f64)],
    plan: &Plan,
    opts: &Options,
    notes: &mut Vec<String>,
) -> Result<TrainingSets, CalibrateError> {
    let train_end = plan.train_end_s;
    let t_end = *cal.time_s.last().unwrap_or(&cal.time_s[0]);
    let to_s = train_end.is_finite().then_some(train_end);
    let sel = |block| RecordingSelection {
        from_s: None,
        to_s,
        block,
        rate_tau_s: opts.rate_tau_s,
    };
    let averaging = record_averaging(cal, series, train_end);
    let block = opts.block.unwrap_or(averaging.block_s);
    if opts.block.is_none() && averaging.block_s != TRAIN_BLOCK {
        notes.push(format!("Training on {}.", averaging.describe()));
    }
    let mut data = dataset::from_recording(cal, &sel(block))?;
    // Tuning solves the exact LS-SVM per fold and grid point, cubic in its size: a long
    // training span is tuned on longer means so that at most MAX_TUNE_MEANS remain.
    let mut tune_block = block;
    let mut tune = dataset::from_recording(cal, &sel(tune_block))?;
    if tune.x.len() > MAX_TUNE_MEANS {
        tune_block *= tune.x.len().div_ceil(MAX_TUNE_MEANS);
        tune = dataset::from_recording(cal, &sel(tune_block))?;
        notes.push(format!(
            "The training span is long: σ, c and the polynomial's degree are tuned on {} means \
             of {tune_block} s (at most {MAX_TUNE_MEANS}) rather than {block} s means.",
            tune.x.len()
        ));
    }
    let train_cyc = &cycles[..plan.train_cycles.min(cycles.len())];
    let labels_of = |block: usize, n: usize| -> Result<Vec<usize>, CalibrateError> {
        let l = cycle_labels(cal, series, train_end.min(t_end), block, train_cyc);
        ensure!(
            l.len() == n,
            Internal,
            "internal: {} cycle labels for {n} training means",
            l.len()
        );
        Ok(l)
    };
    let mut tune_labels = labels_of(tune_block, tune.x.len())?;
    if opts.even_temperature {
        let data_labels = labels_of(block, data.x.len())?;
        let before = data.x.len();
        data = pool_even(&data, &data_labels).0;
        (tune, tune_labels) = pool_even(&tune, &tune_labels);
        notes.push(format!(
            "Training weighted evenly over temperature (--even-temperature): {before} training \
             means pooled into {} cells of one cycle, 1 °C and a tenth of the largest |dT/dt|, \
             one mean each.",
            data.x.len()
        ));
    }
    Ok(TrainingSets {
        data,
        tune,
        tune_labels,
        block_s: block,
        tune_block_s: tune_block,
        noise_1s_dph: averaging.noise_1s_dph,
    })
}

/// [`averaging_s`] of the training span's samples (up to `train_end` s, after the dT/dt
/// estimator's warm-up).
fn record_averaging(cal: &Recording, series: &FeatureSeries, train_end: f64) -> Averaging {
    let keep: Vec<usize> = (0..cal.len())
        .filter(|&k| !series.warming_up[k] && cal.time_s[k] <= train_end)
        .collect();
    let pick = |v: &[f64]| -> Vec<f64> { keep.iter().map(|&k| v[k]).collect() };
    let rate: Vec<f64> = keep.iter().map(|&k| series.rows[k][1]).collect();
    averaging_s(&pick(&cal.rate_dph), &pick(&cal.temp_c), &rate)
}
