//! The model table exported by `host-trainer` and flashed with the firmware.
//!
//! All fields are public so that generated source can build a table in a `const` item. The
//! support vectors are stored already standardised; inputs are standardised on the board with
//! the stored mean and inverse scale, exactly as the trainer did in f64.

use crate::rate::RateFilter;

/// One input feature of the model, computed on the board from the temperature stream.
///
/// Parameters are integers (seconds, milli-degrees) so that the type stays `Eq`/`Hash` and
/// the table's text and CRC carry them exactly. The recursive state of each feature is in
/// [`crate::features`]; its exact update rule is documented there.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Feature {
    /// Gyro temperature sensor reading T, °C.
    TempC,
    /// Rate of change dT/dt from the recursive estimator ([`crate::rate`]), °C/s.
    TempRateCPerS,
    /// Lead-corrected temperature T + τ·dT/dt, °C (sensor-lag correction), τ in s.
    TempLeadC {
        /// Lead time constant τ, s.
        tau_s: u32,
    },
    /// Lagged gradient G with τ·dG/dt = −G + dT/dt, °C/s (gradient-lag term), τ in s.
    TempGradLagCPerS {
        /// Lag time constant τ, s.
        tau_s: u32,
    },
    /// Play-operator (backlash) state of T with total width w, °C (hysteresis term).
    TempPlayC {
        /// Width w of the play band, m°C.
        width_mc: u32,
    },
    /// Time since power-on (first sample), s (warm-up term).
    TimeOnS,
    /// Warm-up transient state e^(−t_on/τ), dimensionless, from 1 at power-on to 0
    /// (warm-up term with the diagnosed time constant; unlike [`Feature::TimeOnS`] it stays
    /// in its trained range however long the board runs).
    WarmupDecay {
        /// Time constant τ, s.
        tau_s: u32,
    },
}

impl Feature {
    /// Stable base name used in model files and exported tables (parameters are not part of
    /// it; [`Feature::parse`] reads the full form written by `Display`).
    pub const fn name(self) -> &'static str {
        match self {
            Feature::TempC => "temp_c",
            Feature::TempRateCPerS => "temp_rate_c_per_s",
            Feature::TempLeadC { .. } => "temp_lead_c",
            Feature::TempGradLagCPerS { .. } => "temp_grad_lag_c_per_s",
            Feature::TempPlayC { .. } => "temp_play_c",
            Feature::TimeOnS => "time_on_s",
            Feature::WarmupDecay { .. } => "warmup_decay",
        }
    }

    /// The parameter's name and value, for parameterised features.
    pub const fn parameter(self) -> Option<(&'static str, u32)> {
        match self {
            Feature::TempLeadC { tau_s }
            | Feature::TempGradLagCPerS { tau_s }
            | Feature::WarmupDecay { tau_s } => Some(("tau_s", tau_s)),
            Feature::TempPlayC { width_mc } => Some(("width_mc", width_mc)),
            Feature::TempC | Feature::TempRateCPerS | Feature::TimeOnS => None,
        }
    }

    /// Inverse of `Display`: `temp_c`, `temp_lead_c(tau_s=600)`, `temp_play_c(width_mc=150)`.
    pub fn parse(spec: &str) -> Option<Self> {
        let (base, param) = match spec.split_once('(') {
            Some((b, rest)) => {
                let inner = rest.strip_suffix(')')?;
                let (k, v) = inner.split_once('=')?;
                (b, Some((k, v.parse::<u32>().ok()?)))
            }
            None => (spec, None),
        };
        let f = match (base, param) {
            ("temp_c", None) => Feature::TempC,
            ("temp_rate_c_per_s", None) => Feature::TempRateCPerS,
            ("time_on_s", None) => Feature::TimeOnS,
            ("temp_lead_c", Some(("tau_s", v))) => Feature::TempLeadC { tau_s: v },
            ("temp_grad_lag_c_per_s", Some(("tau_s", v))) if v > 0 => {
                Feature::TempGradLagCPerS { tau_s: v }
            }
            ("temp_play_c", Some(("width_mc", v))) => Feature::TempPlayC { width_mc: v },
            ("warmup_decay", Some(("tau_s", v))) if v > 0 => Feature::WarmupDecay { tau_s: v },
            _ => return None,
        };
        Some(f)
    }

    /// Inverse of [`Feature::name`] for features without parameters, and of `Display` for
    /// those with (so model files may name either form).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::parse(name)
    }
}

