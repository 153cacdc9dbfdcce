//! The states behind the opaque C types, in safe Rust: one `compensator_core` compensator per
//! axis, of the table's input count D (1…5), or a pass-through when init failed.
//!
//! The boundary (`lib.rs`) turns the C table into [`Parts`] (checked slices) and the caller's
//! buffer into a reference; everything here is ordinary Rust.

use compensator_core::fixed::{Dph, FixedCompensator, FixedError, FixedModelRef, Z};
use compensator_core::{Compensated, Compensator, ModelSpec, SensorLimits, Status, TableError};

use crate::types::{rlg_error, rlg_output};

/// Written first into an initialised `rlg_compensator` ("RLGF"); any other value there means
/// the state was never initialised.
pub(crate) const F32_MAGIC: u32 = 0x524c_4746;
/// The same for `rlg_fixed_compensator` ("RLGQ").
pub(crate) const FIXED_MAGIC: u32 = 0x524c_4751;

/// A table's numbers as the compensator takes them. `'static`: a C table lives in flash for
/// as long as the program runs (the API documents that it must outlive its states).
#[derive(Clone, Copy, Debug)]
pub struct Parts<const D: usize> {
    /// Scaling, kernel, range, features and dT/dt filter.
    pub spec: ModelSpec<D>,
    /// Standardised support vectors.
    pub support: &'static [[f32; D]],
    /// Coefficients, °/h.
    pub alpha_dph: &'static [f32],
    /// The stored CRC-32.
    pub crc32: u32,
}

/// The integer parts of a fixed-point table.
#[derive(Clone, Copy, Debug)]
pub struct FixedParts<const D: usize> {
    /// Support vectors times √γ, Q24.
    pub support: &'static [[Z; D]],
    /// Coefficients, Q24.
    pub alpha: &'static [Dph],
    /// √γ, Q28.
    pub sqrt_gamma_q28: u32,
    /// Bias, Q24.
    pub bias: Dph,
}

/// The C API's limits: the board's defaults, as the Rust firmware uses them.
const LIMITS: SensorLimits = SensorLimits::DEFAULT;

/// The error code of a rejected table.
pub fn table_error(e: TableError) -> rlg_error {
    match e {
        TableError::Shape => rlg_error::RLG_ERR_TABLE_SHAPE,
        TableError::Checksum { .. } => rlg_error::RLG_ERR_TABLE_CRC,
        _ => rlg_error::RLG_ERR_TABLE_INVALID,
    }
}

/// The error code of a fixed-point form that cannot be used.
pub fn fixed_error(_: FixedError) -> rlg_error {
    rlg_error::RLG_ERR_FIXED_FORM
}

/// The output of a state that compensates nothing: the raw rate (or, when it is not finite,
/// the last good one) with `TABLE_FAULT`, as `Compensator` does for a rejected table.
pub fn pass_through(last_good_dph: &mut f32, gyro_dph: f32) -> rlg_output {
    let (rate_dph, status) = if gyro_dph.is_finite() {
        *last_good_dph = gyro_dph;
        (gyro_dph, Status::TABLE_FAULT)
    } else {
        (*last_good_dph, Status::TABLE_FAULT | Status::GYRO_FAULT)
    };
    rlg_output {
        rate_dph,
        correction_dph: 0.0,
        status: status.0,
    }
}

fn output(c: Compensated) -> rlg_output {
    rlg_output {
        rate_dph: c.rate_dph,
        correction_dph: c.correction_dph,
        status: c.status.0,
    }
}

/// One compensator per input count the library is built for (features `inputs-1` …
/// `inputs-5`): a count left out costs no code.
#[derive(Clone, Debug)]
pub enum AnyD<T1, T2, T3, T4, T5> {
    /// One input.
    #[cfg(feature = "inputs-1")]
    D1(T1),
    /// Two inputs (the paper's [T, dT/dt]).
    #[cfg(feature = "inputs-2")]
    D2(T2),
    /// Three inputs.
    #[cfg(feature = "inputs-3")]
    D3(T3),
    /// Four inputs.
    #[cfg(feature = "inputs-4")]
    D4(T4),
    /// Five inputs.
    #[cfg(feature = "inputs-5")]
    D5(T5),
    /// No input count is built in (never constructed; keeps the type parameters used).
    #[doc(hidden)]
    _None(
        core::convert::Infallible,
        core::marker::PhantomData<(T1, T2, T3, T4, T5)>,
    ),
}

