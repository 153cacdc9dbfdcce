//! The fixed-point evaluator against the f64 reference: within 5e-5 °/h over the trained range
//! and along a recording, for the committed board table.
//!
//! Reference: Eq. (10) in f64 over the same table numbers, standardising in f64, so the figure
//! is the whole integer path's error (input conversion to Q24, kernel argument, exp,
//! products, sums) and nothing of the training.

use compensator_core::fixed::{Dph, FixedModel, Q, Z};
use compensator_core::{ModelRef, RateEstimator};
use tests::replay;

/// Budget of the fixed-point path against the f64 reference, °/h.
const BUDGET_DPH: f64 = 5e-5;

fn f64_reference(m: &ModelRef<'_, 2>, x: [f64; 2]) -> f64 {
    let s = m.spec;
    let z: [f64; 2] = core::array::from_fn(|d| {
        (x[d] - f64::from(s.input_mean[d])) * f64::from(s.input_inv_scale[d])
    });
    let g = f64::from(s.gamma);
    m.support
        .iter()
        .zip(m.alpha_dph)
        .map(|(sv, a)| {
            let d2: f64 = (0..2).map(|d| (z[d] - f64::from(sv[d])).powi(2)).sum();
            f64::from(*a) * (-g * d2).exp()
        })
        .sum::<f64>()
        + f64::from(s.bias_dph)
}

/// Support vectors of the committed default table.
const SV: usize = tests::DEFAULT_TABLE_SV;

/// The board's input path: standardise in f32 (as the f32 evaluator does), convert to Q24.
fn fixed_at(fm: &FixedModel<SV, 2>, m: &ModelRef<'_, 2>, x: [f32; 2]) -> Dph {
    let z = m.standardise(&x);
    let zq: [Z; 2] = core::array::from_fn(|d| Q::from_f32_bits(z[d].to_bits()).expect("in range"));
    fm.predict(&zq)
}

fn model() -> (FixedModel<SV, 2>, ModelRef<'static, 2>) {
    let t = tests::default_model_table();
    (
        FixedModel::from_table(t).expect("the board table has a Q form"),
        t.as_model(),
    )
}

#[test]
fn within_budget_over_the_trained_range() {
    let (fm, m) = model();
    let s = m.spec;
    let (mut worst, mut worst_f32, mut sum2, mut n) = (0.0f64, 0.0f64, 0.0f64, 0u32);
    for i in 0..=100 {
        for j in 0..=100 {
            let x = [
                s.input_lo[0] + (s.input_hi[0] - s.input_lo[0]) * i as f32 / 100.0,
                s.input_lo[1] + (s.input_hi[1] - s.input_lo[1]) * j as f32 / 100.0,
            ];
            let want = f64_reference(&m, [f64::from(x[0]), f64::from(x[1])]);
            let e = (fixed_at(&fm, &m, x).to_f64() - want).abs();
            worst = worst.max(e);
            worst_f32 = worst_f32.max((f64::from(m.predict_dph(&x)) - want).abs());
            sum2 += e * e;
            n += 1;
        }
    }
    println!(
        "fixed point vs f64 over the trained range (101×101 grid): max {worst:.2e} °/h, rms {:.2e} °/h; f32 path max {worst_f32:.2e} °/h",
        (sum2 / f64::from(n)).sqrt()
    );
    assert!(worst <= BUDGET_DPH, "max error {worst:e} °/h");
    // The figure is a real error, not a comparison of a thing with itself.
    assert!(worst > 0.0);
}

#[test]
fn within_budget_on_a_recording() {
    let (fm, m) = model();
    let s = m.spec;
    let mut est = RateEstimator::new(s.rate_filter);
    let mut worst = 0.0f64;
    let mut n = 0;
    for r in replay::scenario() {
        // The features the compensator would see (faulty temperatures skipped), clamped.
        if !(r.temp_c > -60.0 && r.temp_c < 130.0) {
            est.skip();
            continue;
        }
        let e = est.update(r.temp_c);
        let x: [f32; 2] = [r.temp_c, e.rate_c_per_s];
        let x: [f32; 2] = core::array::from_fn(|d| x[d].clamp(s.input_lo[d], s.input_hi[d]));
        let want = f64_reference(&m, [f64::from(x[0]), f64::from(x[1])]);
        worst = worst.max((fixed_at(&fm, &m, x).to_f64() - want).abs());
        n += 1;
    }
    println!("fixed point vs f64 along the QEMU scenario ({n} samples): max {worst:.2e} °/h");
    assert!(n > 8000);
    assert!(worst <= BUDGET_DPH, "max error {worst:e} °/h");
}