impl core::fmt::Display for Feature {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.parameter() {
            Some((k, v)) => write!(f, "{}({k}={v})", self.name()),
            None => f.write_str(self.name()),
        }
    }
}

/// Everything about a model except its support vectors and coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelSpec<const D: usize> {
    /// What each input dimension is.
    pub features: [Feature; D],
    /// Per-feature mean used for standardisation, in the feature's unit.
    pub input_mean: [f32; D],
    /// Per-feature 1/scale used for standardisation (z = (x − mean)·inv_scale). 0: the
    /// feature is not a kernel input (its support-vector entries are 0); it enters only
    /// through [`ModelSpec::linear_dph`].
    pub input_inv_scale: [f32; D],
    /// Coefficient of each feature's linear term, °/h per feature unit, on (x − mean): the
    /// partially linear model f(x) = Eq. (10) + Σ_d linear_d·(x_d − mean_d), which carries a
    /// diagnosed physics term (a hysteresis, a lagged gradient, a warm-up) with its own
    /// amplitude next to the kernel. All zero: Eq. (10) alone.
    pub linear_dph: [f32; D],
    /// Smallest value of each feature seen in training (raw unit): the valid range starts here.
    pub input_lo: [f32; D],
    /// Largest value of each feature seen in training (raw unit).
    pub input_hi: [f32; D],
    /// Kernel coefficient γ = 1/(2σ²) of Eq. (8), σ in standardised units.
    pub gamma: f32,
    /// Bias b of Eq. (10), °/h.
    pub bias_dph: f32,
    /// Model output at the reference condition, °/h. The compensated rate is
    /// `raw − (f(x) − reference_dph)`: the temperature-dependent part is removed and the
    /// output stays on the gyro's own scale (the fixed bias at the reference condition is left
    /// for the ordinary bias calibration, as in the paper's Eq. 11).
    pub reference_dph: f32,
    /// The dT/dt estimator the trainer used to compute the training features.
    pub rate_filter: RateFilter,
}

/// A complete model table: the spec plus N support vectors of dimension D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelTable<const N: usize, const D: usize> {
    /// Scaling, kernel, bias and feature definitions.
    pub spec: ModelSpec<D>,
    /// Standardised support vectors x_i of Eq. (10).
    pub support: [[f32; D]; N],
    /// Coefficients a_i of Eq. (10), °/h.
    pub alpha_dph: [f32; N],
    /// CRC-32 of the numeric content above, computed by the exporter (stream and algorithm:
    /// [`crate::crc`]); checked at boot by [`ModelTable::verify`].
    pub crc32: u32,
}

impl<const N: usize, const D: usize> ModelTable<N, D> {
    /// A borrowed view used by the evaluator and the compensator.
    pub const fn as_model(&self) -> ModelRef<'_, D> {
        ModelRef {
            spec: &self.spec,
            support: &self.support,
            alpha_dph: &self.alpha_dph,
        }
    }

    /// The table with `crc32` set to the checksum of its content (for tables built in code,
    /// such as tests and synthetic benchmark tables; exported tables carry it already).
    pub fn sealed(mut self) -> Self {
        self.crc32 = self.as_model().content_crc32();
        self
    }

    /// Checks the stored CRC against the content, then [`ModelRef::validate`]: everything the
    /// board checks once at boot before trusting the table.
    pub fn verify(&self) -> Result<(), TableError> {
        self.as_model().verify(self.crc32)
    }
}

