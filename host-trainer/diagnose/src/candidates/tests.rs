//! The candidates' block columns against the block means of their samples.

use super::columns::{node_stride, periodic_block_columns};
use super::*;
use crate::prepare::{block_samples, prepare, PhysicsModel, MAX_BLOCKS};
use rlg_io::recording::Recording;

fn recording(n: usize) -> Recording {
    Recording {
        time_s: (0..n).map(|k| 1000.0 + k as f64).collect(),
        temp_c: (0..n)
            .map(|k| 20.0 + 10.0 * (k as f64 / 7200.0).sin())
            .collect(),
        rate_dph: vec![-7.1; n],
        ..Recording::default()
    }
}

/// The closed-form periodic block columns of `prep` equal the block means of the per-sample
/// columns within `tol`, at each period.
fn assert_periodic_sums(prep: &Prepared, periods: &[f64], tol: f64) {
    let model = PhysicsModel::paper();
    for &period in periods {
        let fast = periodic_block_columns(period, prep).unwrap();
        let slow: Vec<Vec<f64>> = Family::Periodic
            .columns(&[period], prep, &model, &prep.drive, &[])
            .unwrap()
            .iter()
            .map(|v| prep.blocks(v))
            .collect();
        for (f, s) in fast.iter().zip(&slow) {
            let worst = f
                .iter()
                .zip(s)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(worst < tol, "period {period}: {worst:e}");
        }
    }
}

/// The closed-form block means of the periodic columns are the block means of the
/// per-sample columns, for periods from four blocks to the record's length.
#[test]
fn periodic_block_columns_are_the_block_means_of_the_samples() {
    let prep = prepare(recording(60_000)).unwrap();
    assert_periodic_sums(&prep, &[400.0, 777.7, 5_000.0, 59_000.0], 1e-12);
}

/// A gap of a month inside a block and unevenly spaced time stamps: the block means summed run by
/// run are those of the per-sample columns, and the grid keeps to 0.75 points per block.
#[test]
fn periodic_block_columns_across_a_gap_and_jitter() {
    let mut rec = recording(24_000);
    for (k, t) in rec.time_s.iter_mut().enumerate() {
        if k >= 10_050 {
            *t += 30.0 * 86_400.0;
        }
        // A clock running 0.1 % fast for 400 samples.
        *t += 1e-3 * (k.clamp(3_000, 3_400) - 3_000) as f64;
    }
    let prep = prepare(rec).unwrap();
    assert_periodic_sums(&prep, &[400.0, 777.7, 5_000.0, 1.3e6], 1e-9);
    let grid = Family::Periodic.grid(&prep);
    assert!(
        grid.len() <= (3 * prep.nb()).div_ceil(4),
        "{} points",
        grid.len()
    );
    let f = |p: &Vec<f64>| 1.0 / p[0];
    assert!(
        f(&grid[0]) < 3.0 / (31.0 * 86_400.0),
        "lowest {}",
        f(&grid[0])
    );
}

/// A family's block columns from the scan's fast path and from its per-sample columns.
fn fast_and_slow(
    f: Family,
    nl: &[f64],
    prep: &Prepared,
    model: &PhysicsModel,
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let fast = f.block_columns(nl, prep, model, &prep.drive, &[]).unwrap();
    let slow = f
        .columns(nl, prep, model, &prep.drive, &[])
        .unwrap()
        .iter()
        .map(|v| prep.blocks(v))
        .collect();
    (fast, slow)
}

/// The stepped block means of the bias families are `columns` then `Prepared::blocks`,
/// bit for bit, at the first points of each family's grid.
#[test]
fn stepped_block_columns_are_the_block_means_of_the_samples() {
    let prep = prepare(recording(60_000)).unwrap();
    let model = PhysicsModel::paper();
    for f in [
        Family::Backscatter,
        Family::GradientLag,
        Family::Hysteresis,
        Family::Warmup,
        Family::ModeHop,
        Family::Aging,
    ] {
        let grid = f.grid(&prep);
        assert!(!grid.is_empty(), "{f:?}: no grid point to compare");
        for nl in grid.into_iter().take(3) {
            let (fast, slow) = fast_and_slow(f, &nl, &prep, &model);
            assert_eq!(fast.len(), slow.len(), "{f:?}");
            for (a, b) in fast.iter().zip(&slow) {
                assert!(
                    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "{f:?} at {nl:?}"
                );
            }
        }
    }
}

