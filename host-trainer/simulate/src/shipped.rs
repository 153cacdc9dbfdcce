//! The paper's dynamic scenario as shipped in `host-trainer/scenarios/`, compiled in, and the
//! shortened form of it that the diagnosis' and the close loop's tests start from.

use rlg_physics::Term;

use crate::{Scenario, ScenarioError, Segment};

/// The shipped dynamic scenario (TOML text).
pub const DYNAMIC_TOML: &str = include_str!("../../scenarios/yu2011-dynamic.toml");
/// Where that text lives in the repository (provenance).
pub const DYNAMIC_PATH: &str = "host-trainer/scenarios/yu2011-dynamic.toml";

/// The shipped dynamic scenario: 1 °C/min between 10 and 65 °C with 3 h holds, four cycles.
pub fn dynamic() -> Result<Scenario, ScenarioError> {
    Scenario::from_toml_str(DYNAMIC_TOML, DYNAMIC_PATH)
}

/// [`dynamic`] shortened to two cycles with 1.5 h holds (≈ 9.7 h), its 5 s sensor lag and its
/// backscatter ripple removed (so that the paper's model is the whole truth), with `extra`
/// terms added.
pub fn dynamic_two_cycles(extra: Vec<Term>) -> Result<Scenario, ScenarioError> {
    let mut s = dynamic()?;
    let hold = Segment::Hold { duration_s: 5400.0 };
    let ramp = |to_c: f64| Segment::Ramp {
        to_c,
        rate_c_per_min: 1.0,
    };
    s.profile = vec![Segment::Repeat {
        count: 2,
        segments: vec![hold.clone(), ramp(65.0), hold, ramp(10.0)],
    }];
    s.terms
        .retain(|t| !matches!(t, Term::SensorLag { .. } | Term::Backscatter { .. }));
    s.terms.extend(extra);
    s.validate()?;
    Ok(s)
}
