//! `rlg calibrate` on files written the way real rigs and MEMS IMU loggers write them, made
//! here by a generator of this test's own (not the simulator's physics or noise): a one-hour
//! chamber cycle of a three-axis IMU at 2 Hz, tab-separated, µs epoch stamps, rad/s, one axis
//! with a heating/cooling loop and one whose bias follows a temperature lagging the sensor's;
//! a semicolon export with decimal commas, a byte-order mark and CRLF; a 50 Hz logger that
//! wakes for a few seconds every few minutes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

fn rlg(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rlg"))
        .args(args)
        .output()
        .expect("run rlg");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `rlg calibrate --recording file --out out` with `flags` between.
fn calibrate(file: &Path, out: &Path, flags: &[&str]) -> (Option<i32>, String, String) {
    let mut args = vec!["calibrate", "--recording", file.to_str().unwrap()];
    args.extend_from_slice(flags);
    args.extend(["--out", out.to_str().unwrap()]);
    rlg(&args)
}

fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("real_logs")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Standard normal deviates from a 64-bit LCG through Box–Muller: deterministic, and no
/// relation to the simulator's generator.
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn next(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

const DPH_PER_RAD_S: f64 = 206_264.806_247_096_36;

/// The chamber: 5 min at −20 °C, 25 min up to +75 °C, 5 min there, 25 min back down.
fn chamber_c(t: f64) -> f64 {
    match t {
        t if t < 300.0 => -20.0,
        t if t < 1800.0 => -20.0 + 95.0 * (t - 300.0) / 1500.0,
        t if t < 2100.0 => 75.0,
        t if t < 3600.0 => 75.0 - 95.0 * (t - 2100.0) / 1500.0,
        _ => -20.0,
    }
}

/// One IMU log: per sample (time s, sensor °C, three biases + noise in °/h).
struct Imu {
    time_s: Vec<f64>,
    temp_c: Vec<f64>,
    rate_dph: [Vec<f64>; 3],
}

/// `seconds` of the chamber cycle at `hz`, white noise of 250 °/h per sample.
fn imu(hz: f64, seconds: f64, seed: u64) -> Imu {
    imu_with(hz, seconds, seed, 250.0)
}

/// `seconds` of the chamber cycle at `hz`, white noise of `white_dph` per sample.
fn imu_with(hz: f64, seconds: f64, seed: u64, white_dph: f64) -> Imu {
    let mut g = Normal(seed);
    let dt = 1.0 / hz;
    let n = (seconds * hz) as usize;
    let (mut sensor, mut inner) = (-20.0f64, -20.0f64);
    let mut flicker = [0.0f64; 3];
    let mut out = Imu {
        time_s: Vec::with_capacity(n),
        temp_c: Vec::with_capacity(n),
        rate_dph: [Vec::new(), Vec::new(), Vec::new()],
    };
    // The loop: a play operator of 10 °C on the die's temperature (backlash of the package's
    // stress), its state ±1 on the heating and cooling branches.
    let (half, mut play) = (5.0f64, sensor);
    for k in 0..n {
        let t = k as f64 * dt;
        // The die follows the chamber with 2 min of lag; the gyro's proof mass 5 min behind it.
        sensor += (chamber_c(t) - sensor) * dt / 120.0;
        inner += (sensor - inner) * dt / 300.0;
        play = play.clamp(sensor - half, sensor + half);
        let d = sensor - 25.0;
        let bias = [
            3000.0 + 110.0 * d + 0.3 * d * d,
            // A heating/cooling loop of ±1 000 °/h: the bias depends on the ramp's direction
            // and keeps it until the temperature has turned by the play's width.
            -1500.0 + 80.0 * d + 1000.0 * (sensor - play) / half,
            500.0 - 95.0 * (inner - 25.0),
        ];
        for a in 0..3 {
            flicker[a] = 0.995 * flicker[a] + 3.0 * g.next();
            out.rate_dph[a].push(bias[a] + flicker[a] + white_dph * g.next());
        }
        out.time_s.push(t);
        // A 1/256 °C sensor LSB and a little noise.
        out.temp_c
            .push(((sensor + 0.02 * g.next()) * 256.0).round() / 256.0);
    }
    out
}

/// The three-axis tab-separated file: µs epoch stamps, rad/s, the units in the header.
fn write_tsv(path: &Path, imu: &Imu, with_units: bool) {
    let mut s = String::new();
    if with_units {
        s.push_str(
            "time_us\timu.gyro.x [rad/s]\timu.gyro.y [rad/s]\timu.gyro.z [rad/s]\t\
             imu.temperature [degC]\n",
        );
    } else {
        s.push_str("time_us\tgyro_x\tgyro_y\tgyro_z\ttemp\n");
    }
    let epoch_us = 1_764_633_600_000_000u64;
    for k in 0..imu.time_s.len() {
        let _ = writeln!(
            s,
            "{}\t{:.9}\t{:.9}\t{:.9}\t{:.4}",
            epoch_us + (imu.time_s[k] * 1e6).round() as u64,
            imu.rate_dph[0][k] / DPH_PER_RAD_S,
            imu.rate_dph[1][k] / DPH_PER_RAD_S,
            imu.rate_dph[2][k] / DPH_PER_RAD_S,
            imu.temp_c[k]
        );
    }
    std::fs::write(path, s).unwrap();
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// CV RMS of the summary's model whose name starts with `prefix`, °/h.
fn cv_rms(sum: &serde_json::Value, prefix: &str) -> f64 {
    sum["models"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"].as_str().unwrap().starts_with(prefix))
        .unwrap_or_else(|| panic!("no model {prefix} in {sum}"))["cv_rms_dph"]
        .as_f64()
        .unwrap()
}

/// The axes' folders and their columns in the IMU log.
const AXES: [(&str, &str); 3] = [
    ("imu_gyro_x", "imu.gyro.x"),
    ("imu_gyro_y", "imu.gyro.y"),
    ("imu_gyro_z", "imu.gyro.z"),
];

/// The one-hour three-axis chamber cycle: every axis calibrated into its own folder, the
/// loop axis better by dT/dt than by T alone, the three C headers compiled into one unit.
#[test]
fn one_hour_three_axis_chamber_cycle() {
    let d = dir("imu");
    let log = imu(2.0, 3600.0, 1);
    let file = d.join("imu.tsv");
    write_tsv(&file, &log, true);
    let out = d.join("cal");
    let (code, stdout, stderr) = calibrate(&file, &out, &["--every-axis"]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    for (axis, column) in AXES {
        let report = std::fs::read_to_string(out.join(axis).join("report.md")).unwrap();
        assert!(
            report.contains("averaged to 1 s means"),
            "{axis}: the 2 Hz stream's averaging is not said:\n{report}"
        );
        assert!(report.contains(&format!("Axis `{column}`")), "{report}");
        let header = std::fs::read_to_string(out.join(axis).join("table.h")).unwrap();
        assert!(
            header.contains(&format!("rlg_{axis}_model")),
            "{axis}: header not named by its axis"
        );
    }
    let y = summary(&out.join("imu_gyro_y"));
    let (poly, lssvm) = (cv_rms(&y, "polynomial"), cv_rms(&y, "LS-SVM"));
    assert!(
        lssvm < 0.7 * poly,
        "loop axis: LS-SVM CV rms {lssvm:.1} °/h not clearly below the polynomial's {poly:.1}"
    );
    for (axis, _) in AXES {
        let s = summary(&out.join(axis));
        // The table states its constant and what it removes.
        assert_eq!(s["board"]["removes"], "variation", "{axis}");
        let h = std::fs::read_to_string(out.join(axis).join("table.h")).unwrap();
        let upper = format!("RLG_{}", axis.to_uppercase());
        assert!(
            h.contains(&format!("#define {upper}_REFERENCE_BIAS_DPH "))
                && h.contains(&format!("#define {upper}_REMOVES_WHOLE_BIAS 0")),
            "{axis}: the header does not state its reference"
        );
    }
    // Only the variation removed: the board's output is centred on the stated constant.
    for (k, (axis, _)) in AXES.iter().enumerate() {
        let reference = summary(&out.join(axis))["board"]["reference_dph"]
            .as_f64()
            .unwrap();
        let mean = board_mean(&out.join(axis), &log, k, 2);
        assert!(
            (mean - reference).abs() < 100.0,
            "{axis}: output centred on {mean:.1} °/h, the stated constant is {reference:.1}"
        );
    }
    let module = std::fs::read_to_string(out.join("imu.rs")).unwrap();
    for (axis, _) in AXES {
        assert!(
            module.contains(&format!(
                "pub mod {axis} {{\n    include!(\"{axis}/table.rs\");"
            )),
            "{module}"
        );
    }
    for (axis, _) in AXES {
        let s = summary(&out.join(axis));
        let l = cv_rms(&s, "LS-SVM");
        // Bias moves by about 10⁴ °/h over the cycle; a model worth flashing leaves a few
        // hundred °/h at most (the noise of a 1 s sample is 180 °/h).
        assert!(l.is_finite() && l < 400.0, "{axis}: LS-SVM CV rms {l}");
    }
    evaluate_together(&out, &log);
}

/// The C program of [`evaluate_together`]: `imu_eval REPLAY AXIS` runs the replay file's
/// samples (tests/src/replay.rs format) through axis AXIS's table of `imu.h` with the C API and
/// writes each output's (rate bits, correction bits, status) as little-endian u32s.
const IMU_EVAL_C: &str = r#"#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "imu.h"

int main(int argc, char **argv) {
    const rlg_table *tables[3] = {&rlg_imu_gyro_x_model, &rlg_imu_gyro_y_model,
                                  &rlg_imu_gyro_z_model};
    if (argc != 3 || tables[0] == tables[1] || tables[1] == tables[2]) return 64;
    FILE *f = fopen(argv[1], "rb");
    if (!f) return 66;
    static unsigned char buf[1 << 20];
    size_t len = fread(buf, 1, sizeof buf, f);
    fclose(f);
    uint32_t count;
    memcpy(&count, buf + 8, 4);
    if (len < 12 || len != 12 + 8 * (size_t)count) return 65;
    static rlg_compensator state;
    if (rlg_init(&state, tables[atoi(argv[2])]) != RLG_OK) return 2;
    for (uint32_t k = 0; k < count; k++) {
        float t, g;
        rlg_output o;
        memcpy(&t, buf + 12 + 8 * (size_t)k, 4);
        memcpy(&g, buf + 16 + 8 * (size_t)k, 4);
        if (rlg_update(&state, t, g, &o) != RLG_OK) return 3;
        uint32_t w[3];
        memcpy(&w[0], &o.rate_dph, 4);
        memcpy(&w[1], &o.correction_dph, 4);
        w[2] = o.status;
        fwrite(w, sizeof w, 1, stdout);
    }
    return 0;
}
"#;

/// The three axes' headers included together through `imu.h` (warnings as errors: a collision
/// of names is a redefinition error), linked with the C API's host library, and each axis run
/// through its own table on the log's own samples (every other one, as the board's 1 Hz):
/// every output bit for bit what the axis' Rust table gives through `compensator_core`.
fn evaluate_together(out: &Path, log: &Imu) {
    use compensator_core::{Compensator, SensorLimits};
    use tests::capi;
    use tests::replay::{self, ReplaySample};
    if !capi::tool_or_skip("the IMU headers from C", "cc") {
        return;
    }
    capi::build_library(None, &[], &out.join("librlg_compensator.a")).expect("the C API builds");
    std::fs::write(out.join("imu_eval.c"), IMU_EVAL_C).unwrap();
    let exe = out.join("imu_eval");
    let mut cc = Command::new("cc");
    cc.args(["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(capi::include_dir())
        .arg("-I")
        .arg(out)
        .arg(out.join("imu_eval.c"))
        .arg(out.join("librlg_compensator.a"))
        .args(capi::HOST_NATIVE_LIBS)
        .arg("-o")
        .arg(&exe);
    capi::run_compiler(&mut cc).unwrap_or_else(|e| panic!("{e}"));
    for (k, (axis, _)) in AXES.iter().enumerate() {
        let samples: Vec<ReplaySample> = (0..log.time_s.len())
            .step_by(2)
            .map(|i| ReplaySample {
                temp_c: log.temp_c[i] as f32,
                rate_dph: log.rate_dph[k][i] as f32,
            })
            .collect();
        let file = out.join(format!("{axis}.replay"));
        replay::write(&file, &samples).unwrap();
        let run = Command::new(&exe)
            .arg(&file)
            .arg(k.to_string())
            .output()
            .unwrap();
        assert!(run.status.success(), "{axis}: imu_eval {:?}", run.status);
        let got = capi::read_outputs(&run.stdout);
        let m = rlg_train::model::ModelFile::read(&out.join(axis).join("model.json")).unwrap();
        let t = rlg_train::export::to_f32::<2>(&m).unwrap();
        let mut rust = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
        let want: Vec<capi::OutputBits> = samples
            .iter()
            .map(|x| {
                let o = rust.update(x.temp_c, x.rate_dph);
                (o.rate_dph.to_bits(), o.correction_dph.to_bits(), o.status.0)
            })
            .collect();
        assert_eq!(got.len(), want.len(), "{axis}");
        let same = got.iter().zip(&want).filter(|(a, b)| a == b).count();
        assert_eq!(
            same,
            want.len(),
            "{axis}: {same} of {} outputs bit-identical",
            want.len()
        );
        // The table compensates: the board's output is centred on the stated constant.
        let compensated = want.iter().filter(|w| w.2 == 0).count();
        assert!(
            compensated > want.len() / 2,
            "{axis}: {compensated} compensated"
        );
    }
}

/// A rad/s column with no unit in its header is not taken for °/h: the error names the flag.
#[test]
fn rad_per_s_without_a_unit_is_refused_with_the_flag() {
    let d = dir("no_units");
    let file = d.join("imu.tsv");
    write_tsv(&file, &imu(2.0, 600.0, 2), false);
    let (code, stdout, stderr) = calibrate(&file, &d.join("cal"), &["--rate-col", "gyro_x"]);
    assert_ne!(code, Some(0), "{stdout}");
    assert!(stderr.contains("--rate-unit"), "{stderr}");
}

/// A spreadsheet export: semicolons, decimal commas, a byte-order mark, CRLF, a units row.
#[test]
fn semicolon_export_with_decimal_commas() {
    let d = dir("semicolon");
    let log = imu(1.0, 3600.0, 3);
    let mut s = String::from("\u{feff}Zeit;Drehrate;Temperatur\r\ns;deg/s;degC\r\n");
    for k in 0..log.time_s.len() {
        let _ = write!(
            s,
            "{:.1};{:.7};{:.3}\r\n",
            log.time_s[k],
            log.rate_dph[1][k] / 3600.0,
            log.temp_c[k]
        );
    }
    let file = d.join("export.csv");
    std::fs::write(&file, s.replace('.', ",")).unwrap();
    let out = d.join("cal");
    let (code, stdout, stderr) = calibrate(
        &file,
        &out,
        &[
            "--time-col",
            "Zeit",
            "--rate-col",
            "Drehrate",
            "--temp-col",
            "Temperatur",
            "--remove",
            "whole",
        ],
    );
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    let sum = summary(&out);
    let l = cv_rms(&sum, "LS-SVM");
    assert!(l.is_finite() && l < 400.0, "LS-SVM CV rms {l}");
    // The whole bias removed: the header says so, and the board's output over the record is
    // centred on zero, not on the bias at 25 °C (−1 500 °/h).
    assert_eq!(sum["board"]["removes"], "whole");
    let h = std::fs::read_to_string(out.join("table.h")).unwrap();
    assert!(h.contains("#define RLG_REMOVES_WHOLE_BIAS 1"), "{h}");
    let reference = sum["board"]["reference_dph"].as_f64().unwrap();
    let mean = board_mean(&out, &log, 1, 1);
    assert!(
        mean.abs() < 50.0 && reference < -1000.0,
        "board output's mean {mean:.1} °/h (reference {reference:.1})"
    );
}

/// The mean output of the board table in `out` (its `model.json` through
/// `compensator_core`) over axis `axis` of `log`, every `step`-th sample, °/h.
fn board_mean(out: &Path, log: &Imu, axis: usize, step: usize) -> f64 {
    use compensator_core::{Compensator, SensorLimits};
    let m = rlg_train::model::ModelFile::read(&out.join("model.json")).unwrap();
    let t = rlg_train::export::to_f32::<2>(&m).unwrap();
    let mut board = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
    let outputs: Vec<f64> = (0..log.time_s.len())
        .step_by(step)
        .map(|i| {
            let o = board.update(log.temp_c[i] as f32, log.rate_dph[axis][i] as f32);
            f64::from(o.rate_dph)
        })
        .collect();
    outputs.iter().sum::<f64>() / outputs.len() as f64
}

/// A logger that wakes for 3 s at 50 Hz every 3 minutes: no 1 Hz stream, so the static
/// model on one point per burst, said in a note.
#[test]
fn bursty_50_hz_logger_gets_the_static_model() {
    let d = dir("bursts");
    let log = imu(50.0, 3600.0, 4);
    let mut s = String::from("time_s,rate_dph,temp_c\n");
    for k in 0..log.time_s.len() {
        let t = log.time_s[k];
        if t % 180.0 < 3.0 {
            let _ = writeln!(s, "{t:.3},{:.3},{:.4}", log.rate_dph[0][k], log.temp_c[k]);
        }
    }
    let file = d.join("bursts.csv");
    std::fs::write(&file, s).unwrap();
    let out = d.join("cal");
    let (code, stdout, stderr) = calibrate(&file, &out, &[]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stdout.contains("sampled in bursts"), "{stdout}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("20 bursts"), "{report}");
}

/// An output folder in use is refused; `--force` removes the earlier run's files (no old
/// figure stays beside the new report) and leaves the user's; a copy of the calibration
/// recording given as `--test` is refused.
#[test]
fn outputs_are_honest() {
    let d = dir("outputs");
    let log = imu(1.0, 3600.0, 5);
    let mut s = String::from("time_s,rate_dph,temp_c\n");
    for k in 0..log.time_s.len() {
        let _ = writeln!(
            s,
            "{},{:.3},{:.4}",
            log.time_s[k], log.rate_dph[0][k], log.temp_c[k]
        );
    }
    let file = d.join("a.csv");
    std::fs::write(&file, &s).unwrap();
    let copy = d.join("b.csv");
    std::fs::write(&copy, &s).unwrap();
    let out = d.join("cal");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("held_out.png"), b"an earlier run's figure").unwrap();
    std::fs::write(out.join("notes.txt"), b"the user's").unwrap();
    let args = |extra: &[&str]| {
        let mut v = vec![
            "calibrate",
            "--recording",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        v.extend_from_slice(extra);
        v.iter().map(|a| a.to_string()).collect::<Vec<_>>()
    };
    let run = |v: Vec<String>| rlg(&v.iter().map(String::as_str).collect::<Vec<_>>());

    let (code, _, err) = run(args(&["--test", copy.to_str().unwrap()]));
    assert_eq!(code, Some(1));
    assert!(err.contains("same bytes as --recording"), "{err}");

    let (code, _, err) = run(args(&[]));
    assert_eq!(code, Some(1));
    assert!(
        err.contains("is not empty") && err.contains("--force"),
        "{err}"
    );
    assert!(
        out.join("held_out.png").exists(),
        "a refused run removed files"
    );

    let (code, stdout, err) = run(args(&["--force"]));
    assert_eq!(code, Some(0), "{stdout}\n{err}");
    assert!(
        !out.join("held_out.png").exists(),
        "the earlier run's figure stayed beside a one-cycle report"
    );
    assert!(
        out.join("notes.txt").exists(),
        "--force removed a file not its own"
    );
    assert!(stdout.contains("left `notes.txt`"), "{stdout}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("Figures: `cv_curve.png` (nothing is held out"),
        "{report}"
    );
}

/// An RLG logged at 10 Hz for a day, two chamber cycles: averaged to the board's 1 s, fitted
/// on the RLG's 100 s means (its bias moves little against its noise), the second cycle held
/// out and compensated.
#[test]
fn ten_hz_rlg_day() {
    let d = dir("rlg10hz");
    let mut g = Normal(6);
    let (hz, hours) = (10.0, 24.0);
    let n = (hours * 3600.0 * hz) as usize;
    let chamber = |t: f64| {
        // Two 12 h cycles: 3 h at 10 °C, 3 h up to 60 °C, 3 h there, 3 h down.
        let p = (t % 43_200.0) / 10_800.0;
        match p {
            p if p < 1.0 => 10.0,
            p if p < 2.0 => 10.0 + 50.0 * (p - 1.0),
            p if p < 3.0 => 60.0,
            p => 60.0 - 50.0 * (p - 3.0),
        }
    };
    let mut sensor = 10.0f64;
    let mut s = String::with_capacity(n * 32);
    s.push_str("time_s,rate_dph,temp_c\n");
    let dt = 1.0 / hz;
    for k in 0..n {
        let t = k as f64 * dt;
        let before = sensor;
        sensor += (chamber(t) - sensor) * dt / 900.0;
        let rate_c_per_s = (sensor - before) / dt;
        let bias =
            -7.1 + 2e-4 * (sensor - 35.0) + 3e-6 * (sensor - 35.0).powi(2) + 2.0 * rate_c_per_s;
        let _ = writeln!(
            s,
            "{t:.1},{:.5},{:.3}",
            bias + 0.1 * g.next(),
            sensor + 0.002 * g.next()
        );
    }
    let file = d.join("rlg.csv");
    std::fs::write(&file, s).unwrap();
    let out = d.join("cal");
    let (code, stdout, stderr) = calibrate(&file, &out, &[]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("(10 Hz): it is averaged to 1 s means"),
        "{report}"
    );
    assert!(report.contains("means of 100 s from"), "{report}");
    let sum = summary(&out);
    let held = |prefix: &str| {
        sum["models"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"].as_str().unwrap().starts_with(prefix))
            .and_then(|m| m["held_out"]["stability_dph"].as_f64())
            .unwrap_or_else(|| panic!("no held-out figure of {prefix}: {sum}"))
    };
    let (raw, lssvm) = (held("raw"), held("LS-SVM"));
    assert!(lssvm < 0.5 * raw, "held out: LS-SVM {lssvm} vs raw {raw}");
}

/// The diagnosis of the one-hour cycle: 10 s means instead of 100 s ones, said in a note.
#[test]
fn one_hour_cycle_is_diagnosed() {
    let d = dir("diagnose");
    let file = d.join("imu.tsv");
    write_tsv(&file, &imu(2.0, 3600.0, 7), true);
    let (code, stdout, stderr) = rlg(&[
        "diagnose",
        "--recording",
        file.to_str().unwrap(),
        "--rate-col",
        "imu.gyro.y",
    ]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("means of 10 s instead of 100 s means"),
        "{stdout}"
    );
    assert!(
        stdout.starts_with("verdict: missing_physics") && stdout.contains("\nhysteresis: "),
        "the loop is not named:\n{stdout}"
    );
    assert!(stdout.contains("whitened 10 s means"), "{stdout}");
}

/// `calibrate --diagnose` on the looped axis of one cycle: the diagnosis names the loop, and
/// the model with the play operator's input is adopted by CV (nothing is held out), its CV
/// error under the [T, dT/dt] table's of the same size and far under temperature alone.
#[test]
fn the_loop_is_modelled_where_cv_adopts_it() {
    let d = dir("loop");
    let file = d.join("imu.tsv");
    write_tsv(&file, &imu(2.0, 3600.0, 1), true);
    let out = d.join("cal");
    let (code, stdout, stderr) =
        calibrate(&file, &out, &["--rate-col", "imu.gyro.y", "--diagnose"]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    let s = summary(&out);
    // The loop model is a table of the board's size: it is compared with the [T, dT/dt] table
    // of the same size (the exact LS-SVM's hundreds of vectors do not fit the board).
    let (poly, table, looped) = (
        cv_rms(&s, "polynomial"),
        cv_rms(&s, "board table"),
        cv_rms(&s, "diagnosed"),
    );
    assert!(
        looped < table && looped < 0.5 * poly,
        "CV rms: loop model {looped:.1}, [T, dT/dt] table {table:.1}, polynomial {poly:.1} °/h"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("the close loop adopts the diagnosed features")
            && report.contains("temp_play_c"),
        "{report}"
    );
    assert!(out.join("table_diagnosed.h").exists());
}

/// A quiet MEMS gyro (white noise of 25 °/h a sample against a bias moving 10⁴ °/h over the
/// cycle): the f32 kernel sums of the well-fitting σ, c cancel by more than the export limit,
/// and the board table is still one that fits within a small factor of the LS-SVM, with the
/// reason in the notes, not the first table within the limit (a c of 1 or less, which fitted
/// an order of magnitude worse than the LS-SVM).
#[test]
fn a_quiet_mems_gyro_gets_a_board_table_that_fits() {
    let d = dir("quiet");
    let file = d.join("imu.tsv");
    write_tsv(&file, &imu_with(2.0, 3600.0, 3, 25.0), true);
    let out = d.join("cal");
    let (code, stdout, stderr) = calibrate(&file, &out, &["--every-axis"]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    let mut taken_over = 0;
    for (axis, _) in AXES {
        let s = summary(&out.join(axis));
        let (lssvm, table) = (cv_rms(&s, "LS-SVM"), cv_rms(&s, "board table"));
        let b = &s["board"];
        let (dev, limit) = (
            b["f32_deviation_dph"].as_f64().unwrap(),
            b["f32_limit_dph"].as_f64().unwrap(),
        );
        eprintln!("{axis}: CV rms LS-SVM {lssvm:.1}, table {table:.1} °/h; f32 {dev:.2e} (limit {limit:.2e})");
        // The first table within the limit fits an order of magnitude worse here (a c of 1 or
        // less); the table's own fixed size and the bound's margin on the departure leave it
        // within a small factor of the exact LS-SVM's.
        assert!(
            table < 2.5 * lssvm,
            "{axis}: the board table's CV rms {table:.1} °/h against the LS-SVM's {lssvm:.1}"
        );
        assert!(
            dev <= limit,
            "{axis}: the model file's limit is not the one taken"
        );
        let notes = s["notes"].to_string();
        taken_over += usize::from(notes.contains("taken all the same"));
    }
    assert!(
        taken_over > 0,
        "no axis needed a table over the f32 limit: the case this test is for did not arise"
    );
}

/// One to two hours of a MEMS chamber cycle at 2 Hz with random bias, gain, curvature, dT/dt
/// coefficient, chamber range and lag, and noise of white, AR(1) and random-walk parts of
/// random sizes; with `lag`, the bias also follows the gap between a second, slower thermal
/// lag and the sensor (a gradient the paper's model lacks). Written as the format's CSV.
fn short_cycle(path: &Path, seed: u64, lag: bool) {
    let mut g = Normal(seed);
    let mut u = |lo: f64, hi: f64| lo + (hi - lo) * g.uniform();
    let (hz, dur) = (2.0, u(3600.0, 7200.0));
    let (lo, hi, hold) = (u(-25.0, -10.0), u(60.0, 80.0), u(200.0, 600.0));
    let ramp = (dur - 2.0 * hold) / 2.0;
    let (tau, tau2) = (u(60.0, 240.0), u(200.0, 500.0));
    let (b0, k1, k2, kr) = (
        u(-5000.0, 5000.0),
        u(-150.0, 150.0),
        u(-0.5, 0.5),
        u(-5000.0, 5000.0),
    );
    let k_lag = if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 } * u(60.0, 120.0);
    let (white, phi, ar_scale, rw_step) =
        (u(100.0, 400.0), u(0.99, 0.999), u(1.0, 5.0), u(0.0, 0.5));
    let chamber = |t: f64| {
        if t < hold {
            lo
        } else if t < hold + ramp {
            lo + (hi - lo) * (t - hold) / ramp
        } else if t < 2.0 * hold + ramp {
            hi
        } else {
            hi - (hi - lo) * (t - 2.0 * hold - ramp) / ramp
        }
    };
    let n = (dur * hz) as usize;
    let dt = 1.0 / hz;
    let (mut temp, mut inner, mut ar, mut rw) = (lo, lo, 0.0, 0.0);
    let mut s = String::from("time_s,rate_dph,temp_c\n");
    for k in 0..n {
        let t = k as f64 * dt;
        let before = temp;
        temp += (chamber(t) - temp) * dt / tau;
        inner += (temp - inner) * dt / tau2;
        let d = temp - 25.0;
        let mut bias = b0 + k1 * d + k2 * d * d + kr * (temp - before) / dt;
        if lag {
            bias += k_lag * (inner - temp);
        }
        ar = phi * ar + g.next();
        rw += rw_step * g.next();
        let y = bias + white * g.next() + ar_scale * ar + rw;
        let tq = ((temp + 0.02 * g.next()) * 256.0).round() / 256.0;
        let _ = writeln!(s, "{t:.3},{y:.3},{tq:.5}");
    }
    std::fs::write(path, s).unwrap();
}

/// The diagnosis on short records, on a generator of this test's own: on 12 cycles whose
/// bias the paper's terms describe it seldom cries wolf, and on 12 with a hidden thermal
/// gradient it finds most. The figures are printed; the bounds leave room for the sampling
/// noise of twelve records (a 5 % false-alarm rate gives more than 2 of 12 one time in 50).
#[test]
fn short_record_diagnosis_false_alarms_and_power() {
    let d = dir("short_diagnosis");
    let verdict = |path: &Path| {
        let (code, stdout, stderr) = rlg(&["diagnose", "--recording", path.to_str().unwrap()]);
        assert_eq!(code, Some(0), "{stdout}\n{stderr}");
        stdout.lines().next().unwrap_or_default().to_string()
    };
    let (mut alarms, mut found) = (0, 0);
    for seed in 101..=112 {
        let null = d.join(format!("null{seed}.csv"));
        short_cycle(&null, seed, false);
        alarms += usize::from(verdict(&null) != "verdict: consistent");
        let lag = d.join(format!("lag{seed}.csv"));
        short_cycle(&lag, seed, true);
        found += usize::from(verdict(&lag) == "verdict: missing_physics");
    }
    eprintln!("short records: {alarms} false alarm(s) of 12, {found} of 12 gradients found");
    assert!(alarms <= 2, "{alarms} false alarms of 12");
    assert!(found >= 5, "only {found} of 12 hidden gradients found");
}

/// `--static` on the looped axis fits T alone through the loop: it says so, with the two
/// branches' gap, and the figure it writes shows them in their own colours.
#[test]
fn static_fit_through_a_loop_says_so() {
    let d = dir("static_loop");
    let file = d.join("imu.tsv");
    write_tsv(&file, &imu(2.0, 3600.0, 1), true);
    let out = d.join("cal");
    let (code, stdout, stderr) = calibrate(&file, &out, &["--rate-col", "imu.gyro.y", "--static"]);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stdout.contains("a heating/cooling loop"), "{stdout}");
    assert!(out.join("static_fit.png").exists());
    let (code, stdout, _) = calibrate(
        &file,
        &d.join("x"),
        &["--rate-col", "imu.gyro.x", "--static"],
    );
    assert_eq!(code, Some(0));
    assert!(
        !stdout.contains("heating/cooling loop"),
        "no loop on x:\n{stdout}"
    );
}

/// `train-fleet` takes calibrate's flags: a folder of two IMU logs (tab-separated, named
/// columns) calibrated with `--remove whole`, and characterised with `--static`.
#[test]
fn train_fleet_takes_calibrates_flags() {
    let d = dir("fleet");
    let logs = d.join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    for seed in [11, 12] {
        write_tsv(
            &logs.join(format!("imu{seed}.tsv")),
            &imu(2.0, 3600.0, seed),
            true,
        );
    }
    let run = |out: &str, extra: &[&str]| {
        let out = d.join(out);
        let mut args = vec![
            "train-fleet",
            "--dir",
            logs.to_str().unwrap(),
            "--rate-col",
            "imu.gyro.x",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let (code, stdout, stderr) = rlg(&args);
        assert_eq!(code, Some(0), "{stdout}\n{stderr}");
        out
    };
    let out = run("dynamic", &["--remove", "whole"]);
    for seed in [11, 12] {
        let s = summary(&out.join(format!("imu{seed}")));
        assert_eq!(s["board"]["removes"], "whole", "imu{seed}");
    }
    let out = run("static", &["--static"]);
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert_eq!(md.matches("nothing (static)").count(), 2, "{md}");
    assert!(out.join("imu11").join("static_fit.png").exists());
}
