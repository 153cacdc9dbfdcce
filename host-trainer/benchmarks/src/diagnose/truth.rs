//! The truth sidecar: read back exactly, and the hidden term found in it.

use std::path::Path;

use super::cases::BASE_QUANTUM_C;
use super::BenchError;
use rlg_diagnose::candidates::Family;
use rlg_diagnose::Diagnosis;
use rlg_physics::Term;
use rlg_simulate::Truth;

/// The recording's hidden term, from its truth sidecar only: the scenario's term that the
/// benchmark adds beyond the base set (a reading quantum other than the base's).
pub(super) fn hidden_from_truth(truth: &Truth) -> Option<Term> {
    truth
        .scenario
        .terms
        .iter()
        .find(|t| match t {
            Term::TempQuantization { step_c } => (step_c - BASE_QUANTUM_C).abs() > 1e-9,
            _ => Family::from_name(t.name()).is_some(),
        })
        .cloned()
}

pub(super) fn term_from_finding(d: &Diagnosis) -> Option<Term> {
    d.findings.first()?.term()
}

/// JSON value → TOML value, numbers as f64 (integers kept when they are integers).
///
/// The workspace builds serde_json with `arbitrary_precision`, under which serde_json cannot
/// deserialize internally tagged enums such as [`Term`] (numbers reach the tag buffer as
/// maps: "invalid type: map, expected f64"). The truth sidecar is therefore parsed into a
/// `serde_json::Value` and deserialized through `toml::Value`, which has no such limitation.
pub(super) fn json_to_toml(v: &serde_json::Value) -> Option<toml::Value> {
    Some(match v {
        serde_json::Value::Null => return None,
        serde_json::Value::Bool(b) => toml::Value::Boolean(*b),
        serde_json::Value::Number(n) => match n.as_i64() {
            Some(i) => toml::Value::Integer(i),
            None => toml::Value::Float(n.as_f64()?),
        },
        serde_json::Value::String(s) => toml::Value::String(s.clone()),
        serde_json::Value::Array(a) => {
            toml::Value::Array(a.iter().filter_map(json_to_toml).collect())
        }
        serde_json::Value::Object(o) => toml::Value::Table(
            o.iter()
                .filter_map(|(k, v)| json_to_toml(v).map(|t| (k.clone(), t)))
                .collect(),
        ),
    })
}

/// Reads a truth sidecar.
pub fn read_truth(path: &Path) -> Result<Truth, BenchError> {
    let bad = |message: String| BenchError::Truth {
        path: path.display().to_string(),
        message,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    json_to_toml(&v)
        .ok_or_else(|| bad("empty truth".into()))?
        .try_into()
        .map_err(|e: toml::de::Error| bad(e.to_string()))
}
