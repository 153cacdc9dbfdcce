//! The mechanisms of the term library: the kind of a [`Term`](crate::Term) without its
//! parameters. Everything that names a mechanism (the diagnosis' findings, the close loop's
//! features, the benchmarks) takes this type; its snake_case name is the `kind` tag of a term
//! in TOML and JSON.

use core::fmt;
use core::str::FromStr;

use serde::{Deserialize, Serialize};

macro_rules! mechanisms {
    ($($(#[$doc:meta])* $variant:ident => $name:literal,)*) => {
        /// One mechanism of the term library.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum Mechanism {
            $($(#[$doc])* $variant,)*
        }

        impl Mechanism {
            /// Every mechanism, in the library's order.
            pub const ALL: &'static [Mechanism] = &[$(Mechanism::$variant,)*];

            /// The stable name: the term's `kind` tag in TOML and JSON.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Mechanism::$variant => $name,)*
                }
            }
        }
    };
}

mechanisms! {
    /// Constant Earth rate along the input axis.
    EarthRate => "earth_rate",
    /// Polynomial in the body temperature.
    StaticPoly => "static_poly",
    /// Eq. (11)-style terms in dT/dt.
    RateTerms => "rate_terms",
    /// The temperature sensor lags the body.
    SensorLag => "sensor_lag",
    /// A bias from a lagged thermal gradient.
    GradientLag => "gradient_lag",
    /// Different bias on heating and cooling branches (play operator).
    Hysteresis => "hysteresis",
    /// An exponential transient from power-on.
    Warmup => "warmup",
    /// A bias step at a temperature, with switching hysteresis.
    ModeHop => "mode_hop",
    /// A ripple periodic in temperature (lock-in/backscatter with cavity length).
    Backscatter => "backscatter",
    /// A ripple periodic in time.
    Periodic => "periodic",
    /// A linear drift in time.
    Aging => "aging",
    /// White noise that grows away from a temperature.
    Heteroscedastic => "heteroscedastic",
    /// The temperature reading is rounded to a quantum.
    TempQuantization => "temp_quantization",
}

impl Mechanism {
    /// The mechanism of a stable name, `None` for a name the library does not have.
    pub fn from_name(name: &str) -> Option<Mechanism> {
        Mechanism::ALL.iter().copied().find(|m| m.name() == name)
    }
}

impl fmt::Display for Mechanism {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name the term library does not have.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownMechanism(pub String);

impl fmt::Display for UnknownMechanism {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = Mechanism::ALL.iter().map(|m| m.name()).collect();
        write!(
            f,
            "`{}` is not a mechanism of the term library (one of {})",
            self.0,
            names.join(", ")
        )
    }
}

impl std::error::Error for UnknownMechanism {}

impl FromStr for Mechanism {
    type Err = UnknownMechanism;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Mechanism::from_name(s).ok_or_else(|| UnknownMechanism(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The serde name, the `Display` name and `from_name` agree for every mechanism.
    #[test]
    fn names_round_trip() {
        for &m in Mechanism::ALL {
            let json = serde_json::to_string(&m).unwrap();
            assert_eq!(json, format!("\"{}\"", m.name()));
            assert_eq!(serde_json::from_str::<Mechanism>(&json).unwrap(), m);
            assert_eq!(m.to_string().parse::<Mechanism>(), Ok(m));
        }
        assert!("lock_in".parse::<Mechanism>().is_err());
    }
}
