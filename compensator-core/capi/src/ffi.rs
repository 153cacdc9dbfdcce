//! The `extern "C"` functions: the boundary. Each checks its pointers (NULL, alignment, sizes
//! that fit memory), turns them into references and slices in one `unsafe` block with its
//! safety argument, and hands over to [`crate::state`]. Nothing here can panic.
//!
//! What C must guarantee (the header says it per function): a non-NULL pointer points to a live
//! object of its type (and, for arrays, to as many elements as stated); a table and everything
//! it points to stays valid and unchanged while a state initialised from it is used; no two
//! calls use one state at the same time.
#![allow(unsafe_code)]

use core::mem::{align_of, size_of};

use compensator_core::crc::feature_from_code;
use compensator_core::fixed::{Dph, Z};
use compensator_core::{Feature, ModelSpec, RateFilter};

use crate::state::{
    f32_compensator, fixed_compensator, pass_through, AnyD, F32State, FixedParts, FixedState,
    Parts, F32_MAGIC, FIXED_MAGIC,
};
use crate::types::{
    rlg_compensator, rlg_error, rlg_fixed_compensator, rlg_fixed_table, rlg_output, rlg_table,
};

use rlg_error::{
    RLG_ERR_ALIGNMENT, RLG_ERR_NOT_INITIALIZED, RLG_ERR_NULL, RLG_ERR_TABLE_FEATURE,
    RLG_ERR_TABLE_SHAPE, RLG_OK,
};

// The opaque C types hold the Rust states: checked here for every target the crate is built
// for (the header states one size, enough for 64-bit hosts).
const _: () = assert!(size_of::<F32State>() <= size_of::<rlg_compensator>());
const _: () = assert!(align_of::<F32State>() <= align_of::<rlg_compensator>());
const _: () = assert!(size_of::<FixedState>() <= size_of::<rlg_fixed_compensator>());
const _: () = assert!(align_of::<FixedState>() <= align_of::<rlg_fixed_compensator>());
const _: () = assert!(align_of::<rlg_compensator>() == crate::types::RLG_STATE_ALIGN);
const _: () = assert!(align_of::<rlg_fixed_compensator>() == crate::types::RLG_STATE_ALIGN);

/// `p` as a slice of `len` elements, or why not: NULL, misaligned, or larger than memory.
///
/// # Safety
/// A non-NULL, aligned `p` must point to `len` initialised `T`s that stay valid and unchanged
/// for `'a`.
unsafe fn slice<'a, T>(p: *const T, len: usize) -> Result<&'a [T], rlg_error> {
    if p.is_null() {
        return Err(RLG_ERR_NULL);
    }
    if !p.is_aligned() {
        return Err(RLG_ERR_ALIGNMENT);
    }
    if len
        .checked_mul(size_of::<T>())
        .is_none_or(|bytes| bytes > isize::MAX as usize)
    {
        return Err(RLG_ERR_TABLE_SHAPE);
    }
    // SAFETY: non-NULL and aligned (checked above), at most isize::MAX bytes (checked above);
    // validity of the `len` elements for 'a is the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(p, len) })
}

/// `p` as a mutable slice (see [`slice`]).
///
/// # Safety
/// A non-NULL, aligned `p` must point to `len` `T`s that nothing else accesses during `'a`.
unsafe fn slice_mut<'a, T>(p: *mut T, len: usize) -> Result<&'a mut [T], rlg_error> {
    // SAFETY: the caller's contract is that of `slice` and more.
    unsafe { slice(p, len) }?;
    // SAFETY: checked by `slice` above; exclusive access for 'a is the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts_mut(p, len) })
}

/// D values at `p` as an array.
///
/// # Safety
/// As for [`slice`] with `len` = D.
unsafe fn array<const D: usize>(p: *const f32) -> Result<[f32; D], rlg_error> {
    // SAFETY: the caller's contract.
    let s = unsafe { slice(p, D) }?;
    let mut out = [0.0; D];
    out.copy_from_slice(s);
    Ok(out)
}

