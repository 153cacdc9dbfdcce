//! The C API from C on the host: programs built with the system `cc` against the host library
//! (`librlg_compensator.a`, dev profile) replay the held-out record of the main job (77 426
//! samples), and every output is compared, bit for bit, with the Rust code run here on the same
//! inputs: the f32 `Compensator` and the fixed-point `FixedCompensator` on the committed table,
//! and three axes, each with its own table and symbol prefix, through the multi-axis calls and
//! through the README's example. Bad input (NULL pointers, a corrupted table, NaN, an
//! out-of-range temperature, an update before init) gives the documented codes and bits.
//!
//! The C programs are built once per test binary. Without `cc` the tests fail, unless
//! `RLG_ALLOW_MISSING_TOOLS` is set.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::Instant;

use compensator_core::fixed::{FixedCompensator, FixedModel};
use compensator_core::{Compensated, Compensator, ModelTable, SensorLimits, Status};
use tests::capi::{self, OutputBits};
use tests::replay::{self, ReplaySample};

/// Support vectors of the three-axis set (the committed table's size).
const N: usize = tests::DEFAULT_TABLE_SV;

/// What every test here shares: the record, the three axes' tables, the built programs.
struct Setup {
    record: Vec<ReplaySample>,
    replay_file: PathBuf,
    axes: [ModelTable<N, 2>; 3],
    replay_exe: PathBuf,
    readme_exe: PathBuf,
    bad_exe: PathBuf,
}

/// The table of axis `k`: the committed table for x, synthetic 64-vector tables for y and z.
fn axis_table(k: usize) -> ModelTable<N, 2> {
    if k == 0 {
        *tests::default_model_table()
    } else {
        let t = tests::budgets::synthetic_table(N, 2011 + k as u64);
        tests::budgets::sized::<N>(&t).expect("N vectors")
    }
}

/// The `c` code block of the README's "Using the compensator from C".
fn readme_example() -> String {
    let readme = std::fs::read_to_string(
        tests::firmware::workspace_root().join("compensator-core/capi/README.md"),
    )
    .expect("compensator-core/capi/README.md");
    let section = readme
        .split("## Using the compensator from C")
        .nth(1)
        .expect("the README's section");
    let start = section.find("```c\n").expect("a c block") + 5;
    let len = section[start..].find("```").expect("its end");
    section[start..start + len].to_string()
}

fn compile(dir: &Path, source: &Path, exe: &Path) {
    let mut cmd = Command::new("cc");
    cmd.args(["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror"])
        .arg("-I")
        .arg(capi::include_dir())
        .arg("-I")
        .arg(dir)
        .arg(source)
        .arg(dir.join("librlg_compensator.a"))
        .args(capi::HOST_NATIVE_LIBS)
        .arg("-o")
        .arg(exe);
    capi::run_compiler(&mut cmd).unwrap_or_else(|e| panic!("{e}"));
}

fn setup() -> Option<&'static Setup> {
    static SETUP: OnceLock<Option<Setup>> = OnceLock::new();
    SETUP
        .get_or_init(|| {
            if !capi::tool_or_skip("C API host tests", "cc") {
                return None;
            }
            let t0 = Instant::now();
            let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c_api_host");
            std::fs::create_dir_all(&dir).unwrap();
            capi::build_library(None, &[], &dir.join("librlg_compensator.a"))
                .unwrap_or_else(|e| panic!("{e}"));
            let axes = [axis_table(0), axis_table(1), axis_table(2)];
            capi::write_table_header(&axes[0].as_model(), "rlg", &dir, "rlg_model_table.h");
            for (k, name) in ["gyro_x", "gyro_y", "gyro_z"].iter().enumerate() {
                capi::write_table_header(
                    &axes[k].as_model(),
                    name,
                    &dir,
                    &format!("{name}_table.h"),
                );
            }
            std::fs::write(dir.join("readme_example.c"), readme_example()).unwrap();
            let c = capi::c_dir();
            let exe = |n: &str| dir.join(n);
            compile(&dir, &c.join("c_api_replay.c"), &exe("c_api_replay"));
            compile(&dir, &c.join("c_api_readme.c"), &exe("c_api_readme"));
            compile(&dir, &c.join("c_api_bad_input.c"), &exe("c_api_bad_input"));
            let record = capi::held_out_record();
            let replay_file = dir.join("heldout.bin");
            replay::write(&replay_file, &record).unwrap();
            println!(
                "setup (library, headers, three programs, record): {:.1} s",
                t0.elapsed().as_secs_f64()
            );
            Some(Setup {
                replay_exe: exe("c_api_replay"),
                readme_exe: exe("c_api_readme"),
                bad_exe: exe("c_api_bad_input"),
                record,
                replay_file,
                axes,
            })
        })
        .as_ref()
}

