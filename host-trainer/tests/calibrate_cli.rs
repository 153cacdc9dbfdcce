//! `rlg calibrate` from the command line: a scenario of its own simulated, calibrated with no
//! σ or c, the close loop's diagnosed features compared; paths checked before the work.

use std::path::Path;
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

/// −20 … 50 °C at 0.5 °C/min, three cycles, a hysteresis and a sensor lag.
const SCENARIO: &str = r#"
name = "own-gyro"
sample_period_s = 1.0
power_on_s = 0.0
start_c = -20.0

[thermal]
air_tau_s = 400.0
body_tau_s = 1500.0
self_heating_c = 3.0
self_heating_per_c = -0.01

[[profile]]
kind = "repeat"
count = 3
segments = [
    { kind = "hold", duration_s = 7200.0 },
    { kind = "ramp", to_c = 50.0, rate_c_per_min = 0.5 },
    { kind = "hold", duration_s = 7200.0 },
    { kind = "ramp", to_c = -20.0, rate_c_per_min = 0.5 },
]

[[terms]]
kind = "earth_rate"
latitude_deg = 48.0
axis = "down"

[[terms]]
kind = "static_poly"
coeffs_dph = [0.02, -3.0e-4, 8.0e-6, -6.0e-8]

[[terms]]
kind = "rate_terms"
linear = 1.5

[[terms]]
kind = "sensor_lag"
tau_s = 90.0

[[terms]]
kind = "hysteresis"
width_c = 8.0
height_dph = 0.004

[noise]
arw_dph_rt_h = 2e-4
bias_instability_dph = 3e-4
rrw_dph_per_rt_h = 3e-5
"#;

#[test]
fn calibrate_with_the_close_loop_from_the_command_line() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("calibrate_cli");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scenario = dir.join("own.toml");
    std::fs::write(&scenario, SCENARIO).unwrap();
    let rec = dir.join("own.csv");
    let (code, _, err) = rlg(&[
        "simulate",
        "--scenario",
        scenario.to_str().unwrap(),
        "--seed",
        "7",
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");

    // An output path that is a file fails at once, before the work.
    let (code, _, err) = rlg(&[
        "calibrate",
        "--recording",
        rec.to_str().unwrap(),
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert_eq!(code, Some(1));
    assert!(
        err.starts_with("error: --out") && err.contains("is a file"),
        "{err}"
    );

    let out = dir.join("cal");
    let (code, stdout, err) = rlg(&[
        "calibrate",
        "--recording",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--diagnose",
    ]);
    assert_eq!(code, Some(0), "{err}");
    print!("{stdout}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let held = |name: &str| {
        summary["models"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == name)
            .and_then(|m| m["held_out"]["stability_dph"].as_f64())
    };
    let ls = held("LS-SVM on [T, dT/dt]").unwrap();
    let sw = held("stepwise (paper's 9 terms)").unwrap();
    assert!(ls < sw, "LS-SVM {ls} vs stepwise {sw}");
    // The hysteresis is diagnosed and its feature adopted; held out it beats the LS-SVM.
    let dg = held("diagnosed features (close loop)").expect("an adopted diagnosed model");
    assert!(dg < ls, "diagnosed {dg} vs LS-SVM {ls}");
    assert!(stdout.contains("temp_play_c"), "{stdout}");

    // Its board table is written beside the [T, dT/dt] one, held to the same f32 limit, and
    // through the board's f32 compensator it holds the f64 model's held-out figure.
    let db = &summary["diagnosed_board"];
    let features: Vec<&str> = db["features"]
        .as_array()
        .expect("a diagnosed board table")
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    assert!(
        features.iter().any(|f| f.starts_with("temp_play_c(")),
        "{features:?}"
    );
    assert!(db["f32_deviation_dph"].as_f64().unwrap() <= db["f32_limit_dph"].as_f64().unwrap());
    let board = db["held_out_stability_dph"].as_f64().unwrap();
    assert!(
        (board - dg).abs() <= 0.05 * dg,
        "board f32 {board} vs f64 {dg}"
    );
    let m = rlg_train::model::ModelFile::read(&out.join("model_diagnosed.json")).unwrap();
    assert_eq!(m.lssvm.features, features);
    rlg_train::export::check_precision(&m).unwrap();
    for f in ["table_diagnosed.rs", "table_diagnosed.h"] {
        let text = std::fs::read_to_string(out.join(f)).unwrap();
        assert!(text.contains("temp_play_c("), "{f}");
    }
    let files = summary["files"].as_array().unwrap();
    for f in [
        "model_diagnosed.json",
        "table_diagnosed.rs",
        "table_diagnosed.h",
    ] {
        assert!(files.iter().any(|x| x == f), "{f} not listed");
    }
    // Every key it writes is documented.
    let schema =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/calibrate/SUMMARY.md"))
            .unwrap();
    for k in db.as_object().unwrap().keys() {
        assert!(
            schema.contains(&format!("`diagnosed_board.{k}`")),
            "undocumented key diagnosed_board.{k}"
        );
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Board table on the diagnosed features"));
}