/// The f32 parts of a table of D inputs.
///
/// # Safety
/// `t`'s pointers must satisfy [`slice`]'s contract for their documented lengths and `'static`.
unsafe fn parts<const D: usize>(t: &rlg_table) -> Result<Parts<D>, rlg_error> {
    let n = t.n_support as usize;
    if n == 0 {
        return Err(RLG_ERR_TABLE_SHAPE);
    }
    // SAFETY: the table's `features` points to D `rlg_feature`s (the API's contract).
    let codes = unsafe { slice(t.features, D) }?;
    let mut features = [Feature::TempC; D];
    for (f, c) in features.iter_mut().zip(codes) {
        *f = feature_from_code(c.code, c.param).ok_or(RLG_ERR_TABLE_FEATURE)?;
    }
    // SAFETY (the five arrays): each points to D floats (the API's contract).
    let spec = ModelSpec {
        features,
        input_mean: unsafe { array(t.input_mean) }?,
        input_inv_scale: unsafe { array(t.input_inv_scale) }?,
        linear_dph: unsafe { array(t.linear_dph) }?,
        input_lo: unsafe { array(t.input_lo) }?,
        input_hi: unsafe { array(t.input_hi) }?,
        gamma: t.gamma,
        bias_dph: t.bias_dph,
        reference_dph: t.reference_dph,
        rate_filter: RateFilter {
            alpha: t.rate_alpha,
            beta: t.rate_beta,
            dt_s: t.rate_dt_s,
            warmup_samples: t.rate_warmup_samples,
        },
    };
    // SAFETY: `support` points to N × D floats row by row, i.e. N `[f32; D]` (same alignment
    // as f32, no padding), valid for the program's life (the API's contract).
    let support = unsafe { slice(t.support.cast::<[f32; D]>(), n) }?;
    // SAFETY: `alpha_dph` points to N floats, valid for the program's life.
    let alpha_dph = unsafe { slice(t.alpha_dph, n) }?;
    Ok(Parts {
        spec,
        support,
        alpha_dph,
        crc32: t.crc32,
    })
}

/// The integer parts of a fixed-point table of N vectors and D inputs.
///
/// # Safety
/// As for [`parts`].
unsafe fn fixed_parts<const D: usize>(
    t: &rlg_fixed_table,
    n: usize,
) -> Result<FixedParts<D>, rlg_error> {
    // SAFETY: `support_q24` points to N × D int32_t; `Z` is a transparent `i32`, so that is N
    // `[Z; D]` (the API's contract for the lengths and lifetime).
    let support = unsafe { slice(t.support_q24.cast::<[Z; D]>(), n) }?;
    // SAFETY: `alpha_q24` points to N int32_t; `Dph` is a transparent `i32`.
    let alpha = unsafe { slice(t.alpha_q24.cast::<Dph>(), n) }?;
    Ok(FixedParts {
        support,
        alpha,
        sqrt_gamma_q28: t.sqrt_gamma_q28,
        bias: compensator_core::fixed::Q(t.bias_q24),
    })
}

/// The caller's table pointer as a reference.
///
/// # Safety
/// A non-NULL, aligned `t` must point to a valid `T` for `'a`.
unsafe fn table_ref<'a, T>(t: *const T) -> Result<&'a T, rlg_error> {
    // SAFETY: the caller's contract; `slice` checks NULL and alignment.
    let s = unsafe { slice(t, 1) }?;
    s.first().ok_or(RLG_ERR_NULL)
}

