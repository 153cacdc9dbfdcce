//! The board's f32 evaluation of Eq. (10) (`compensator_core`) against the trainer's f64
//! evaluation of the same model, on the numbers the exporter writes (`export::to_f32`).

use compensator_core::{Compensator, Feature, SensorLimits};
use rlg_train::dataset;
use rlg_train::export::to_f32;
use rlg_train::features;
use rlg_train::model::{ModelFile, Provenance};

/// Largest allowed |f32 board output − f64 trainer output| over the trained range, °/h.
///
/// Measured with the board's exp (`fastexp::exp_neg`, 1.5 ulp), `cargo test -p tests --test
/// f32_vs_f64 -- --nocapture`: on the 200×200 grid of the two-input synthetic model
/// 4.2e-7 °/h (σ = 1, c = 1e3) and 9.8e-6 °/h (σ = 0.5, c = 1e5: large, cancelling
/// coefficients; 8.6e-6 with `libm::expf`, so this stress case uses the budget up); along a
/// 12 000 s thermal cycle 4.0e-7 °/h for f(x) and 5.3e-7 °/h for the `Compensator`
/// correction f(x) − reference; 2.8e-6 °/h on the Table 1 static model (σ = 1, c = 1e4,
/// 20 000 points).
pub const F32_VS_F64_BUDGET_DPH: f64 = 1e-5;

/// Deterministic uniform numbers in [0, 1) (xorshift64*), so the data set is fixed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A smooth non-linear bias law, °/h: about −7.1 °/h, ±0.02 °/h over 10…65 °C and ±0.02 °C/s.
fn bias_law_dph(t_c: f64, rate_c_per_s: f64) -> f64 {
    let u = (t_c - 37.5) / 27.5;
    -7.1 - 0.012 * u * u
        + 0.006 * (3.0 * u).sin()
        + 0.4 * rate_c_per_s
        + 8.0 * u * rate_c_per_s * rate_c_per_s
}

fn names2() -> Vec<String> {
    vec![
        Feature::TempC.name().to_string(),
        Feature::TempRateCPerS.name().to_string(),
    ]
}

fn synthetic_model(sigma: f64, c: f64) -> ModelFile {
    let mut rng = Rng(0x0123_4567_89ab_cdef);
    let n = 500;
    let mut x = Vec::with_capacity(n);
    let mut y = Vec::with_capacity(n);
    for _ in 0..n {
        let t = 10.0 + 55.0 * rng.next();
        let r = -0.02 + 0.04 * rng.next();
        // The board's features are f32; train on f32-representable inputs as the trainer does.
        let (t, r) = (f64::from(t as f32), f64::from(r as f32));
        x.push(vec![t, r]);
        y.push(bias_law_dph(t, r) + 2e-4 * (rng.next() - 0.5));
    }
    let prov = Provenance::from_bytes("synthetic", b"synthetic", "f32_vs_f64 test");
    ModelFile::train(&names2(), &x, &y, sigma, c, 60.0, 1.0, false, prov).unwrap()
}

/// Max |f32 − f64| over a grid of `k`×`k` points spanning the trained range.
fn grid_max_diff(m: &ModelFile, k: usize) -> f64 {
    let t = to_f32::<2>(m).unwrap();
    let board = t.as_model();
    let (lo, hi) = (&t.spec.input_lo, &t.spec.input_hi);
    let mut worst = 0.0f64;
    for i in 0..k {
        for j in 0..k {
            let p = [
                lo[0] + (hi[0] - lo[0]) * i as f32 / (k - 1) as f32,
                lo[1] + (hi[1] - lo[1]) * j as f32 / (k - 1) as f32,
            ];
            let f32_out = f64::from(board.predict_dph(&p));
            let f64_out = m.predict_dph(&[f64::from(p[0]), f64::from(p[1])]);
            worst = worst.max((f32_out - f64_out).abs());
        }
    }
    worst
}

