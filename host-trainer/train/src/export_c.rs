//! Export of a board table as a C header, for readout boards whose firmware is C.
//!
//! The header holds exactly the f32 numbers of the Rust table (printed with the shortest digits
//! that round-trip, which every C compiler reads back to the same float), the feature list, the
//! table's CRC-32 (stream and algorithm: `compensator_core::crc`), and, for the C API of
//! `compensator-core/capi` (`rlg_compensator.h`, which it includes), a ready-to-use table
//! object `<name>_model` for `rlg_init` and, where the table has one, its fixed-point form
//! `<name>_fixed_model` for `rlg_fixed_init`.
//!
//! Every name is prefixed by the table's [`CName`] (`rlg` by default), the include guard is
//! `<NAME>_MODEL_TABLE_H` and the sizes `<NAME>_N`, `<NAME>_D`, so the headers of several
//! axes can be included together. Everything is `static const`.
//!
//! This module only renders text from a `compensator_core` table; the conversion from a model
//! file and the precision check are [`crate::export`]'s, which calls it.

use std::fmt::{self, Write as _};

use compensator_core::fixed::{self, FixedModelRef, Q};
use compensator_core::{ModelRef, TableError};

/// The symbol prefix of a C table header: a C identifier of at most [`CName::MAX_LEN`]
/// characters that is not reserved (no leading `__` or `_` + capital); its upper-case form
/// prefixes the macros.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct CName(String);

/// Why a string is not a [`CName`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{name:?} is not a usable C name prefix: {reason}")]
pub struct CNameError {
    /// The refused string.
    pub name: String,
    /// Why.
    pub reason: &'static str,
}

impl CName {
    /// The longest prefix accepted: with the longest suffix the names stay within the 63
    /// significant characters C guarantees.
    pub const MAX_LEN: usize = 40;
    /// The prefix of the tables exported before names existed (`rlg_support`, …).
    pub const DEFAULT: &'static str = "rlg";

    /// `name` checked as a C identifier prefix.
    pub fn new(name: &str) -> Result<Self, CNameError> {
        let fail = |reason| {
            Err(CNameError {
                name: name.to_string(),
                reason,
            })
        };
        let mut chars = name.chars();
        match chars.next() {
            None => return fail("it is empty"),
            Some(c) if !(c.is_ascii_alphabetic() || c == '_') => {
                return fail("it must start with a letter or '_'")
            }
            _ => {}
        }
        if !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return fail("only ASCII letters, digits and '_' are allowed");
        }
        let b = name.as_bytes();
        if b[0] == b'_'
            && b.get(1)
                .is_some_and(|c| *c == b'_' || c.is_ascii_uppercase())
        {
            return fail("names starting with '__' or '_' and a capital are reserved in C");
        }
        if name.len() > Self::MAX_LEN {
            return fail("it is longer than 40 characters");
        }
        Ok(CName(name.to_string()))
    }

    /// The prefix of objects (`rlg_gyro_x` → `rlg_gyro_x_support`).
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// The prefix of macros (`RLG_GYRO_X_N`).
    pub fn upper(&self) -> String {
        self.0.to_ascii_uppercase()
    }
}

impl Default for CName {
    fn default() -> Self {
        CName(Self::DEFAULT.to_string())
    }
}

impl fmt::Display for CName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::str::FromStr for CName {
    type Err = CNameError;
    fn from_str(s: &str) -> Result<Self, CNameError> {
        CName::new(s)
    }
}

/// An f32 as a C float literal that reads back to the same bits (`1.5e0f`, `-7.1e0f`).
pub fn c_float(v: f32) -> String {
    // Rust's `{:e}` is the shortest round-trip form in scientific notation, valid C syntax.
    format!("{v:e}f")
}

fn list(v: &[f32]) -> String {
    let items: Vec<String> = v.iter().map(|x| c_float(*x)).collect();
    format!("{{{}}}", items.join(", "))
}

