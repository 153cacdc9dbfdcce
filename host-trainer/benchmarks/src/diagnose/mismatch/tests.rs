//! Tests of the mismatched set's generator, detectability and report.

use super::detect::Metric;
use super::gen::DT_S;
use super::hidden::{hetero_d, mean_effect};
use super::noise::{log_spaced, NoiseDraw};
use super::*;
use crate::diagnose::{Label, PValues};
use rlg_diagnose::prepare::prepare;
use rlg_physics::Term;

/// The same seed and case number give the same recording and conditions; another case
/// number gives another draw.
#[test]
fn generator_is_deterministic() {
    let model = PhysicsModel::paper();
    let kind = Kind::Library(Family::GradientLag);
    let a = build_case(3, kind, 11, &model).expect("case");
    let b = build_case(3, kind, 11, &model).expect("case");
    assert_eq!(a.recording, b.recording);
    assert_eq!(a.conditions, b.conditions);
    assert_eq!(a.hidden, b.hidden);
    assert_eq!(a.describe(), b.describe());
    let c = build_case(4, kind, 11, &model).expect("case");
    assert_ne!(a.conditions, c.conditions);
}

/// Second moments of the means of three 100-sample blocks (the first starting at sample
/// 30, as the diagnosis' blocks do) over `runs` independent realisations of `noise` on a
/// constant rate. An ensemble, not one long series: the bank's slowest processes
/// (correlation times up to days) barely move within one record, so a single series
/// under-reads their variance.
fn ensemble_moments(noise: &NoiseDraw, runs: u64) -> [[f64; 3]; 3] {
    let (first, m) = (30, 100);
    let rate = -7.1;
    let clean = vec![rate; first + 3 * m];
    let mut s = [[0.0; 3]; 3];
    for k in 0..runs {
        let x = noise.generate(&clean, None, DT_S, 1000 + k);
        let b: Vec<f64> = (0..3)
            .map(|i| {
                let blk = &x[first + i * m..first + (i + 1) * m];
                blk.iter().sum::<f64>() / m as f64 - rate
            })
            .collect();
        for i in 0..3 {
            for j in 0..3 {
                s[i][j] += b[i] * b[j] / runs as f64;
            }
        }
    }
    s
}

/// The noise's 100 s means have the covariance the draw's dense Σ says: every diagonal
/// element within 10 % and every neighbour covariance within 10 % of the diagonal, for a
/// clean case's own draw and for a draw with every part (1/f bank, random walk, angle
/// quantisation); and the Student-t white noise has the Gaussian's variance.
#[test]
fn noise_has_the_covariance_of_its_draw() {
    let model = PhysicsModel::paper();
    let clean = build_case(0, Kind::Clean, 2, &model).expect("case");
    let mut all = NoiseDraw {
        arw_dph_rt_h: 2.5e-4,
        student_t: false,
        bias_instability_dph: 5e-4,
        one_over_f: true,
        gm_tau_s: log_spaced(50.0, 4.0, 16),
        gm_sigma_dph: 0.0,
        rrw_dph_per_rt_h: 5e-4,
        quantum_arcsec: 0.3,
        spikes: Vec::new(),
    };
    all.gm_sigma_dph = 1.5e-4;
    let mut own = clean.conditions.noise.clone();
    own.spikes.clear();
    own.student_t = false;
    for noise in [own, all] {
        let sigma = noise.block_cov(3, 100, DT_S, 30);
        let s = ensemble_moments(&noise, 4000);
        for i in 0..3 {
            let want = sigma[i * 3 + i];
            assert!(
                (s[i][i] / want - 1.0).abs() < 0.1,
                "block {i}: {} vs {want} ({noise:?})",
                s[i][i]
            );
            if i + 1 < 3 {
                let c = sigma[i * 3 + i + 1];
                assert!(
                    (s[i][i + 1] - c).abs() < 0.1 * want,
                    "blocks {i}, {}: {} vs {c}",
                    i + 1,
                    s[i][i + 1]
                );
            }
        }
    }
    let t = NoiseDraw {
        student_t: true,
        gm_tau_s: vec![1e3],
        gm_sigma_dph: 0.0,
        rrw_dph_per_rt_h: 0.0,
        quantum_arcsec: 0.0,
        ..clean.conditions.noise.clone()
    };
    let x = t.generate(&vec![0.0; 2_000_000], None, DT_S, 9);
    let var = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
    let want = t.white_sigma(DT_S).powi(2);
    assert!((var / want - 1.0).abs() < 0.1, "t3: {var} vs {want}");
}

/// What the noise-scale detectability takes as a sample's variance about its block's line,
/// w² plus the unscaled part (angle count, bank), is what the generator makes, within 5 %:
/// for a counted output whose quantum dominates, for a short bank whose processes move
/// within a block, and for plain white noise (where D is the diagnosis' own formula).
#[test]
fn noise_scale_detectability_sees_the_samples_variance() {
    let white = NoiseDraw {
        arw_dph_rt_h: 2.5e-4,
        student_t: false,
        bias_instability_dph: 0.0,
        one_over_f: false,
        gm_tau_s: Vec::new(),
        gm_sigma_dph: 0.0,
        rrw_dph_per_rt_h: 0.0,
        quantum_arcsec: 0.0,
        spikes: Vec::new(),
    };
    let counted = NoiseDraw {
        quantum_arcsec: 0.15,
        ..white.clone()
    };
    let short_bank = NoiseDraw {
        gm_tau_s: vec![40.0, 120.0, 400.0],
        gm_sigma_dph: 0.02,
        ..white.clone()
    };
    let m = 100;
    for noise in [&white, &counted, &short_bank] {
        // A rate that sweeps across counts, as a drifting bias does.
        let clean: Vec<f64> = (0..400_000).map(|i| -7.1 + 1e-6 * f64::from(i)).collect();
        let x = noise.generate(&clean, None, DT_S, 5);
        let mut sum = 0.0;
        let blocks = x.len() / m;
        for b in 0..blocks {
            let y = &x[b * m..(b + 1) * m];
            sum += rlg_diagnose::variance::line_variance(y).expect("variance");
        }
        let got = sum / blocks as f64;
        let want = noise.white_sigma(DT_S).powi(2) + noise.unscaled_line_variance(DT_S, m);
        assert!(
            (got / want - 1.0).abs() < 0.05,
            "{got} vs {want} ({noise:?})"
        );
    }
    let temp: Vec<f64> = (0..86_400)
        .map(|i| 20.0 + 30.0 * (f64::from(i) / 9000.0).sin())
        .collect();
    let ours = white.scale_detectability(&temp, 0.3, 0.0, DT_S, m);
    let diag = rlg_diagnose::variance::heteroscedastic_detectability(&temp, 0.3, 0.0);
    assert!((ours / diag - 1.0).abs() < 1e-9, "{ours} vs {diag}");
    let diluted = counted.scale_detectability(&temp, 0.3, 0.0, DT_S, m);
    assert!(diluted < 0.5 * diag, "{diluted} vs {diag}");
    let heavy = NoiseDraw {
        student_t: true,
        ..white.clone()
    };
    let t3 = heavy.scale_detectability(&temp, 0.3, 0.0, DT_S, m);
    assert!((t3 / diag - 0.5f64.sqrt()).abs() < 1e-9, "{t3} vs {diag}");
}

