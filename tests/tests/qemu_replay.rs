//! The firmware image in QEMU reproduces the host's `Compensator` bit for bit.
//!
//! A deterministic scenario (a gyro body following a 10 → 65 → 10 °C chamber profile at
//! 1 °C/min with holds through a 300 s lag, quantised to 0.01 °C, a −7.1 °/h gyro with
//! pseudo-noise, and injected NaN, out-of-range, spike, dropout and frozen-sensor faults) is
//! compiled into the image, replayed on the emulated Cortex-M4F, and every output
//! sample is compared with `compensator_core::Compensator` run on the host over the same f32
//! inputs with the same model table file.
//!
//! Needs `qemu-system-arm` and the thumb target (`bash tests/setup.sh`). Without QEMU the test
//! fails, unless `RLG_ALLOW_MISSING_TOOLS` is set (then it is skipped with a message).

use std::time::{Duration, Instant};

use compensator_core::{Compensator, SensorLimits, Status};
use tests::firmware::{self, log_field};
use tests::replay;

#[allow(dead_code, missing_docs)]
#[path = "../../firmware/src/model_table.rs"]
mod model_table;

/// QEMU needs well under a second for the scenario; this only catches a hung image.
const QEMU_TIMEOUT: Duration = Duration::from_secs(120);

/// Status bits and their names in the image's summary line.
const BITS: [(Status, &str); 6] = [
    (Status::WARMING_UP, "warming_up"),
    (Status::OUT_OF_RANGE, "out_of_range"),
    (Status::TEMP_FAULT, "temp_fault"),
    (Status::GYRO_FAULT, "gyro_fault"),
    (Status::TABLE_FAULT, "table_fault"),
    (Status::TEMP_STUCK, "temp_stuck"),
];

#[test]
fn qemu_replay_matches_host_bit_for_bit() {
    if !firmware::qemu_or_skip("qemu_replay_matches_host_bit_for_bit") {
        return;
    }
    let t_start = Instant::now();
    let (input, run, t_built) = run_scenario();
    let n = input.len() as u32;
    let (counts, ok) = compare_with_host(&input, &run);
    check_faults(&input, &run);
    check_summary(&run, n, ok, counts);
    check_cost(&run);
    println!(
        "{} samples bit-identical; build {:.1} s, QEMU {:.2} s; counts ok={ok} {:?}",
        n,
        (t_built - t_start).as_secs_f64(),
        run.elapsed.as_secs_f64(),
        BITS.iter().map(|b| b.1).zip(counts).collect::<Vec<_>>()
    );
}

/// Builds the image with the scenario compiled in and runs it in QEMU: the scenario, the run
/// (log printed, exit code and framing checked) and when the build ended.
fn run_scenario() -> (Vec<replay::ReplaySample>, firmware::QemuRun, Instant) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let bin = dir.join("qemu_replay_scenario.bin");
    let elf = dir.join("qemu_replay_firmware.elf");
    let input = replay::scenario();
    replay::write(&bin, &input).expect("write the replay file");

    firmware::build_image(&bin, &elf).unwrap_or_else(|e| panic!("{e}"));
    let t_built = Instant::now();
    let run = firmware::run_qemu(&elf, QEMU_TIMEOUT).unwrap_or_else(|e| panic!("{e}"));
    println!("firmware log ({} lines):", run.log.len());
    for line in &run.log {
        println!("  {line}");
    }
    for line in &run.other_stderr {
        println!("  qemu stderr: {line}");
    }
    assert_eq!(
        run.exit_code,
        Some(0),
        "QEMU exit code (1 = panic/HardFault in the image)"
    );

    // Framing: every sample present, in order.
    let n = input.len() as u32;
    assert_eq!(run.begin_count, Some(n), "B line");
    assert_eq!(run.end_count, Some(n), "E line");
    assert_eq!(run.records.len(), input.len(), "S lines");
    (input, run, t_built)
}

/// Every output sample of the board against the host reference over the same inputs and the
/// same table file; returns the host's count of each status bit of [`BITS`] and of samples ok.
fn compare_with_host(input: &[replay::ReplaySample], run: &firmware::QemuRun) -> ([u64; 6], u64) {
    let mut host = Compensator::new(model_table::MODEL.as_model(), SensorLimits::DEFAULT);
    assert!(host.table_ok(), "the model table must validate");
    let mut counts = [0u64; 6];
    let mut ok = 0u64;
    let mut mismatches = Vec::new();
    for (k, (s, r)) in input.iter().zip(&run.records).enumerate() {
        assert_eq!(r.index, k as u32, "record order");
        // The image saw exactly the replayed bits.
        assert_eq!(
            (r.temp_c_bits, r.gyro_dph_bits),
            (s.temp_c.to_bits(), s.rate_dph.to_bits()),
            "input echo {k}"
        );
        let want = host.update(s.temp_c, s.rate_dph);
        for (c, (bit, _)) in counts.iter_mut().zip(BITS) {
            *c += u64::from(want.status.contains(bit));
        }
        ok += u64::from(want.status.is_ok());
        let got = (r.rate_dph_bits, r.correction_dph_bits, r.status);
        let exp = (
            want.rate_dph.to_bits(),
            want.correction_dph.to_bits(),
            want.status.0,
        );
        if got != exp {
            mismatches.push(format!(
                "sample {k}: board rate {} corr {} status {:#04x}, host rate {} corr {} status {:#04x}",
                f32::from_bits(got.0),
                f32::from_bits(got.1),
                got.2,
                want.rate_dph,
                want.correction_dph,
                exp.2
            ));
        }
    }
    assert!(
        mismatches.is_empty(),
        "{} of {} samples differ, first: {:#?}",
        mismatches.len(),
        input.len(),
        &mismatches[..mismatches.len().min(10)]
    );

    (counts, ok)
}

