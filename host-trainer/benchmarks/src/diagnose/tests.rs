//! Tests of the diagnosis benchmark.

use super::cases::{build_case, case_runs, case_simulation};
use super::detectability::{case_detectability, effect, noise_scale_peak, noise_sigmas};
use super::label::Label;
use super::report::report_markdown;
use super::result::{CaseResult, PValues};
use super::truth::{hidden_from_truth, read_truth};
use super::*;
use super::{run_benchmark, BenchOptions};
use rlg_diagnose::linalg::centred;
use rlg_diagnose::prepare::prepare;
use rlg_eval::metrics::rms;
use rlg_physics::Mechanism;
use rlg_simulate::simulate;
use rlg_simulate::NoiseParams;

/// The truth sidecar reads back exactly (the TOML route around serde_json's
/// `arbitrary_precision`), and every generated case is concealed at the detectability it
/// was built for: D recomputed from the sidecar and the recording lies in 3 … 10 and the
/// effect's peak stays below half the 1 s noise σ (unless no draw met the bound).
#[test]
fn cases_are_concealed_at_their_detectability() {
    let model = PhysicsModel::paper();
    let dir = tempfile::tempdir().expect("temp dir");
    let mut concealed = 0;
    for (id, f) in Family::ALL.into_iter().enumerate() {
        let case = build_case(id, Some(f), 7, &model).expect("case");
        let sim = simulate(&case.scenario, 1).expect("simulates");
        let csv = dir.path().join(format!("c{id}.csv"));
        write_simulation(&sim, &csv).expect("writes");
        let truth = read_truth(&truth_path(&csv)).expect("reads truth");
        assert_eq!(truth, sim.truth);
        let rec = Recording::read_csv(&csv).expect("reads csv");
        let prep = prepare(&rec).expect("prepares");
        let h = hidden_from_truth(&truth).expect("hidden term");
        assert_eq!(h.name(), f.name());
        let e = effect(&h, &truth);
        let d = case_detectability(&h, &truth, &prep, &model).expect("short");
        let (s1, _) = noise_sigmas(&truth.scenario.noise);
        assert!(
            (3.0 - 1e-6..=10.0 + 1e-6).contains(&d),
            "{}: D = {d}",
            f.name()
        );
        let peak = e
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()))
            .max(noise_scale_peak(&h, &truth.body_c, &truth.scenario.noise));
        if peak < 0.5 * s1 {
            concealed += 1;
        }
    }
    assert!(
        concealed + 1 >= Family::ALL.len(),
        "{concealed} of {} concealed",
        Family::ALL.len()
    );
}

/// A case's second run is the same gyro in the chamber again: the same thermal history
/// and noise-free bias, its own noise; its first run is the benchmark's recording.
#[test]
fn a_case_run_again_differs_in_its_noise_only() {
    let (profile, hidden, runs) = case_runs(42, Some(Family::Hysteresis), 7, 2).expect("runs");
    let (p0, h0, sim) = case_simulation(42, Some(Family::Hysteresis), 7).expect("case");
    assert_eq!((&profile, &hidden), (&p0, &h0));
    assert_eq!(runs[0].recording, sim.recording);
    let (a, b) = (&runs[0], &runs[1]);
    assert_eq!(a.truth.bias_dph, b.truth.bias_dph);
    assert_eq!(a.truth.body_c, b.truth.body_c);
    assert_eq!(a.truth.scenario, b.truth.scenario);
    assert_ne!(a.truth.seed, b.truth.seed);
    let same = a
        .recording
        .rate_dph
        .iter()
        .zip(&b.recording.rate_dph)
        .filter(|(x, y)| x == y)
        .count();
    assert!(same < a.recording.len() / 10, "{same} equal rate samples");
}

/// σ of 100 s means from the noise parameters against a long simulation of the noise.
#[test]
fn noise_sigmas_match_simulated_noise() {
    let p = NoiseParams {
        arw_dph_rt_h: 2.5e-4,
        bias_instability_dph: 5e-4,
        ..Default::default()
    };
    let mut g = rlg_simulate::NoiseGen::new(&p, 5);
    let x: Vec<f64> = (0..2_000_000).map(|_| g.step(1.0, 1.0)).collect();
    let m = rlg_eval::metrics::block_means(&x, 100);
    let sd = rms(&centred(&m)).expect("block means");
    let (_, s100) = noise_sigmas(&p);
    assert!((sd / s100 - 1.0).abs() < 0.05, "{sd} vs {s100}");
}

/// The verdict at a smaller α: the finding survives while its own p-value is within α,
/// then the verdict falls to `unexplained` (something else still significant) or
/// `none`; at or above the run's α it is the run's verdict.
#[test]
fn verdict_at_a_smaller_alpha() {
    let mut r = CaseResult {
        id: 0,
        profile: String::new(),
        truth: Label::Mechanism(Mechanism::Aging),
        detectability: 4.0,
        detectability_marginal: 0.0,
        peak_over_sigma1: 0.1,
        energy_in_span: 0.8,
        predicted: Label::Mechanism(Mechanism::Aging),
        param_ok: None,
        param_rel_err: None,
        param: None,
        iou: None,
        gain_fraction: None,
        seconds: 0.0,
        best_delta_bic: (Label::None, 0.0, 0.0),
        p_values: PValues {
            best: 0.004,
            finding: Some(0.02),
            structure: 0.3,
            verdict: None,
            true_family_alone: Some(0.001),
        },
        alpha: 0.05,
        shift: 0,
    };
    let aging = Label::Mechanism(Mechanism::Aging);
    assert_eq!(r.predicted_at(0.05), aging);
    assert_eq!(r.predicted_at(0.1), aging);
    assert_eq!(r.predicted_at(0.02), aging);
    assert_eq!(r.predicted_at(0.01), Label::Unexplained);
    assert_eq!(r.predicted_at(0.003), Label::None);
    r.p_values.structure = 0.001;
    assert_eq!(r.predicted_at(0.003), Label::Unexplained);
    r.predicted = Label::None;
    r.p_values = PValues {
        best: 0.2,
        finding: None,
        structure: 0.5,
        verdict: None,
        true_family_alone: None,
    };
    assert_eq!(r.predicted_at(0.01), Label::None);
    // A significant candidate that does not count (not separable from slow noise): the
    // verdict's own p-value decides.
    r.p_values = PValues {
        best: 0.001,
        finding: None,
        structure: 0.5,
        verdict: Some(0.5),
        true_family_alone: None,
    };
    assert_eq!(r.predicted_at(0.01), Label::None);
    r.p_values.verdict = Some(0.004);
    assert_eq!(r.predicted_at(0.01), Label::Unexplained);
}

