//! Which samples train and which are held out: whole temperature cycles, or a later
//! recording, or (one cycle, no test recording) nothing.

use crate::error::{ensure, CalibrateError};
use crate::result::HeldOut;

/// The split of a calibration recording of `cycles` temperature cycles.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Plan {
    /// What is held out.
    pub held_out: HeldOut,
    /// End of the training span, s (infinite: all of the recording trains).
    pub train_end_s: f64,
    /// Cycles of the recording that train.
    pub train_cycles: usize,
}

/// The split: with a test recording all of `cycles` train; otherwise the first
/// `train_cycles` (default ⌈k/2⌉, at most k − 1) of k ≥ 2 cycles train and the rest are held
/// out; one cycle and no test recording hold nothing out, and `notes` says so.
pub(crate) fn plan(
    cycles: &[(f64, f64)],
    has_test: bool,
    train_cycles: Option<usize>,
    notes: &mut Vec<String>,
) -> Result<Plan, CalibrateError> {
    let k = cycles.len();
    let (held_out, train_end_s) = match has_test {
        true => (HeldOut::TestRecording, f64::INFINITY),
        false if k >= 2 => {
            let n_train = match train_cycles {
                Some(n) => {
                    ensure!(
                        n < k,
                        Option,
                        "--train-cycles {n}: the recording has {k} temperature cycles; train on \
                         fewer to leave one held out, or give --test"
                    );
                    n
                }
                None => k.div_ceil(2).min(k - 1),
            };
            (
                HeldOut::Cycles {
                    train: n_train,
                    test: k - n_train,
                },
                cycles[n_train - 1].1,
            )
        }
        false => {
            notes.push(format!(
                "No held-out data: the recording is one temperature cycle and no --test was \
                 given. Every figure below is TRAINING or cross-validated (CV, {} of the \
                 cycle); record another cycle or a later run to measure held-out stability.",
                "blocked folds"
            ));
            (HeldOut::Nothing, f64::INFINITY)
        }
    };
    let train_cycles = match held_out {
        HeldOut::Cycles { train, .. } => train,
        _ => k,
    };
    Ok(Plan {
        held_out,
        train_end_s,
        train_cycles,
    })
}