/// Applies `$e` to whichever compensator `$v` holds (bound to `$c`).
macro_rules! each_d {
    ($v:expr, $c:ident => $e:expr) => {
        match $v {
            #[cfg(feature = "inputs-1")]
            AnyD::D1($c) => $e,
            #[cfg(feature = "inputs-2")]
            AnyD::D2($c) => $e,
            #[cfg(feature = "inputs-3")]
            AnyD::D3($c) => $e,
            #[cfg(feature = "inputs-4")]
            AnyD::D4($c) => $e,
            #[cfg(feature = "inputs-5")]
            AnyD::D5($c) => $e,
            AnyD::_None(never, _) => match *never {},
        }
    };
}

/// The f32 compensator of any input count.
pub type F32Any = AnyD<F32Comp<1>, F32Comp<2>, F32Comp<3>, F32Comp<4>, F32Comp<5>>;

/// The f32 compensator of D inputs over a C table (holding its spec).
pub type F32Comp<const D: usize> = Compensator<'static, D, ModelSpec<D>>;

/// The fixed-point compensator of D inputs over a C table.
pub type FixedComp<const D: usize> = FixedCompensator<'static, D, ModelSpec<D>>;

/// The fixed-point compensator of any input count.
pub type FixedAny = AnyD<FixedComp<1>, FixedComp<2>, FixedComp<3>, FixedComp<4>, FixedComp<5>>;

/// What an `rlg_compensator` holds once initialised. `repr(C)`: `magic` comes first, where the
/// boundary reads it before trusting the rest.
#[repr(C)]
#[derive(Clone, Debug)]
pub struct F32State {
    /// [`F32_MAGIC`].
    pub magic: u32,
    /// The pass-through's last good rate, °/h.
    pub last_good_dph: f32,
    /// The compensator; `None` when init failed before one could be built.
    pub comp: Option<F32Any>,
}

/// A compensator of D inputs from checked parts (its table checked: CRC, then content).
pub fn f32_compensator<const D: usize>(p: Parts<D>) -> F32Comp<D> {
    Compensator::from_parts(p.spec, p.support, p.alpha_dph, p.crc32, LIMITS)
}

impl F32Any {
    /// The error code of the table check (`RLG_OK` when the table passed).
    pub fn table_code(&self) -> rlg_error {
        each_d!(self, c => c.table_error().map_or(rlg_error::RLG_OK, table_error))
    }
}

impl F32State {
    /// The state after init: a compensator (whose table may still have failed its check, so
    /// that it passes the raw rate through with `TABLE_FAULT`), or a pass-through.
    pub fn new(comp: Option<F32Any>) -> Self {
        F32State {
            magic: F32_MAGIC,
            last_good_dph: 0.0,
            comp,
        }
    }

    /// One sample.
    pub fn update(&mut self, temp_c: f32, gyro_dph: f32) -> rlg_output {
        match &mut self.comp {
            Some(any) => each_d!(any, c => output(c.update(temp_c, gyro_dph))),
            None => pass_through(&mut self.last_good_dph, gyro_dph),
        }
    }
}

/// What an `rlg_fixed_compensator` holds once initialised.
#[repr(C)]
#[derive(Clone, Debug)]
pub struct FixedState {
    /// [`FIXED_MAGIC`].
    pub magic: u32,
    /// The pass-through's last good rate, °/h.
    pub last_good_dph: f32,
    /// The compensator; `None` when init failed before one could be built.
    pub comp: Option<FixedAny>,
}

/// A fixed-point compensator of D inputs: the table checked (CRC, content), then the integer
/// parts checked against it. On any failure there is none, and the state passes the raw rate
/// through with `TABLE_FAULT` (what a compensator with a rejected table does on the f32 path).
pub fn fixed_compensator<const D: usize>(
    p: Parts<D>,
    q: FixedParts<D>,
) -> Result<FixedComp<D>, rlg_error> {
    let comp = f32_compensator(p);
    if let Some(e) = comp.table_error() {
        return Err(table_error(e));
    }
    let m = compensator_core::ModelRef {
        spec: comp.spec(),
        support: p.support,
        alpha_dph: p.alpha_dph,
    };
    let model = FixedModelRef::verified(&m, q.support, q.alpha, q.sqrt_gamma_q28, q.bias)
        .map_err(fixed_error)?;
    FixedCompensator::new(comp, model).map_err(fixed_error)
}

impl FixedState {
    /// See [`F32State::new`].
    pub fn new(comp: Option<FixedAny>) -> Self {
        FixedState {
            magic: FIXED_MAGIC,
            last_good_dph: 0.0,
            comp,
        }
    }

    /// One sample.
    pub fn update(&mut self, temp_c: f32, gyro_dph: f32) -> rlg_output {
        match &mut self.comp {
            Some(any) => each_d!(any, c => output(c.update(temp_c, gyro_dph))),
            None => pass_through(&mut self.last_good_dph, gyro_dph),
        }
    }
}
