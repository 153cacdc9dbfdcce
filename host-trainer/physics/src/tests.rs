//! Each term against its closed-form behaviour.

use super::*;

/// A ramp T = T0 + r·t sampled at 1 Hz for `n` s.
fn ramp(t0: f64, r: f64, n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
    let temp = t.iter().map(|t| t0 + r * t).collect();
    (t, temp, vec![r; n])
}

#[test]
fn earth_rate_reproduces_table_1_level() {
    let (t, temp, rate) = ramp(20.0, 0.0, 3);
    let term = Term::EarthRate {
        latitude_deg: 28.2,
        axis: Axis::Down,
    };
    let c = contribution(&term, &t, &temp, &rate);
    // 15.0411 °/h · sin 28.2° = 7.1075 °/h; Table 1's mean output is −7.104 °/h.
    assert!((c[0] + 15.041_07 * 28.2f64.to_radians().sin()).abs() < 1e-4);
    assert!((c[0] + 7.1075).abs() < 1e-3);
    let up = Term::EarthRate {
        latitude_deg: 28.2,
        axis: Axis::Up,
    };
    assert_eq!(contribution(&up, &t, &temp, &rate)[2], -c[2]);
}

#[test]
fn static_poly_matches_direct_evaluation() {
    let term = Term::StaticPoly {
        center_c: 10.0,
        scale_c: 50.0,
        coeffs_dph: vec![1.0, -2.0, 3.0],
    };
    let (t, temp, rate) = ramp(-40.0, 1.0, 100);
    let c = contribution(&term, &t, &temp, &rate);
    for (ci, ti) in c.iter().zip(&temp) {
        let x = (ti - 10.0) / 50.0;
        assert!((ci - (1.0 - 2.0 * x + 3.0 * x * x)).abs() < 1e-12);
    }
}

#[test]
fn rate_terms_match_eq_11_terms() {
    let term = Term::RateTerms {
        linear: 2.1572,
        cubic: -4.2769e3,
        temp_linear: 1.9163e-5,
    };
    let r = 1.0 / 60.0; // 1 °C/min
    let (t, temp, rate) = ramp(30.0, r, 2);
    let c = contribution(&term, &t, &temp, &rate);
    let expect = 2.1572 * r - 4.2769e3 * r.powi(3) + 1.9163e-5 * 30.0 * r;
    assert!((c[0] - expect).abs() < 1e-12);
}

#[test]
fn sensor_lag_on_a_ramp_lags_by_tau_times_rate() {
    let (tau, r) = (90.0, 0.02);
    let (t, temp, rate) = ramp(0.0, r, 2000);
    let s = contribution(&Term::SensorLag { tau_s: tau }, &t, &temp, &rate);
    assert!((temp[1999] - s[1999] - tau * r).abs() < 1e-9);
}

#[test]
fn gradient_lag_settles_to_gain_times_rate() {
    // Starting at rest (G = 0) the rate steps to r: G = r·(1 − e^{−t/τ}) after the first
    // (ramped) interval, so the bias approaches gain·r.
    let (tau, gain, r) = (300.0, 2.0, 0.01);
    let t: Vec<f64> = (0..5000).map(|i| i as f64).collect();
    let temp = vec![20.0; 5000];
    let mut rate = vec![r; 5000];
    rate[0] = 0.0;
    let c = contribution(&Term::GradientLag { tau_s: tau, gain }, &t, &temp, &rate);
    assert!((c[4999] - gain * r).abs() < 1e-8);
    let mid = gain * r * (1.0 - tau * (1.0 - (-1.0 / tau).exp()) * (-299.0 / tau).exp());
    assert!((c[300] - mid).abs() < 1e-12, "{} vs {mid}", c[300]);
}

#[test]
fn hysteresis_branches_differ_by_twice_the_height() {
    let term = Term::Hysteresis {
        width_c: 6.0,
        height_dph: 0.003,
        node_lag_s: 0.0,
    };
    let t: Vec<f64> = (0..201).map(|i| i as f64).collect();
    // Up from 0 to 50 then back down to 0.
    let temp: Vec<f64> = (0..201)
        .map(|i| {
            if i <= 100 {
                0.5 * i as f64
            } else {
                100.0 - 0.5 * i as f64
            }
        })
        .collect();
    let c = contribution(&term, &t, &temp, &vec![0.0; 201]);
    // 25 °C is reached at i = 50 (rising) and i = 150 (falling).
    assert!((c[50] - c[150] - 0.006).abs() < 1e-12);
}

