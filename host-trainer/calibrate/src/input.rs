//! What a calibration takes, whatever rate the log was written at: a stream is brought to the
//! board's 1 Hz (a faster one averaged to 1 s means), and a bursty log, which holds no stream,
//! is reduced to one mean per burst for a temperature-only model. Each step is said in a note.

use std::borrow::Cow;

use rlg_io::recording::Recording;
use rlg_io::resample::{bin_means, burst_means};
use rlg_io::sampling::{find_bursts, median_step_s, Bursts, BURST_GAP};

use crate::error::CalibrateError;
use crate::stream::check_stream;

/// Fewest bursts for a log to be taken as bursty (fewer are a stream with dropouts).
pub const MIN_BURSTS: usize = 5;
/// Longest median burst, s: a logger that wakes for longer writes a stream with gaps.
pub const MAX_BURST_S: f64 = 50.0;
/// Fastest stream taken, Hz: faster logs are averaged by `rlg resample` first (a 10⁷-sample
/// file is a few hours at 1 kHz).
pub const MAX_RATE_HZ: f64 = 1000.0;

/// How a log was sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// A stream with this median step, s.
    Stream {
        /// Median step, s.
        step_s: f64,
    },
    /// Bursts of samples minutes apart.
    Bursts(Bursts),
}

/// How `rec` was sampled (see the module doc).
pub fn sampling(rec: &Recording) -> Sampling {
    match find_bursts(&rec.time_s, MIN_BURSTS, MAX_BURST_S) {
        Some((_, b)) => Sampling::Bursts(b),
        None => Sampling::Stream {
            step_s: median_step_s(&rec.time_s).unwrap_or(f64::NAN),
        },
    }
}

/// Describes bursts for a note.
pub fn describe_bursts(b: &Bursts) -> String {
    format!(
        "{} bursts of about {} samples over {:.1} s, one every {:.0} s",
        b.count, b.samples, b.length_s, b.period_s
    )
}

/// `rec` as a 1 Hz stream (`what` names it in errors and notes): as it is when its median
/// step is within 10 % of a second, a faster stream averaged to 1 s means. A bursty log or a
/// stream slower than the board is refused with the reason and the way out.
pub fn at_board_rate<'a>(
    rec: Cow<'a, Recording>,
    what: &str,
    notes: &mut Vec<String>,
) -> Result<(Cow<'a, Recording>, f64), CalibrateError> {
    match sampling(&rec) {
        Sampling::Bursts(b) => Err(CalibrateError::Input(format!(
            "{what} is sampled in bursts ({}): it holds no 1 Hz stream, so no dT/dt model can be \
             trained from it; give --static for a temperature-only model on the burst means",
            describe_bursts(&b)
        ))),
        Sampling::Stream { step_s } if (0.999 / MAX_RATE_HZ..0.9).contains(&step_s) => {
            let (means, report) = bin_means(&rec, 1.0).map_err(|e| {
                CalibrateError::Input(format!("{what}: averaging to 1 s means: {e}"))
            })?;
            notes.push(format!(
                "{what} is sampled every {step_s:.4} s ({:.0} Hz): it is averaged to 1 s means \
                 (the board's rate) before anything else, {} samples into {}.",
                1.0 / step_s,
                report.input_samples,
                report.output_samples
            ));
            let dt = check_stream(&means, what)?;
            Ok((Cow::Owned(means), dt))
        }
        Sampling::Stream { step_s } if step_s < 0.9 => Err(CalibrateError::Input(format!(
            "{what}: samples every {step_s:.2e} s, faster than {MAX_RATE_HZ:.0} Hz; average it \
             first with `rlg resample --period-s 1` (or check --time-unit)"
        ))),
        Sampling::Stream { .. } => {
            let dt = check_stream(&rec, what)?;
            Ok((rec, dt))
        }
    }
}

/// `rec` reduced for a temperature-only model: one mean per burst of a bursty log, 1 s means
/// of a stream faster than 1 Hz, else as it is; with a note when reduced.
pub fn for_static<'a>(
    rec: &'a Recording,
    what: &str,
    notes: &mut Vec<String>,
) -> Result<Cow<'a, Recording>, CalibrateError> {
    let reduce = |e: rlg_io::resample::ResampleError| {
        CalibrateError::Input(format!("{what}: reducing the log: {e}"))
    };
    match sampling(rec) {
        Sampling::Bursts(b) => {
            let (means, _) = burst_means(rec, BURST_GAP).map_err(reduce)?;
            notes.push(format!(
                "{what} is sampled in bursts ({}): each burst is one point, its mean time, rate \
                 and temperature.",
                describe_bursts(&b)
            ));
            Ok(Cow::Owned(means))
        }
        Sampling::Stream { step_s } if step_s < 0.9 => {
            let (means, _) = bin_means(rec, 1.0).map_err(reduce)?;
            notes.push(format!(
                "{what} is sampled every {step_s:.4} s: averaged to 1 s means first."
            ));
            Ok(Cow::Owned(means))
        }
        Sampling::Stream { .. } => Ok(Cow::Borrowed(rec)),
    }
}