/// Every kind of case reaches the detectability drawn for it within 1e-6 (recomputed from
/// its recording, its final noise and its hidden effect), D is linear in the amplitude
/// of the effects that have one, and the truth label is the mechanism, `unexplained` for
/// the effects outside the library, `none` for a clean case.
#[test]
fn cases_reach_their_detectability() {
    let model = PhysicsModel::paper();
    let kinds = [
        Kind::Library(Family::GradientLag),
        Kind::Library(Family::SensorLag),
        Kind::Library(Family::TempQuantization),
        Kind::Library(Family::Heteroscedastic),
        Kind::Step,
        Kind::RateSquared,
        Kind::BumpInTime,
        Kind::Telegraph,
        Kind::BumpInTemperature,
        Kind::Clean,
    ];
    for (id, kind) in kinds.into_iter().enumerate() {
        let case = build_case(id, kind, 5, &model).expect("case");
        let want = match kind {
            Kind::Library(f) => Label::Mechanism(f.mechanism()),
            k if k.outside() => Label::Unexplained,
            _ => Label::None,
        };
        assert_eq!(case.hidden.label(), want, "{}", kind.name());
        if kind == Kind::Clean {
            assert_eq!(case.hidden, Hidden::None);
            continue;
        }
        assert!((3.0..=10.0).contains(&case.target_d));
        let prep = prepare(&case.recording).expect("prepares");
        let tr = &case.trajectory;
        let d = match hetero_d(&case.hidden, tr, &prep, &case.conditions.noise) {
            Some(d) => d,
            None => {
                let metric = Metric::new(&prep, &model, &case.conditions.noise)
                    .expect("metric")
                    .expect("positive definite");
                let bias = &case.conditions.bias;
                let e =
                    mean_effect(&case.hidden, tr, bias, &case.recording.temp_c).expect("effect");
                let d = metric.d(&prep, &e);
                if !matches!(
                    kind,
                    Kind::Library(Family::SensorLag | Family::TempQuantization)
                ) {
                    let e2 = mean_effect(&case.hidden.scaled(2.0), tr, bias, &[]).expect("effect");
                    let d2 = metric.d(&prep, &e2);
                    assert!(
                        (d2 / d - 2.0).abs() < 1e-9,
                        "{}: {d2} vs 2·{d}",
                        kind.name()
                    );
                }
                d
            }
        };
        assert!(
            (d / case.target_d - 1.0).abs() < 1e-6,
            "{}: D {d} vs target {}",
            kind.name(),
            case.target_d
        );
        assert!((case.d / case.target_d - 1.0).abs() < 1e-6);
    }
}

/// With `other_shapes` the seven families that have another form hide it, labelled with
/// their mechanism, at the same drawn D (linear in its amplitude) and on the same conditions;
/// the three that act through the reading or the noise keep their term and recording.
#[test]
fn other_shapes_keep_the_draw_and_the_mechanism() {
    let model = PhysicsModel::paper();
    for (id, f) in Family::ALL.into_iter().enumerate() {
        let kind = Kind::Library(f);
        let lib = build_case(id, kind, 5, &model).expect("case");
        let variant = Variant {
            other_shapes: true,
            ..Variant::default()
        };
        let other = build_case_in(id, kind, 5, &model, variant).expect("case");
        assert_eq!(other.hidden.label(), Label::Mechanism(f.mechanism()));
        assert_eq!(other.target_d, lib.target_d, "{}", f.name());
        let Hidden::Shaped { shape } = &other.hidden else {
            assert!(matches!(
                f,
                Family::SensorLag | Family::TempQuantization | Family::Heteroscedastic
            ));
            assert_eq!(other.hidden, lib.hidden);
            assert_eq!(other.recording, lib.recording);
            continue;
        };
        assert_eq!(shape.family(), f);
        assert_eq!(other.conditions, lib.conditions, "{}", f.name());
        assert!(other.describe().contains(shape.form()));
        let prep = prepare(&other.recording).expect("prepares");
        let metric = Metric::new(&prep, &model, &other.conditions.noise)
            .expect("metric")
            .expect("positive definite");
        let tr = &other.trajectory;
        let d = metric.d(&prep, &other.hidden.bias_effect(tr));
        let d2 = metric.d(&prep, &other.hidden.scaled(2.0).bias_effect(tr));
        assert!(
            (d / other.target_d - 1.0).abs() < 1e-6,
            "{}: D {d}",
            f.name()
        );
        assert!((d2 / d - 2.0).abs() < 1e-9, "{}", f.name());
    }
}

/// The two effects outside the library are labelled `unexplained`, the verdict that names
/// structure without a library term; a clean case `none`.
#[test]
fn outside_effects_are_labelled_unexplained() {
    let model = PhysicsModel::paper();
    let plan = MismatchOptions::quick(1).plan();
    for (id, kind) in plan.into_iter().filter(|(_, k)| k.outside()).take(2) {
        let case = build_case(id, kind, 1, &model).expect("case");
        assert!(matches!(
            case.hidden,
            Hidden::Step { .. } | Hidden::RateSquared { .. }
        ));
        assert_eq!(case.hidden.label(), Label::Unexplained, "{}", kind.name());
    }
    assert_eq!(Hidden::None.label(), Label::None);
}

/// Kinds read back from their names; the plan numbers families first, then the outside
/// effects, then the clean cases, then (with `--outside-kinds`) the further outside effects,
/// and `only` keeps the numbers.
#[test]
fn plan_and_names() {
    for k in [Kind::Step, Kind::RateSquared, Kind::Clean]
        .into_iter()
        .chain(Kind::MORE_OUTSIDE)
    {
        assert_eq!(Kind::from_name(k.name()), Some(k));
    }
    assert_eq!(
        Kind::from_name("mode_hop"),
        Some(Kind::Library(Family::ModeHop))
    );
    assert_eq!(Kind::from_name("nonsense"), None);
    let mut o = MismatchOptions::quick(1);
    assert_eq!(o.plan().len(), 2 * 10 + 2 * 2 + 8);
    o.only = vec![Kind::RateSquared];
    assert_eq!(
        o.plan(),
        vec![(22, Kind::RateSquared), (23, Kind::RateSquared)]
    );
    o.variant.outside_kinds = true;
    assert_eq!(
        o.plan(),
        vec![(22, Kind::RateSquared), (23, Kind::RateSquared)]
    );
    o.only = Vec::new();
    let plan = o.plan();
    assert_eq!(plan.len(), 2 * 10 + 2 * 2 + 8 + 3 * 2);
    assert_eq!(plan[..32], MismatchOptions::quick(1).plan()[..]);
    assert_eq!(
        plan[32..].iter().map(|(_, k)| *k).collect::<Vec<_>>(),
        [
            Kind::BumpInTime,
            Kind::BumpInTime,
            Kind::Telegraph,
            Kind::Telegraph
        ]
        .into_iter()
        .chain([Kind::BumpInTemperature; 2])
        .collect::<Vec<_>>()
    );
}

