//! Export of a trained model for the board: [`to_f32`], the one conversion from the f64 model
//! file to the board's f32 numbers, the check that the board evaluates them within the limit
//! ([`precision`]), and the files: the Rust table ([`crate::export_rs`]) and the C header
//! ([`crate::export_c`]) print exactly those numbers, and the host tests evaluate exactly those
//! numbers through `compensator_core` (see `tests/tests/f32_vs_f64.rs`).

use std::path::Path;

use compensator_core::{Feature, ModelRef, ModelSpec};

use crate::export_c::{c_header_with, CName};
pub use crate::export_rs::{f32_literal, reference, table_item, table_source};
use crate::features::{self, FeatureError};
use crate::model::{self, ModelError, ModelFile};

/// Why a model could not be exported.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The model file is inconsistent, or the output could not be written.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The model's dT/dt filter parameters do not give a usable filter.
    #[error(transparent)]
    Filter(#[from] FeatureError),
    /// The model has a number of features the board table type is not instantiated for.
    #[error("model has {got} features; the table is being built for {want}")]
    Dimension {
        /// Features in the model.
        got: usize,
        /// Features requested.
        want: usize,
    },
    /// A feature name the board does not know.
    #[error("feature {0:?} is not a board feature")]
    Feature(String),
    /// A value does not fit in a finite f32.
    #[error("{0} does not fit in a finite f32")]
    Range(&'static str),
    /// The converted table fails the board's own validation.
    #[error("the converted table fails board validation: {0}")]
    Table(compensator_core::TableError),
    /// The board's f32 evaluation of the table departs from the f64 model by more than
    /// [`EXPORT_LIMIT_DPH`] somewhere in the trained range.
    #[error("the board's f32 evaluation departs from the model by {deviation_dph:.2e} °/h (limit {limit_dph:.1e} °/h): coefficients up to |a| = {max_alpha_dph:.2e} °/h cancel in f32; retrain with a smaller c")]
    Precision {
        /// Largest |f32 − f64| found, °/h.
        deviation_dph: f64,
        /// The limit, °/h.
        limit_dph: f64,
        /// Largest |a_i| of the model, °/h.
        max_alpha_dph: f64,
    },
}

/// The design budget of |board f32 − trainer f64|, °/h (measured by `tests/tests/f32_vs_f64.rs`;
/// the close loop lowers c until a model meets it).
pub const F32_BUDGET_DPH: f64 = 1e-5;

/// The largest |board f32 − trainer f64| a table may show at export, °/h: five times the
/// f32 budget of the tests (1e-5 °/h, `tests/tests/f32_vs_f64.rs`), the level of the
/// fixed-point budget. A table beyond it would compensate differently on the board than the
/// model that was validated, so it is refused rather than written.
pub const EXPORT_LIMIT_DPH: f64 = 5e-5;

/// Points [`f32_deviation_dph`] probes beyond the support vectors.
const PROBES: usize = 1024;

/// Largest |f32 board correction − f64 correction| over the support vectors and [`PROBES`]
/// quasi-random points (Halton) of the trained input box, °/h, each input rounded to f32
/// first (what the board would see).
pub fn f32_deviation_dph(m: &ModelFile) -> Result<f64, ExportError> {
    Ok(precision(m)?.deviation_dph)
}

/// The f32 evaluation of a table against its f64 model, and the limit it is held to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Precision {
    /// Largest |f32 − f64| of the correction f(x) − reference, °/h ([`f32_deviation_dph`]).
    pub deviation_dph: f64,
    /// Largest |correction| over the same points, °/h.
    pub max_correction_dph: f64,
    /// The limit: [`EXPORT_LIMIT_DPH`], or [`LIMIT_F32_STEPS`] f32 steps of the largest
    /// correction when that is coarser (a correction of ±400 °/h, a MEMS gyro's over a few
    /// °C, is itself only representable to 3e-5 °/h in f32).
    pub limit_dph: f64,
}

/// See [`Precision::limit_dph`]: an f32 sum of a few dozen terms of that size rounds by a
/// few steps of its largest value.
pub const LIMIT_F32_STEPS: f64 = 4.0;

/// One f32 step (unit in the last place) at |v|.
pub fn f32_step(v: f64) -> f64 {
    let r = v.abs() as f32;
    if !r.is_finite() {
        return f64::INFINITY;
    }
    f64::from(f32::from_bits(r.to_bits() + 1) - r)
}