#[test]
fn warmup_decays_exponentially_after_power_on() {
    let term = Term::Warmup {
        amplitude_dph: 0.01,
        tau_s: 600.0,
        t_on_s: 100.0,
    };
    let (t, temp, rate) = ramp(20.0, 0.0, 2000);
    let c = contribution(&term, &t, &temp, &rate);
    assert_eq!(c[99], 0.0);
    assert!((c[100] - 0.01).abs() < 1e-15);
    assert!((c[700] - 0.01 * (-1.0f64).exp()).abs() < 1e-15);
}

#[test]
fn mode_hop_switches_at_the_two_thresholds() {
    let term = Term::ModeHop {
        temp_c: 40.0,
        step_dph: 0.002,
        hysteresis_c: 3.0,
        node_lag_s: 0.0,
    };
    let temp = [35.0, 40.0, 40.5, 38.0, 37.1, 36.9, 39.9];
    let t: Vec<f64> = (0..temp.len()).map(|i| i as f64).collect();
    let c = contribution(&term, &t, &temp, &[0.0; 7]);
    assert_eq!(c, vec![0.0, 0.0, 0.002, 0.002, 0.002, 0.0, 0.0]);
}

#[test]
fn backscatter_and_periodic_are_sinusoids() {
    let bs = Term::Backscatter {
        period_c: 8.0,
        amplitude_dph: 1e-3,
        phase_rad: 0.0,
        node_lag_s: 0.0,
    };
    let (t, temp, rate) = ramp(0.0, 1.0, 9);
    let c = contribution(&bs, &t, &temp, &rate);
    assert!((c[2] - 1e-3).abs() < 1e-15 && (c[6] + 1e-3).abs() < 1e-15 && c[8].abs() < 1e-15);
    let p = Term::Periodic {
        period_s: 4.0,
        amplitude_dph: 2.0,
        phase_rad: 0.0,
        windows_s: vec![[0.0, 5.0]],
    };
    let c = contribution(&p, &t, &temp, &rate);
    assert!((c[1] - 2.0).abs() < 1e-12 && (c[3] + 2.0).abs() < 1e-12);
    assert_eq!(c[5], 0.0);
}

#[test]
fn aging_is_linear_in_days() {
    let term = Term::Aging {
        rate_dph_per_day: 0.001,
    };
    let t = [0.0, 43_200.0, 86_400.0];
    let c = contribution(&term, &t, &[20.0; 3], &[0.0; 3]);
    assert_eq!(c, vec![0.0, 0.0005, 0.001]);
}

#[test]
fn heteroscedastic_scale_and_quantization() {
    let h = Term::Heteroscedastic {
        k: 0.5,
        ref_c: 20.0,
    };
    let c = contribution(&h, &[0.0, 1.0], &[20.0, 80.0], &[0.0; 2]);
    assert_eq!(c, vec![1.0, 1.0 + 0.5 * 4.0]);
    let q = Term::TempQuantization { step_c: 0.0625 };
    let c = contribution(&q, &[0.0, 1.0], &[20.03, 20.04], &[0.0; 2]);
    assert_eq!(c, vec![20.0, 20.0625]);
}

#[test]
fn names_round_trip_through_toml() {
    let terms = vec![
        Term::EarthRate {
            latitude_deg: 28.2,
            axis: Axis::Down,
        },
        Term::RateTerms {
            linear: 1.0,
            cubic: 0.0,
            temp_linear: 0.0,
        },
        Term::ModeHop {
            temp_c: 40.0,
            step_dph: 0.002,
            hysteresis_c: 3.0,
            node_lag_s: 0.0,
        },
    ];
    #[derive(Serialize, Deserialize)]
    struct W {
        terms: Vec<Term>,
    }
    let s = toml::to_string(&W {
        terms: terms.clone(),
    })
    .unwrap();
    assert!(s.contains("kind = \"mode_hop\""), "{s}");
    let back: W = toml::from_str(&s).unwrap();
    assert_eq!(back.terms, terms);
    for t in &terms {
        assert!(s.contains(t.name()));
    }
    assert!(toml::from_str::<W>("[[terms]]\nkind = \"aging\"\nrate = 1.0\n").is_err());
    assert!(Term::Backscatter {
        period_c: 0.0,
        amplitude_dph: 1.0,
        phase_rad: 0.0,
        node_lag_s: 0.0
    }
    .validate()
    .is_err());
}

