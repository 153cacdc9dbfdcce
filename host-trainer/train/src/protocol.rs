//! The project's training protocol: the choices every trainer here shares (the paper
//! reproduction, the board's default table, the close loop).

use crate::lssvm::tune::Validation;

/// Block length of the training means, samples (100 s at 1 Hz, as in the paper).
pub const TRAIN_BLOCK: usize = 100;
/// dT/dt estimator time constant, s.
pub const RATE_TAU_S: f64 = 60.0;
/// Cross-validation of σ and c: 5 folds of interleaved blocks of 10 consecutive 100 s means
/// (≈ 17 min, longer than the slow noise neighbouring means share).
pub const CV: Validation = Validation::Blocked {
    block: 10,
    folds: 5,
};
/// Support vectors in the board's table (fixed-size LS-SVM, Nyström with a Rényi-entropy
/// active set): the board budget is sized for 64.
pub const SUPPORT_VECTORS: usize = 64;
