//! The properties the fuzz targets (`tests/fuzz/`) check, as plain functions: the fuzzer
//! calls them on generated inputs, and `tests/tests/fuzz_corpus.rs` replays the kept corpus
//! (and any crash once found) through them on every test run.

use compensator_core::{
    Compensator, Feature, ModelSpec, ModelTable, RateFilter, SensorLimits, Status,
};
use rlg_io::recording::Recording;
use rlg_train::model::ModelFile;

/// The recording reader on arbitrary bytes (as lossy UTF-8): an error or a recording, never
/// a panic; an accepted recording is well-formed, writes and reads back, and its features
/// compute or say why not.
pub fn recording(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    if let Ok(rec) = Recording::parse_csv(&text, "fuzz") {
        assert!(!rec.is_empty());
        assert!(rec.time_s.windows(2).all(|w| w[1] > w[0]));
        assert!(rec
            .rate_dph
            .iter()
            .chain(&rec.temp_c)
            .all(|v| v.is_finite()));
        let _ = rec.unit_warnings();
        if let Ok(csv) = rec.to_csv_string() {
            let back = Recording::parse_csv(&csv, "fuzz round trip").expect("own output reads");
            assert_eq!(back.len(), rec.len());
        }
        let _ = rlg_train::features::compute(
            &[Feature::TempC, Feature::TempRateCPerS],
            &rec.temp_c,
            &rec.time_s,
            60.0,
            1.0,
        );
    }
}

/// The model-file loader and the table exporter on arbitrary bytes: an error or a model,
/// never a panic; a model that loads either exports or says why not.
pub fn model_file(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    if let Ok(m) = ModelFile::from_json(&text, "fuzz") {
        let _ = rlg_train::export::table_source(&m, "fuzz");
        let _ = m.predict_dph(&m.input_lo.clone());
    }
}

/// `Compensator::update` on the input sequence the bytes spell (8 bytes a sample: f32
/// temperature, f32 rate, little-endian), with a two-input table of large cancelling
/// coefficients and a three-input table with recursive features and a linear term.
pub fn core_update(data: &[u8]) {
    run(&TABLE2, data);
    run(&TABLE3, data);
}

/// The two-input spec (also the base of the synthetic budget tables, `crate::budgets`).
pub(crate) const SPEC2: ModelSpec<2> = ModelSpec {
    features: [Feature::TempC, Feature::TempRateCPerS],
    input_mean: [36.4, 0.0],
    input_inv_scale: [0.0419, 174.4],
    linear_dph: [0.0, 0.0],
    input_lo: [11.2, -0.015],
    input_hi: [68.9, 0.015],
    gamma: 0.5,
    bias_dph: -7.1,
    reference_dph: -7.1,
    rate_filter: RateFilter {
        alpha: 0.0327,
        beta: 0.000_272,
        dt_s: 1.0,
        warmup_samples: 300,
    },
};
/// A fuzzing table.
const TABLE2: ModelTable<3, 2> = ModelTable {
    spec: SPEC2,
    support: [[-1.0, 0.0], [0.0, 0.5], [1.0, -0.5]],
    alpha_dph: [1.0e3, -2.0e3, 1.0e3],
    crc32: 0,
};
/// A fuzzing table.
const TABLE3: ModelTable<2, 3> = ModelTable {
    spec: ModelSpec {
        features: [
            Feature::TempC,
            Feature::TempGradLagCPerS { tau_s: 600 },
            Feature::TempPlayC { width_mc: 4000 },
        ],
        input_mean: [36.4, 0.0, 36.0],
        input_inv_scale: [0.0419, 300.0, 0.0],
        linear_dph: [0.0, 0.0, -1.0e-3],
        input_lo: [11.2, -0.01, 10.0],
        input_hi: [68.9, 0.01, 70.0],
        gamma: 0.5,
        bias_dph: -7.1,
        reference_dph: -7.1,
        rate_filter: SPEC2.rate_filter,
    },
    support: [[-1.0, 0.5, 0.0], [1.0, -0.5, 0.0]],
    alpha_dph: [0.01, -0.01],
    crc32: 0,
};

/// Every output finite; a rate that is passed through changed or held is flagged; a
/// non-finite rate is a gyro fault.
fn run<const N: usize, const D: usize>(t: &ModelTable<N, D>, data: &[u8]) {
    let mut c = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
    assert!(c.table_ok());
    for w in data.chunks_exact(8) {
        let temp = f32::from_le_bytes([w[0], w[1], w[2], w[3]]);
        let rate = f32::from_le_bytes([w[4], w[5], w[6], w[7]]);
        let out = c.update(temp, rate);
        assert!(
            out.rate_dph.is_finite() && out.correction_dph.is_finite(),
            "{out:?}"
        );
        if out.correction_dph == 0.0 && rate.is_finite() && out.rate_dph != rate {
            assert!(!out.status.is_ok(), "{out:?}");
        }
        if !rate.is_finite() {
            assert!(out.status.0 & Status::GYRO_FAULT.0 != 0, "{out:?}");
        }
    }
}
