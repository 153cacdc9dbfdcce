//! The close loop end to end on the board: a calibration recording with a hysteresis the
//! paper's model lacks is diagnosed, the finding becomes the play-operator feature (a linear
//! term beside the kernel on [T, dT/dt]), cross-validation adopts it, it beats the
//! [T, dT/dt] LS-SVM on a later recording of the same gyro (which neither the diagnosis nor
//! the training saw), and its exported three-input table runs in QEMU (Cortex-M4F) bit for bit
//! like the host `Compensator`; its C header evaluates as the Rust board code does.
//!
//! Needs `qemu-system-arm` and the thumb target (`bash tests/setup.sh`); without QEMU it fails,
//! unless `RLG_ALLOW_MISSING_TOOLS` is set.

use std::time::Duration;

use compensator_core::Feature;
use rlg_closeloop::{augmented_features, first_cycle_end_s, train_and_score_on, Inputs, Protocol};
use rlg_diagnose::{diagnose, Options, PhysicsModel};
use rlg_physics::Term;
use rlg_simulate::{simulate, Scenario};
use rlg_train::export;
use rlg_train::model::Provenance;
use tests::budgets::{build_image, ImageOptions};
use tests::e2e::compare_with_host;
use tests::firmware;
use tests::replay::{self, ReplaySample};

/// The shortened dynamic scenario with a hysteresis of 6 °C width and ±0.002 °/h added.
fn scenario() -> Scenario {
    rlg_simulate::shipped::dynamic_two_cycles(vec![Term::Hysteresis {
        width_c: 6.0,
        height_dph: 0.002,
        node_lag_s: 0.0,
    }])
    .expect("scenario is valid")
}

#[test]
fn diagnosed_hysteresis_becomes_a_board_feature_that_runs_bit_for_bit() {
    if !firmware::qemu_or_skip("diagnosed_hysteresis_becomes_a_board_feature_that_runs_bit_for_bit")
    {
        return;
    }
    let rec = simulate(&scenario(), 3).expect("simulates").recording;
    let test = simulate(&scenario(), 4).expect("simulates").recording;
    let d = diagnose(&rec, &PhysicsModel::paper(), &Options::default()).expect("diagnoses");
    let (feats, _) = augmented_features(&d);
    assert_eq!(feats.features.len(), 3, "{:#?}", d.findings);
    assert_eq!(feats.linear, [false, false, true]);
    let Feature::TempPlayC { width_mc } = feats.features[2] else {
        panic!("expected the play feature, got {feats:?}");
    };
    assert!(
        (width_mc as f64 / 6000.0 - 1.0).abs() < 0.2,
        "width {width_mc} m°C"
    );

    let prov = Provenance::from_bytes("qemu_close_loop scenario", b"", "qemu_close_loop test");
    let protocol = Protocol::default();
    let base = train_and_score_on(&rec, &test, &Inputs::base(), &protocol, &prov).unwrap();
    let aug = train_and_score_on(&rec, &test, &feats, &protocol, &prov).unwrap();
    for (name, s) in [("[T, dT/dt]", &base), ("augmented", &aug)] {
        println!(
            "{name}: σ = {:.3}, c = {:.3e}, CV rms {:.4e}, test-run 100 s stability {:.4e} °/h (board f32 {:?}, max |f32 − f64| {:.1e})",
            s.sigma, s.c, s.cv_rms_dph, s.test_b100_dph, s.board_b100_dph, s.board_deviation_dph
        );
    }
    assert!(
        protocol.adopts(&base, &aug),
        "cross-validation keeps the base model"
    );
    assert!(
        aug.test_b100_dph < 0.95 * base.test_b100_dph,
        "augmented {} vs base {}",
        aug.test_b100_dph,
        base.test_b100_dph
    );

    // The three-input table on the board, replaying the test run's second cycle (the
    // board's state starts there, as on the host it is compared with).
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let table = dir.join("close_loop_table.rs");
    let source = export::table_source(&aug.model, "qemu_close_loop test").unwrap();
    std::fs::write(&table, source).unwrap();
    let end = first_cycle_end_s(&test).expect("two cycles");
    let split = test.time_s.partition_point(|t| *t <= end);
    let samples: Vec<ReplaySample> = (split..test.len())
        .map(|k| ReplaySample {
            temp_c: test.temp_c[k] as f32,
            rate_dph: test.rate_dph[k] as f32,
        })
        .collect();
    let bin = dir.join("close_loop_replay.bin");
    replay::write(&bin, &samples).unwrap();
    let elf = dir.join("close_loop_firmware.elf");
    let opts = ImageOptions {
        table_file: Some(table),
        ..ImageOptions::default()
    };
    build_image(&bin, &opts, &elf).unwrap_or_else(|e| panic!("{e}"));
    let run = firmware::run_qemu(&elf, Duration::from_secs(300)).unwrap_or_else(|e| panic!("{e}"));
    for line in &run.log {
        println!("  {line}");
    }
    assert_eq!(run.exit_code, Some(0));
    assert!(run.log.iter().any(|l| l.contains("D=3")), "{:?}", run.log);
    assert_eq!(run.records.len(), samples.len());
    let t = export::to_f32::<3>(&aug.model).unwrap();
    let (identical, _) = compare_with_host(t.as_model(), &samples, &run.records);
    println!(
        "{identical} of {} samples bit-identical on the board",
        samples.len()
    );
    assert_eq!(identical, samples.len());

    // Its C header, for a C firmware: the same numbers through the reference C evaluator,
    // over a grid of the three inputs (the play state spans the temperature range).
    let s = &t.spec;
    let at = |d: usize, k: usize| s.input_lo[d] + (s.input_hi[d] - s.input_lo[d]) * k as f32 / 8.0;
    let xs: Vec<Vec<f32>> = (0..=8)
        .flat_map(|i| {
            (0..=8).flat_map(move |j| (0..=8).map(move |k| vec![at(0, i), at(1, j), at(2, k)]))
        })
        .collect();
    let header = export::c_header_source(&aug.model, "qemu_close_loop test").unwrap();
    if let Some(got) = tests::c_header::evaluate(&header, &dir.join("close_loop_c"), &xs, t.crc32())
    {
        let board = t.as_model();
        let worst = xs
            .iter()
            .zip(&got)
            .map(|(x, g)| (g - f64::from(board.predict_dph(&[x[0], x[1], x[2]]))).abs())
            .fold(0.0, f64::max);
        println!(
            "three-input C header vs Rust board code over {} points: max {worst:.2e} °/h",
            xs.len()
        );
        // Two f32 evaluations of one table, each held to its f32 limit of the f64 model.
        let limit = export::precision(&aug.model).unwrap().limit_dph;
        assert!(
            worst <= limit,
            "{worst:e} against the table's limit {limit:e}"
        );
    }
}