/// Runs a built program; its stdout.
fn run(exe: &Path, args: &[&Path], extra: &[&str]) -> Vec<u8> {
    let out = Command::new(exe)
        .args(args)
        .args(extra)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{} {extra:?}: {}\n{}",
        exe.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

fn bits(c: &Compensated) -> OutputBits {
    (c.rate_dph.to_bits(), c.correction_dph.to_bits(), c.status.0)
}

/// The gyro rate axis `k` sees (the C programs add the same f32 offsets).
fn axis_rate(s: &ReplaySample, k: usize) -> f32 {
    match k {
        0 => s.rate_dph,
        1 => s.rate_dph + 0.5,
        _ => s.rate_dph + 1.0,
    }
}

/// Counts identical samples, and reports the first differences.
fn compare(what: &str, got: &[OutputBits], want: &[OutputBits]) {
    assert_eq!(got.len(), want.len(), "{what}: sample count");
    let same = got.iter().zip(want).filter(|(a, b)| a == b).count();
    let first: Vec<String> = got
        .iter()
        .zip(want)
        .enumerate()
        .filter(|(_, (a, b))| a != b)
        .take(5)
        .map(|(k, (a, b))| format!("sample {k}: C {a:08x?}, Rust {b:08x?}"))
        .collect();
    println!("{what}: {same} of {} outputs bit-identical", want.len());
    assert!(same == want.len(), "{what}: {first:#?}");
}

/// The f32 and fixed-point paths on the committed table, one axis.
#[test]
fn c_replay_of_the_held_out_record_is_bit_identical_to_rust() {
    let Some(s) = setup() else { return };
    let table = tests::default_model_table();
    assert_eq!(s.record.len(), 77_426, "the main job's held-out record");
    let t0 = Instant::now();
    let got = capi::read_outputs(&run(&s.replay_exe, &[&s.replay_file], &["f32"]));
    let mut rust = Compensator::from_table(table, SensorLimits::DEFAULT);
    let want: Vec<OutputBits> = s
        .record
        .iter()
        .map(|x| bits(&rust.update(x.temp_c, x.rate_dph)))
        .collect();
    compare("f32", &got, &want);
    // The record exercises the compensation, not only pass-through.
    assert!(want.iter().filter(|w| w.2 == 0).count() > 70_000);

    let got = capi::read_outputs(&run(&s.replay_exe, &[&s.replay_file], &["fixed"]));
    let fixed = FixedModel::from_table(table).expect("the committed table has a Q24 form");
    let mut rust = FixedCompensator::from_table(table, &fixed, SensorLimits::DEFAULT).unwrap();
    let want: Vec<OutputBits> = s
        .record
        .iter()
        .map(|x| bits(&rust.update(x.temp_c, x.rate_dph)))
        .collect();
    compare("fixed point", &got, &want);
    println!(
        "two replays and references: {:.1} s",
        t0.elapsed().as_secs_f64()
    );
}

/// The three axes' Rust outputs (f32 or fixed point), axis-interleaved as the C programs write.
fn three_axes(s: &Setup, fixed_point: bool) -> Vec<OutputBits> {
    let mut out = vec![(0, 0, 0); 3 * s.record.len()];
    for (k, t) in s.axes.iter().enumerate() {
        let mut f32c = Compensator::from_table(t, SensorLimits::DEFAULT);
        let fm = FixedModel::from_table(t).expect("a Q24 form");
        let mut fc = FixedCompensator::from_table(t, &fm, SensorLimits::DEFAULT).unwrap();
        for (i, x) in s.record.iter().enumerate() {
            let g = axis_rate(x, k);
            out[3 * i + k] = if fixed_point {
                bits(&fc.update(x.temp_c, g))
            } else {
                bits(&f32c.update(x.temp_c, g))
            };
        }
    }
    out
}

/// Three axes with their own tables (`gyro_x_model`, …, included together), through
/// `rlg_init_axes` / `rlg_update_axes`, f32 and fixed point, and through the README's example.
#[test]
fn three_axes_each_match_their_own_rust_table() {
    let Some(s) = setup() else { return };
    let crcs: Vec<u32> = s.axes.iter().map(|t| t.crc32).collect();
    assert!(
        crcs[0] != crcs[1] && crcs[1] != crcs[2],
        "three different tables"
    );
    let want = three_axes(s, false);
    let got = capi::read_outputs(&run(&s.replay_exe, &[&s.replay_file], &["axes"]));
    compare("three axes, f32", &got, &want);
    // Each axis differs from the others: a mixed-up table would not pass.
    assert_ne!(want[0].1, want[1].1);

    let got = capi::read_outputs(&run(&s.replay_exe, &[&s.replay_file], &["fixed_axes"]));
    compare("three axes, fixed point", &got, &three_axes(s, true));

    let rates = run(&s.readme_exe, &[&s.replay_file], &[]);
    let got: Vec<u32> = rates
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let want_rates: Vec<u32> = want.iter().map(|w| w.0).collect();
    assert_eq!(got.len(), want_rates.len());
    let same = got.iter().zip(&want_rates).filter(|(a, b)| a == b).count();
    println!(
        "README example, three axes: {same} of {} output rates bit-identical",
        got.len()
    );
    assert_eq!(same, got.len());
}

/// One line of the bad-input program: code, and status, rate bits, correction bits when the
/// call wrote an output.
type Line = (i32, Option<OutputBits>);

fn parse_bad_input(text: &str) -> HashMap<String, Line> {
    text.lines()
        .map(|l| {
            let f: Vec<&str> = l.split(' ').collect();
            assert_eq!(f.len(), 5, "{l}");
            let code = f[1].parse().unwrap();
            let out = (f[2] != "-").then(|| {
                (
                    u32::from_str_radix(f[3], 16).unwrap(),
                    u32::from_str_radix(f[4], 16).unwrap(),
                    f[2].parse::<u8>().unwrap(),
                )
            });
            (f[0].to_string(), (code, out))
        })
        .collect()
}

/// Bad input gives an error code or the documented status bit, never a trap.
#[test]
fn bad_input_gives_codes_and_status_bits_never_a_fault() {
    let Some(s) = setup() else { return };
    let text = String::from_utf8(run(&s.bad_exe, &[], &[])).unwrap();
    let lines = parse_bad_input(&text);
    let get = |k: &str| *lines.get(k).unwrap_or_else(|| panic!("no line {k}"));
    const OK: i32 = 0;
    const NULL: i32 = 1;
    const ALIGN: i32 = 2;
    const NOT_INIT: i32 = 3;
    const SHAPE: i32 = 4;
    const FEATURE: i32 = 5;
    const CRC: i32 = 6;
    const FIXED_FORM: i32 = 8;
    let raw = (-7.05f32).to_bits();
    let table_fault = Some((raw, 0, Status::TABLE_FAULT.0));
    let codes = [
        ("init_null_state", NULL, None),
        ("init_null_table", NULL, None),
        ("update_after_null_table", OK, table_fault),
        ("update_null_state", NULL, table_fault),
        ("update_null_out", NULL, None),
        ("update_before_init", NOT_INIT, table_fault),
        ("fixed_update_before_init", NOT_INIT, table_fault),
        ("init_misaligned_state", ALIGN, None),
        ("init_corrupted_table", CRC, None),
        ("update_corrupted_table", OK, table_fault),
        ("init_too_many_features", SHAPE, None),
        ("init_no_support_vectors", SHAPE, None),
        ("init_null_support", NULL, None),
        ("init_misaligned_support", ALIGN, None),
        ("init_unknown_feature", FEATURE, None),
        ("init_good", OK, None),
        ("fixed_init_null_table", NULL, None),
        ("fixed_update_after_null_table", OK, table_fault),
        ("fixed_init_null_inner_table", NULL, None),
        ("fixed_init_mismatched_q24", FIXED_FORM, None),
        ("fixed_init_corrupted_table", CRC, None),
        ("fixed_update_corrupted_table", OK, table_fault),
        ("fixed_init_good", OK, None),
        ("fixed_temp_nan", OK, Some((raw, 0, Status::TEMP_FAULT.0))),
        ("axes_init_null_tables", NULL, None),
        ("axes_init_one_corrupted", CRC, None),
        ("axes_errors_0", OK, None),
        ("axes_errors_1", CRC, None),
        ("axes_update_null_temps", NULL, None),
        ("axes_update", OK, table_fault),
        ("fixed_axes_init_null_states", NULL, None),
    ];
    for (name, code, out) in codes {
        assert_eq!(get(name), (code, out), "{name}");
    }
    // The sensor faults against the Rust compensator on the same sequence.
    let mut rust = Compensator::from_table(tests::default_model_table(), SensorLimits::DEFAULT);
    for _ in 0..400 {
        rust.update(30.0, -7.05);
    }
    let seq = [
        ("warm", 30.0, -7.05),
        ("temp_nan", f32::NAN, -7.05),
        ("temp_out_of_range", 150.0, -7.05),
        ("temp_below_range", -80.0, -7.05),
        ("gyro_nan", 30.0, f32::NAN),
        ("gyro_infinite", 30.0, f32::INFINITY),
        ("both_nan", f32::NAN, f32::NAN),
        ("recovered", 30.0, -7.05),
    ];
    let mut last_good = 0.0f32;
    for (name, t, g) in seq {
        let want = rust.update(t, g);
        assert_eq!(get(name), (OK, Some(bits(&want))), "{name}");
        // And what the header documents for each.
        let st = want.status;
        match name {
            "warm" | "recovered" => assert!(st.is_ok(), "{name}: {st:?}"),
            "temp_nan" | "temp_out_of_range" | "temp_below_range" => {
                assert_eq!(st, Status::TEMP_FAULT);
                assert_eq!(want.rate_dph, g, "raw rate passed through");
            }
            "gyro_nan" | "gyro_infinite" => {
                assert_eq!(st, Status::GYRO_FAULT);
                assert_eq!(want.rate_dph, last_good, "last good output held");
            }
            _ => assert_eq!(st, Status::TEMP_FAULT | Status::GYRO_FAULT),
        }
        if g.is_finite() {
            last_good = want.rate_dph;
        }
    }
    assert_eq!(lines.len(), codes.len() + seq.len(), "{text}");
}