/// An `int32_t` literal (the most negative value has no literal of its own).
fn c_i32(v: i32) -> String {
    if v == i32::MIN {
        "(-2147483647 - 1)".to_string()
    } else {
        v.to_string()
    }
}

/// The fixed-point form of a table as the header writes it.
struct FixedParts<const D: usize> {
    /// √γ, Q28.
    sqrt_gamma_q28: u32,
    /// Support vectors times √γ, Q24.
    support: Vec<[i32; D]>,
    /// Coefficients, Q24.
    alpha: Vec<i32>,
    /// Bias, Q24.
    bias: i32,
}

/// The fixed-point parts of `t` (√γ in Q28, support vectors × √γ, coefficients and bias in
/// Q24), exactly as `rlg_fixed_init` checks them; `Err` with the reason when the table has no
/// fixed-point form.
fn fixed_parts<const D: usize>(t: &ModelRef<'_, D>) -> Result<FixedParts<D>, fixed::FixedError> {
    let sg = fixed::sqrt_gamma_q28(t.spec.gamma)?;
    let support = t
        .support
        .iter()
        .map(|sv| fixed::scaled_vector(sv, sg))
        .collect::<Result<Vec<_>, _>>()?;
    let q =
        |v: f32, what| Q::<24>::from_f32_bits(v.to_bits()).ok_or(fixed::FixedError::Range(what));
    let alpha = t
        .alpha_dph
        .iter()
        .map(|a| q(*a, "alpha_dph"))
        .collect::<Result<Vec<_>, _>>()?;
    let bias = q(t.spec.bias_dph, "bias_dph")?;
    q(t.spec.reference_dph, "reference_dph")?;
    // The same check as the board's init (linear terms, Σ|a|): what is written is accepted.
    FixedModelRef::verified(t, &support, &alpha, sg, bias)?;
    Ok(FixedParts {
        sqrt_gamma_q28: sg,
        support: support.iter().map(|v| v.map(|z| z.0)).collect(),
        alpha: alpha.iter().map(|a| a.0).collect(),
        bias: bias.0,
    })
}

/// The C header text of table `t` with symbol prefix `name`; `what` is one line of provenance
/// for the header comment. Refused when the table fails the board's validation.
pub fn c_header<const D: usize>(
    t: &ModelRef<'_, D>,
    name: &CName,
    what: &str,
) -> Result<String, TableError> {
    c_header_with(t, name, what, None)
}

/// The bias at the reference condition and what the board removes, as a header states them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reference {
    /// The reference temperature, °C.
    pub temp_c: f64,
    /// The bias there, °/h.
    pub bias_dph: f64,
    /// Whether the board removes the whole bias (else only its variation about `bias_dph`).
    pub removes_whole: bool,
}

/// [`c_header`] with the reference stated as documented constants (`<NAME>_REFERENCE_TEMP_C`,
/// `<NAME>_REFERENCE_BIAS_DPH`, `<NAME>_REMOVES_WHOLE_BIAS`), where a model file gives it.
/// Macros rather than `static const`s: a translation unit that does not read them must not
/// warn under `-Wall -Wextra`.
pub fn c_header_with<const D: usize>(
    t: &ModelRef<'_, D>,
    name: &CName,
    what: &str,
    reference: Option<&Reference>,
) -> Result<String, TableError> {
    t.validate()?;
    let mut o = String::new();
    header_comment(&mut o, t, name, what);
    spec_constants(&mut o, t, name);
    if let Some(r) = reference {
        reference_constants(&mut o, r, name);
    }
    api_table(&mut o, t, name);
    fixed_form(&mut o, t, name);
    let _ = writeln!(o, "#endif /* {}_MODEL_TABLE_H */", name.upper());
    Ok(o)
}

// Writing to a String cannot fail: the `fmt::Result`s below are dropped.

