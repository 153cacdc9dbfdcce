//! The close loop on the concealed-effect benchmark: for each recording with a hidden lag,
//! hysteresis or warm-up, diagnose it, turn the finding into a feature, and compare on the
//! held-out cycles the paper's LS-SVM on [T, dT/dt] with the augmented one, and with the one
//! augmented by the true term's feature (the oracle: what a perfect diagnosis would give).
//!
//! The recordings are the benchmark's own (`diagnose::bench::case_simulation`, same seed and
//! case numbers as `rlg benchmark-diagnose`). Static-step profiles have no second cycle to
//! hold out and are listed as skipped.

use rayon::prelude::*;

use crate::diagnose::bench::{case_id, case_simulation};
use crate::diagnose::{diagnose, Family, Options, PhysicsModel, Verdict};
use crate::model::Provenance;

use super::{
    augmented_features, first_cycle_end_s, suggest_from_term, train_and_score, Inputs, Protocol,
    Scored,
};

/// The families with a compensation feature.
pub const FAMILIES: [Family; 4] = [
    Family::SensorLag,
    Family::GradientLag,
    Family::Hysteresis,
    Family::Warmup,
];

/// One benchmark recording through the close loop.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopCase {
    /// Benchmark case number.
    pub id: usize,
    /// Hidden mechanism.
    pub truth: String,
    /// Profile description.
    pub profile: String,
    /// The diagnosis' top mechanism, or its verdict.
    pub diagnosed: String,
    /// Features of the augmented model (`Display` form), base features excluded.
    pub added: Vec<String>,
    /// Whether cross-validation adopted the augmented model.
    pub adopted: bool,
    /// Held-out 100 s stability, °/h: [T, dT/dt]; augmented by the diagnosis; augmented by
    /// the true term (None: the case was skipped).
    pub b100_dph: Option<[f64; 3]>,
    /// The same for the board's f32 path.
    pub board_b100_dph: Option<[f64; 3]>,
    /// Why the case was skipped, if it was.
    pub skipped: Option<String>,
}

fn scores(base: &Scored, aug: &Scored, oracle: &Scored) -> ([f64; 3], Option<[f64; 3]>) {
    let b = [base.test_b100_dph, aug.test_b100_dph, oracle.test_b100_dph];
    let board = match (
        base.board_b100_dph,
        aug.board_b100_dph,
        oracle.board_b100_dph,
    ) {
        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
        _ => None,
    };
    (b, board)
}

fn run_case(id: usize, fam: Family, seed: u64) -> anyhow::Result<LoopCase> {
    let (profile, hidden, sim) = case_simulation(id, Some(fam), seed)?;
    let rec = sim.recording;
    let mut case = LoopCase {
        id,
        truth: fam.name().to_string(),
        profile,
        diagnosed: String::new(),
        added: Vec::new(),
        adopted: false,
        b100_dph: None,
        board_b100_dph: None,
        skipped: None,
    };
    let end = match first_cycle_end_s(&rec) {
        Ok(e) => e,
        Err(e) => {
            case.skipped = Some(e.to_string());
            return Ok(case);
        }
    };
    let d = diagnose(&rec, &PhysicsModel::paper(), &Options::default())?;
    case.diagnosed = match (d.verdict, d.findings.first()) {
        (Verdict::MissingPhysics, Some(f)) => f.mechanism.clone(),
        (v, _) => format!("{v:?}"),
    };
    let (aug, _) = augmented_features(&d);
    let base_inputs = Inputs::base();
    case.added = aug
        .describe()
        .into_iter()
        .filter(|f| !base_inputs.describe().contains(f))
        .collect();
    let protocol = Protocol::default();
    let cmd = Provenance::from_bytes(
        &format!("concealed-effect benchmark, seed {seed}, case {id} (simulated)"),
        &[],
        "rlg benchmark-close-loop",
    );
    let base = train_and_score(&rec, end, &base_inputs, &protocol, &cmd)?;
    let augmented = if aug != base_inputs {
        train_and_score(&rec, end, &aug, &protocol, &cmd)?
    } else {
        base.clone()
    };
    let oracle_inputs = match &hidden {
        Some(t) => Inputs::base().with(&suggest_from_term(t)),
        None => Inputs::base(),
    };
    let oracle = train_and_score(&rec, end, &oracle_inputs, &protocol, &cmd)?;
    case.adopted = protocol.adopts(&base, &augmented);
    let (b, board) = scores(&base, &augmented, &oracle);
    case.b100_dph = Some(b);
    case.board_b100_dph = board;
    Ok(case)
}