/// Dispatches on the table's input count: `$f::<D>()` for D = `$d` in 1…5, for the counts
/// the library is built for (features `inputs-1` … `inputs-5`); another count is a shape error.
macro_rules! by_d {
    ($d:expr, $f:ident ( $($a:expr),* )) => {
        match $d {
            #[cfg(feature = "inputs-1")]
            1 => $f::<1>($($a),*).map(AnyD::D1),
            #[cfg(feature = "inputs-2")]
            2 => $f::<2>($($a),*).map(AnyD::D2),
            #[cfg(feature = "inputs-3")]
            3 => $f::<3>($($a),*).map(AnyD::D3),
            #[cfg(feature = "inputs-4")]
            4 => $f::<4>($($a),*).map(AnyD::D4),
            #[cfg(feature = "inputs-5")]
            5 => $f::<5>($($a),*).map(AnyD::D5),
            _ => Err(RLG_ERR_TABLE_SHAPE),
        }
    };
}

/// A compensator for the table (whose own check may have failed: see its `table_error`).
///
/// # Safety
/// `t` as for [`parts`].
unsafe fn f32_any<const D: usize>(t: &rlg_table) -> Result<crate::state::F32Comp<D>, rlg_error> {
    // SAFETY: the caller's contract.
    let p = unsafe { parts::<D>(t) }?;
    Ok(f32_compensator(p))
}

/// A fixed-point compensator for the table.
///
/// # Safety
/// `t` as for [`parts`] and [`fixed_parts`].
unsafe fn fixed_any<const D: usize>(
    t: &rlg_fixed_table,
) -> Result<crate::state::FixedComp<D>, rlg_error> {
    // SAFETY: the caller's contract.
    let table = unsafe { table_ref(t.table) }?;
    // SAFETY: the caller's contract.
    let p = unsafe { parts::<D>(table) }?;
    // SAFETY: the caller's contract.
    let q = unsafe { fixed_parts::<D>(t, p.support.len()) }?;
    fixed_compensator(p, q)
}

/// The caller's state buffer as the initialised state behind it, or why not.
///
/// # Safety
/// A non-NULL, aligned `p` must point to a live buffer of the opaque type `C`, used by no one
/// else during `'a`; `S` must be a `repr(C)` state with its `u32` magic first that fits `C`.
unsafe fn state_mut<'a, C, S>(p: *mut C, magic: u32) -> Result<&'a mut S, rlg_error> {
    if p.is_null() {
        return Err(RLG_ERR_NULL);
    }
    if !p.is_aligned() {
        return Err(RLG_ERR_ALIGNMENT);
    }
    // SAFETY: the buffer is live and at least 4 bytes, aligned to 8 (checked); any bit pattern
    // is a valid u32.
    let found = unsafe { p.cast::<u32>().read() };
    if found != magic {
        return Err(RLG_ERR_NOT_INITIALIZED);
    }
    // SAFETY: only this crate's init writes the magic, and it writes a whole `S` (which fits
    // the buffer, asserted at compile time) in the same call; the caller may copy that state
    // as bytes (it holds no pointer into itself). Exclusive use is the caller's contract.
    Ok(unsafe { &mut *p.cast::<S>() })
}

/// Writes `s` into the caller's state buffer.
///
/// # Safety
/// As for [`state_mut`], without the magic.
unsafe fn state_write<C, S>(p: *mut C, s: S) -> rlg_error {
    if p.is_null() {
        return RLG_ERR_NULL;
    }
    if !p.is_aligned() {
        return RLG_ERR_ALIGNMENT;
    }
    // SAFETY: non-NULL, aligned, and `S` fits `C` (asserted at compile time); the old
    // contents are not read.
    unsafe { p.cast::<S>().write(s) };
    RLG_OK
}

/// The caller's output pointer as a reference.
///
/// # Safety
/// A non-NULL, aligned `out` must point to a live `rlg_output`.
unsafe fn out_mut<'a>(out: *mut rlg_output) -> Result<&'a mut rlg_output, rlg_error> {
    // SAFETY: the caller's contract.
    let s = unsafe { slice_mut(out, 1) }?;
    s.first_mut().ok_or(RLG_ERR_NULL)
}