/// The further effects outside the library: a bump in time inside the record, a telegraph
/// of at least two switches (not one step) in ascending order, a bump at a temperature the
/// body passes through; each adds what it says to the bias.
#[test]
fn more_outside_effects_are_what_they_say() {
    let model = PhysicsModel::paper();
    for (id, kind) in Kind::MORE_OUTSIDE.into_iter().enumerate() {
        for seed in 1..=4 {
            let case = build_case(300 + id, kind, seed, &model).expect("case");
            let tr = &case.trajectory;
            let end = tr.t_s[tr.t_s.len() - 1];
            let e = case.hidden.bias_effect(tr);
            let peak = e.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
            assert!(peak > 0.0, "{}: {:?}", kind.name(), case.hidden);
            match &case.hidden {
                Hidden::BumpInTime {
                    centre_s,
                    width_s,
                    amplitude_dph,
                } => {
                    assert!(*centre_s > 0.15 * end && *centre_s < 0.85 * end);
                    assert!((1200.0..=7200.0).contains(width_s));
                    assert!((peak / amplitude_dph.abs() - 1.0).abs() < 0.01);
                }
                Hidden::Telegraph {
                    switches_s,
                    level_dph,
                } => {
                    assert!(switches_s.len() >= 2, "{switches_s:?}");
                    assert!(switches_s.windows(2).all(|w| w[1] > w[0]), "{switches_s:?}");
                    let levels: Vec<f64> = e.iter().copied().filter(|v| *v != 0.0).collect();
                    assert!(levels.iter().all(|v| v == level_dph));
                    assert!(!levels.is_empty() && levels.len() < e.len());
                }
                Hidden::BumpInTemperature {
                    centre_c,
                    amplitude_dph,
                    ..
                } => {
                    let (lo, hi) = tr
                        .node_c
                        .iter()
                        .fold((f64::MAX, f64::MIN), |(a, b), t| (a.min(*t), b.max(*t)));
                    assert!(*centre_c > lo && *centre_c < hi, "{centre_c} in {lo}..{hi}");
                    assert!(peak > 0.5 * amplitude_dph.abs());
                }
                h => panic!("{}: {h:?}", kind.name()),
            }
        }
    }
}

/// A made-up scored case whose every p-value is `p`, run at α = 10 %.
fn made_up(id: usize, kind: Kind, truth: Label, predicted: Label, p: f64) -> MismatchResult {
    MismatchResult {
        kind,
        conditions: vec!["angle quantisation".into()],
        form: None,
        two: None,
        coarse: None,
        noise_in_time: None,
        result: CaseResult {
            id,
            profile: String::new(),
            truth,
            detectability: 4.0,
            detectability_marginal: 0.0,
            peak_over_sigma1: 0.0,
            energy_in_span: 0.0,
            predicted,
            param_ok: None,
            param_rel_err: None,
            param: None,
            iou: None,
            gain_fraction: None,
            seconds: 1.0,
            best_delta_bic: (Label::None, 0.0, 0.0),
            p_values: PValues {
                best: p,
                finding: None,
                structure: p,
                verdict: Some(p),
                true_family_alone: None,
            },
            alpha: 0.1,
            shift: 0,
        },
    }
}

/// Two clean cases (p 0.5 and 0.03), an outside-library step and a missed aging.
fn made_up_run() -> Vec<MismatchResult> {
    let r = made_up;
    vec![
        r(0, Kind::Clean, Label::None, Label::None, 0.5),
        r(1, Kind::Clean, Label::None, Label::Unexplained, 0.03),
        r(2, Kind::Step, Label::Unexplained, Label::Unexplained, 0.0),
        r(
            3,
            Kind::Library(Family::Aging),
            Label::Mechanism(Family::Aging.mechanism()),
            Label::None,
            0.4,
        ),
    ]
}

/// The report shows every section and the calibration figure is a PNG, on made-up results.
#[test]
fn report_and_figure() {
    let results = made_up_run();
    let md = mismatch_report_markdown(&results);
    for needle in [
        "α = 10.0 %",
        "false alarms on clean recordings",
        "top-1, library families, D 3–5",
        "outside-library effects named as a library mechanism",
        "| 5 % | 50 % (1/2)",
        "| angle quantisation | 1 / 0 of 2 (0) |",
        "| hidden effects concealed",
        "| step |",
    ] {
        assert!(md.contains(needle), "missing `{needle}` in\n{md}");
    }
    // Every case is at D = 4: no row for the outside effects at D ≥ 6, rather than a "–".
    assert!(!md.contains("at D ≥ 6 called"), "{md}");
    assert!(!md.contains("| – |"), "{md}");
    let dir = tempfile::tempdir().expect("temp dir");
    let png = dir.path().join("calibration.png");
    calibration_png(&results, &png).expect("draws");
    let b = std::fs::read(&png).expect("reads");
    assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
}

/// The detection curve counts each bin of D: named first, found at all (a wrong name is
/// found, a `consistent` is not), outside-library effects called `unexplained`; the figure
/// is a PNG.
#[test]
fn detection_curve_counts_each_bin() {
    let aging = || Label::Mechanism(Family::Aging.mechanism());
    let hop = Label::Mechanism(Family::ModeHop.mechanism());
    let lib = Kind::Library(Family::Aging);
    let at = |mut r: MismatchResult, d: f64| {
        r.result.detectability = d;
        r
    };
    let results = vec![
        made_up(0, Kind::Clean, Label::None, Label::None, 0.5),
        at(made_up(1, lib, aging(), aging(), 0.01), 6.5),
        at(made_up(2, lib, aging(), hop, 0.01), 7.0),
        at(made_up(3, lib, aging(), Label::None, 0.3), 7.5),
        at(made_up(4, lib, aging(), aging(), 0.01), 3.5),
        at(
            made_up(5, Kind::Step, Label::Unexplained, Label::Unexplained, 0.0),
            7.0,
        ),
        at(
            made_up(6, Kind::Step, Label::Unexplained, Label::None, 0.5),
            6.2,
        ),
    ];
    let b = super::curve::bins(&results);
    assert_eq!(b.len(), 2, "{b:?}");
    assert_eq!(
        (
            b[0].lo,
            b[0].library,
            b[0].top1,
            b[0].detected,
            b[0].outside
        ),
        (3.0, 1, 1, 1, 0)
    );
    assert_eq!(
        (b[1].lo, b[1].library, b[1].top1, b[1].detected),
        (6.0, 3, 1, 2)
    );
    assert_eq!((b[1].outside, b[1].unexplained), (2, 1));
    assert!((b[1].at - 7.0).abs() < 1e-12);
    let md = mismatch_report_markdown(&results);
    assert!(md.contains("| 6–8 | 33 % (1/3) ["), "{md}");
    assert!(md.contains("| 3–4 | 100 % (1/1) ["), "{md}");
    // No outside-library case at D 3–4: its column is "–"; at D 6–8 one of two.
    assert!(
        md.lines()
            .any(|l| l.starts_with("| 3–4 |") && l.ends_with("| – |")),
        "{md}"
    );
    assert!(
        md.lines()
            .any(|l| l.starts_with("| 6–8 |") && l.contains("| 50 % (1/2) [")),
        "{md}"
    );
    // Without outside-library cases the column is left out; with two effects, the first is
    // found when some finding names it (here none does, though the verdict names the second).
    let mut two: Vec<MismatchResult> = results
        .iter()
        .filter(|r| !r.kind.outside())
        .cloned()
        .collect();
    for r in &mut two {
        r.two = Some(TwoFound {
            first: (r.result.detectability, false),
            second: (7.0, true),
            second_mechanism: "mode_hop".into(),
        });
    }
    let md2 = mismatch_report_markdown(&two);
    assert!(!md2.contains("outside: `unexplained`"), "{md2}");
    assert!(md2.contains("(the first of two effects)"), "{md2}");
    assert!(
        md2.contains("| 6–8 | 33 % (1/3) [6–79 %] | 0 % (0/3) ["),
        "{md2}"
    );
    // Beside a coarse reading, the quantum's finding alone is not the effect found.
    let mut coarse: Vec<MismatchResult> = results
        .iter()
        .filter(|r| matches!(r.kind, Kind::Library(_)))
        .cloned()
        .collect();
    for r in &mut coarse {
        r.result.predicted = Label::Mechanism(Family::TempQuantization.mechanism());
        r.coarse = Some(CoarseFound {
            quantum_c: 0.25,
            d: r.result.detectability,
            effect_found: r.result.id == 1,
            effect_first: false,
            artefact_named: true,
            other_named: false,
        });
    }
    let b = super::curve::bins(&coarse);
    assert_eq!((b[1].library, b[1].top1, b[1].detected), (3, 0, 1), "{b:?}");
    assert!(mismatch_report_markdown(&coarse).contains("(beside a coarse temperature reading)"));
    let dir = tempfile::tempdir().expect("temp dir");
    let png = dir.path().join("detection.png");
    detection_png(&results, "made-up", &png).expect("draws");
    let bytes = std::fs::read(&png).expect("reads");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
}

