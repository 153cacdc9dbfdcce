//! Training: features from the board's own estimators, datasets from recordings, the LS-SVM
//! of Yu et al. 2011 (Eqs. 8–10; exact, iterative and reduced solvers, tuning), the model file
//! and its export to f32 and to the board's Rust and C tables.

pub mod dataset;
pub mod export;
pub mod export_c;
pub mod export_rs;
pub mod features;
pub mod lssvm;
pub mod model;
pub mod protocol;
