//! The shipped scenarios reproduce the paper's published figures.

use super::*;
use rlg_eval::baselines::eq11;
use rlg_eval::metrics::bias_stability_dph;
use rlg_eval::paper;
use rlg_physics::Term;

fn load(name: &str) -> Scenario {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("scenarios")
        .join(name);
    Scenario::from_file(&p).unwrap()
}

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
    let table = rlg_io::table1::bundled().unwrap();
    assert_eq!(table.len(), 11);
    for (k, row) in table.iter().enumerate() {
        let (chamber, body, out) = (row.chamber_c, row.temp_c, row.rate_dph);
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

/// Raw 100 s stability ≈ 0.0102 °/h; after Eq. (11) compensation from the recorded sensor
/// temperature ≈ 0.0016 °/h (the paper's figures); the noise alone (output − true bias) below
/// the paper's LS-SVM figure of 0.0011 °/h, so that figure is reachable at all.
#[test]
fn dynamic_scenario_reproduces_paper_stabilities() {
    let s = load("yu2011-dynamic.toml");
    let sim = simulate(&s, 2011).unwrap();
    let r = &sim.recording;
    let raw = bias_stability_dph(&r.rate_dph, 100).unwrap();
    assert!((raw / paper::RAW_B100_DPH - 1.0).abs() < 0.20, "raw {raw}");
    // dT/dt from the quantised sensor: central difference over ±30 s (one-sided at the ends).
    let n = r.len();
    let h = 30;
    let comp: Vec<f64> = (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(h), (i + h).min(n - 1));
            let dtdt = (r.temp_c[b] - r.temp_c[a]) / (r.time_s[b] - r.time_s[a]);
            r.rate_dph[i] - eq11::bias_dph(r.temp_c[i], dtdt)
        })
        .collect();
    let c = bias_stability_dph(&comp, 100).unwrap();
    assert!(
        (c / paper::STEPWISE_B100_DPH - 1.0).abs() < 0.30,
        "compensated {c}"
    );
    let noise: Vec<f64> = (0..n)
        .map(|i| r.rate_dph[i] - sim.truth.bias_dph[i])
        .collect();
    let floor = bias_stability_dph(&noise, 100).unwrap();
    assert!(
        floor < paper::LSSVM_B100_DPH && floor > 0.0008,
        "noise floor {floor}"
    );
    eprintln!(
        "100 s stability: raw {raw:.5} °/h, Eq. (11)-compensated {c:.5} °/h, noise {floor:.5} °/h"
    );
    assert!(sim.truth.scenario.profile.len() == 1 && r.time_s[n - 1] > 3.0 * 7.8 * 3600.0);
}

/// The shipped files that restate the paper's Eq. (11) and latitude (the paper model the
/// diagnosis starts from, both scenarios) hold exactly the numbers of `rlg_eval::paper`.
#[test]
fn shipped_files_state_the_papers_numbers() {
    #[derive(serde::Deserialize)]
    struct Terms {
        terms: Vec<Term>,
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let model: Terms =
        toml::from_str(&std::fs::read_to_string(dir.join("models/paper.toml")).unwrap()).unwrap();
    let sets = [
        ("models/paper.toml", model.terms, true),
        (
            "yu2011-dynamic.toml",
            load("yu2011-dynamic.toml").terms,
            true,
        ),
        (
            "yu2011-static.toml",
            load("yu2011-static.toml").terms,
            false,
        ),
    ];
    for (name, terms, has_eq11) in sets {
        let mut seen = 0;
        for t in &terms {
            match t {
                Term::EarthRate { latitude_deg, .. } => {
                    assert_eq!(*latitude_deg, paper::LATITUDE_DEG, "{name}");
                    seen += 1;
                }
                Term::StaticPoly { coeffs_dph, .. } if has_eq11 => {
                    assert_eq!(coeffs_dph[..], paper::eq11::STATIC_POLY_DPH[..], "{name}");
                    seen += 1;
                }
                Term::RateTerms {
                    linear,
                    cubic,
                    temp_linear,
                } => {
                    let e = (paper::eq11::RATE_LINEAR, paper::eq11::RATE_CUBIC);
                    assert_eq!((*linear, *cubic), e, "{name}");
                    assert_eq!(*temp_linear, paper::eq11::TEMP_RATE, "{name}");
                    seen += 1;
                }
                _ => {}
            }
        }
        assert_eq!(seen, if has_eq11 { 3 } else { 1 }, "{name}: {terms:?}");
    }
}
