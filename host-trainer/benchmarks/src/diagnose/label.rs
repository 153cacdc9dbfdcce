//! The labels of the benchmark: a mechanism, `none` or `unexplained`.

use serde::{Deserialize, Serialize};

use rlg_diagnose::{Diagnosis, Verdict};
use rlg_physics::Mechanism;

/// What a case hid, or what the diagnosis said of it: a mechanism of the term library,
/// nothing, or structure no library term explains. In JSON and in the report its name: the
/// mechanism's, `none` or `unexplained`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Label {
    /// A mechanism of the term library.
    Mechanism(Mechanism),
    /// Nothing hidden; or the diagnosis found the recording consistent with the model.
    None,
    /// The diagnosis found structure but no library term for it.
    Unexplained,
}

impl Label {
    /// The label's name.
    pub fn name(self) -> &'static str {
        match self {
            Label::Mechanism(m) => m.name(),
            Label::None => "none",
            Label::Unexplained => "unexplained",
        }
    }

    /// The label of a name, `None` for a name that is none of them.
    pub fn from_name(name: &str) -> Option<Label> {
        match name {
            "none" => Some(Label::None),
            "unexplained" => Some(Label::Unexplained),
            _ => Mechanism::from_name(name).map(Label::Mechanism),
        }
    }

    /// The diagnosis' label: its first finding's mechanism, or its verdict.
    pub fn of(d: &Diagnosis) -> Label {
        match (d.verdict, d.findings.first()) {
            (Verdict::MissingPhysics, Some(f)) => Label::Mechanism(f.mechanism),
            (Verdict::UnexplainedStructure, _) => Label::Unexplained,
            (Verdict::Consistent, _) | (Verdict::MissingPhysics, None) => Label::None,
        }
    }
}

impl std::fmt::Display for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Label {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Label {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Label::from_name(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("`{name}` is not a label")))
    }
}