/// [`Precision`] of `m`: its table evaluated in f32 over the support vectors and [`PROBES`]
/// quasi-random points of the trained box.
pub fn precision(m: &ModelFile) -> Result<Precision, ExportError> {
    let (deviation_dph, max_correction_dph) = match m.lssvm.dim() {
        1 => deviation::<1>(m),
        2 => deviation::<2>(m),
        3 => deviation::<3>(m),
        4 => deviation::<4>(m),
        5 => deviation::<5>(m),
        got => Err(ExportError::Dimension { got, want: 5 }),
    }?;
    Ok(Precision {
        deviation_dph,
        max_correction_dph,
        limit_dph: EXPORT_LIMIT_DPH
            .max(LIMIT_F32_STEPS * f32_step(max_correction_dph))
            .max(m.f32_limit_dph.unwrap_or(0.0)),
    })
}

/// The radical inverse of `i` in base `b` (Halton sequence component).
fn radical_inverse(mut i: usize, b: usize) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while i > 0 {
        f /= b as f64;
        r += f * (i % b) as f64;
        i /= b;
    }
    r
}

fn deviation<const D: usize>(m: &ModelFile) -> Result<(f64, f64), ExportError> {
    const PRIMES: [usize; 5] = [2, 3, 5, 7, 11];
    let t = to_f32::<D>(m)?;
    let board = t.as_model();
    let l = &m.lssvm;
    // The board subtracts the correction f(x) − reference, so that is what is compared.
    let reference = t.spec.reference_dph;
    let largest = std::cell::Cell::new(0.0f64);
    let at = |x: [f32; D]| {
        let xf: Vec<f64> = x.iter().map(|v| f64::from(*v)).collect();
        let want = m.correction_dph(&xf);
        largest.set(largest.get().max(want.abs()));
        (f64::from(board.predict_dph(&x) - reference) - want).abs()
    };
    let mut worst = 0.0f64;
    for sv in &l.support {
        let x: [f32; D] = core::array::from_fn(|d| {
            let raw = sv[d] * l.scaling.scale[d] + l.scaling.mean[d];
            (raw.clamp(m.input_lo[d], m.input_hi[d])) as f32
        });
        worst = worst.max(at(x));
    }
    for i in 1..=PROBES {
        let x: [f32; D] = core::array::from_fn(|d| {
            let u = radical_inverse(i, PRIMES[d]);
            (m.input_lo[d] + u * (m.input_hi[d] - m.input_lo[d])) as f32
        });
        worst = worst.max(at(x));
    }
    Ok((worst, largest.get()))
}

/// [`precision`] checked against its limit; returns the deviation, °/h.
pub fn check_precision(m: &ModelFile) -> Result<f64, ExportError> {
    let p = precision(m)?;
    if p.deviation_dph > p.limit_dph || p.deviation_dph.is_nan() {
        return Err(ExportError::Precision {
            deviation_dph: p.deviation_dph,
            limit_dph: p.limit_dph,
            max_alpha_dph: m
                .lssvm
                .alpha_dph
                .iter()
                .fold(0.0, |a, v| f64::max(a, v.abs())),
        });
    }
    Ok(p.deviation_dph)
}

/// The board's numbers for a model: what the exported table holds, in owned form.
#[derive(Clone, Debug, PartialEq)]
pub struct F32Model<const D: usize> {
    /// Scaling, kernel, bias, range, reference and dT/dt filter.
    pub spec: ModelSpec<D>,
    /// Standardised support vectors.
    pub support: Vec<[f32; D]>,
    /// Coefficients a_i, °/h.
    pub alpha_dph: Vec<f32>,
}

impl<const D: usize> F32Model<D> {
    /// A borrowed view for `compensator_core`'s evaluator and compensator.
    pub fn as_model(&self) -> ModelRef<'_, D> {
        ModelRef {
            spec: &self.spec,
            support: &self.support,
            alpha_dph: &self.alpha_dph,
        }
    }

    /// CRC-32 of the table's content, as the board computes it at boot
    /// (`compensator_core::crc`); the exported table stores this value.
    pub fn crc32(&self) -> u32 {
        self.as_model().content_crc32()
    }
}

/// Nearest f32, or an error when it is not finite.
fn f32_of(v: f64, what: &'static str) -> Result<f32, ExportError> {
    let r = v as f32;
    if r.is_finite() {
        Ok(r)
    } else {
        Err(ExportError::Range(what))
    }
}

/// The next f32 towards −∞ / +∞ (finite, non-zero-crossing inputs are all we need here).
fn f32_next(v: f32, down: bool) -> f32 {
    if v == 0.0 {
        let tiny = f32::from_bits(1);
        return if down { -tiny } else { tiny };
    }
    let bits = v.to_bits();
    // For positive v the bit pattern grows with the value; for negative it shrinks.
    let up_bits = if v > 0.0 { bits + 1 } else { bits - 1 };
    let down_bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(if down { down_bits } else { up_bits })
}

