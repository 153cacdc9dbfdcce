//! Benchmark harnesses, kept apart from what they measure: the LS-SVM's scale and speed, and
//! the concealed-effect benchmarks of the diagnosis and of the close loop.

pub mod closeloop;
pub mod diagnose;
pub mod lssvm;