/// Initialises one axis's f32 compensator from its table: checks every pointer, the layout
/// (`n_features` in 1…`RLG_MAX_FEATURES`, `n_support` ≥ 1), the feature codes, the stored
/// CRC-32 against the content, then the content (finite numbers, scales, ranges, the dT/dt
/// filter). Call once at boot, before the first `rlg_update`.
///
/// Returns `RLG_OK`, or why the table was refused. A refused table still leaves a usable
/// state (unless `state` itself is NULL or misaligned): every `rlg_update` then passes the raw
/// rate through with `RLG_STATUS_TABLE_FAULT`, so the gyro output never stops.
///
/// `table` and everything it points to must stay valid and unchanged while `state` is used (the
/// generated tables are `static const`).
///
/// # Safety
/// `state`: NULL or a writable `rlg_compensator`. `table`: NULL or a valid `rlg_table` whose
/// non-NULL pointers point to arrays of the stated lengths.
#[no_mangle]
pub unsafe extern "C" fn rlg_init(
    state: *mut rlg_compensator,
    table: *const rlg_table,
) -> rlg_error {
    // SAFETY: the caller's contract on `table`.
    let built = unsafe { table_ref(table) }.and_then(|t| {
        // SAFETY: the caller's contract on the table's arrays.
        unsafe { by_d!(t.n_features, f32_any(t)) }
    });
    let (comp, code) = match built {
        Ok(any) => {
            let code = any.table_code();
            (Some(any), code)
        }
        Err(e) => (None, e),
    };
    // SAFETY: the caller's contract on `state`.
    match unsafe { state_write(state, F32State::new(comp)) } {
        RLG_OK => code,
        e => e,
    }
}

/// Processes one sample of one axis: the temperature T, °C, and the gyro's rate over the last
/// period, °/h. Call it once per table period (`rate_dt_s`, 1 s for the shipped tables), every
/// period, also when a reading failed (pass NAN): the dT/dt estimator counts calls as time.
///
/// Writes the output to `*out` and returns `RLG_OK`; with `RLG_STATUS_TABLE_FAULT` set the raw
/// rate was passed through. For a state that cannot be used (`RLG_ERR_NOT_INITIALIZED`: never
/// set up by `rlg_init`; `RLG_ERR_NULL`, `RLG_ERR_ALIGNMENT`: the `state` pointer) the raw rate
/// is still written to `*out`, with `RLG_STATUS_TABLE_FAULT`; a NULL or misaligned `out` gets
/// nothing.
///
/// # Safety
/// `state`: NULL or an `rlg_compensator` not used concurrently; `out`: NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn rlg_update(
    state: *mut rlg_compensator,
    temp_c: f32,
    gyro_dph: f32,
    out: *mut rlg_output,
) -> rlg_error {
    #[cfg(feature = "no-panic-control")]
    {
        let v: &[u8] = core::hint::black_box(&[1, 2]);
        core::hint::black_box(v[core::hint::black_box(5)]);
    }
    // SAFETY: the caller's contract on `out`.
    let out = match unsafe { out_mut(out) } {
        Ok(o) => o,
        Err(e) => return e,
    };
    // SAFETY: the caller's contract on `state`.
    match unsafe { state_mut::<_, F32State>(state, F32_MAGIC) } {
        Ok(s) => {
            *out = s.update(temp_c, gyro_dph);
            RLG_OK
        }
        Err(e) => {
            *out = pass_through(&mut 0.0, gyro_dph);
            e
        }
    }
}