/// A borrowed model whose support-vector count is known only at run time (host tests build
/// one from vectors; the board borrows its const [`ModelTable`]).
#[derive(Clone, Copy, Debug)]
pub struct ModelRef<'a, const D: usize> {
    /// Scaling, kernel, bias and feature definitions.
    pub spec: &'a ModelSpec<D>,
    /// Standardised support vectors.
    pub support: &'a [[f32; D]],
    /// Coefficients, °/h; same length as `support`.
    pub alpha_dph: &'a [f32],
}

/// Why a table cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum TableError {
    /// `support` and `alpha_dph` differ in length, or the table is empty.
    Shape,
    /// A stored number is NaN or infinite.
    NonFinite,
    /// A scale is negative, γ is not positive, a range has lo > hi, or a feature outside the
    /// kernel (scale 0) has a non-zero support-vector entry.
    Invalid,
    /// The dT/dt filter gains are outside the stable region.
    RateFilter,
    /// The stored CRC-32 does not match the table's content (corrupted flash or a table
    /// edited after export).
    Checksum {
        /// CRC-32 stored in the table.
        stored: u32,
        /// CRC-32 computed over the content at check time.
        computed: u32,
    },
}

impl core::fmt::Display for TableError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            TableError::Shape => "support vectors and coefficients differ in count, or none",
            TableError::NonFinite => "table holds a NaN or infinite number",
            TableError::Invalid => {
                "table has a negative scale, a non-positive gamma, an empty range, or a kernel entry for a feature outside the kernel"
            }
            TableError::RateFilter => "dT/dt filter gains are outside the stable region",
            TableError::Checksum { stored, computed } => {
                return write!(
                    f,
                    "table CRC-32 mismatch: stored {stored:#010x}, computed {computed:#010x}"
                )
            }
        })
    }
}

impl core::error::Error for TableError {}

impl<const D: usize> ModelRef<'_, D> {
    /// Checks a stored CRC-32 against the content, then [`ModelRef::validate`]: the boot check
    /// of [`ModelTable::verify`] for a table held as parts.
    pub fn verify(&self, stored_crc32: u32) -> Result<(), TableError> {
        let computed = self.content_crc32();
        if computed != stored_crc32 {
            return Err(TableError::Checksum {
                stored: stored_crc32,
                computed,
            });
        }
        self.validate()
    }

    /// Checks everything the evaluator relies on to stay finite.
    pub fn validate(&self) -> Result<(), TableError> {
        let s = self.spec;
        if self.support.is_empty() || self.support.len() != self.alpha_dph.len() {
            return Err(TableError::Shape);
        }
        let scalars = [s.gamma, s.bias_dph, s.reference_dph];
        let all_finite = scalars.iter().all(|v| v.is_finite())
            && self.alpha_dph.iter().all(|v| v.is_finite())
            && self.support.iter().flatten().all(|v| v.is_finite())
            && s.input_mean
                .iter()
                .chain(&s.input_inv_scale)
                .chain(&s.linear_dph)
                .all(|v| v.is_finite())
            && s.input_lo.iter().chain(&s.input_hi).all(|v| v.is_finite());
        if !all_finite {
            return Err(TableError::NonFinite);
        }
        let ranges_ok = s.input_lo.iter().zip(&s.input_hi).all(|(lo, hi)| lo <= hi);
        // `get`, not indexing: the board's 1 Hz path is proven panic-free at link time.
        let outside_kernel_ok =
            s.input_inv_scale.iter().enumerate().all(|(d, inv)| {
                *inv != 0.0 || self.support.iter().all(|sv| sv.get(d) == Some(&0.0))
            });
        if s.gamma <= 0.0
            || s.input_inv_scale.iter().any(|v| *v < 0.0)
            || !ranges_ok
            || !outside_kernel_ok
        {
            return Err(TableError::Invalid);
        }
        if !s.rate_filter.is_stable() {
            return Err(TableError::RateFilter);
        }
        Ok(())
    }
}