/// The header's comment: what the table is, Eq. (10), how the C API takes it.
fn header_comment<const D: usize>(o: &mut String, t: &ModelRef<'_, D>, name: &CName, what: &str) {
    let s = t.spec;
    let p = name.as_str();
    let _ = writeln!(o, "/* @generated: LS-SVM temperature model of RLG bias (Yu et al. 2011, Eqs. 8-10) — do not edit.");
    let _ = writeln!(o, " * {what}");
    let _ = writeln!(
        o,
        " * f(x) = sum_i alpha_dph[i] * exp(-gamma * |z - support[i]|^2) + bias_dph"
    );
    let _ = writeln!(
        o,
        " *        + sum_d linear_dph[d] * (x[d] - input_mean[d]),"
    );
    let _ = writeln!(
        o,
        " * z[d] = (x[d] - input_mean[d]) * input_inv_scale[d]; clamp x to [input_lo, input_hi];"
    );
    let _ = writeln!(
        o,
        " * compensated rate = raw - (f(x) - reference_dph), all in deg/h."
    );
    let _ = writeln!(
        o,
        " * With the C API (rlg_compensator.h): rlg_init(&state, &{p}_model), then"
    );
    let _ = writeln!(
        o,
        " * rlg_update(&state, temp_c, gyro_dph, &out) once every {} s. */",
        s.rate_filter.dt_s
    );
}

/// The reference bias, its temperature and what the board removes.
fn reference_constants(o: &mut String, r: &Reference, name: &CName) {
    let u = name.upper();
    let _ = writeln!(
        o,
        "/* The bias at the reference condition (T = REFERENCE_TEMP_C, dT/dt = 0), deg/h, and what\n\
         \x20* the board removes: REMOVES_WHOLE_BIAS 1: raw - f(x), the output centred on zero;\n\
         \x20* 0: raw - (f(x) - REFERENCE_BIAS_DPH), the output centred on REFERENCE_BIAS_DPH. */"
    );
    let _ = writeln!(
        o,
        "#define {u}_REFERENCE_TEMP_C {}",
        c_float(r.temp_c as f32)
    );
    let _ = writeln!(
        o,
        "#define {u}_REFERENCE_BIAS_DPH {}",
        c_float(r.bias_dph as f32)
    );
    let _ = writeln!(
        o,
        "#define {u}_REMOVES_WHOLE_BIAS {}",
        u8::from(r.removes_whole)
    );
}

/// The include guard, the sizes, the feature names and the spec's constants.
fn spec_constants<const D: usize>(o: &mut String, t: &ModelRef<'_, D>, name: &CName) {
    let s = t.spec;
    let n = t.support.len();
    let (p, u) = (name.as_str(), name.upper());
    let _ = writeln!(o, "#ifndef {u}_MODEL_TABLE_H");
    let _ = writeln!(o, "#define {u}_MODEL_TABLE_H");
    let _ = writeln!(o, "#include <stdint.h>");
    let _ = writeln!(o, "#include \"rlg_compensator.h\"");
    let _ = writeln!(o, "#define {u}_N {n}");
    let _ = writeln!(o, "#define {u}_D {D}");
    let names: Vec<String> = s.features.iter().map(|f| format!("\"{f}\"")).collect();
    let _ = writeln!(
        o,
        "/* Feature names (compensator_core::Feature, Display form). */"
    );
    let _ = writeln!(
        o,
        "static const char *const {p}_features[{u}_D] = {{{}}};",
        names.join(", ")
    );
    let vectors = [
        ("input_mean", &s.input_mean),
        ("input_inv_scale", &s.input_inv_scale),
        ("linear_dph", &s.linear_dph),
        ("input_lo", &s.input_lo),
        ("input_hi", &s.input_hi),
    ];
    for (field, v) in vectors {
        let _ = writeln!(o, "static const float {p}_{field}[{u}_D] = {};", list(v));
    }
    let scalars = [
        ("gamma", s.gamma),
        ("bias_dph", s.bias_dph),
        ("reference_dph", s.reference_dph),
    ];
    for (field, v) in scalars {
        let _ = writeln!(o, "static const float {p}_{field} = {};", c_float(v));
    }
    let r = &s.rate_filter;
    let _ = writeln!(
        o,
        "/* dT/dt estimator (alpha-beta, compensator_core::rate). */"
    );
    let _ = writeln!(
        o,
        "static const float {p}_rate_alpha = {};",
        c_float(r.alpha)
    );
    let _ = writeln!(o, "static const float {p}_rate_beta = {};", c_float(r.beta));
    let _ = writeln!(o, "static const float {p}_rate_dt_s = {};", c_float(r.dt_s));
    let _ = writeln!(
        o,
        "static const uint32_t {p}_rate_warmup_samples = {}u;",
        r.warmup_samples
    );
}

