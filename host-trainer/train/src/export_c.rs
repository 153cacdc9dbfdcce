//! Export of a converted table as a C header, for readout boards whose firmware is C.
//!
//! The header holds exactly the f32 numbers of [`crate::export::to_f32`] (printed with the
//! shortest digits that round-trip, which every C compiler reads back to the same float), the
//! feature list, and the table's CRC-32 (stream and algorithm: `compensator_core::crc`). A
//! reference C evaluator of Eq. (10) that uses it is `tests/tests/c/rlg_eval.c`; the test
//! `tests/tests/c_export.rs` compiles it with the host C compiler and checks it against the
//! f64 reference and the CRC.
//!
//! Names are prefixed `rlg_`; everything is `static const`, so the header may be included in
//! one translation unit.

use std::fmt::Write as _;

use crate::export::{ExportError, F32Model};

/// An f32 as a C float literal that reads back to the same bits (`1.5e0f`, `-7.1e0f`).
pub fn c_float(v: f32) -> String {
    // Rust's `{:e}` is the shortest round-trip form in scientific notation, valid C syntax.
    format!("{v:e}f")
}

fn list(v: &[f32]) -> String {
    let items: Vec<String> = v.iter().map(|x| c_float(*x)).collect();
    format!("{{{}}}", items.join(", "))
}

/// The C header text of `t`; `what` is one line of provenance for the header comment.
pub fn c_header<const D: usize>(t: &F32Model<D>, what: &str) -> Result<String, ExportError> {
    t.as_model().validate().map_err(ExportError::Table)?;
    let s = &t.spec;
    let n = t.support.len();
    let mut o = String::new();
    // Writing to a String cannot fail.
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
        " * compensated rate = raw - (f(x) - reference_dph), all in deg/h. */"
    );
    let _ = writeln!(o, "#ifndef RLG_MODEL_TABLE_H");
    let _ = writeln!(o, "#define RLG_MODEL_TABLE_H");
    let _ = writeln!(o, "#include <stdint.h>");
    let _ = writeln!(o, "#define RLG_N {n}");
    let _ = writeln!(o, "#define RLG_D {D}");
    let names: Vec<String> = s.features.iter().map(|f| format!("\"{f}\"")).collect();
    let _ = writeln!(
        o,
        "/* Feature names (compensator_core::Feature, Display form). */"
    );
    let _ = writeln!(
        o,
        "static const char *const rlg_features[RLG_D] = {{{}}};",
        names.join(", ")
    );
    let _ = writeln!(
        o,
        "static const float rlg_input_mean[RLG_D] = {};",
        list(&s.input_mean)
    );
    let _ = writeln!(
        o,
        "static const float rlg_input_inv_scale[RLG_D] = {};",
        list(&s.input_inv_scale)
    );
    let _ = writeln!(
        o,
        "static const float rlg_linear_dph[RLG_D] = {};",
        list(&s.linear_dph)
    );
    let _ = writeln!(
        o,
        "static const float rlg_input_lo[RLG_D] = {};",
        list(&s.input_lo)
    );
    let _ = writeln!(
        o,
        "static const float rlg_input_hi[RLG_D] = {};",
        list(&s.input_hi)
    );
    let _ = writeln!(o, "static const float rlg_gamma = {};", c_float(s.gamma));
    let _ = writeln!(
        o,
        "static const float rlg_bias_dph = {};",
        c_float(s.bias_dph)
    );
    let _ = writeln!(
        o,
        "static const float rlg_reference_dph = {};",
        c_float(s.reference_dph)
    );
    let r = &s.rate_filter;
    let _ = writeln!(
        o,
        "/* dT/dt estimator (alpha-beta, compensator_core::rate). */"
    );
    let _ = writeln!(
        o,
        "static const float rlg_rate_alpha = {};",
        c_float(r.alpha)
    );
    let _ = writeln!(o, "static const float rlg_rate_beta = {};", c_float(r.beta));
    let _ = writeln!(o, "static const float rlg_rate_dt_s = {};", c_float(r.dt_s));
    let _ = writeln!(
        o,
        "static const uint32_t rlg_rate_warmup_samples = {}u;",
        r.warmup_samples
    );
    let _ = writeln!(
        o,
        "/* Feature codes and parameters as hashed by the CRC (compensator_core::crc). */"
    );
    let codes: Vec<String> = s
        .features
        .iter()
        .map(|f| compensator_core::crc::feature_code(*f).to_string() + "u")
        .collect();
    let params: Vec<String> = s
        .features
        .iter()
        .map(|f| match f.parameter() {
            Some((_, v)) => format!("{v}u"),
            None => "0u".into(),
        })
        .collect();
    let has: Vec<&str> = s
        .features
        .iter()
        .map(|f| if f.parameter().is_some() { "1u" } else { "0u" })
        .collect();
    let _ = writeln!(
        o,
        "static const uint32_t rlg_feature_code[RLG_D] = {{{}}};",
        codes.join(", ")
    );
    let _ = writeln!(
        o,
        "static const uint32_t rlg_feature_has_param[RLG_D] = {{{}}};",
        has.join(", ")
    );
    let _ = writeln!(
        o,
        "static const uint32_t rlg_feature_param[RLG_D] = {{{}}};",
        params.join(", ")
    );
    let _ = writeln!(o, "static const float rlg_support[RLG_N][RLG_D] = {{");
    for sv in &t.support {
        let _ = writeln!(o, "    {},", list(sv));
    }
    let _ = writeln!(o, "}};");
    let _ = writeln!(o, "static const float rlg_alpha_dph[RLG_N] = {{");
    for a in &t.alpha_dph {
        let _ = writeln!(o, "    {},", c_float(*a));
    }
    let _ = writeln!(o, "}};");
    let _ = writeln!(
        o,
        "/* CRC-32/ISO-HDLC of the numeric content (compensator_core::crc). */"
    );
    let _ = writeln!(o, "static const uint32_t rlg_crc32 = {:#010x}u;", t.crc32());
    let _ = writeln!(o, "#endif /* RLG_MODEL_TABLE_H */");
    Ok(o)
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
}
