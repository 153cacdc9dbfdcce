//! The shipped scenarios reproduce the paper's published figures.

use super::*;
use rlg_eval::metrics::bias_stability_dph;

fn load(name: &str) -> Scenario {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("scenarios")
        .join(name);
    Scenario::from_file(&p).unwrap()
}

/// Yu et al. 2011, Table 1: chamber °C, gyro body °C, gyro output °/h.
const TABLE_1: [(f64, f64, f64); 11] = [
    (-40.0, -34.80, -7.0771),
    (-30.0, -24.89, -7.0864),
    (-20.0, -14.97, -7.0926),
    (-10.0, -4.94, -7.0987),
    (0.0, 5.09, -7.1040),
    (10.0, 14.80, -7.1066),
    (20.0, 24.75, -7.1096),
    (30.0, 33.74, -7.1128),
    (40.0, 45.05, -7.1150),
    (50.0, 54.07, -7.1182),
    (60.0, 63.59, -7.1184),
];

/// Body temperature tolerance of the static calibration, °C (measured worst: 0.79 at 40 °C).
const STATIC_BODY_TOL_C: f64 = 1.0;
/// Output tolerance of the static calibration, °/h.
const STATIC_RATE_TOL_DPH: f64 = 3e-4;

/// 1 h means after each 2 h soak match Table 1.
#[test]
fn static_scenario_reproduces_table_1() {
    let s = load("yu2011-static.toml");
    let sim = simulate(&s, 2011).unwrap();
    let r = &sim.recording;
    for (k, &(chamber, body, out)) in TABLE_1.iter().enumerate() {
        let (t0, t1) = (k as f64 * 10_800.0 + 7_200.0, (k + 1) as f64 * 10_800.0);
        let idx: Vec<usize> = (0..r.len())
            .filter(|&i| r.time_s[i] >= t0 && r.time_s[i] < t1)
            .collect();
        assert_eq!(idx.len(), 3600);
        let mean = |v: &[f64]| idx.iter().map(|&i| v[i]).sum::<f64>() / idx.len() as f64;
        let (temp, rate, air) = (
            mean(&r.temp_c),
            mean(&r.rate_dph),
            mean(r.chamber_c.as_ref().unwrap()),
        );
        assert!((air - chamber).abs() < 0.01, "air {air} at {chamber}");
        assert!(
            (temp - body).abs() < STATIC_BODY_TOL_C,
            "{chamber} °C: body {temp} vs {body}"
        );
        assert!(
            (rate - out).abs() < STATIC_RATE_TOL_DPH,
            "{chamber} °C: output {rate} vs {out}"
        );
        eprintln!(
            "{chamber:>4} °C: body {:+.3} °C, output {:+.2e} °/h off Table 1",
            temp - body,
            rate - out
        );
    }
}

/// Eq. (11) of the paper, °/h, with T in °C and dT/dt in °C/s.
fn eq11(t: f64, r: f64) -> f64 {
    -0.00960 + 7.1445e-4 * t - 2.6387e-5 * t * t + 2.1772e-7 * t * t * t + 2.1572 * r
        - 4.2769e3 * r * r * r
        + 1.9163e-5 * t * r
}

/// Raw 100 s stability ≈ 0.0102 °/h; after Eq. (11) compensation from the recorded sensor
/// temperature ≈ 0.0016 °/h (the paper's figures); the noise alone (output − true bias) below
/// the paper's LS-SVM figure of 0.0011 °/h, so that figure is reachable at all.
#[test]
fn dynamic_scenario_reproduces_paper_stabilities() {
    let s = load("yu2011-dynamic.toml");
    let sim = simulate(&s, 2011).unwrap();
    let r = &sim.recording;
    let raw = bias_stability_dph(&r.rate_dph, 100).unwrap();
    assert!((raw / 0.0102 - 1.0).abs() < 0.20, "raw {raw}");
    // dT/dt from the quantised sensor: central difference over ±30 s (one-sided at the ends).
    let n = r.len();
    let h = 30;
    let comp: Vec<f64> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(h), (i + h).min(n - 1));
            let dtdt = (r.temp_c[b] - r.temp_c[a]) / (r.time_s[b] - r.time_s[a]);
            r.rate_dph[i] - eq11(r.temp_c[i], dtdt)
        })
        .collect();
    let c = bias_stability_dph(&comp, 100).unwrap();
    assert!((c / 0.0016 - 1.0).abs() < 0.30, "compensated {c}");
    let noise: Vec<f64> = (0..n)
        .map(|i| r.rate_dph[i] - sim.truth.bias_dph[i])
        .collect();
    let floor = bias_stability_dph(&noise, 100).unwrap();
    assert!(floor < 0.0011 && floor > 0.0008, "noise floor {floor}");
    eprintln!(
        "100 s stability: raw {raw:.5} °/h, Eq. (11)-compensated {c:.5} °/h, noise {floor:.5} °/h"
    );
    assert!(sim.truth.scenario.profile.len() == 1 && r.time_s[n - 1] > 3.0 * 7.8 * 3600.0);
}