/// Range ends are rounded outwards so that every trained point stays inside the f32 range.
fn f32_outward(v: f64, down: bool, what: &'static str) -> Result<f32, ExportError> {
    let r = f32_of(v, what)?;
    let inside = if down {
        f64::from(r) <= v
    } else {
        f64::from(r) >= v
    };
    if inside {
        Ok(r)
    } else {
        f32_of(f64::from(f32_next(r, down)), what)
    }
}

/// Whether the table stores b − reference and a reference of 0 instead of b and the
/// reference: the board sums f(x) in f32 and subtracts the reference, so a gyro whose output
/// sits far from zero would lose its correction to the rounding of the absolute value (at
/// −7 000 °/h one f32 step is 4.9e-4 °/h, ten times [`EXPORT_LIMIT_DPH`]). Folded, the board
/// sums the small correction itself; the compensated output, raw − (f(x) − reference), is the
/// same. Folding applies where one f32 step at the reference exceeds 2 % of the export limit
/// (|reference| ≥ 16 °/h), so tables of gyros near zero keep their literal b.
pub fn folds_reference(reference_dph: f64) -> bool {
    f32_step(reference_dph) > EXPORT_LIMIT_DPH / 50.0 && reference_dph.is_finite()
}

/// Converts the f64 model to the board's f32 table values. Fails when the model has not
/// exactly `D` features, or when the result would fail `ModelRef::validate`.
///
/// Mapping: support vectors, a_i, b, mean, the range (rounded outwards) and `reference_dph`
/// are rounded to nearest f32 (b and the reference after [`folds_reference`]); `input_inv_scale` = 1/scale and γ = 1/(2σ²) are computed in f64
/// and then rounded; the dT/dt filter is `RateFilter::from_tau_s(rate_tau_s, dt_s)` in f32.
pub fn to_f32<const D: usize>(m: &ModelFile) -> Result<F32Model<D>, ExportError> {
    m.validate()?;
    let l = &m.lssvm;
    if l.dim() != D {
        return Err(ExportError::Dimension {
            got: l.dim(),
            want: D,
        });
    }
    let mut feats = [Feature::TempC; D];
    for (slot, name) in feats.iter_mut().zip(&l.features) {
        *slot = Feature::from_name(name).ok_or_else(|| ExportError::Feature(name.clone()))?;
    }
    let per = |v: &[f64], what| -> Result<[f32; D], ExportError> {
        let mut out = [0.0f32; D];
        for (o, x) in out.iter_mut().zip(v) {
            *o = f32_of(*x, what)?;
        }
        Ok(out)
    };
    let kept = m.kept_dph();
    let folded = if folds_reference(kept) { kept } else { 0.0 };
    let mut inv_scale = [0.0f32; D];
    let mut linear = [0.0f32; D];
    let mut lo = [0.0f32; D];
    let mut hi = [0.0f32; D];
    for d in 0..D {
        // A feature outside the kernel gets inverse scale 0: its standardised input is 0 on
        // the board, as in the trainer.
        inv_scale[d] = if l.is_kernel_input(d) {
            f32_of(1.0 / l.scaling.scale[d], "input_inv_scale")?
        } else {
            0.0
        };
        linear[d] = f32_of(l.linear_dph.get(d).copied().unwrap_or(0.0), "linear_dph")?;
        lo[d] = f32_outward(m.input_lo[d], true, "input_lo")?;
        hi[d] = f32_outward(m.input_hi[d], false, "input_hi")?;
    }
    let spec = ModelSpec {
        features: feats,
        input_mean: per(&l.scaling.mean, "input_mean")?,
        input_inv_scale: inv_scale,
        linear_dph: linear,
        input_lo: lo,
        input_hi: hi,
        gamma: f32_of(1.0 / (2.0 * l.sigma * l.sigma), "gamma")?,
        bias_dph: f32_of(l.bias_dph - folded, "bias_dph")?,
        reference_dph: f32_of(kept - folded, "reference_dph")?,
        rate_filter: features::rate_filter(m.rate_tau_s, m.dt_s)?,
    };
    let support = l
        .support
        .iter()
        .map(|sv| per(sv, "support"))
        .collect::<Result<Vec<_>, _>>()?;
    let alpha_dph = l
        .alpha_dph
        .iter()
        .map(|a| f32_of(*a, "alpha_dph"))
        .collect::<Result<Vec<_>, _>>()?;
    let out = F32Model {
        spec,
        support,
        alpha_dph,
    };
    out.as_model().validate().map_err(ExportError::Table)?;
    Ok(out)
}