/// `cut_start` drops exactly the first samples of every column, leaves the recording alone
/// at zero, and a report of shifted results says so.
#[test]
fn cut_start_moves_where_the_blocks_start() {
    let n = 500;
    let rec = Recording {
        time_s: (0..n).map(|i| i as f64).collect(),
        rate_dph: (0..n).map(|i| 0.01 * i as f64).collect(),
        temp_c: (0..n).map(|i| 20.0 + 0.001 * i as f64).collect(),
        chamber_c: Some((0..n).map(|i| 21.0 + 0.001 * i as f64).collect()),
        extra: vec![("note".into(), (0..n).map(|i| i.to_string()).collect())],
        comments: vec!["made here".into()],
    };
    assert!(matches!(cut_start(&rec, 0), std::borrow::Cow::Borrowed(_)));
    let cut = cut_start(&rec, 37);
    assert_eq!(cut.time_s.len(), n - 37);
    assert_eq!(cut.time_s[0], 37.0);
    assert_eq!(cut.rate_dph[..], rec.rate_dph[37..]);
    assert_eq!(cut.temp_c[..], rec.temp_c[37..]);
    assert_eq!(
        cut.chamber_c.as_deref(),
        Some(&rec.chamber_c.as_ref().unwrap()[37..])
    );
    assert_eq!(cut.extra[0].1[..], rec.extra[0].1[37..]);

    let r = CaseResult {
        id: 0,
        profile: String::new(),
        truth: Label::None,
        detectability: 0.0,
        detectability_marginal: 0.0,
        peak_over_sigma1: 0.0,
        energy_in_span: 0.0,
        predicted: Label::None,
        param_ok: None,
        param_rel_err: None,
        param: None,
        iou: None,
        gain_fraction: None,
        seconds: 0.0,
        best_delta_bic: (Label::None, 0.0, 0.0),
        p_values: PValues::default(),
        alpha: 0.02,
        shift: 0,
    };
    let said = "without its first 37 samples";
    assert!(!report_markdown(std::slice::from_ref(&r)).contains(said));
    assert!(report_markdown(&[CaseResult { shift: 37, ..r }]).contains(said));
}

/// The quick benchmark end to end (ignored by default: `cargo test --workspace --lib
/// quick_benchmark -- --ignored`, run by the test command). Regression floors a few
/// cases below what the quick run reaches at α 2 %: at least 15 of the 20 hidden terms
/// named and at most 2 of the 8 clean recordings flagged.
#[test]
#[ignore = "release-mode benchmark"]
fn quick_benchmark() {
    let dir = tempfile::tempdir().expect("temp dir");
    let r = run_benchmark(&BenchOptions::quick(1), dir.path()).expect("runs");
    let hidden: Vec<_> = r.iter().filter(|c| c.truth != Label::None).collect();
    let ok = hidden.iter().filter(|c| c.truth == c.predicted).count();
    let fa = r
        .iter()
        .filter(|c| c.truth == Label::None && c.predicted != Label::None)
        .count();
    println!("{}", report_markdown(&r));
    assert!(ok >= 15, "{ok}/{}", hidden.len());
    assert!(fa <= 2, "{fa} false alarms");
}

/// A case's noise seeds come from its own stream: case k of one master seed does not share
/// its noise with case k ± 1 of the adjacent master seeds, nor with another case of its own.
#[test]
fn adjacent_seeds_do_not_share_noise_sequences() {
    let seeds = |id, seed| {
        let (_, _, runs) = case_runs(id, None, seed, 2).expect("runs");
        runs.iter().map(|r| r.truth.seed).collect::<Vec<_>>()
    };
    let mut all = [
        seeds(5, 1),
        seeds(4, 2),
        seeds(6, 0),
        seeds(5, 2),
        seeds(4, 1),
    ]
    .concat();
    let n = all.len();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), n, "a noise seed is shared");
}

/// A case's truth sidecar, written beside its recording, reads back with the noise seed it
/// was simulated with.
#[test]
fn a_case_truth_reads_back_with_its_seed() {
    let dir = std::env::temp_dir().join(format!("rlg-truth-seed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let (_, _, sim) = case_simulation(251, None, 1).expect("case");
    let csv = dir.join("case.csv");
    rlg_simulate::write_simulation(&sim, &csv).expect("writes");
    let truth = read_truth(&rlg_simulate::truth_path(&csv)).expect("reads back");
    assert_eq!(truth.seed, sim.truth.seed);
    let _ = std::fs::remove_dir_all(&dir);
}