#[test]
fn two_input_model_agrees_on_a_dense_grid() {
    for &(sigma, c) in &[(1.0, 1e3), (0.5, 1e5)] {
        let m = synthetic_model(sigma, c);
        // The model must actually fit the law, or agreement would prove little.
        assert!(
            m.training.rms_dph < 2e-4,
            "training RMS {}",
            m.training.rms_dph
        );
        let worst = grid_max_diff(&m, 200);
        eprintln!("σ = {sigma}, c = {c}: grid max |f32 − f64| = {worst:.3e} °/h");
        assert!(
            worst <= F32_VS_F64_BUDGET_DPH,
            "σ = {sigma}, c = {c}: {worst:e} °/h"
        );
    }
}

#[test]
fn two_input_model_agrees_along_a_feature_sequence() {
    let m = synthetic_model(1.0, 1e3);
    let t = to_f32::<2>(&m).unwrap();
    // A thermal cycle: 10 → 65 °C and back at up to ≈ 0.019 °C/s, sampled at 1 Hz.
    let n = 12_000;
    let time: Vec<f64> = (0..n).map(f64::from).collect();
    let temp: Vec<f64> = time
        .iter()
        .map(|s| 37.5 - 27.0 * (2.0 * std::f64::consts::PI * s / 9000.0).cos())
        .collect();
    let series = features::compute(&t.spec.features, &temp, &time, m.rate_tau_s, m.dt_s).unwrap();
    let mut comp = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
    assert!(comp.table_ok());
    let (mut worst_pred, mut worst_corr) = (0.0f64, 0.0f64);
    for (k, row) in series.rows.iter().enumerate() {
        // Clamp to the trained range as the board does.
        let x: Vec<f64> = row
            .iter()
            .zip(m.input_lo.iter().zip(&m.input_hi))
            .map(|(v, (l, h))| v.clamp(*l, *h))
            .collect();
        let p = [x[0] as f32, x[1] as f32];
        let f32_out = f64::from(t.as_model().predict_dph(&p));
        worst_pred =
            worst_pred.max((f32_out - m.predict_dph(&[f64::from(p[0]), f64::from(p[1])])).abs());
        // The full board step: its correction is f(x) − reference.
        let out = comp.update(temp[k] as f32, -7.1);
        if !out.status.is_fault() {
            let want = m.correction_dph(&[f64::from(p[0]), f64::from(p[1])]);
            worst_corr = worst_corr.max((f64::from(out.correction_dph) - want).abs());
        }
    }
    eprintln!("sequence: max |f32 − f64| prediction {worst_pred:.3e} °/h, correction {worst_corr:.3e} °/h");
    assert!(worst_pred <= F32_VS_F64_BUDGET_DPH, "{worst_pred:e}");
    assert!(worst_corr <= F32_VS_F64_BUDGET_DPH, "{worst_corr:e}");
}

/// Yu et al. 2011, Table 1, as shipped in the repository (with its citation comments).
const TABLE1_CSV: &str = include_str!("../../host-trainer/data/yu2011_table1_static.csv");

#[test]
fn table1_static_model_agrees() {
    let d = dataset::table1_from_csv_text(TABLE1_CSV, "table1").unwrap();
    assert_eq!(d.x.len(), 11);
    let prov = Provenance::from_bytes("table1", TABLE1_CSV.as_bytes(), "f32_vs_f64 test");
    let m = ModelFile::train(
        &d.features,
        &d.x,
        &d.y_dph,
        1.0,
        1e4,
        60.0,
        1.0,
        false,
        prov,
    )
    .unwrap();
    let t = to_f32::<1>(&m).unwrap();
    let (lo, hi) = (t.spec.input_lo[0], t.spec.input_hi[0]);
    let k = 20_000;
    let mut worst = 0.0f64;
    for i in 0..k {
        let p = lo + (hi - lo) * i as f32 / (k - 1) as f32;
        let d = f64::from(t.as_model().predict_dph(&[p])) - m.predict_dph(&[f64::from(p)]);
        worst = worst.max(d.abs());
    }
    eprintln!("Table 1 model: max |f32 − f64| = {worst:.3e} °/h");
    assert!(worst <= F32_VS_F64_BUDGET_DPH, "{worst:e}");
}
