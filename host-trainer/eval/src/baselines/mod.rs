//! The paper's regression baselines: the least-squares polynomial of the static test
//! (Table 1, Fig. 2(a)), stepwise multiple regression over the nine candidate terms, and
//! Eq. (11) as published.

pub mod eq11;
pub mod ols;
pub mod poly;
pub mod static_quad;
pub mod stepwise;

pub use ols::{ols, Ols, OlsError};
pub use poly::{PolyError, PolyFit};
pub use static_quad::{static_polynomial, static_quadratic, StaticPoint, StaticRepro};
pub use stepwise::{
    fit_terms, paper_candidates, stepwise, Candidate, LinearFit, Step, StepAction, StepwiseError,
    StepwiseFit, StepwiseOptions, PAPER_TERMS,
};