/// A run of hidden effects only (`--only` without `none`) says it measured no false alarms
/// instead of printing an empty calibration and "0 of 0" for every condition.
#[test]
fn report_without_clean_recordings_leaves_out_their_sections() {
    let results: Vec<MismatchResult> = made_up_run()
        .into_iter()
        .filter(|r| r.kind != Kind::Clean)
        .collect();
    let md = mismatch_report_markdown(&results);
    assert!(md.contains("No clean recordings in this run"), "{md}");
    for gone in [
        "Calibration on the",
        "False alarms by condition",
        "false alarms on clean recordings",
        "0 of 0",
    ] {
        assert!(!md.contains(gone), "`{gone}` in\n{md}");
    }
    assert!(
        md.contains("top-1, library families, D 3–5 | 0 % (0/1)"),
        "{md}"
    );
    assert!(md.contains("| step |"), "{md}");
}

/// With two effects hidden, the top-1 row says it scores the first effect only.
#[test]
fn two_effect_runs_say_whose_top_1_it_is() {
    let mut results = made_up_run();
    results[3].two = Some(super::TwoFound {
        first: (4.0, false),
        second: (4.0, true),
        second_mechanism: "hysteresis".into(),
    });
    let md = mismatch_report_markdown(&results);
    assert!(
        md.contains("| top-1 is the first of two effects, library families, D 3–5 | 0 % (0/1) |"),
        "{md}"
    );
    assert!(!md.contains("| top-1, library"), "{md}");
}

/// `clean_results` reads the clean cases of either set's `results.json` (a mismatched run's
/// entries by their kind, a matched run's results by their truth), and their calibration
/// pools: one of the two clean cases of each run is flagged at 5 %.
#[test]
fn clean_results_of_both_sets_pool() {
    let results = made_up_run();
    let mismatched =
        clean_results(&serde_json::to_string(&results).expect("writes")).expect("reads");
    let matched: Vec<CaseResult> = results.iter().map(|r| r.result.clone()).collect();
    let matched = clean_results(&serde_json::to_string(&matched).expect("writes")).expect("reads");
    for clean in [&mismatched, &matched] {
        assert_eq!(clean.iter().map(|c| c.id).collect::<Vec<_>>(), [0, 1]);
    }
    let pooled: Vec<&CaseResult> = mismatched.iter().chain(&matched).collect();
    let md = calibration_markdown(&pooled);
    assert!(md.contains("Calibration on the 4 clean recordings"), "{md}");
    assert!(md.contains("| 5 % | 50 % (2/4)"), "{md}");
    assert!(md.contains("| 1 % | 0 % (0/4)"), "{md}");
}

/// Clean case `id` of `seed` (its conditions must include a rate random walk) diagnosed
/// with the defaults, asserted `consistent`.
fn clean_case_with_rate_random_walk_is_consistent(id: usize, seed: u64) -> rlg_diagnose::Diagnosis {
    let model = PhysicsModel::paper();
    let case = build_case(id, Kind::Clean, seed, &model).expect("case");
    assert!(
        case.conditions
            .tags()
            .iter()
            .any(|t| t == "rate random walk"),
        "{}",
        case.describe()
    );
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    assert_eq!(
        d.verdict,
        rlg_diagnose::Verdict::Consistent,
        "{:#?}",
        d.evidence
    );
    d
}

/// A clean recording (3 °C/min ramps, angle quantisation, rate random walk and 1/f-like
/// bias) whose slow drift fills the generic test's time chunks: significant under white
/// noise and bias instability, not under the record's noise refitted with rate random walk.
/// It is `consistent`, and the evidence says why.
#[test]
fn slow_drift_is_not_structure_under_rate_random_walk() {
    let d = clean_case_with_rate_random_walk_is_consistent(167, 3);
    assert!(
        d.evidence.structure_p_value > 0.05,
        "{}",
        d.evidence.structure_p_value
    );
    assert!(
        d.evidence
            .notes
            .iter()
            .any(|n| n.contains("generic structure test") && n.contains("rate random walk")),
        "{:?}",
        d.evidence.notes
    );
    // A kept case's report beside its recording is the diagnosis as `rlg diagnose --json`
    // writes it.
    let dir = tempfile::tempdir().expect("temp dir");
    let csv = dir.path().join("mismatched0167.csv");
    crate::diagnose::write_report_beside(&csv, &d).expect("writes");
    let kept: serde_json::Value = serde_json::from_slice(
        &std::fs::read(dir.path().join("mismatched0167.diagnosis.json")).expect("kept"),
    )
    .expect("JSON");
    assert_eq!(kept, serde_json::to_value(&d).expect("serialises"));
    assert_eq!(kept["verdict"], "consistent");
}

/// A step at one time in the independent generator's recording (1.68e-3 °/h at 10.2 h
/// under 1/f-like bias) is not aging: a single step fits it better than aging, and the step
/// is either the structure (`unexplained_structure`, reported within an hour of its time)
/// or slow drift not separable from the record's own slow noise, said in a note.
#[test]
fn step_at_one_time_is_not_named_aging() {
    let model = PhysicsModel::paper();
    let case = build_case(127, Kind::Step, 1, &model).expect("case");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    assert!(d.findings.is_empty(), "{:#?}", d.findings);
    match d.verdict {
        rlg_diagnose::Verdict::UnexplainedStructure => {
            let step = d.evidence.step.as_ref().expect("the step is reported");
            assert_eq!(step.instead_of.name(), "aging", "{step:?}");
            let at_h = (step.t_s - case.recording.time_s[0]) / 3600.0;
            assert!((at_h - 10.2).abs() < 1.0, "{step:?}");
        }
        rlg_diagnose::Verdict::Consistent => assert!(
            d.evidence
                .notes
                .iter()
                .any(|n| n.starts_with("a single step") && n.contains("slow drift")),
            "{:?}",
            d.evidence.notes
        ),
        v => panic!("{v:?}: {:#?}", d.evidence),
    }
}