/// Writes [`table_source`] to `out` atomically.
pub fn write_table(m: &ModelFile, command: &str, out: &Path) -> Result<(), ExportError> {
    let text = table_source(m, command)?;
    model::write_atomic(out, text.as_bytes())?;
    Ok(())
}

/// The language of an exported board table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A Rust const table for `compensator-core` (`.rs`).
    Rust,
    /// A C header with the same f32 numbers (`.h`, [`crate::export_c`]).
    C,
}

impl Format {
    /// The format a file name implies: `.rs` Rust, `.h` C, else none.
    pub fn of_path(path: &Path) -> Option<Format> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("rs") => Some(Format::Rust),
            Some("h") => Some(Format::C),
            _ => None,
        }
    }

    /// The format to write `out` in: the one given, or the one its name implies; an error
    /// when they disagree or when neither says.
    pub fn resolve(given: Option<Format>, out: &Path) -> Result<Format, String> {
        match (given, Format::of_path(out)) {
            (Some(g), Some(p)) if g != p => Err(format!(
                "--format {} but {} is a {} file name; give the name a .{} extension or drop \
                 --format",
                g.name(),
                out.display(),
                p.language(),
                g.extension()
            )),
            (Some(f), _) | (None, Some(f)) => Ok(f),
            (None, None) => Err(format!(
                "cannot tell the format from {}: name it .rs (Rust) or .h (C), or give \
                 --format rust|c",
                out.display()
            )),
        }
    }

    /// `rust` or `c`.
    pub fn name(self) -> &'static str {
        match self {
            Format::Rust => "rust",
            Format::C => "c",
        }
    }

    fn language(self) -> &'static str {
        match self {
            Format::Rust => "Rust",
            Format::C => "C",
        }
    }

    fn extension(self) -> &'static str {
        match self {
            Format::Rust => "rs",
            Format::C => "h",
        }
    }
}

/// The C header of `m` ([`crate::export_c::c_header`]: the f32 numbers of the Rust table),
/// after the same f32 precision check, with the default symbol prefix (`rlg_…`); `what` is the
/// provenance line of its comment.
pub fn c_header_source(m: &ModelFile, what: &str) -> Result<String, ExportError> {
    c_header_source_named(m, &CName::default(), what)
}

/// [`c_header_source`] with the symbol prefix `name` (`<name>_model`, `<NAME>_N`, guard
/// `<NAME>_MODEL_TABLE_H`), so that the headers of several axes can be included together.
pub fn c_header_source_named(
    m: &ModelFile,
    name: &CName,
    what: &str,
) -> Result<String, ExportError> {
    fn header<const D: usize>(
        m: &ModelFile,
        name: &CName,
        what: &str,
    ) -> Result<String, ExportError> {
        c_header_with(&to_f32::<D>(m)?.as_model(), name, what, Some(&reference(m)))
            .map_err(ExportError::Table)
    }
    check_precision(m)?;
    match m.lssvm.dim() {
        1 => header::<1>(m, name, what),
        2 => header::<2>(m, name, what),
        3 => header::<3>(m, name, what),
        4 => header::<4>(m, name, what),
        5 => header::<5>(m, name, what),
        got => Err(ExportError::Dimension { got, want: 5 }),
    }
}

/// Writes the board table of `m` to `out` atomically, in `format` (a C header with the default
/// symbol prefix).
pub fn write_board_table(
    m: &ModelFile,
    command: &str,
    out: &Path,
    format: Format,
) -> Result<(), ExportError> {
    write_board_table_named(m, command, out, format, &CName::default())
}