/// The feature codes the CRC hashes, the support vectors and coefficients, the CRC and the
/// `rlg_table` object for the C API.
fn api_table<const D: usize>(o: &mut String, t: &ModelRef<'_, D>, name: &CName) {
    let s = t.spec;
    let r = &s.rate_filter;
    let (p, u) = (name.as_str(), name.upper());
    let _ = writeln!(
        o,
        "/* Feature codes and parameters as hashed by the CRC (compensator_core::crc). */"
    );
    let codes: Vec<u32> = s
        .features
        .iter()
        .map(|f| compensator_core::crc::feature_code(*f))
        .collect();
    let params: Vec<u32> = s
        .features
        .iter()
        .map(|f| f.parameter().map_or(0, |(_, v)| v))
        .collect();
    let has: Vec<u32> = s
        .features
        .iter()
        .map(|f| u32::from(f.parameter().is_some()))
        .collect();
    let u32s = |v: &[u32]| {
        v.iter()
            .map(|x| format!("{x}u"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        o,
        "static const uint32_t {p}_feature_code[{u}_D] = {{{}}};",
        u32s(&codes)
    );
    let _ = writeln!(
        o,
        "static const uint32_t {p}_feature_has_param[{u}_D] = {{{}}};",
        u32s(&has)
    );
    let _ = writeln!(
        o,
        "static const uint32_t {p}_feature_param[{u}_D] = {{{}}};",
        u32s(&params)
    );
    let _ = writeln!(o, "static const float {p}_support[{u}_N][{u}_D] = {{");
    for sv in t.support {
        let _ = writeln!(o, "    {},", list(sv));
    }
    let _ = writeln!(o, "}};");
    let _ = writeln!(o, "static const float {p}_alpha_dph[{u}_N] = {{");
    for a in t.alpha_dph {
        let _ = writeln!(o, "    {},", c_float(*a));
    }
    let _ = writeln!(o, "}};");
    let crc = t.content_crc32();
    let _ = writeln!(
        o,
        "/* CRC-32/ISO-HDLC of the numeric content (compensator_core::crc). */"
    );
    let _ = writeln!(o, "static const uint32_t {p}_crc32 = {crc:#010x}u;");
    let pairs: Vec<String> = codes
        .iter()
        .zip(&params)
        .map(|(c, v)| format!("{{{c}u, {v}u}}"))
        .collect();
    let _ = writeln!(
        o,
        "/* The table for the C API: rlg_init(&state, &{p}_model). */"
    );
    let _ = writeln!(
        o,
        "static const rlg_feature {p}_feature_list[{u}_D] = {{{}}};",
        pairs.join(", ")
    );
    let _ = writeln!(o, "static const rlg_table {p}_model = {{");
    let _ = writeln!(o, "    {u}_N, {u}_D, {p}_feature_list,");
    let _ = writeln!(
        o,
        "    {p}_input_mean, {p}_input_inv_scale, {p}_linear_dph, {p}_input_lo, {p}_input_hi,"
    );
    let _ = writeln!(
        o,
        "    {}, {}, {},",
        c_float(s.gamma),
        c_float(s.bias_dph),
        c_float(s.reference_dph)
    );
    let _ = writeln!(
        o,
        "    {}, {}, {}, {}u,",
        c_float(r.alpha),
        c_float(r.beta),
        c_float(r.dt_s),
        r.warmup_samples
    );
    let _ = writeln!(o, "    &{p}_support[0][0], {p}_alpha_dph, {crc:#010x}u,");
    let _ = writeln!(o, "}};");
}

/// The fixed-point form of the table for `rlg_fixed_init`, or why there is none.
fn fixed_form<const D: usize>(o: &mut String, t: &ModelRef<'_, D>, name: &CName) {
    let (p, u) = (name.as_str(), name.upper());
    match fixed_parts(t) {
        Ok(FixedParts {
            sqrt_gamma_q28: sg,
            support,
            alpha,
            bias,
        }) => {
            let _ = writeln!(
                o,
                "/* Fixed-point form (compensator_core::fixed): rlg_fixed_init(&state, &{p}_fixed_model)."
            );
            let _ = writeln!(
                o,
                " * Support vectors times sqrt(gamma) and coefficients in Q24, sqrt(gamma) in Q28;"
            );
            let _ = writeln!(
                o,
                " * rlg_fixed_init checks each against the conversion of the f32 numbers above. */"
            );
            let _ = writeln!(o, "static const int32_t {p}_support_q24[{u}_N][{u}_D] = {{");
            for sv in &support {
                let items: Vec<String> = sv.iter().map(|v| c_i32(*v)).collect();
                let _ = writeln!(o, "    {{{}}},", items.join(", "));
            }
            let _ = writeln!(o, "}};");
            let _ = writeln!(o, "static const int32_t {p}_alpha_q24[{u}_N] = {{");
            for a in &alpha {
                let _ = writeln!(o, "    {},", c_i32(*a));
            }
            let _ = writeln!(o, "}};");
            let _ = writeln!(o, "static const rlg_fixed_table {p}_fixed_model = {{");
            let _ = writeln!(
                o,
                "    &{p}_model, &{p}_support_q24[0][0], {p}_alpha_q24, {sg}u, {},",
                c_i32(bias)
            );
            let _ = writeln!(o, "}};");
        }
        Err(e) => {
            let _ = writeln!(o, "/* No fixed-point form: {e}. */");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_literals_round_trip() {
        for v in [
            1.0f32,
            -7.1,
            1e-5,
            0.041893255,
            174.4377,
            f32::MIN_POSITIVE,
            3.0e-45,
        ] {
            let s = c_float(v);
            let t = s.trim_end_matches('f');
            assert_eq!(t.parse::<f32>().unwrap().to_bits(), v.to_bits(), "{s}");
        }
    }

    /// Identifiers are accepted; empty, non-identifier, reserved and overlong names are not.
    #[test]
    fn names_are_c_identifiers() {
        for ok in ["rlg", "gyro_x", "_imu2", "A1"] {
            assert_eq!(CName::new(ok).unwrap().as_str(), ok);
        }
        assert_eq!(CName::new("gyro_x").unwrap().upper(), "GYRO_X");
        assert_eq!(CName::default().as_str(), "rlg");
        for bad in [
            "",
            "1x",
            "gyro-x",
            "gyro x",
            "__x",
            "_X",
            "ä",
            &"x".repeat(41),
        ] {
            assert!(CName::new(bad).is_err(), "{bad:?}");
        }
        assert!("x;y"
            .parse::<CName>()
            .unwrap_err()
            .to_string()
            .contains("x;y"));
    }

    #[test]
    fn int_literals() {
        assert_eq!(c_i32(-5), "-5");
        assert_eq!(c_i32(i32::MIN), "(-2147483647 - 1)");
    }
}
