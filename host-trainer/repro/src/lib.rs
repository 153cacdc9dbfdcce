//! Reproduction of every result of Yu et al. 2011, reported the way a gyro test lab would:
//! training and held-out figures apart, each beside the paper's value.
//!
//! * [`static_test`]: Table 1 / Fig. 2. The least-squares quadratic (errors within 0.5e-4 °/h
//!   of the published row, [`rlg_eval::baselines::static_quad`]) and an LS-SVM on the same 11
//!   points, σ and c chosen by closed-form leave-one-out; training errors and, beside them,
//!   leave-one-out errors of both models.
//! * [`dynamic`]: Figs. 3–6 and the 100 s stabilities. The paper's protocol on the simulated
//!   `yu2011-dynamic` run: train on the first temperature cycle, test on the others; raw,
//!   Eq. (11) as published, stepwise regression refitted, LS-SVM on [T, dT/dt] tuned by
//!   blocked cross-validation, and the 64-vector board table; Allan deviations.
//! * [`figures`] and [`report`]: the PNG figures and the report folder (`rlg report`).

pub mod dynamic;
mod error;
pub mod figures;
pub mod pipeline;
pub mod report;
pub mod sparse_eval;
pub mod static_test;

pub use error::ReproError;
pub use rlg_eval::paper;
