//! `rlg calibrate` end to end on simulated gyros: the shipped scenario agrees with the
//! reproduction, a scenario written here (not shipped) calibrates with no σ or c given, the C
//! header of its table compiles and evaluates as the Rust board code does, and a large-bias
//! bursty log gives a static table that runs on the board.

use indicatif::ProgressBar;

use compensator_core::{Compensator, SensorLimits};
use rlg_calibrate::report::{self, FileInfo, Inputs};
use rlg_calibrate::static_cal::{calibrate_static, StaticOptions};
use rlg_calibrate::{calibrate, HeldOut, Model, Options};
use rlg_io::recording::Recording;
use rlg_repro::dynamic;
use rlg_simulate::scenario::Scenario;
use rlg_train::export;
use rlg_train::model::{ModelFile, Provenance};

fn provenance(what: &str) -> Provenance {
    Provenance::from_bytes(what, what.as_bytes(), "rlg calibrate (test)")
}

fn held(c: &rlg_calibrate::Calibration, name: Model) -> f64 {
    c.row(name)
        .and_then(|r| r.held_out.as_ref())
        .map_or(f64::NAN, |h| h.stability_dph)
}

/// With the reproduction's split (first cycle trains), `calibrate` on the shipped scenario's
/// recording gives the figures `rlg report` prints: same data, same folds, same models.
#[test]
fn calibrate_agrees_with_report_on_the_shipped_scenario() {
    let dy =
        dynamic::reproduce(&dynamic::DynamicOptions::default(), &ProgressBar::hidden()).unwrap();
    let opts = Options {
        train_cycles: Some(1),
        ..Options::default()
    };
    let c = calibrate(
        &dy.run.recording,
        None,
        &opts,
        &provenance("yu2011-dynamic"),
        &ProgressBar::hidden(),
    )
    .unwrap();
    assert_eq!(
        c.split.held_out,
        HeldOut::Cycles { train: 1, test: 3 },
        "{:?}",
        c.split
    );
    assert_eq!((c.tuned.sigma, c.tuned.c), (dy.tuned.sigma, dy.tuned.c));
    for (ours, theirs) in [
        (Model::Raw, dynamic::Row::Raw),
        (Model::Stepwise, dynamic::Row::Stepwise),
        (Model::Lssvm, dynamic::Row::Lssvm),
        (Model::Board, dynamic::Row::Board),
    ] {
        let a = held(&c, ours);
        let b = dy.model(theirs).unwrap().test_b100_dph;
        println!("{ours}: calibrate {a:.6e}, report {b:.6e}");
        assert!((a / b - 1.0).abs() < 1e-9, "{ours}: {a} vs {b}");
    }
}

/// A gyro of one's own: −20 … 50 °C at 0.5 °C/min, three cycles, a hysteresis and a sensor
/// lag (not a shipped scenario).
const OWN_SCENARIO: &str = r#"
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
fn a_gyro_of_its_own_calibrates_without_sigma_or_c_and_its_tables_agree() {
    let scenario = Scenario::from_toml_str(OWN_SCENARIO, "own-gyro.toml").unwrap();
    let sim = rlg_simulate::simulate(&scenario, 7).unwrap();
    let c = calibrate(
        &sim.recording,
        None,
        &Options::default(),
        &provenance("own-gyro"),
        &ProgressBar::hidden(),
    )
    .unwrap();
    assert_eq!(c.split.held_out, HeldOut::Cycles { train: 2, test: 1 });
    assert_eq!(c.split.cv_groups, 2, "{}", c.split.validation);
    let (raw, sw, ls, board) = (
        held(&c, Model::Raw),
        held(&c, Model::Stepwise),
        held(&c, Model::Lssvm),
        held(&c, Model::Board),
    );
    println!(
        "own gyro, HELD-OUT 100 s stability: raw {raw:.3e}, stepwise {sw:.3e}, LS-SVM {ls:.3e}, \
         board {board:.3e}; σ {:.3}, c {:.3}",
        c.tuned.sigma, c.tuned.c
    );
    assert!(ls < sw, "LS-SVM {ls} vs stepwise {sw}");
    assert!(board < 0.25 * raw, "board {board} vs raw {raw}");

    // The folder: every file, a summary in the documented schema.
    let dir = tempfile::tempdir().unwrap();
    let inputs = Inputs {
        command: "rlg calibrate --recording own.csv --out cal".into(),
        recording: FileInfo {
            file: "own.csv".into(),
            sha256: String::new(),
            samples: sim.recording.len(),
        },
        test_recording: None,
    };
    let files = report::write(&c, &inputs, dir.path()).unwrap();
    for f in [
        "report.md",
        "summary.json",
        "model.json",
        "table.rs",
        "table.h",
        "held_out.png",
        "residual_vs_temperature.png",
        "allan.png",
        "cv_curve.png",
    ] {
        assert!(files.contains(&dir.path().join(f)), "{f} not written");
        assert!(
            std::fs::metadata(dir.path().join(f)).unwrap().len() > 0,
            "{f}"
        );
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(summary["schema_version"], report::SCHEMA_VERSION);
    let schema = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../host-trainer/calibrate/SUMMARY.md"
    ))
    .unwrap();
    let mut keys = Vec::new();
    fn walk(v: &serde_json::Value, path: &str, out: &mut Vec<String>) {
        match v {
            serde_json::Value::Object(m) => {
                for (k, x) in m {
                    let p = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    out.push(p.clone());
                    walk(x, &p, out);
                }
            }
            serde_json::Value::Array(a) => {
                if let Some(x) = a.iter().find(|x| x.is_object()) {
                    walk(x, &format!("{path}[]"), out);
                }
            }
            _ => {}
        }
    }
    walk(&summary, "", &mut keys);
    let missing: Vec<&String> = keys
        .iter()
        .filter(|k| !schema.contains(&format!("`{k}`")))
        .collect();
    assert!(missing.is_empty(), "undocumented summary keys: {missing:?}");

    // The C header evaluates as the Rust board code does.
    let m = ModelFile::read(&dir.path().join("model.json")).unwrap();
    let t = export::to_f32::<2>(&m).unwrap();
    let header = std::fs::read_to_string(dir.path().join("table.h")).unwrap();
    let s = t.spec;
    let xs: Vec<Vec<f32>> = (0..=40)
        .flat_map(|i| {
            (0..=40).map(move |j| {
                vec![
                    s.input_lo[0] + (s.input_hi[0] - s.input_lo[0]) * i as f32 / 40.0,
                    s.input_lo[1] + (s.input_hi[1] - s.input_lo[1]) * j as f32 / 40.0,
                ]
            })
        })
        .collect();
    if let Some(got) = tests::c_header::evaluate(&header, &dir.path().join("c"), &xs, t.crc32()) {
        let board = t.as_model();
        let worst = xs
            .iter()
            .zip(&got)
            .map(|(x, g)| (g - f64::from(board.predict_dph(&[x[0], x[1]]))).abs())
            .fold(0.0, f64::max);
        println!(
            "C header vs Rust board code over {} points: max {worst:.2e} °/h",
            xs.len()
        );
        assert!(worst <= 1e-5, "{worst:e}");
    }
}