/// [`write_board_table`] with the C header's symbol prefix `c_name` (ignored for Rust).
pub fn write_board_table_named(
    m: &ModelFile,
    command: &str,
    out: &Path,
    format: Format,
    c_name: &CName,
) -> Result<(), ExportError> {
    let text = match format {
        Format::Rust => table_source(m, command)?,
        Format::C => c_header_source_named(m, c_name, command)?,
    };
    model::write_atomic(out, text.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(sigma: f64, c: f64) -> ModelFile {
        let x: Vec<Vec<f64>> = (0..200)
            .map(|i| {
                let t = i as f64;
                vec![
                    10.0 + 55.0 * (t * 0.618_033_988_7).fract(),
                    0.02 * ((t * 0.414_213_562_4).fract() - 0.5),
                ]
            })
            .collect();
        let y: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, r)| {
                -7.1 + 1e-3 * (r[0] / 9.0).sin() + 0.4 * r[1] + 1e-4 * ((i * 37 % 11) as f64 - 5.0)
            })
            .collect();
        let f = vec!["temp_c".to_string(), "temp_rate_c_per_s".to_string()];
        let prov = crate::model::Provenance::from_bytes("synthetic", b"", "export test");
        ModelFile::train(&f, &x, &y, sigma, c, 60.0, 1.0, false, prov).unwrap()
    }

    /// A well-regularised model exports within the f32 budget; a wide kernel with a huge c
    /// (cancelling coefficients of ~1e5 °/h) is refused with the reason, not written.
    #[test]
    fn exports_are_refused_when_the_board_cannot_evaluate_them() {
        let good = model(1.0, 100.0);
        let d = check_precision(&good).unwrap();
        assert!(d < F32_BUDGET_DPH, "{d}");
        assert!(table_source(&good, "t").is_ok());
        let bad = model(5.0, 1e9);
        let e = table_source(&bad, "t").unwrap_err();
        let ExportError::Precision {
            deviation_dph,
            max_alpha_dph,
            ..
        } = e
        else {
            panic!("{e}");
        };
        assert!(
            deviation_dph > EXPORT_LIMIT_DPH && max_alpha_dph > 1e3,
            "{e}"
        );
        assert!(e.to_string().contains("smaller c"));
    }

    #[test]
    fn literals_round_trip_and_are_float_literals() {
        let mut state: u32 = 0x9e37_79b9;
        let mut samples = vec![
            1.0f32,
            1e-5,
            -7.1,
            0.0,
            -0.0,
            f32::MAX,
            f32::MIN_POSITIVE,
            1e20,
            3.0e-45,
        ];
        for _ in 0..10_000 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let v = f32::from_bits(state);
            if v.is_finite() {
                samples.push(v);
            }
        }
        for v in samples {
            let s = f32_literal(v);
            assert_eq!(s.parse::<f32>().unwrap().to_bits(), v.to_bits(), "{s}");
            assert!(
                s.contains('.') || s.contains('e'),
                "{s} would be an integer literal"
            );
        }
    }

    #[test]
    fn outward_rounding_keeps_the_value_inside() {
        for &v in &[-34.8f64, 63.59, 0.1, -0.1, 1e-7, -1e-7] {
            assert!(f64::from(f32_outward(v, true, "x").unwrap()) <= v);
            assert!(f64::from(f32_outward(v, false, "x").unwrap()) >= v);
        }
        assert!(f32_of(1e300, "x").is_err());
    }

    /// The format comes from --format or the file name; a disagreement or an unknown name
    /// is an error naming the fix.
    #[test]
    fn format_from_flag_or_extension() {
        let p = |s: &str| std::path::PathBuf::from(s);
        assert_eq!(Format::resolve(None, &p("m_table.rs")), Ok(Format::Rust));
        assert_eq!(Format::resolve(None, &p("m_table.h")), Ok(Format::C));
        assert_eq!(
            Format::resolve(Some(Format::C), &p("out.inc")),
            Ok(Format::C)
        );
        let e = Format::resolve(Some(Format::Rust), &p("m_table.h")).unwrap_err();
        assert!(
            e.contains("--format rust") && e.contains("C file name"),
            "{e}"
        );
        let e = Format::resolve(None, &p("m_table.txt")).unwrap_err();
        assert!(e.contains("--format rust|c"), "{e}");
    }

    /// The C header of a model holds its support vectors and is refused, like the Rust
    /// table, when f32 cannot evaluate it.
    #[test]
    fn c_header_of_a_model_file() {
        let good = model(1.0, 100.0);
        let h = c_header_source(&good, "t").unwrap();
        assert!(
            h.contains(&format!("#define RLG_N {}", good.lssvm.support.len())),
            "{h}"
        );
        assert!(c_header_source(&model(5.0, 1e9), "t").is_err());
        // A named header prefixes every symbol, guard and size.
        let x = c_header_source_named(&good, &CName::new("gyro_x").unwrap(), "t").unwrap();
        for want in [
            "#ifndef GYRO_X_MODEL_TABLE_H",
            "#define GYRO_X_N ",
            "gyro_x_support[GYRO_X_N]",
            "rlg_table gyro_x_model",
            "rlg_fixed_table gyro_x_fixed_model",
        ] {
            assert!(x.contains(want), "{want}");
        }
        assert!(!x.contains(" rlg_support") && !x.contains("RLG_N"), "{x}");
        assert!(h.contains("#ifndef RLG_MODEL_TABLE_H") && h.contains("rlg_table rlg_model"));
    }
}