/// `Term::parameters` names are exactly the serde field names (the names in TOML/JSON), for
/// every term: the serialised object's scalar keys and the listed names coincide.
#[test]
fn parameter_names_are_the_serde_names() {
    let terms = [
        Term::EarthRate {
            latitude_deg: 28.2,
            axis: Axis::Down,
        },
        Term::StaticPoly {
            center_c: 1.0,
            scale_c: 2.0,
            coeffs_dph: vec![1.0, 2.0],
        },
        Term::RateTerms {
            linear: 1.0,
            cubic: 2.0,
            temp_linear: 3.0,
        },
        Term::SensorLag { tau_s: 5.0 },
        Term::GradientLag {
            tau_s: 5.0,
            gain: 1.0,
        },
        Term::Hysteresis {
            width_c: 1.0,
            height_dph: 2.0,
            node_lag_s: 0.0,
        },
        Term::Warmup {
            amplitude_dph: 1.0,
            tau_s: 2.0,
            t_on_s: 3.0,
        },
        Term::ModeHop {
            temp_c: 1.0,
            step_dph: 2.0,
            hysteresis_c: 3.0,
            node_lag_s: 0.0,
        },
        Term::Backscatter {
            period_c: 1.0,
            amplitude_dph: 2.0,
            phase_rad: 3.0,
            node_lag_s: 0.0,
        },
        Term::Periodic {
            period_s: 1.0,
            amplitude_dph: 2.0,
            phase_rad: 3.0,
            windows_s: vec![],
        },
        Term::Aging {
            rate_dph_per_day: 1.0,
        },
        Term::Heteroscedastic { k: 1.0, ref_c: 2.0 },
        Term::TempQuantization { step_c: 0.01 },
        Term::Hysteresis {
            width_c: 1.0,
            height_dph: 2.0,
            node_lag_s: 300.0,
        },
        Term::ModeHop {
            temp_c: 1.0,
            step_dph: 2.0,
            hysteresis_c: 3.0,
            node_lag_s: -300.0,
        },
        Term::Backscatter {
            period_c: 1.0,
            amplitude_dph: 2.0,
            phase_rad: 3.0,
            node_lag_s: 300.0,
        },
    ];
    for t in &terms {
        let v = serde_json::to_value(t).unwrap();
        let mut keys: Vec<String> = v
            .as_object()
            .unwrap()
            .iter()
            .filter(|(_, x)| x.is_number())
            .map(|(k, _)| k.clone())
            .collect();
        if let Some(c) = v.get("coeffs_dph").and_then(|c| c.as_array()) {
            keys.extend((0..c.len()).map(|k| format!("coeffs_dph[{k}]")));
        }
        let mut names: Vec<String> = t.parameters().into_iter().map(|p| p.0).collect();
        keys.sort();
        names.sort();
        assert_eq!(keys, names, "{}", t.name());
        for (k, val) in t.parameters() {
            let direct = v.get(&k).and_then(|x| x.as_f64());
            assert!(direct.is_none_or(|d| d == val), "{k}");
        }
    }
}

