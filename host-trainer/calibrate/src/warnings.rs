//! What the report says about a tuning it should not be trusted blindly on: a σ or c at the
//! end of its grid (the best value may lie beyond it), and a training error far below the
//! cross-validated one (the model learnt the noise of the points it was fitted on).

use rlg_train::lssvm::tune::Grid;

/// A tuned value within this factor of a grid end is at the edge (refinement moves by at
/// least a quarter of a coarse step, so an interior optimum stays further in).
pub const EDGE_FACTOR: f64 = 1.05;

/// A training RMS under this fraction of the CV RMS is called over-fitting: for a linear
/// smoother with p effective parameters on n points the ratio is about √((1 − p/n)/(1 + p/n)),
/// so 0.5 means p/n ≈ 0.6, most of the points fitted through.
pub const OVERFIT_RATIO: f64 = 0.5;

/// Where `v` sits on `(lo, hi)`: `Some("smallest")` / `Some("largest")` at an end.
fn edge(v: f64, (lo, hi): (f64, f64)) -> Option<&'static str> {
    if v <= lo * EDGE_FACTOR {
        Some("smallest")
    } else if v >= hi / EDGE_FACTOR {
        Some("largest")
    } else {
        None
    }
}

/// The notes on `what`'s tuning (σ, c on `grid`) and on its training against CV RMS.
pub fn tuning_notes(
    what: &str,
    (sigma, c): (f64, f64),
    grid: &Grid,
    (train_rms_dph, cv_rms_dph): (f64, f64),
) -> Vec<String> {
    let mut notes = Vec::new();
    let ends = [
        (
            "σ",
            sigma,
            grid.sigma,
            [
                "a σ this small follows every wiggle of the training points",
                "a σ this large makes the model nearly a plane in its inputs",
            ],
        ),
        (
            "c",
            c,
            grid.c,
            [
                "a c this small regularises the model towards a constant (--c-min lowers the grid)",
                "a c this large leaves almost no regularisation",
            ],
        ),
    ];
    for (name, v, range, why) in ends {
        if let Some(end) = edge(v, range) {
            notes.push(format!(
                "{what}: {name} = {v:.4} is the grid's {end} ({:.3}…{:.3}): the best value may \
                 lie beyond it; {}.",
                range.0,
                range.1,
                why[usize::from(end == "largest")]
            ));
        }
    }
    if train_rms_dph < OVERFIT_RATIO * cv_rms_dph {
        notes.push(format!(
            "{what} over-fits: its TRAINING rms {train_rms_dph:.3e} °/h is under half its CV rms \
             {cv_rms_dph:.3e} °/h; judge it by the CV (or held-out) figure, not the training one."
        ));
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_and_overfitting_are_said() {
        let g = Grid::default();
        let mid = (0.5, 100.0);
        assert!(tuning_notes("m", mid, &g, (1.0, 1.1)).is_empty());
        let n = tuning_notes("m", (g.sigma.0, 100.0), &g, (1.0, 1.1));
        assert_eq!(n.len(), 1);
        assert!(n[0].contains("σ = 0.0500 is the grid's smallest"), "{n:?}");
        let n = tuning_notes("m", (0.5, g.c.1), &g, (0.1, 8.0));
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(
            n[0].contains("c = 100000.0000 is the grid's largest"),
            "{n:?}"
        );
        assert!(n[1].contains("over-fits"), "{n:?}");
    }
}