/// A MEMS-like thermal log: bursts of 250 samples at 50 Hz every 300 s while the gyro cools
/// from 24 to 16 °C over 8 h; absolute bias `offset` °/h moving +100 °/h per °C with some
/// curvature, and 30 °/h of white noise per sample.
fn bursty_log(offset: f64, seed: u64) -> (Recording, impl Fn(f64) -> f64) {
    let bias = move |t: f64| offset + 100.0 * (t - 20.0) + 1.5 * (t - 20.0).powi(2);
    let mut state = seed;
    let mut gauss = move || {
        let mut s = 0.0;
        for _ in 0..12 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            s += (state >> 11) as f64 / (1u64 << 53) as f64;
        }
        s - 6.0
    };
    let mut rec = Recording::default();
    let duration = 8.0 * 3600.0;
    let mut start = 0.0;
    while start < duration {
        for k in 0..250 {
            let t = start + f64::from(k) / 50.0;
            let temp = 24.0 - 8.0 * t / duration;
            rec.time_s.push(t);
            rec.temp_c.push(temp + 0.005 * gauss());
            rec.rate_dph.push(bias(temp) + 30.0 * gauss());
        }
        start += 300.0;
    }
    (rec, bias)
}

#[test]
fn a_large_bias_bursty_log_gives_a_static_table_that_runs_on_the_board() {
    for offset in [-7000.0, -50_000.0] {
        let (log, bias) = bursty_log(offset, 11);
        // A dynamic calibration is refused, with the reason and the way out.
        let (means, _) = rlg_io::resample::burst_means(&log, 5.0).unwrap();
        let e = calibrate(
            &means,
            None,
            &Options::default(),
            &provenance("mems"),
            &ProgressBar::hidden(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("no dT/dt model") && e.contains("--static"),
            "{e}"
        );

        let c = calibrate_static(
            &means,
            None,
            &StaticOptions::default(),
            &provenance("mems"),
            &ProgressBar::hidden(),
        )
        .unwrap();
        assert_eq!(c.points.len(), 96);
        println!(
            "table σ {} c {} cv {:.3e} train rms {:.3e}, refused {}, poly degree {} cv {:?}",
            c.table_point.sigma,
            c.table_point.c,
            c.table_point.cv_rms_dph,
            c.model.training.rms_dph,
            c.refused.len(),
            c.poly_degree,
            c.poly_cv_dph
        );
        assert!(c.reference_folded, "reference {}", c.model.reference_dph);
        assert!(c.f32_deviation_dph <= c.f32_limit_dph);

        // The board at 1 Hz through a slow sweep inside the trained range: its correction is
        // the f64 model's within the export limit, and it removes the temperature dependence.
        let t = export::to_f32::<1>(&c.model).unwrap();
        let mut comp = Compensator::new(t.as_model(), SensorLimits::DEFAULT);
        assert!(comp.table_ok());
        let (lo, hi) = (c.model.input_lo[0], c.model.input_hi[0]);
        let n = 4000;
        let mut worst_f32 = 0.0f64;
        let mut resid = Vec::new();
        for k in 0..n {
            let temp = hi - (hi - lo) * f64::from(k) / f64::from(n);
            let out = comp.update(temp as f32, bias(temp) as f32);
            if k < 300 {
                continue; // the board's dT/dt estimator warms up
            }
            let want = c.model.correction_dph(&[f64::from(temp as f32)]);
            worst_f32 = worst_f32.max((f64::from(out.correction_dph) - want).abs());
            resid.push(f64::from(out.rate_dph) - c.model.reference_dph);
        }
        let spread = resid.iter().fold(f64::NEG_INFINITY, |a, v| a.max(*v))
            - resid.iter().fold(f64::INFINITY, |a, v| a.min(*v));
        let f32_step =
            f64::from(offset as f32) - f64::from(f32::from_bits((offset as f32).to_bits() - 1));
        println!(
            "offset {offset} °/h: board correction vs f64 max {worst_f32:.2e} °/h; compensated \
             output spread {spread:.3} °/h over {lo:.2}…{hi:.2} °C (raw spread {:.0} °/h; f32 \
             step of the output {:.1e})",
            bias(hi) - bias(lo),
            f32_step.abs()
        );
        assert!(
            worst_f32 <= c.f32_limit_dph,
            "{worst_f32:e} vs {:e}",
            c.f32_limit_dph
        );
        // Burst means of 250 samples carry 30/√250 ≈ 1.9 °/h of noise: the model's error is
        // a fraction of that, against 800 °/h of raw temperature dependence.
        assert!(spread < 3.0, "{spread}");
    }
}

/// Eight gyros with different physics (lag, hysteresis, rate coefficient, curvature) in one
/// folder: eight tables, each tuned on its own recording, and a summary judged against limits.
#[test]
fn a_fleet_of_eight_gyros_gives_eight_tables_each_tuned() {
    use rlg_calibrate::fleet::{self, Limits};
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("fleet");
    std::fs::create_dir_all(&input).unwrap();
    for g in 0..8u32 {
        let f = f64::from(g);
        let text = OWN_SCENARIO
            .replace("tau_s = 90.0", &format!("tau_s = {:.1}", 20.0 + 25.0 * f))
            .replace(
                "height_dph = 0.004",
                &format!("height_dph = {:.4}", 0.001 * f),
            )
            .replace("linear = 1.5", &format!("linear = {:.2}", 0.5 + 0.4 * f))
            .replace(
                "coeffs_dph = [0.02, -3.0e-4, 8.0e-6, -6.0e-8]",
                &format!(
                    "coeffs_dph = [0.02, {:.2e}, 8.0e-6, -6.0e-8]",
                    -3.0e-4 + 1e-4 * f
                ),
            );
        let scenario = Scenario::from_toml_str(&text, "gyro.toml").unwrap();
        let sim = rlg_simulate::simulate(&scenario, 100 + u64::from(g)).unwrap();
        sim.recording
            .write_csv(&input.join(format!("gyro{g}.csv")))
            .unwrap();
    }
    let out = dir.path().join("out");
    let limits = Limits {
        max_stability_dph: Some(5e-3),
        min_improvement: Some(2.0),
    };
    let read = |p: &std::path::Path| Ok(Recording::read_csv(p)?);
    let rows = fleet::calibrate_fleet(
        &input,
        &out,
        &fleet::FleetModel::Dynamic(Options::default()),
        &limits,
        "rlg train-fleet (test)",
        &read,
        &ProgressBar::hidden(),
    )
    .unwrap();
    print!("{}", fleet::summary_markdown(&rows, 100, &limits, 0.0));
    assert_eq!(rows.len(), 8);
    for (g, r) in rows.iter().enumerate() {
        assert!(r.error.is_none(), "{}: {:?}", r.name, r.error);
        assert_eq!(r.pass, Some(true), "{}: {:?}", r.name, r.failures);
        let folder = out.join(format!("gyro{g}"));
        for f in ["table.rs", "table.h", "model.json", "summary.json"] {
            assert!(folder.join(f).is_file(), "{g}: {f}");
        }
        let m = ModelFile::read(&folder.join("model.json")).unwrap();
        assert_eq!((m.lssvm.sigma, m.lssvm.c), (r.sigma, r.c));
    }
    // Tuned on each gyro's own data: not one σ, c for all.
    let mut distinct: Vec<(u64, u64)> = rows
        .iter()
        .map(|r| (r.sigma.to_bits(), r.c.to_bits()))
        .collect();
    distinct.sort_unstable();
    distinct.dedup();
    assert!(distinct.len() >= 3, "{distinct:?}");
    assert_eq!(fleet::summary_csv(&rows).lines().count(), 9);
}