/// The scan's block means of a term driven by another node, stepped at a stride of the
/// node's lag over 200, are those of the term stepped at every sample to within a few
/// per cent of its amplitude, for a lagging and a leading node of each family.
#[test]
fn strided_block_columns_of_a_node_follow_the_samples() {
    let prep = prepare(recording(60_000)).unwrap();
    let model = PhysicsModel::paper();
    for f in [Family::Hysteresis, Family::ModeHop, Family::Backscatter] {
        for lag in [3200.0, -1600.0] {
            let nl = f
                .grid(&prep)
                .into_iter()
                .filter(|p| node_lag(f, p) == lag)
                // A mode hop mid-range, which the node's swing crosses.
                .nth(if f == Family::ModeHop { 100 } else { 7 })
                .expect("a lagged point");
            let term = f.term(&nl, &[1.0, 0.0], 1000.0);
            assert!(node_stride(&term, &prep) > 1, "{f:?} {lag}: not strided");
            let (fast, slow) = fast_and_slow(f, &nl, &prep, &model);
            for (a, b) in fast.iter().zip(&slow) {
                let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let worst = a
                    .iter()
                    .zip(b)
                    .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                let rms = (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>()
                    / a.len() as f64)
                    .sqrt();
                assert!(scale > 0.1, "{f:?} {lag}: a column of nothing");
                assert!(
                    worst <= 0.2 * scale && rms <= 0.02 * scale,
                    "{f:?} {lag}: {worst} {rms}"
                );
            }
        }
    }
}

/// A record longer than MAX_BLOCKS 100 s blocks is averaged over whole multiples of 100 s.
#[test]
fn long_records_get_longer_blocks() {
    assert_eq!(block_samples(100 * MAX_BLOCKS, 1.0), 100);
    assert_eq!(block_samples(100 * MAX_BLOCKS + 1, 1.0), 200);
    assert_eq!(block_samples(2_678_400, 1.0), 700);
    assert_eq!(block_samples(2 * 2_678_400, 0.5), 1400);
}

/// A record too short for MIN_BLOCKS means of 100 s takes the longest shorter block that
/// gives them (an hour at 2 Hz: 10 s); one that 10 s blocks cannot fill keeps 100 s (and is
/// refused by `prepare`); from MIN_BLOCKS × 100 s on, nothing changes.
#[test]
fn short_records_get_shorter_blocks() {
    use crate::prepare::MIN_BLOCKS;
    assert_eq!(block_samples(7_200, 0.5), 20);
    assert_eq!(block_samples(4 * 3_600, 1.0), 50);
    assert_eq!(block_samples(8_000, 1.0), 20);
    assert_eq!(block_samples(1_000, 1.0), 100);
    assert_eq!(block_samples(100 * MIN_BLOCKS, 1.0), 100);
}

/// A sensor lagging the body by τ on a model whose baseline has dT/dt and T·dT/dt columns:
/// with no noise, the baseline beside the sensor-lag column at the true τ leaves a small part
/// of what the baseline alone leaves. Fitted on the late reading, the baseline's rate
/// coefficients take the lag's first-order part, and a column built from them (the null
/// fit's coefficients) misses much of the rest.
#[test]
fn the_sensor_lag_column_at_the_true_lag_explains_a_lagging_sensor() {
    let (n, tau_s, period_s) = (60_000, 600.0, 14_400.0);
    let w = 2.0 * std::f64::consts::PI / period_s;
    let body = |t: f64| 20.0 + 15.0 * (w * t).sin();
    let body_rate = |t: f64| 15.0 * w * (w * t).cos();
    // The reading: the body's temperature through a first-order lag of τ, stepped at 0.1 s.
    let mut read = Vec::with_capacity(n);
    let mut x = body(0.0);
    for k in 0..n {
        for j in 0..10 {
            let t = k as f64 + 0.1 * j as f64;
            x += 0.1 / tau_s * (body(t) - x);
        }
        read.push(x);
    }
    let bias = |t: f64| {
        let d = body(t) - 20.0;
        0.01 * d - 5e-4 * d * d + 2e-5 * d.powi(3) + 2.0 * body_rate(t)
    };
    let rec = Recording {
        time_s: (0..n).map(|k| k as f64 + 1.0).collect(),
        temp_c: read,
        rate_dph: (0..n).map(|k| bias(k as f64 + 1.0)).collect(),
        ..Recording::default()
    };
    let prep = prepare(rec).unwrap();
    let model = PhysicsModel::paper();
    let base = crate::baseline::Baseline::fit(&prep, &model).unwrap();
    let rms = |r: &[f64]| (r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64).sqrt();
    let null = rms(&base.resid_b);
    let mut cols = base.cols_b.clone();
    cols.extend(base.candidate_blocks(Family::SensorLag, &[tau_s]).unwrap());
    let with = rms(&crate::linalg::Basis::new(&cols).residual(&prep.y_b));
    assert!(
        null > 1e-3,
        "the lag leaves {null:e} °/h beside the baseline"
    );
    assert!(with < 0.1 * null, "{with:e} of {null:e} °/h left");
}
