//! Evaluation: bias stability and Allan deviation, held-out comparison tables, the paper's
//! baselines (least-squares polynomial, stepwise regression, Eq. 11) and the gyro noise model
//! (IEEE 952 terms with their exact Allan variance and a generator); the paper's published
//! numbers ([`paper`]).

pub mod baselines;
pub mod metrics;
pub mod noise;
pub mod paper;
