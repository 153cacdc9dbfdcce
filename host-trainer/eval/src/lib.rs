//! Evaluation: bias stability and Allan deviation, held-out comparison tables, the paper's
//! baselines (least-squares polynomial, stepwise regression, Eq. 11); the paper's published
//! numbers ([`paper`]).

pub mod baselines;
pub mod metrics;
pub mod paper;
