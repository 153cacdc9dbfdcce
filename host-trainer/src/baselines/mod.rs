//! The paper's regression baselines: the least-squares polynomial of the static test
//! (Table 1, Fig. 2(a)), stepwise multiple regression over the nine candidate terms, and
//! Eq. (11) as published.

pub mod ols;
pub mod poly;

pub use ols::{ols, Ols, OlsError};
pub use poly::{PolyError, PolyFit};