/// One term of every kind: the serde `kind` tag of each is its [`Mechanism`]'s name, and
/// together they cover the whole library.
#[test]
fn every_term_kind_is_a_mechanism() {
    let terms = [
        Term::EarthRate {
            latitude_deg: 28.2,
            axis: Axis::Down,
        },
        Term::StaticPoly {
            center_c: 0.0,
            scale_c: 1.0,
            coeffs_dph: vec![1.0],
        },
        Term::RateTerms {
            linear: 1.0,
            cubic: 0.0,
            temp_linear: 0.0,
        },
        Term::SensorLag { tau_s: 60.0 },
        Term::GradientLag {
            tau_s: 600.0,
            gain: 1.0,
        },
        Term::Hysteresis {
            width_c: 2.0,
            height_dph: 1e-3,
            node_lag_s: 0.0,
        },
        Term::Warmup {
            amplitude_dph: 1e-3,
            tau_s: 900.0,
            t_on_s: 0.0,
        },
        Term::ModeHop {
            temp_c: 30.0,
            step_dph: 1e-3,
            hysteresis_c: 1.0,
            node_lag_s: 0.0,
        },
        Term::Backscatter {
            period_c: 25.0,
            amplitude_dph: 1e-3,
            phase_rad: 0.0,
            node_lag_s: 0.0,
        },
        Term::Periodic {
            period_s: 3600.0,
            amplitude_dph: 1e-3,
            phase_rad: 0.0,
            windows_s: vec![],
        },
        Term::Aging {
            rate_dph_per_day: 1e-3,
        },
        Term::Heteroscedastic {
            k: 0.5,
            ref_c: 20.0,
        },
        Term::TempQuantization { step_c: 0.1 },
    ];
    let kinds: Vec<Mechanism> = terms.iter().map(Term::mechanism).collect();
    assert_eq!(kinds, Mechanism::ALL);
    for t in &terms {
        let v = serde_json::to_value(t).unwrap();
        assert_eq!(v["kind"], t.mechanism().name(), "{t:?}");
    }
}

/// A term driven by another node: a positive `node_lag_s` is the first-order lag of T_c
/// (on a ramp from rest, T_c − τ·rate·(1 − e^(−t/τ)); at rest at the first sample), a
/// negative one the node that lag follows (T_c + |τ|·rate), and 0 is T_c itself, so a
/// lagged node's term is the unlagged term of that node's temperature, bit for bit.
#[test]
fn driving_node_lags_or_leads_the_reading() {
    let (tau, r) = (500.0, 0.02);
    let n = 20_000;
    let (t, temp, rate) = ramp(10.0, r, n);
    let bs = |lag: f64| Term::Backscatter {
        period_c: 7.0,
        amplitude_dph: 1.0,
        phase_rad: 0.3,
        node_lag_s: lag,
    };
    let at = |temp_c: f64| (std::f64::consts::TAU * temp_c / 7.0 + 0.3).sin();
    let lagged = contribution(&bs(tau), &t, &temp, &rate);
    let led = contribution(&bs(-tau), &t, &temp, &rate);
    let own = contribution(&bs(0.0), &t, &temp, &rate);
    assert_eq!(lagged[0], at(temp[0]), "a lagging node starts at rest");
    for i in [10_000, 19_999] {
        // The exact lag of a ramp from rest, start transient included (at 20 τ it is still
        // τ·r·e⁻²⁰ ≈ 2e-8 °C, well above the rounding this checks for).
        let node = temp[i] - tau * r * (1.0 - (-t[i] / tau).exp());
        assert!((lagged[i] - at(node)).abs() < 1e-9, "lag at {i}");
        assert!(
            (led[i] - at(temp[i] + tau * r)).abs() < 1e-12,
            "lead at {i}"
        );
        assert_eq!(own[i], at(temp[i]));
    }
    // The node's own temperature through the unlagged term: identical outputs.
    let mut lag = FirstOrderLag::new(temp[0]);
    let node: Vec<f64> = (0..n)
        .map(|i| lag.step(temp[i], if i == 0 { 0.0 } else { 1.0 }, tau))
        .collect();
    let hop = |lag: f64| Term::ModeHop {
        temp_c: 200.0,
        step_dph: 1.0,
        hysteresis_c: 2.0,
        node_lag_s: lag,
    };
    let via_node = contribution(&hop(0.0), &t, &node, &rate);
    let via_lag = contribution(&hop(tau), &t, &temp, &rate);
    assert_eq!(via_node, via_lag);
    // The hop switches when the node, τ·r = 10 °C behind the reading, reaches 200 °C.
    let first = via_lag.iter().position(|v| *v != 0.0).unwrap();
    assert!((temp[first] - 210.0).abs() < 0.05, "{}", temp[first]);
    let play = |lag: f64| Term::Hysteresis {
        width_c: 4.0,
        height_dph: 1.0,
        node_lag_s: lag,
    };
    let via_node = contribution(&play(0.0), &t, &node, &rate);
    assert_eq!(via_node, contribution(&play(tau), &t, &temp, &rate));
    assert!(Term::ModeHop {
        temp_c: 1.0,
        step_dph: 1.0,
        hysteresis_c: 1.0,
        node_lag_s: f64::NAN,
    }
    .validate()
    .is_err());
}
