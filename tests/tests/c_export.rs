//! The C header export and the reference C evaluator (`tests/tests/c/rlg_eval.c`), compiled
//! with the host C compiler (`cc`): its CRC equals the table's, and its f(x) agrees with the
//! f64 reference of Eq. (10) within the f32 budget (1e-5 °/h) over the trained range.
//!
//! Without a C compiler the test fails, unless `RLG_ALLOW_MISSING_TOOLS` is set.

use rlg_train::export::F32Model;
use rlg_train::export_c::{c_header, CName};

/// Agreement budget of an f32 evaluator with the f64 reference, °/h.
const BUDGET_DPH: f64 = 1e-5;

#[test]
fn c_evaluator_matches_the_f64_reference_and_the_crc() {
    let table = tests::default_model_table();
    let model = F32Model {
        spec: table.spec,
        support: table.support.to_vec(),
        alpha_dph: table.alpha_dph.to_vec(),
    };
    assert_eq!(model.crc32(), table.crc32);
    let header = c_header(
        &model.as_model(),
        &CName::default(),
        "the committed board table (firmware/src/model_table.rs)",
    )
    .unwrap();
    let s = table.spec;
    let mut xs = Vec::new();
    for i in 0..=60 {
        for j in 0..=60 {
            xs.push(vec![
                s.input_lo[0] + (s.input_hi[0] - s.input_lo[0]) * i as f32 / 60.0,
                s.input_lo[1] + (s.input_hi[1] - s.input_lo[1]) * j as f32 / 60.0,
            ]);
        }
    }
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("c_export");
    // The CRC line is checked against the stored CRC inside `evaluate`.
    let Some(got) = tests::c_header::evaluate(&header, &dir, &xs, table.crc32) else {
        return;
    };
    assert_eq!(got.len(), xs.len());
    let m = table.as_model();
    let mut worst = 0.0f64;
    for (x, g) in xs.iter().zip(&got) {
        let want = tests::budgets::predict_f64(&m, &m.standardise(&[x[0], x[1]]));
        worst = worst.max((g - want).abs());
    }
    println!(
        "C evaluator vs f64 reference over {} points: max {worst:.2e} °/h",
        xs.len()
    );
    assert!(worst <= BUDGET_DPH, "{worst:e}");
    assert!(worst > 0.0, "an f32 evaluator cannot be exact everywhere");
}