/// Initialises one axis's fixed-point compensator (Eq. 10 in integers, for FPU-less cores):
/// the f32 table is checked as by `rlg_init`, then each integer part against the conversion of
/// its f32 number, so the table's CRC covers them too. Returns `RLG_OK` or why not; on any
/// failure the state passes the raw rate through with `RLG_STATUS_TABLE_FAULT`.
///
/// # Safety
/// `state`: NULL or a writable `rlg_fixed_compensator`. `table`: NULL or a valid
/// `rlg_fixed_table` whose non-NULL pointers point to arrays of the stated lengths.
#[no_mangle]
pub unsafe extern "C" fn rlg_fixed_init(
    state: *mut rlg_fixed_compensator,
    table: *const rlg_fixed_table,
) -> rlg_error {
    // SAFETY: the caller's contract on `table`.
    let built = unsafe { table_ref(table) }.and_then(|t| {
        // SAFETY: the caller's contract on the inner table.
        let inner = unsafe { table_ref(t.table) }?;
        // SAFETY: the caller's contract on the arrays.
        unsafe { by_d!(inner.n_features, fixed_any(t)) }
    });
    let (comp, code) = match built {
        Ok(any) => (Some(any), RLG_OK),
        Err(e) => (None, e),
    };
    // SAFETY: the caller's contract on `state`.
    match unsafe { state_write(state, FixedState::new(comp)) } {
        RLG_OK => code,
        e => e,
    }
}

/// `rlg_update` for a fixed-point state: the same rules, rates and status bits; the correction
/// is the Q24 model output minus the reference, as the nearest float.
///
/// # Safety
/// `state`: NULL or an `rlg_fixed_compensator` not used concurrently; `out`: NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn rlg_fixed_update(
    state: *mut rlg_fixed_compensator,
    temp_c: f32,
    gyro_dph: f32,
    out: *mut rlg_output,
) -> rlg_error {
    // SAFETY: the caller's contract on `out`.
    let out = match unsafe { out_mut(out) } {
        Ok(o) => o,
        Err(e) => return e,
    };
    // SAFETY: the caller's contract on `state`.
    match unsafe { state_mut::<_, FixedState>(state, FIXED_MAGIC) } {
        Ok(s) => {
            *out = s.update(temp_c, gyro_dph);
            RLG_OK
        }
        Err(e) => {
            *out = pass_through(&mut 0.0, gyro_dph);
            e
        }
    }
}

/// The first error of several, `RLG_OK` if none.
fn first(acc: rlg_error, e: rlg_error) -> rlg_error {
    if acc == RLG_OK {
        e
    } else {
        acc
    }
}

/// Initialises `axes` states, one per axis, each from its own table (`tables[k]` for
/// `states[k]`), as `rlg_init` does each. Writes each axis's code to `errors[k]` when `errors`
/// is not NULL; returns the first error, `RLG_OK` if every axis initialised.
///
/// # Safety
/// `states`: NULL or `axes` writable states; `tables`: NULL or `axes` table pointers (each as
/// for `rlg_init`); `errors`: NULL or `axes` writable codes.
#[no_mangle]
pub unsafe extern "C" fn rlg_init_axes(
    states: *mut rlg_compensator,
    tables: *const *const rlg_table,
    axes: usize,
    errors: *mut rlg_error,
) -> rlg_error {
    // SAFETY: the caller's contract on `states` and `tables`.
    let (states, tables) = match unsafe { (slice_mut(states, axes), slice(tables, axes)) } {
        (Ok(s), Ok(t)) => (s, t),
        (Err(e), _) | (_, Err(e)) => return e,
    };
    let mut errors = if errors.is_null() {
        None
    } else {
        // SAFETY: the caller's contract on `errors`.
        match unsafe { slice_mut(errors, axes) } {
            Ok(e) => Some(e),
            Err(e) => return e,
        }
    };
    let mut result = RLG_OK;
    for (k, (s, t)) in states.iter_mut().zip(tables).enumerate() {
        // SAFETY: `s` is a live state of the caller's array; `*t` as for `rlg_init`.
        let e = unsafe { rlg_init(s, *t) };
        if let Some(slot) = errors.as_deref_mut().and_then(|v| v.get_mut(k)) {
            *slot = e;
        }
        result = first(result, e);
    }
    result
}