/// Each injected fault is flagged on the board at its samples, and the board recovers:
/// after a one-sample fault the next sample is compensated again without a warm-up, after
/// the 40-sample dropout the estimator re-warms (WARMING_UP) and then compensates again.
fn check_faults(input: &[replay::ReplaySample], run: &firmware::QemuRun) {
    let status = |k: usize| Status(run.records[k].status);
    let stuck_after = SensorLimits::DEFAULT.stuck_samples as usize;
    for (first, len, fault) in replay::SCENARIO_FAULTS {
        let after = first + len;
        if fault == replay::Injected::StuckTemp {
            // The frozen reading starts one sample before `first` (the last true reading);
            // flagged from its `stuck_after`-th repeat, compensated throughout, and the jump
            // back restarts the estimator (a warm-up, no fault).
            for k in first..after {
                let flagged = k - (first - 1) >= stuck_after;
                assert_eq!(
                    status(k).contains(Status::TEMP_STUCK),
                    flagged,
                    "stuck at sample {k}: status {:#04x}",
                    status(k).0
                );
                assert!(!status(k).contains(Status::TEMP_FAULT), "sample {k}");
            }
            assert!(
                status(after).contains(Status::WARMING_UP) && !status(after).is_fault(),
                "stuck: at sample {after}: {:#04x}",
                status(after).0
            );
        } else {
            let want = match fault {
                replay::Injected::NanRate => Status::GYRO_FAULT,
                _ => Status::TEMP_FAULT,
            };
            for k in first..after {
                assert!(
                    status(k).contains(want),
                    "{fault:?} at sample {k}: status {:#04x}",
                    status(k).0
                );
            }
        }
        if len == 1 {
            assert!(
                !status(after).is_fault() && !status(after).contains(Status::WARMING_UP),
                "{fault:?}: no recovery at sample {after}: {:#04x}",
                status(after).0
            );
        } else {
            assert!(status(after).contains(Status::WARMING_UP));
            // Back to compensating: no fault, warmed up (OUT_OF_RANGE may stay: the
            // scenario ends below the table's trained range, and that is flagged, clamped).
            let back = (after..input.len())
                .find(|&k| !status(k).is_fault() && !status(k).contains(Status::WARMING_UP))
                .expect("recovers after the fault");
            assert!(back - after <= 300, "re-warm took {} samples", back - after);
        }
    }
    // No false alarm of the frozen-sensor rule: the settled holds read one code for minutes,
    // and only the injected frozen span is flagged.
    let (first, len, _) = replay::SCENARIO_FAULTS
        .into_iter()
        .find(|f| f.2 == replay::Injected::StuckTemp)
        .expect("a stuck fault in the scenario");
    for k in 0..input.len() {
        if status(k).contains(Status::TEMP_STUCK) {
            assert!(
                (first..first + len).contains(&k),
                "TEMP_STUCK at sample {k}"
            );
        }
    }
    // Every fault episode was logged once, at its first sample, as a defmt warning.
    let warnings: Vec<&String> = run.log.iter().filter(|l| l.contains("fault 0x")).collect();
    for (first, _, fault) in replay::SCENARIO_FAULTS {
        let at = if fault == replay::Injected::StuckTemp {
            first - 1 + stuck_after
        } else {
            first
        };
        assert!(
            warnings
                .iter()
                .any(|l| l.contains(&format!("sample {at}: fault"))),
            "no warning for {fault:?} at {at}: {warnings:#?}"
        );
    }
}