/// A warm-up of τ 1 900 s lives in the record's first hour, where a held-out check on 1 h
/// chunks calls it worse than nothing (`unexplained_structure`); on chunks of half its τ it
/// is the finding, the true τ within twice its reported σ.
#[test]
fn short_warmup_passes_its_heldout_check() {
    let model = PhysicsModel::paper();
    let case = build_case(37, Kind::Library(Family::Warmup), 1, &model).expect("case");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    assert_eq!(
        d.verdict,
        rlg_diagnose::Verdict::MissingPhysics,
        "{:#?}",
        d.evidence
    );
    let f = &d.findings[0];
    assert_eq!(f.mechanism.name(), "warmup", "{:#?}", d.evidence);
    let (tau, sd) = (f.parameters["tau_s"], f.uncertainty["tau_s"]);
    assert!((tau - 1911.39).abs() < 2.0 * sd, "tau {tau} ± {sd}");
}

/// An aging of −3.0e-3 °/h per day in the independent generator's recording, on noise with
/// no rate random walk (D 9.9): white noise and bias instability fail the Allan check. The
/// rate random walk REML fits in their place, its 100 s level held
/// (`noise::reml::white_and_b_given_k`), explains the drift as well as a ramp at α (the
/// drift is about a 1.7σ excursion of that walk over a day), so `consistent` with the K in
/// a note is a right answer: the slow check is calibrated (test
/// `the_slow_check_is_calibrated_on_rate_random_walk`) and a day cannot tell this drift
/// from that walk. What must hold either way: no other mechanism is named, the noise
/// model's rate random walk is said, and an aging found has its rate within the benchmark's
/// tolerance.
#[test]
fn a_day_long_drift_is_aging_or_said_to_be_rate_random_walk() {
    let model = PhysicsModel::paper();
    let case = build_case(85, Kind::Library(Family::Aging), 1, &model).expect("case");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    match d.verdict {
        rlg_diagnose::Verdict::MissingPhysics => {
            let f = &d.findings[0];
            assert_eq!(f.mechanism.name(), "aging", "{:#?}", d.evidence);
            let rate = f.parameters["rate_dph_per_day"];
            assert!(
                (rate / -3.035e-3 - 1.0).abs() < 0.25,
                "rate {rate} °/h per day"
            );
        }
        rlg_diagnose::Verdict::Consistent => {
            assert!(d.evidence.noise_fit[2] > 0.0, "{:?}", d.evidence.noise_fit);
            assert!(
                d.evidence
                    .notes
                    .iter()
                    .any(|n| n.contains("rate random walk added")),
                "{:?}",
                d.evidence.notes
            );
        }
        v => panic!("{v:?}: {:#?}", d.evidence),
    }
}

/// A clean recording of the independent generator whose noise holds rate random walk and a
/// 1/f-like bank: white noise and bias instability pass the Allan check, and under them the
/// record's drift is an aging at p ≤ 2 %. Under the same record's noise refitted with rate
/// random walk it is not significant: the verdict is `consistent`, with the drift reported
/// as not separable from the record's own slow noise.
#[test]
fn slow_wander_of_a_clean_record_is_not_aging() {
    let model = PhysicsModel::paper();
    let case = build_case(202, Kind::Clean, 3, &model).expect("case");
    let opts = rlg_diagnose::Options::default();
    let d = rlg_diagnose::diagnose(&case.recording, &model, &opts).expect("diagnoses");
    let aging = d
        .evidence
        .candidates
        .iter()
        .find(|c| c.mechanism.name() == "aging")
        .expect("aging is a candidate");
    let p_rrw = aging.p_value_rrw.expect("tested under rate random walk");
    assert!(
        aging.p_value_alone <= opts.alpha && p_rrw > opts.alpha && aging.p_value >= p_rrw,
        "{aging:?}"
    );
    assert_eq!(
        d.verdict,
        rlg_diagnose::Verdict::Consistent,
        "{:#?}",
        d.evidence
    );
    assert!(
        d.evidence
            .notes
            .iter()
            .any(|n| n.starts_with("aging is significant") && n.contains("rate random walk")),
        "{:#?}",
        d.evidence.notes
    );
}

/// With `effect_elsewhere` a mechanism of the bias is driven by the body's other node: on the
/// default case's conditions and drawn D, the recording's rate is the default one less the
/// effect on the sensor's node plus the effect on the other node (the noise is the same
/// draw), that effect has the drawn D in the sensor's metric, and the reading is unchanged.
/// Sensor and noise terms, the step in time and the clean cases are unchanged.
#[test]
fn effect_elsewhere_is_driven_by_the_other_node() {
    let model = PhysicsModel::paper();
    let variant = Variant {
        effect_elsewhere: true,
        ..Variant::default()
    };
    let mut kinds: Vec<Kind> = Family::ALL.into_iter().map(Kind::Library).collect();
    kinds.extend([Kind::Step, Kind::Clean]);
    let mut moved = 0;
    for (id, kind) in kinds.into_iter().enumerate() {
        let base = build_case(id, kind, 6, &model).expect("case");
        let alt = build_case_in(id, kind, 6, &model, variant).expect("case");
        assert_eq!(alt.conditions, base.conditions, "{kind:?}");
        assert_eq!(alt.target_d, base.target_d, "{kind:?}");
        assert_eq!(alt.recording.temp_c, base.recording.temp_c, "{kind:?}");
        let tr = &alt.trajectory;
        let bias_term = matches!(
            kind,
            Kind::Library(f) if !matches!(
                f,
                Family::SensorLag | Family::TempQuantization | Family::Heteroscedastic
            )
        );
        if !bias_term {
            assert!(!alt.effect_elsewhere, "{kind:?}");
            assert_eq!(alt.recording, base.recording, "{kind:?}");
            continue;
        }
        moved += 1;
        assert!(alt.effect_elsewhere && alt.describe().contains(" on the c"));
        let here = alt.hidden.bias_effect(tr);
        let there = alt.hidden.bias_effect(&tr.at_other_node());
        let base_here = base.hidden.bias_effect(&base.trajectory);
        // The same noise draw: the rates differ by the effects alone (where the rate is a
        // count, to within two counts: each end of a sample's count is rounded).
        let tol = 1e-9 + 2.0 * alt.conditions.noise.quantum_arcsec / DT_S;
        for i in (0..here.len()).step_by(97) {
            let want = base.recording.rate_dph[i] - base_here[i] + there[i];
            assert!(
                (alt.recording.rate_dph[i] - want).abs() <= tol,
                "{kind:?} sample {i}"
            );
        }
        // A time-only term is the same on either node; a thermal one is not.
        let differs = here.iter().zip(&there).any(|(a, b)| (a - b).abs() > 1e-12);
        let Kind::Library(f) = kind else {
            unreachable!()
        };
        assert_eq!(differs, f.is_thermal(), "{kind:?}");
        let prep = prepare(&alt.recording).expect("prepares");
        let metric = Metric::new(&prep, &model, &alt.conditions.noise)
            .expect("metric")
            .expect("positive definite");
        let d = metric.d(&prep, &there);
        assert!((d / alt.target_d - 1.0).abs() < 1e-6, "{kind:?}: D {d}");
    }
    assert_eq!(moved, 7);
}

