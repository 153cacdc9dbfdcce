//! The table CRC-32: exported tables carry the checksum the board computes, a flipped bit is a
//! `TABLE_FAULT`, and a board image with a corrupted table keeps running, passing every raw
//! rate through with the fault flag, and logs the mismatch (QEMU).
//!
//! The QEMU part needs `qemu-system-arm` and the thumb target (`bash tests/setup.sh`); without
//! QEMU it fails, unless `RLG_ALLOW_MISSING_TOOLS` is set (then it is skipped with a message).

use compensator_core::{Compensator, SensorLimits, Status, TableError};
use tests::budgets::{self, ImageOptions};
use tests::{firmware, replay};

// Only `MODEL` is checked here; the reference constants are checked in `export_roundtrip.rs`.
#[expect(
    dead_code,
    reason = "the table's reference constants are not read by this test"
)]
mod table1 {
    include!("generated/table1_model.rs");
}

/// The committed tables (board default, Table 1 static) verify: the exporter's CRC equals the
/// board's computation over the compiled numbers.
#[test]
fn committed_tables_verify() {
    tests::default_model_table().verify().unwrap();
    table1::MODEL.verify().unwrap();
}

/// Flipping any single bit of any coefficient of the board table is caught at construction
/// and turns every output into the raw rate with `TABLE_FAULT`.
#[test]
fn any_flipped_coefficient_bit_is_a_table_fault() {
    let good = *tests::default_model_table();
    for k in [0, good.alpha_dph.len() / 2, good.alpha_dph.len() - 1] {
        for bit in [0u32, 11, 22, 23, 30, 31] {
            let mut bad = good;
            bad.alpha_dph[k] = f32::from_bits(bad.alpha_dph[k].to_bits() ^ (1 << bit));
            let mut c = Compensator::from_table(&bad, SensorLimits::DEFAULT);
            assert!(
                matches!(c.table_error(), Some(TableError::Checksum { .. })),
                "coefficient {k} bit {bit}: {:?}",
                c.table_error()
            );
            let out = c.update(30.0, -7.1);
            assert_eq!(
                (out.rate_dph, out.correction_dph, out.status),
                (-7.1, 0.0, Status::TABLE_FAULT)
            );
        }
    }
}

#[test]
fn qemu_corrupted_table_passes_raw_rates_and_keeps_running() {
    if !firmware::qemu_or_skip("qemu_corrupted_table_passes_raw_rates_and_keeps_running") {
        return;
    }
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let bin = dir.join("table_crc_scenario.bin");
    let elf = dir.join("table_crc_firmware.elf");
    let input = replay::scenario();
    replay::write(&bin, &input).unwrap();
    let opts = ImageOptions {
        table_file: None,
        fault: Some("table".into()),
        ..Default::default()
    };
    budgets::build_image(&bin, &opts, &elf).unwrap_or_else(|e| panic!("{e}"));
    let run = firmware::run_qemu(&elf, budgets::QEMU_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
    for l in &run.log {
        println!("  {l}");
    }
    assert_eq!(run.exit_code, Some(0), "the image must finish normally");
    // Started once (a reset would log the start line again) and logged the mismatch.
    let starts = run
        .log
        .iter()
        .filter(|l| l.contains("model table N="))
        .count();
    assert_eq!(starts, 1, "start lines: the image reset");
    let crc = tests::default_model_table().crc32;
    let err = run
        .log
        .iter()
        .find(|l| l.contains("CRC-32 mismatch"))
        .expect("a defmt error for the CRC mismatch");
    assert!(err.starts_with("ERROR"), "{err}");
    assert!(err.contains(&format!("stored {crc:#010x}")), "{err}");
    // Every sample of the 1 Hz stream was processed: raw rate through, TABLE_FAULT set.
    assert_eq!(run.records.len(), input.len());
    for (k, (s, r)) in input.iter().zip(&run.records).enumerate() {
        assert_eq!(r.index, k as u32);
        assert!(r.status & Status::TABLE_FAULT.0 != 0, "sample {k}");
        assert_eq!(r.correction_dph_bits, 0f32.to_bits(), "sample {k}");
        if s.rate_dph.is_finite() {
            assert_eq!(r.rate_dph_bits, s.rate_dph.to_bits(), "sample {k}");
        } else {
            assert!(f32::from_bits(r.rate_dph_bits).is_finite(), "sample {k}");
        }
    }
    let summary = run.log.iter().find(|l| l.contains("summary:")).unwrap();
    assert_eq!(
        firmware::log_field(summary, "table_fault"),
        Some(input.len() as u64),
        "{summary}"
    );
}
