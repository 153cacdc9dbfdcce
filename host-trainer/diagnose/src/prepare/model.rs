//! A physics model: the terms of the shared library a recording is diagnosed against, read
//! from a model file or a scenario file.

use std::path::Path;

use serde::de::IgnoredAny;
use serde::{Deserialize, Serialize};

use crate::DiagnoseError;
use rlg_physics::{Mechanism, Term};

/// A physics model: the terms with initial parameters (TOML `[[terms]]`, as in scenarios;
/// `rlg terms` lists the kinds).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhysicsModel {
    /// Short name.
    #[serde(default)]
    pub name: String,
    /// The terms.
    pub terms: Vec<Term>,
}

/// The paper's model: Earth rate, cubic static polynomial and the rate terms of Eq. (11).
pub const PAPER_MODEL_TOML: &str = include_str!("../../../models/paper.toml");

/// What a model file may hold: a model's keys, and the other keys of a scenario file
/// (`rlg simulate`'s input), which are ignored so that a scenario serves as the model of the
/// physics it simulates. Any other key stays an error that names it. The ignored keys are
/// checked against the scenario's fields by a test.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    #[serde(default)]
    name: String,
    terms: Vec<Term>,
    #[serde(default, rename = "sample_period_s")]
    _sample_period_s: IgnoredAny,
    #[serde(default, rename = "power_on_s")]
    _power_on_s: IgnoredAny,
    #[serde(default, rename = "duration_s")]
    _duration_s: IgnoredAny,
    #[serde(default, rename = "start_c")]
    _start_c: IgnoredAny,
    #[serde(default, rename = "thermal")]
    _thermal: IgnoredAny,
    #[serde(default, rename = "profile")]
    _profile: IgnoredAny,
    #[serde(default, rename = "noise")]
    _noise: IgnoredAny,
}

impl PhysicsModel {
    /// Reads a model file (`--model`): a model, or a scenario whose `[[terms]]` are taken
    /// (see [`PhysicsModel::from_toml`]). Errors name the path.
    pub fn read(path: &Path) -> Result<Self, DiagnoseError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| DiagnoseError::Model {
            origin: origin.clone(),
            message: format!("cannot read the file: {e}"),
        })?;
        Self::from_toml(&text, &origin)
    }

    /// Parses a model from TOML text; `origin` names it in errors. The text is a model
    /// (`name`, `[[terms]]`) or a scenario file, of which only `name` and `[[terms]]` are
    /// read; a key that is neither a model's nor a scenario's is refused by name.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, DiagnoseError> {
        let f: ModelFile = toml::from_str(text).map_err(|e| DiagnoseError::Model {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        let m = PhysicsModel {
            name: f.name,
            terms: f.terms,
        };
        for t in &m.terms {
            t.validate().map_err(|message| DiagnoseError::Model {
                origin: origin.to_string(),
                message,
            })?;
        }
        Ok(m)
    }

    /// The paper's model (see [`PAPER_MODEL_TOML`]).
    pub fn paper() -> Self {
        // The embedded file is checked by a unit test, so this cannot fail at run time.
        Self::from_toml(PAPER_MODEL_TOML, "models/paper.toml").unwrap_or(PhysicsModel {
            name: "paper".into(),
            terms: Vec::new(),
        })
    }

    /// Whether the model holds a term of this mechanism.
    pub fn has(&self, m: Mechanism) -> bool {
        self.terms.iter().any(|t| t.mechanism() == m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// The field names a derived `Deserialize` of a struct asks for (its `FIELDS`), read by a
    /// deserializer that records them and stops.
    fn struct_fields<T: serde::de::DeserializeOwned>() -> BTreeSet<&'static str> {
        use serde::de::{Error as _, Visitor};
        struct Probe<'a>(&'a mut &'static [&'static str]);
        impl<'de> serde::Deserializer<'de> for Probe<'_> {
            type Error = serde::de::value::Error;
            fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
                Err(Self::Error::custom("not a struct"))
            }
            fn deserialize_struct<V: Visitor<'de>>(
                self,
                _: &'static str,
                fields: &'static [&'static str],
                _: V,
            ) -> Result<V::Value, Self::Error> {
                *self.0 = fields;
                Err(Self::Error::custom("fields recorded"))
            }
            serde::forward_to_deserialize_any! {
                bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes
                byte_buf option unit unit_struct newtype_struct seq tuple tuple_struct map enum
                identifier ignored_any
            }
        }
        let mut fields: &'static [&'static str] = &[];
        let _ = T::deserialize(Probe(&mut fields));
        fields.iter().copied().collect()
    }

    /// A model file accepts exactly a scenario's keys (of which it reads `name` and `terms`),
    /// so a scenario field added later is not refused in a model file, and no other key is
    /// silently ignored.
    #[test]
    fn model_file_keys_are_the_scenario_keys() {
        let scenario = struct_fields::<rlg_simulate::Scenario>();
        assert!(scenario.contains("terms") && scenario.contains("noise"));
        assert_eq!(struct_fields::<ModelFile>(), scenario);
    }

    /// The shipped dynamic scenario read as a model gives the simulator's terms.
    #[test]
    fn scenario_file_reads_as_its_terms() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/yu2011-dynamic.toml");
        let m = PhysicsModel::read(&path).expect("the scenario reads as a model");
        let sim = rlg_simulate::shipped::dynamic().expect("the shipped scenario is valid");
        assert_eq!(m.terms, sim.terms);
        assert_eq!(m.name, sim.name);
    }

    /// A key that is neither a model's nor a scenario's is refused by name, with the file's
    /// name; so is a file that cannot be read.
    #[test]
    fn unknown_model_key_is_refused_by_name() {
        let text = format!("nosie = 1.0\n{PAPER_MODEL_TOML}");
        let e = PhysicsModel::from_toml(&text, "typo.toml").expect_err("unknown key");
        let msg = e.to_string();
        assert!(
            msg.contains("typo.toml") && msg.contains("`nosie`"),
            "{msg}"
        );
        let dir = tempfile::tempdir().expect("temp dir");
        let missing = dir.path().join("absent.toml");
        let msg = PhysicsModel::read(&missing)
            .expect_err("no file")
            .to_string();
        assert!(msg.contains("absent.toml"), "{msg}");
    }
}