/// Runs the `per_term` benchmark cases of each family in [`FAMILIES`] (master seed `seed`).
pub fn run(seed: u64, per_term: usize) -> anyhow::Result<Vec<LoopCase>> {
    let plan: Vec<(usize, Family)> = FAMILIES
        .iter()
        .flat_map(|&f| (0..per_term).map(move |k| (case_id(f, k, per_term), f)))
        .collect();
    plan.into_par_iter()
        .map(|(id, f)| run_case(id, f, seed))
        .collect()
}

/// Relative change of the held-out stability, %, of `new` against `old`.
fn change(old: f64, new: f64) -> f64 {
    100.0 * (new / old - 1.0)
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Summary per hidden mechanism and the per-case table (Markdown).
pub fn report_markdown(cases: &[LoopCase]) -> String {
    let mut s = String::from(
        "| hidden | cases | cyclic | diagnosed right | feature added | adopted by CV | chosen better / worse than [T, dT/dt] | median change: augmented / chosen / true feature | board = host (≤ 1 %) |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    let b = |c: &LoopCase| c.b100_dph.unwrap_or([f64::NAN; 3]);
    let chosen = |c: &LoopCase| if c.adopted { b(c)[1] } else { b(c)[0] };
    for fam in FAMILIES {
        let all: Vec<&LoopCase> = cases.iter().filter(|c| c.truth == fam.name()).collect();
        let cyc: Vec<&LoopCase> = all
            .iter()
            .copied()
            .filter(|c| c.b100_dph.is_some())
            .collect();
        let right = cyc.iter().filter(|c| c.diagnosed == fam.name()).count();
        let added = cyc.iter().filter(|c| !c.added.is_empty()).count();
        let adopted = cyc.iter().filter(|c| c.adopted).count();
        let better = cyc.iter().filter(|c| chosen(c) < b(c)[0]).count();
        let worse = cyc.iter().filter(|c| chosen(c) > b(c)[0]).count();
        let med = |i: usize| median(cyc.iter().map(|c| change(b(c)[0], b(c)[i])).collect());
        let d_chosen = median(cyc.iter().map(|c| change(b(c)[0], chosen(c))).collect());
        let agree = cyc
            .iter()
            .filter(|c| {
                c.board_b100_dph
                    .is_some_and(|bb| (0..3).all(|i| (bb[i] / b(c)[i] - 1.0).abs() <= 0.01))
            })
            .count();
        s.push_str(&format!(
            "| {} | {} | {} | {right} | {added} | {adopted} | {better} / {worse} | {:+.1} % / {d_chosen:+.1} % / {:+.1} % | {agree} of {} |\n",
            fam.name(),
            all.len(),
            cyc.len(),
            med(1),
            med(2),
            cyc.len()
        ));
    }
    s.push_str(
        "\n| case | hidden | profile | diagnosed | feature added | adopted | [T, dT/dt] (°/h) | augmented (°/h) | true feature (°/h) |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for c in cases {
        match (c.b100_dph, &c.skipped) {
            (Some(b), _) => s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {:.4e} | {:.4e} ({:+.1} %) | {:.4e} ({:+.1} %) |\n",
                c.id,
                c.truth,
                c.profile,
                c.diagnosed,
                if c.added.is_empty() {
                    "—".to_string()
                } else {
                    c.added.join(", ")
                },
                if c.adopted { "yes" } else { "no" },
                b[0],
                b[1],
                change(b[0], b[1]),
                b[2],
                change(b[0], b[2])
            )),
            (None, why) => s.push_str(&format!(
                "| {} | {} | {} | skipped: {} | | | | | |\n",
                c.id,
                c.truth,
                c.profile,
                why.as_deref().unwrap_or("?")
            )),
        }
    }
    s
}