/// The image's own summary agrees with the host's counts, and the scenario exercises every
/// path but the table fault.
fn check_summary(run: &firmware::QemuRun, n: u32, ok: u64, counts: [u64; 6]) {
    let summary = run
        .log
        .iter()
        .find(|l| l.contains("summary:"))
        .expect("summary line in the defmt log");
    assert_eq!(
        log_field(summary, "samples"),
        Some(u64::from(n)),
        "{summary}"
    );
    assert_eq!(log_field(summary, "ok"), Some(ok), "{summary}");
    for ((_, name), c) in BITS.iter().zip(counts) {
        assert_eq!(log_field(summary, name), Some(c), "{name} in {summary}");
    }
    assert_eq!(
        log_field(summary, "temp_sensor_errors"),
        Some(0),
        "{summary}"
    );
    // The scenario must exercise every path but the table fault, or the comparison is weak.
    for ((bit, name), c) in BITS.iter().zip(counts) {
        if *bit == Status::TABLE_FAULT {
            assert_eq!(c, 0);
        } else {
            assert!(c > 0, "scenario never sets {name}");
        }
    }
}

/// The image's cost figures: the SysTick calibration, the update's cost within the board's
/// budget per support vector, and the table the image started with.
fn check_cost(run: &firmware::QemuRun) {
    // SysTick calibration: a loop of known instruction count against the 40-per-tick claim
    // the cost figures rely on.
    let cal = run
        .log
        .iter()
        .find(|l| l.contains("calibration:"))
        .expect("calibration line");
    let (instr, ticks) = (
        log_field(cal, "instructions").unwrap(),
        log_field(cal, "ticks").unwrap(),
    );
    let per_tick = instr as f64 / ticks as f64;
    assert!(
        (per_tick / 40.0 - 1.0).abs() < 0.01,
        "{per_tick} instructions per SysTick tick: {cal}"
    );
    let cost = run
        .log
        .iter()
        .find(|l| l.contains("cost:"))
        .expect("cost line");
    let field = |k: &str| log_field(cost, k).unwrap_or_else(|| panic!("{k} in {cost}")) as f64;
    println!(
        "update cost (one step: both reads and Compensator::update): mean {:.2} ticks ≈ {:.0} \
         instructions, min {} ≈ {:.0}, max {} ≈ {:.0}",
        field("total") / field("calls"),
        field("total") / field("calls") * per_tick,
        field("min"),
        field("min") * per_tick,
        field("max"),
        field("max") * per_tick
    );
    // The update cost is bounded by the board budget per support vector.
    let per_sv =
        field("total") / field("calls") * per_tick / model_table::MODEL.support.len() as f64;
    assert!(
        per_sv <= tests::budgets::limits::F32_INSTR_PER_SV,
        "{per_sv:.1} instructions per support vector: {cost}"
    );
    let start = run
        .log
        .iter()
        .find(|l| l.contains("model table N="))
        .expect("start line");
    assert_eq!(
        log_field(start, "N"),
        Some(model_table::MODEL.support.len() as u64),
        "{start}"
    );
    assert_eq!(log_field(start, "D"), Some(2), "{start}");
}

/// A panic and a HardFault end QEMU with exit code 1 and a log line, instead of hanging.
#[test]
fn panic_and_hardfault_exit_qemu_with_failure() {
    if !firmware::qemu_or_skip("panic_and_hardfault_exit_qemu_with_failure") {
        return;
    }
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let bin = dir.join("qemu_fault_replay.bin");
    replay::write(&bin, &replay::default_replay()).expect("write the replay file");
    for (fault, marker) in [
        (firmware::FaultInjection::Panic, "injected by RLG_FW_FAULT"),
        (firmware::FaultInjection::HardFault, "HardFault at pc="),
    ] {
        let elf = dir.join(format!("qemu_fault_{fault:?}.elf"));
        firmware::build_faulty_image(&bin, &elf, fault).unwrap_or_else(|e| panic!("{e}"));
        let run =
            firmware::run_qemu(&elf, QEMU_TIMEOUT).unwrap_or_else(|e| panic!("{fault:?}: {e}"));
        println!("{fault:?}: exit {:?}, log {:#?}", run.exit_code, run.log);
        assert_eq!(run.exit_code, Some(1), "{fault:?}");
        assert!(
            run.log.iter().any(|l| l.contains(marker)),
            "{fault:?}: {:?}",
            run.log
        );
        assert!(
            run.records.is_empty(),
            "{fault:?} struck before the first sample"
        );
    }
}

/// `firmware/replay/default.bin` is what [`replay::default_replay`] writes; regenerate it with
/// `RLG_BLESS=1 cargo test -p tests --test qemu_replay default_replay`.
#[test]
fn default_replay_file_is_current() {
    let path = firmware::workspace_root().join("firmware/replay/default.bin");
    let want = replay::encode(&replay::default_replay()).expect("encode");
    if std::env::var_os("RLG_BLESS").is_some() {
        std::fs::write(&path, &want).expect("write default.bin");
    }
    let have = std::fs::read(&path).expect("read firmware/replay/default.bin");
    assert!(
        have == want,
        "firmware/replay/default.bin is stale: rerun with RLG_BLESS=1"
    );
    assert_eq!(replay::decode(&have).expect("decode").len(), 900);
}