/// One sample on each of `axes` axes: `rlg_update(&states[k], temp_c[k], gyro_dph[k],
/// &out[k])` for each k (one temperature per axis: pass the same value where the axes share a
/// sensor). Returns the first error, `RLG_OK` if none.
///
/// # Safety
/// `states`, `temp_c`, `gyro_dph`, `out`: NULL or arrays of `axes` elements (`out` and
/// `states` writable and not used concurrently).
#[no_mangle]
pub unsafe extern "C" fn rlg_update_axes(
    states: *mut rlg_compensator,
    axes: usize,
    temp_c: *const f32,
    gyro_dph: *const f32,
    out: *mut rlg_output,
) -> rlg_error {
    // SAFETY: the caller's contract on the four arrays.
    let arrays = unsafe {
        (
            slice_mut(states, axes),
            slice(temp_c, axes),
            slice(gyro_dph, axes),
            slice_mut(out, axes),
        )
    };
    let (states, temp_c, gyro_dph, out) = match arrays {
        (Ok(s), Ok(t), Ok(g), Ok(o)) => (s, t, g, o),
        (Err(e), ..) | (_, Err(e), ..) | (_, _, Err(e), _) | (.., Err(e)) => return e,
    };
    let mut result = RLG_OK;
    for (((s, t), g), o) in states.iter_mut().zip(temp_c).zip(gyro_dph).zip(out) {
        // SAFETY: `s` and `o` are live elements of the caller's arrays.
        result = first(result, unsafe { rlg_update(s, *t, *g, o) });
    }
    result
}

/// `rlg_init_axes` for fixed-point states.
///
/// # Safety
/// As for `rlg_init_axes`, with fixed-point states and tables.
#[no_mangle]
pub unsafe extern "C" fn rlg_fixed_init_axes(
    states: *mut rlg_fixed_compensator,
    tables: *const *const rlg_fixed_table,
    axes: usize,
    errors: *mut rlg_error,
) -> rlg_error {
    // SAFETY: the caller's contract on `states` and `tables`.
    let (states, tables) = match unsafe { (slice_mut(states, axes), slice(tables, axes)) } {
        (Ok(s), Ok(t)) => (s, t),
        (Err(e), _) | (_, Err(e)) => return e,
    };
    let mut errors = if errors.is_null() {
        None
    } else {
        // SAFETY: the caller's contract on `errors`.
        match unsafe { slice_mut(errors, axes) } {
            Ok(e) => Some(e),
            Err(e) => return e,
        }
    };
    let mut result = RLG_OK;
    for (k, (s, t)) in states.iter_mut().zip(tables).enumerate() {
        // SAFETY: `s` is a live state of the caller's array; `*t` as for `rlg_fixed_init`.
        let e = unsafe { rlg_fixed_init(s, *t) };
        if let Some(slot) = errors.as_deref_mut().and_then(|v| v.get_mut(k)) {
            *slot = e;
        }
        result = first(result, e);
    }
    result
}

/// `rlg_update_axes` for fixed-point states.
///
/// # Safety
/// As for `rlg_update_axes`, with fixed-point states.
#[no_mangle]
pub unsafe extern "C" fn rlg_fixed_update_axes(
    states: *mut rlg_fixed_compensator,
    axes: usize,
    temp_c: *const f32,
    gyro_dph: *const f32,
    out: *mut rlg_output,
) -> rlg_error {
    // SAFETY: the caller's contract on the four arrays.
    let arrays = unsafe {
        (
            slice_mut(states, axes),
            slice(temp_c, axes),
            slice(gyro_dph, axes),
            slice_mut(out, axes),
        )
    };
    let (states, temp_c, gyro_dph, out) = match arrays {
        (Ok(s), Ok(t), Ok(g), Ok(o)) => (s, t, g, o),
        (Err(e), ..) | (_, Err(e), ..) | (_, _, Err(e), _) | (.., Err(e)) => return e,
    };
    let mut result = RLG_OK;
    for (((s, t), g), o) in states.iter_mut().zip(temp_c).zip(gyro_dph).zip(out) {
        // SAFETY: `s` and `o` are live elements of the caller's arrays.
        result = first(result, unsafe { rlg_fixed_update(s, *t, *g, o) });
    }
    result
}