/// `--logger` leaves the case as drawn (conditions, hidden effect, D) and changes only the
/// recording, each artefact as it says: minutes or seconds missing, means of k seconds,
/// Unix millisecond stamps that stay strictly increasing, readings at a sensor's error
/// values. Every artefact is drawn among a few cases, and a recording survives a CSV round
/// trip through the reader the diagnosis uses.
#[test]
fn logger_artefacts_change_only_the_recording() {
    use super::logger::Logger;
    let model = PhysicsModel::paper();
    let variant = Variant {
        logger: true,
        ..Variant::default()
    };
    let mut seen = std::collections::BTreeSet::new();
    let dir = std::env::temp_dir().join(format!("rlg-logger-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    for id in 0..24 {
        let kind = if id % 3 == 0 {
            Kind::Library(Family::Aging)
        } else {
            Kind::Clean
        };
        let base = build_case(id, kind, 5, &model).expect("case");
        let alt = build_case_in(id, kind, 5, &model, variant).expect("case");
        assert_eq!(alt.conditions, base.conditions);
        assert_eq!(alt.hidden, base.hidden);
        assert_eq!(alt.d, base.d);
        let (b, a) = (&base.recording, &alt.recording);
        let logger = alt.logger.clone().expect("an artefact");
        assert!(alt.describe().contains(&logger.describe()));
        assert!(alt.tags().iter().any(|t| t == logger.tag()));
        let steps = || a.time_s.windows(2).map(|w| w[1] - w[0]);
        assert!(steps().all(|d| d > 0.0), "{logger:?}");
        match &logger {
            Logger::Dropouts { gaps } => {
                assert!(a.len() < b.len());
                assert!(steps().fold(0.0, f64::max) >= gaps[0].1, "{logger:?}");
            }
            Logger::Hiccups { .. } => {
                assert!(
                    a.len() < b.len() && a.len() > b.len() * 9 / 10,
                    "{logger:?}"
                );
            }
            Logger::Averaged { period_s } => {
                let k = *period_s as usize;
                assert_eq!(a.len(), b.len() / k);
                let m: f64 = b.rate_dph[k..2 * k].iter().sum::<f64>() / k as f64;
                assert!((a.rate_dph[1] - m).abs() < 1e-12);
            }
            Logger::EpochClock { offset_s, .. } => {
                assert_eq!(a.len(), b.len());
                assert!(a.time_s[0] >= *offset_s - 1.0 && a.time_s[0] > 1e9);
                assert!(a
                    .time_s
                    .iter()
                    .all(|t| (t * 1e3 - (t * 1e3).round()).abs() < 1e-3));
                assert_eq!(a.rate_dph, b.rate_dph);
            }
            Logger::TempFaults { count } => {
                let bad = a
                    .temp_c
                    .iter()
                    .filter(|t| **t == 85.0 || **t == -127.0)
                    .count();
                assert!(bad >= 1 && bad <= *count, "{bad} of {count}");
                assert_eq!(a.rate_dph, b.rate_dph);
            }
        }
        seen.insert(logger.tag());
        if id < 5 {
            let path = dir.join(format!("{id}.csv"));
            a.write_csv(&path).expect("written");
            let back = Recording::read_csv(&path).expect("read back");
            assert_eq!(back.len(), a.len());
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(seen.len(), 5, "{seen:?}");
}

/// A second effect leaves the first as its single-effect twin draws it, is another
/// mechanism of the bias at a D of its own in 3…10, and adds exactly its term to the rate
/// (the noise and the reading are the twin's); a sensor term gets none.
#[test]
fn a_second_effect_is_another_mechanism_beside_the_first() {
    let model = PhysicsModel::paper();
    let variant = Variant {
        second_effect: true,
        ..Variant::default()
    };
    let mut seen = 0;
    let families = [
        Family::Warmup,
        Family::Aging,
        Family::Hysteresis,
        Family::ModeHop,
    ];
    for (id, f) in families.into_iter().enumerate() {
        let kind = Kind::Library(f);
        let one = build_case(id, kind, 7, &model).expect("case");
        let two = build_case_in(id, kind, 7, &model, variant).expect("case");
        assert_eq!((&two.hidden, two.d), (&one.hidden, one.d), "{}", f.name());
        let Some((term, d2)) = &two.second else {
            continue;
        };
        seen += 1;
        assert_ne!(term.mechanism(), f.mechanism());
        assert!((3.0..10.0).contains(d2), "{d2}");
        assert_eq!(two.conditions.bias.last(), Some(term));
        assert_eq!(two.recording.temp_c, one.recording.temp_c);
        let tr = &two.trajectory;
        let added = rlg_physics::contribution(term, &tr.t_s, &tr.node_c, &tr.dnode_c_per_s);
        // The counted angle's quantum (≤ 0.2″) is the only part of the noise that does not
        // add: over 100 s its rounding moves a mean by at most 2 × 0.2″ / 100 s = 0.004 °/h.
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let diff: Vec<f64> = two
            .recording
            .rate_dph
            .iter()
            .zip(&one.recording.rate_dph)
            .map(|(a, b)| a - b)
            .collect();
        let worst = diff
            .chunks_exact(100)
            .zip(added.chunks_exact(100))
            .map(|(d, e)| (mean(d) - mean(e)).abs())
            .fold(0.0, f64::max);
        let peak = added.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            peak > 0.0 && worst <= 0.0041,
            "{worst} against a peak of {peak}"
        );
    }
    assert!(seen >= 3, "{seen} of 4 cases got a second effect");
    let sensor =
        build_case_in(9, Kind::Library(Family::SensorLag), 7, &model, variant).expect("case");
    assert!(sensor.second.is_none());
}

/// An aging (−8.2e-3 °/h per day) beside a gradient's lag (D 6.7) under 1/f-like noise with
/// rate random walk (seed 1, case 91 of the two-effect set): the lag is significant but,
/// with the drift left out of the model, lowers no held-out error alone, and the record
/// was `unexplained_structure` with nothing named. Held out beside another family
/// significant on its own it does, and that family beside it too: the lag is named, with a
/// note giving both gains, and aging is found on the next pass.
#[test]
fn an_effect_masked_by_a_second_is_credited_beside_it() {
    let model = PhysicsModel::paper();
    let variant = Variant {
        second_effect: true,
        ..Variant::default()
    };
    let case = build_case_in(91, Kind::Library(Family::Aging), 1, &model, variant).expect("case");
    let (term, _) = case.second.as_ref().expect("a second effect");
    assert_eq!(term.mechanism().name(), "gradient_lag");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    let mut found: Vec<&str> = d.findings.iter().map(|f| f.mechanism.name()).collect();
    found.sort_unstable();
    assert_eq!(found, ["aging", "gradient_lag"], "{:#?}", d.evidence);
    let alone = d
        .evidence
        .candidates
        .iter()
        .find(|c| c.mechanism.name() == "gradient_lag");
    assert!(
        alone.is_some_and(|c| c.heldout_gain <= 0.0),
        "{:#?}",
        d.evidence.candidates
    );
    assert!(
        d.evidence
            .notes
            .iter()
            .any(|n| n.starts_with("gradient_lag lowers no held-out error alone")),
        "{:#?}",
        d.evidence.notes
    );
}

/// An aging that slows (here as the square root of time, seed 1, case 90 of the other
/// shapes) beats the record's noise refitted with rate random walk as a decay from power-on,
/// not as a straight line, while the record ranks the line before every decay: the decay's
/// test alone named it `warmup`. With the decay's test as the drift's evidence, aging names
/// it, and a note says so.
#[test]
fn an_aging_that_slows_is_named_aging_not_warmup() {
    let model = PhysicsModel::paper();
    let variant = Variant {
        other_shapes: true,
        ..Variant::default()
    };
    let case = build_case_in(90, Kind::Library(Family::Aging), 1, &model, variant).expect("case");
    assert!(
        matches!(case.hidden, Hidden::Shaped { .. }),
        "{:?}",
        case.hidden
    );
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    let found: Vec<&str> = d.findings.iter().map(|f| f.mechanism.name()).collect();
    assert_eq!(found.first(), Some(&"aging"), "{:#?}", d.evidence);
    assert!(
        d.evidence
            .notes
            .iter()
            .any(|n| n.starts_with("aging's straight line alone does not beat")),
        "{:#?}",
        d.evidence.notes
    );
}

/// A sensor lag read at 0.01 °C with no reading noise (case 5 of seed 2: ramps between
/// holds, D 9.4). Un-lagged by τ times the slope of the rounded steps, the reading would carry
/// its rounding into the lagging sensor's column as a lag of its own, and `temp_quantization`
/// ranks first; with the slope of the de-quantised reading the sensor's lag is named first,
/// with its τ within 20 %.
#[test]
fn a_lagging_sensor_read_rounded_is_named_sensor_lag() {
    let model = PhysicsModel::paper();
    let case = build_case(5, Kind::Library(Family::SensorLag), 2, &model).expect("case");
    let Hidden::Library {
        term: Term::SensorLag { tau_s },
    } = case.hidden
    else {
        panic!("{:?}", case.hidden)
    };
    assert_eq!(case.conditions.temp_noise_c, 0.0);
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    let f = d.findings.first().expect("a finding");
    assert_eq!(f.mechanism.name(), "sensor_lag", "{:#?}", d.evidence);
    let tau = f.parameters["tau_s"];
    assert!((tau / tau_s - 1.0).abs() < 0.2, "tau {tau} against {tau_s}");
}

/// A temperature reading rounded to 0.345 °C (case 7 of seed 3's `temp_quantization`, D 9.8).
/// On its staircase a gradient's lag takes the rounding's spikes of dT/dt too, and fits the
/// record about as well as the quantisation does; the rounding is seen in the reading, so the
/// quantisation is named first, at the reading's quantum.
#[test]
fn a_rounded_reading_is_named_before_a_lag_that_fits_about_as_well() {
    let model = PhysicsModel::paper();
    let case = build_case(7, Kind::Library(Family::TempQuantization), 3, &model).expect("case");
    let Hidden::Library {
        term: Term::TempQuantization { step_c },
    } = case.hidden
    else {
        panic!("{:?}", case.hidden)
    };
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    let f = d.findings.first().expect("a finding");
    assert_eq!(f.mechanism.name(), "temp_quantization", "{:#?}", d.evidence);
    let q = f.parameters["step_c"];
    assert!(
        (q / step_c - 1.0).abs() < 0.05,
        "quantum {q} against {step_c}"
    );
}

/// A coarse reading keeps the case's draw and rounds the reading to a 9- to 12-bit sensor's
/// quantum (the bias is the twin's: the rate moves only through the noise's share of the
/// changed amplitude, so the hidden term and its family are the twin's); a hidden
/// `temp_quantization` keeps its own quantum. A noise level in time leaves a clean case's
/// bias, reading and slow noise alone and multiplies its white noise as drawn.
#[test]
fn coarse_readings_and_noise_in_time_keep_the_twin() {
    let model = PhysicsModel::paper();
    let coarse = Variant {
        coarse_reading: true,
        ..Variant::default()
    };
    let mut quanta = Vec::new();
    for (id, f) in [
        (0, Family::Aging),
        (1, Family::Hysteresis),
        (2, Family::Warmup),
    ] {
        let kind = Kind::Library(f);
        let one = build_case(id, kind, 5, &model).expect("case");
        let two = build_case_in(id, kind, 5, &model, coarse).expect("case");
        assert_eq!(one.conditions, two.conditions, "{}", f.name());
        assert_eq!(one.hidden.label(), two.hidden.label());
        let q = two.coarse.expect("a coarse reading").quantum_c;
        assert!([0.0625, 0.125, 0.25, 0.5].contains(&q), "{q}");
        for (t, t1) in two.recording.temp_c.iter().zip(&one.recording.temp_c) {
            let k = t / q;
            assert!((k - k.round()).abs() < 1e-9, "{t} is not a multiple of {q}");
            assert!(
                (t - t1).abs() <= q / 2.0 + 0.02,
                "{t} against the twin's {t1}"
            );
        }
        quanta.push(q);
    }
    let tq = build_case_in(
        3,
        Kind::Library(Family::TempQuantization),
        5,
        &model,
        coarse,
    )
    .expect("case");
    assert!(tq.coarse.is_none());

    let in_time = Variant {
        noise_in_time: true,
        ..Variant::default()
    };
    let mut forms = std::collections::BTreeSet::new();
    for id in 0..12 {
        let one = build_case(id, Kind::Clean, 5, &model).expect("case");
        let two = build_case_in(id, Kind::Clean, 5, &model, in_time).expect("case");
        let change = two.noise_in_time.expect("a change in time");
        forms.insert(format!("{:?}", change.form));
        assert_eq!(one.conditions, two.conditions);
        assert_eq!(one.recording.temp_c, two.recording.temp_c);
        // Without angle quantisation the white part adds: the difference is the white
        // noise times (scale − 1), zero where the scale is 1.
        if one.conditions.noise.quantum_arcsec == 0.0 {
            let scale = change.scale(&two.recording.time_s);
            let at_one = scale
                .iter()
                .zip(&one.recording.rate_dph)
                .zip(&two.recording.rate_dph);
            for ((s, a), b) in at_one {
                if *s == 1.0 {
                    assert!((a - b).abs() < 1e-9, "{a} against {b}");
                }
            }
            assert_ne!(one.recording.rate_dph, two.recording.rate_dph);
        }
        let lib =
            build_case_in(id, Kind::Library(Family::Aging), 5, &model, in_time).expect("case");
        assert!(lib.noise_in_time.is_none(), "only clean cases");
    }
    assert_eq!(forms.len(), 3, "{forms:?}");
}

#[test]
fn a_figure_names_the_variant_it_draws() {
    assert_eq!(Variant::default().describe(), "mismatched set");
    let v = Variant {
        second_effect: true,
        coarse_reading: true,
        ..Variant::default()
    };
    assert_eq!(v.describe(), "mismatched set, two effects, coarse reading");
}

/// A noise level that rises with temperature (seed 1, case 105, D 5.1) on a record whose
/// rate random walk makes the generic test's time chunks significant under white noise and
/// bias instability alone: the first pass finds that to be the record's own slow drift. After
/// the finding a later pass asks the generic test under rate random walk too (the finding
/// does not change the record's noise), so the drift does not overturn the finding as
/// structure no term explains.
#[test]
fn a_finding_is_not_overturned_by_the_slow_drift_the_first_pass_saw() {
    let model = PhysicsModel::paper();
    let case = build_case(105, Kind::Library(Family::Heteroscedastic), 1, &model).expect("case");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    assert!(d.evidence.structure_slow_drift, "{:#?}", d.evidence);
    assert_eq!(
        d.verdict,
        rlg_diagnose::Verdict::MissingPhysics,
        "{:#?}",
        d.evidence
    );
    assert_eq!(d.findings[0].mechanism.name(), "heteroscedastic");
}

/// A sensor's lag at D 5.7 (seed 1, case 5) that a gradient's lag fits about as well (ΔBIC
/// within 6 of each other, both lowering the held-out residual): whichever is the finding,
/// the other is named as its close alternative, and a note says the record does not tell
/// them apart well.
#[test]
fn a_near_tie_names_the_close_alternative() {
    let model = PhysicsModel::paper();
    let case = build_case(5, Kind::Library(Family::SensorLag), 1, &model).expect("case");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    let f = d.findings.first().expect("a finding");
    let named: Vec<&str> = std::iter::once(f.mechanism)
        .chain(f.close_alternatives.iter().copied())
        .map(|m| m.name())
        .collect();
    assert!(named.contains(&"sensor_lag"), "{named:?}");
    assert!(named.contains(&"gradient_lag"), "{named:?}");
    for m in &f.close_alternatives {
        let c = d
            .evidence
            .candidates
            .iter()
            .find(|c| c.mechanism == *m)
            .expect("scored");
        assert!(c.delta_bic - f.delta_bic < rlg_diagnose::CLOSE_DELTA_BIC);
        assert!(c.heldout_gain > 0.0 && c.p_value <= rlg_diagnose::Options::default().alpha);
    }
    assert!(
        d.evidence
            .notes
            .iter()
            .any(|n| n.contains("nearly as well") && n.contains("tell them apart")),
        "{:?}",
        d.evidence.notes
    );
}

/// A sensor's lag at D 7.0 on a chamber hunting ±0.2 °C about its set point every 1110 s
/// (seed 1, case 3): the lagged reading's error repeats at the hunting's period, and a
/// `periodic` of that period fitted it best. The temperature oscillates at that period, so
/// the period is not attributed to `periodic` (a note says why, and it is no close
/// alternative either), and the thermal family that predicts it from the temperature is the
/// finding.
#[test]
fn a_period_of_the_chambers_own_hunting_is_not_a_periodic() {
    let model = PhysicsModel::paper();
    let case = build_case(3, Kind::Library(Family::SensorLag), 1, &model).expect("case");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &rlg_diagnose::Options::default())
        .expect("diagnoses");
    let f = d.findings.first().expect("a finding");
    assert_eq!(f.mechanism.name(), "sensor_lag");
    assert!(f.close_alternatives.iter().all(|m| m.name() != "periodic"));
    let periodic = d
        .evidence
        .candidates
        .iter()
        .find(|c| c.mechanism.name() == "periodic")
        .expect("scored");
    assert!(
        periodic.delta_bic < f.delta_bic,
        "periodic fits better: {periodic:?}"
    );
    assert!(
        d.evidence
            .notes
            .iter()
            .any(|n| n.contains("the temperature oscillates too")),
        "{:?}",
        d.evidence.notes
    );
}

/// A clean recording of 1.5 day/night cycles (−5…39 °C, 25 h) whose bias wanders as a rate
/// random walk (K 5.2e-4 °/h/√h) and a 1/f-like bank, where white + B passes the Allan check:
/// a hysteresis loop two thirds as wide as the range fits the wander (significant under
/// white + B) but predicts no cycle from the other. A thermal term that does not recur must beat
/// the record's slow noise as a slow function of time must, and this one does not:
/// `consistent`, the loop's p-value under rate random walk reported above α and the loop said
/// to be slow drift.
#[test]
fn a_loop_that_does_not_recur_must_beat_the_records_slow_noise() {
    let d = clean_case_with_rate_random_walk_is_consistent(201, 1);
    let alpha = rlg_diagnose::Options::default().alpha;
    let loop_ = d
        .evidence
        .candidates
        .iter()
        .find(|c| c.mechanism.name() == "hysteresis")
        .expect("hysteresis scored");
    assert!(loop_.delta_bic < loop_.threshold, "{loop_:?}");
    assert!(loop_.cycle_gain.is_some_and(|g| g <= 0.0), "{loop_:?}");
    assert!(loop_.p_value_rrw.is_some_and(|p| p > alpha), "{loop_:?}");
    assert!(
        d.evidence
            .notes
            .iter()
            .any(|n| n.starts_with("hysteresis is significant") && n.contains("slow drift")),
        "{:?}",
        d.evidence.notes
    );
}

/// Recordings whose drift fits best as aging, which does not beat the record's noise refitted
/// with rate random walk, and which a loop fits less well: a clean one (seed 2, case 169: a
/// day/night sine, rate random walk and a 1/f-like bank) and an aging of 8.7e-3 °/h per day on
/// rate random walk and 1/f-like noise (seed 3, case 85, D 4.0). The loop takes part of the
/// same drift (heating earlier, cooling later), so it must beat that noise too, and it does
/// not: no hysteresis is named, and the drift is said to be slow noise.
#[test]
fn a_loop_weighed_after_slow_drift_must_beat_the_records_slow_noise() {
    let model = PhysicsModel::paper();
    let opts = rlg_diagnose::Options::default();
    for (id, kind, seed) in [(169, Kind::Clean, 2), (85, Kind::Library(Family::Aging), 3)] {
        let case = build_case(id, kind, seed, &model).expect("case");
        let d = rlg_diagnose::diagnose(&case.recording, &model, &opts).expect("diagnoses");
        let score = |m: &str| {
            d.evidence
                .candidates
                .iter()
                .find(|c| c.mechanism.name() == m)
                .expect("scored")
        };
        let (drift, loop_) = (score("aging"), score("hysteresis"));
        assert!(
            drift.delta_bic < loop_.delta_bic && drift.p_value_rrw.is_some_and(|p| p > opts.alpha),
            "{id}: {drift:?}"
        );
        assert!(
            loop_.p_value_rrw.is_some_and(|p| p > opts.alpha),
            "{id}: {loop_:?}"
        );
        assert!(
            d.findings
                .iter()
                .all(|f| f.mechanism.name() != "hysteresis"),
            "{id}: {:#?}",
            d.findings
        );
        assert!(
            d.evidence.notes.iter().any(|n| n.contains("slow drift")),
            "{id}: {:?}",
            d.evidence.notes
        );
    }
}

/// A bump at one temperature of 1σ 2.7 °C on a day/night sine over −38…−9 °C (seed 1, case
/// 236 of the outside-library kinds, D 8.1): wider than the generic test's windows fit well,
/// so a backscatter lobe fitted it better than any of them. Against a window as wide as the
/// bump (two fifths of the range or more) the ripple loses: the structure is not attributed,
/// and the bump's window holds the hidden bump's centre.
#[test]
fn a_bump_in_temperature_as_wide_as_a_ripples_lobe_is_not_named_as_the_ripple() {
    let model = PhysicsModel::paper();
    let opts = rlg_diagnose::Options::default();
    let case = build_case(236, Kind::BumpInTemperature, 1, &model).expect("case");
    let d = rlg_diagnose::diagnose(&case.recording, &model, &opts).expect("diagnoses");
    assert!(d.findings.is_empty(), "{:#?}", d.findings);
    assert_eq!(d.verdict, rlg_diagnose::Verdict::UnexplainedStructure);
    let bump = d.evidence.bump.as_ref().expect("a bump preferred");
    assert_eq!(bump.instead_of.name(), "backscatter", "{bump:?}");
    assert!(bump.p_under_family < bump.p_under_bump, "{bump:?}");
    let (lo, hi) = case
        .recording
        .temp_c
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(*t), b.max(*t))
        });
    assert!(
        bump.hi_c - bump.lo_c > (hi - lo) / 3.0,
        "{bump:?} on {lo}..{hi}"
    );
    let Hidden::BumpInTemperature { centre_c, .. } = case.hidden else {
        panic!("{:?}", case.hidden)
    };
    assert!(
        (bump.lo_c..bump.hi_c).contains(&centre_c),
        "{bump:?}: {centre_c}"
    );
}
