"""`rlg calibrate`'s LS-SVM job as a scikit-learn user would write it, timed stage by stage.

    python calibrate_sklearn.py RECORDING.csv SUMMARY.json [--components 512] [--n-jobs 2]

RECORDING is a continuous 1 Hz stream (time_s, rate_dph, temp_c; `#` comment lines), SUMMARY
the `summary.json` that `rlg calibrate` wrote for the same file: its `split.train_span_s[1]`
is taken as the end of training, so that both tools split at the same time.

Steps, as `rlg calibrate` takes them (host-trainer/calibrate/src/lib.rs):
* inputs [T, dT/dt]: T as recorded, dT/dt from the board's first-order recursive estimator
  (see `rate_estimate`), run over the whole stream; the first ceil(5 tau) - 1 samples are its
  warm-up and are dropped;
* training samples: not warming up, time <= train end; held out: time >= train end;
* tuning means: 100 s means of the training samples, or longer means when more than
  MAX_TUNE_MEANS = 1500 would remain (block = 100 * ceil(n100 / 1500) s, rlg's rule); each
  mean is labelled with the temperature cycle its first sample falls in (cycles found as
  rlg_io::cycles does: boundaries mid-way through the low holds);
* Pipeline(StandardScaler, Nystroem(rbf, gamma = 1/(2 sigma^2), M components),
  Ridge(alpha = 1/c)) in GridSearchCV over the same coarse sigma x c grid (9 x 7) with
  LeaveOneGroupOut over the cycles, or, beyond MAX_FOLDS = 10 cycles, over MAX_FOLDS runs of
  consecutive whole cycles (rlg's folds); best point by mean out-of-fold RMSE;
* refit of the best point on all 100 s training means, prediction of the held-out 1 Hz
  samples, held-out 100 s bias stability: sample standard deviation of consecutive
  non-overlapping 100-sample means of rate - model.

Ridge(alpha = 1/c) minimises |y - Phi w - b|^2 + |w|^2 / c with an unpenalised intercept,
which is the LS-SVM's objective (|w|^2/2 + c/2 sum e^2, free bias) on the Nystroem feature map
Phi instead of the exact kernel.

Prints the wall time of each stage and the total, the chosen sigma and c, the held-out
stability, and a final line `RESULT {json}`.
"""

import argparse
import json
import math
import resource
import sys
import time

import numpy as np
from scipy.signal import lfilter, lfilter_zi
from sklearn.kernel_approximation import Nystroem
from sklearn.linear_model import Ridge
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

RATE_TAU_S = 60.0  # rlg_train::protocol::RATE_TAU_S
BLOCK = 100  # 100 s means (rlg_train::protocol::TRAIN_BLOCK)
WINDOW = 100  # 100 s bias stability
MAX_TUNE_MEANS = 1500  # rlg_calibrate::MAX_TUNE_MEANS
MAX_FOLDS = 10  # rlg_calibrate::MAX_FOLDS
SIGMAS = np.exp(np.linspace(math.log(0.05), math.log(5.0), 9))  # Grid::default()
CS = np.exp(np.linspace(math.log(0.1), math.log(1e5), 7))
PREDICT_CHUNK = 16384  # rows per predict call: all 5e5 held-out rows x M float64 at once are GBs


def read_csv(path):
    """time_s, rate_dph, temp_c by header name; lines starting with # are comments."""
    with open(path) as f:
        for line in f:
            if not line.startswith("#"):
                header = [h.strip() for h in line.split(",")]
                break
        cols = [header.index(n) for n in ("time_s", "rate_dph", "temp_c")]
        a = np.loadtxt(f, delimiter=",", comments="#", usecols=cols, dtype=np.float64)
    return a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy()


def filter_gains(tau_s, dt_s):
    """The estimator's gains: theta = exp(-dt/tau), alpha = 1 - theta^2, beta = (1 - theta)^2."""
    theta = math.exp(-dt_s / tau_s)
    return 1.0 - theta * theta, (1.0 - theta) ** 2


def rate_estimate(temp, tau_s, dt_s):
    """dT/dt of the board's critically damped alpha-beta tracker (compensator_core::rate).

    The board runs, per sample T_k (level L, slope S per sample; L_0 = T_0, S_0 = 0):
        P = L + S;  r = T_k - P;  L <- P + alpha r;  S <- S + beta r;  dT/dt = S / dt.
    This is linear, so its slope output is the IIR filter
        S(z)/T(z) = beta (1 - z^-1) / (1 - (2 - alpha - beta) z^-1 + (1 - alpha) z^-2),
    run here with scipy.signal.lfilter in float64. Starting it in the steady state of a
    constant input T_0 (lfilter_zi * T_0) is the board's start (L = T_0, S = 0). The board
    computes in float32 (and rounds T to float32 first); `check_rate` measures the difference.
    On the simulated campaign it is below 4.3e-6 C/s (99 % below 3.6e-6 C/s, against an
    rms dT/dt of 6e-3 C/s); the largest differences are in the hot holds, where float32
    resolves the filter's level only to 7.6e-6 C at 69 C.
    """
    alpha, beta = filter_gains(tau_s, dt_s)
    b = beta * np.array([1.0, -1.0])
    a = np.array([1.0, -(2.0 - alpha - beta), 1.0 - alpha])
    s, _ = lfilter(b, a, temp, zi=lfilter_zi(b, a) * temp[0])
    return s / dt_s


def rate_estimate_loop(temp, tau_s, dt_s, dtype):
    """The board's recursion written out sample by sample in `dtype` scalars (np.float32:
    the board's arithmetic, T rounded to float32 first; np.float64: the same recursion
    without rounding). Slow: for checking only."""
    f = dtype
    theta = f(math.exp(f(-dt_s) / f(tau_s)))
    alpha, beta = f(1.0) - theta * theta, (f(1.0) - theta) * (f(1.0) - theta)
    out = np.zeros(len(temp))
    level, slope = f(temp[0]), f(0.0)
    for k in range(1, len(temp)):
        predicted = level + slope
        residual = f(temp[k]) - predicted
        level = predicted + alpha * residual
        slope = slope + beta * residual
        out[k] = float(slope / f(dt_s))
    return out


def check_rate(temp, rate, tau_s, dt_s, n, warm):
    """|lfilter - recursion| over the first n samples: the largest in float64 (is the filter
    the recursion?), and the largest and 99th percentile after the warm-up in float32 (how far
    is float64 from the board's arithmetic?)."""
    r64 = rate_estimate_loop(temp[:n], tau_s, dt_s, np.float64)
    r32 = rate_estimate_loop(temp[:n], tau_s, dt_s, np.float32)
    d32 = np.abs(rate[warm - 1:n] - r32[warm - 1:])
    return (float(np.max(np.abs(rate[:n] - r64))), float(np.max(d32)),
            float(np.percentile(d32, 99)), r32)


def cycle_ends(time_s, temp):
    """End times of the temperature cycles (rlg_io::cycles::cycle_spans): a boundary half-way
    between a downward crossing of mid - band and the next upward crossing of mid + band
    (mid the middle of the range, band 10 % of it); the last cycle ends at the last sample."""
    lo, hi = float(np.min(temp)), float(np.max(temp))
    mid, band = 0.5 * (lo + hi), 0.1 * (hi - lo)
    state = np.full(len(temp), np.nan)
    state[temp > mid + band] = 1.0
    state[temp < mid - band] = 0.0
    if np.isnan(state[0]):
        state[0] = 1.0 if temp[0] > mid else 0.0
    # Forward fill: the hysteresis state holds until the other threshold is crossed.
    idx = np.where(np.isnan(state), 0, np.arange(len(state)))
    state = state[np.maximum.accumulate(idx)]
    change = np.flatnonzero(np.diff(state)) + 1
    ends, last_down = [], None
    for k in change:
        if state[k] == 0.0:
            last_down = time_s[k]
        elif last_down is not None:
            ends.append(0.5 * (last_down + time_s[k]))
            last_down = None
    ends.append(time_s[-1])
    return np.array(ends)


def block_means(x, block):
    n = len(x) // block
    return x[: n * block].reshape(n, block, *x.shape[1:]).mean(axis=1)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("recording")
    p.add_argument("summary", help="rlg calibrate's summary.json for the same recording")
    p.add_argument("--components", type=int, default=512,
                   help="Nystroem components M (512: rlg's fixed-size model beyond 4000 means)")
    p.add_argument("--n-jobs", type=int, default=2)
    p.add_argument("--tau", type=float, default=RATE_TAU_S)
    p.add_argument("--check-samples", type=int, default=30000,
                   help="samples the float64 dT/dt filter is checked on against the float32 "
                        "recursion (outside the timed stages; 0: no check)")
    args = p.parse_args()

    with open(args.summary) as f:
        summary = json.load(f)
    train_end = float(summary["split"]["train_span_s"][1])
    train_cycles = int(summary["split"]["train_cycles"])

    stages = {}
    t_all = time.perf_counter()

    t0 = time.perf_counter()
    time_s, rate_dph, temp = read_csv(args.recording)
    stages["read csv"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    step = np.diff(time_s)
    dt = float(np.median(step))
    if not (0.9 <= dt <= 1.1 and np.all(np.abs(step - dt) < 0.01 * dt)):
        sys.exit("not a gap-free 1 Hz stream; this script does not bridge gaps")
    dtdt = rate_estimate(temp, args.tau, dt)
    warm = math.ceil(5.0 * args.tau / dt)
    # The estimate is trusted from the warm-th absorbed sample on (index warm - 1).
    ready = np.arange(len(temp)) >= warm - 1
    x_all = np.column_stack([temp, dtdt])
    stages["features [T, dT/dt]"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    ends = cycle_ends(time_s, temp)
    train = ready & (time_s <= train_end)
    held = ready & (time_s >= train_end)
    x_tr, y_tr, t_tr = x_all[train], rate_dph[train], time_s[train]
    n100 = len(y_tr) // BLOCK
    tune_block = BLOCK * math.ceil(n100 / MAX_TUNE_MEANS) if n100 > MAX_TUNE_MEANS else BLOCK
    x_tune, y_tune = block_means(x_tr, tune_block), block_means(y_tr, tune_block)
    first_t = t_tr[: len(y_tune) * tune_block : tune_block]
    groups = np.minimum(np.searchsorted(ends[:train_cycles], first_t, side="right"),
                        train_cycles - 1)
    # rlg's folds: beyond MAX_FOLDS cycles, runs of consecutive whole cycles form MAX_FOLDS
    # groups (rlg_calibrate::validation_of), so both tools fit the same number of folds.
    distinct = np.unique(groups)
    if len(distinct) > MAX_FOLDS:
        groups = np.searchsorted(distinct, groups) * MAX_FOLDS // len(distinct)
    x_100, y_100 = block_means(x_tr, BLOCK), block_means(y_tr, BLOCK)
    stages["split, cycles, means"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    pipe = Pipeline([
        ("scale", StandardScaler()),
        ("nystroem", Nystroem(kernel="rbf", n_components=args.components, random_state=0)),
        ("ridge", Ridge()),
    ])
    grid = {
        "nystroem__gamma": list(1.0 / (2.0 * SIGMAS**2)),
        "ridge__alpha": list(1.0 / CS),
    }
    search = GridSearchCV(pipe, grid, cv=LeaveOneGroupOut(),
                          scoring="neg_root_mean_squared_error", n_jobs=args.n_jobs,
                          refit=False)
    search.fit(x_tune, y_tune, groups=groups)
    best = search.best_params_
    sigma = math.sqrt(1.0 / (2.0 * best["nystroem__gamma"]))
    c = 1.0 / best["ridge__alpha"]
    cv_rmse = -search.best_score_
    stages["grid search (63 points x folds)"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    model = pipe.set_params(**best).fit(x_100, y_100)
    stages["refit on 100 s means"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    x_ho, y_ho = x_all[held], rate_dph[held]
    pred = np.concatenate([model.predict(x_ho[i:i + PREDICT_CHUNK])
                           for i in range(0, len(y_ho), PREDICT_CHUNK)])
    stability = float(np.std(block_means(y_ho - pred, WINDOW), ddof=1))
    raw = float(np.std(block_means(y_ho, WINDOW), ddof=1))
    stages["predict held-out + stability"] = time.perf_counter() - t0
    total = time.perf_counter() - t_all

    check = None
    if args.check_samples > 0:
        t0 = time.perf_counter()
        n = min(args.check_samples, len(temp))
        d64, d32, p99, ref = check_rate(temp, dtdt, args.tau, dt, n, warm)
        rms_rate = float(np.sqrt(np.mean(dtdt[warm - 1:n] ** 2)))
        check = {"samples": n, "max_abs_diff_f64_c_per_s": d64,
                 "max_abs_diff_f32_c_per_s": d32, "p99_abs_diff_f32_c_per_s": p99,
                 "rms_rate_c_per_s": rms_rate}
        t_check = time.perf_counter() - t0
        print(f"dT/dt check over the first {n} samples (took {t_check:.2f} s, not in the total):")
        print(f"  lfilter vs the recursion in float64: max |diff| {d64:.1e} C/s")
        print(f"  lfilter vs the board's float32 recursion after warm-up: max |diff| {d32:.2e}, "
              f"99th percentile {p99:.2e} C/s (rms dT/dt {rms_rate:.2e} C/s)")
        for k in (warm - 1, n // 4, n // 2, n - 1):
            print(f"  sample {k:6d}: T {temp[k]:8.4f} C  dT/dt lfilter {dtdt[k]: .9e}  "
                  f"float32 loop {ref[k]: .9e}")

    cyc_note = ("same as rlg" if len(ends) == int(summary["split"]["cycles"])
                and abs(ends[train_cycles - 1] - train_end) < 1e-6 else "DIFFERS from rlg")
    print(f"samples {len(temp)}, cycles {len(ends)} ({cyc_note}), train end {train_end:.1f} s, "
          f"{train_cycles} training cycles")
    print(f"training samples {int(train.sum())}, tuning means {len(y_tune)} of {tune_block} s, "
          f"{len(np.unique(groups))} folds (leave one group of whole cycles out), training means "
          f"{len(y_100)} of {BLOCK} s, held-out samples {len(y_ho)}")
    for name, s in stages.items():
        print(f"  {name:<34} {s:8.2f} s")
    print(f"  {'total':<34} {total:8.2f} s")
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"sigma {sigma:.4g}, c {c:.4g} (CV rmse {cv_rmse:.4e} deg/h, Nystroem M = "
          f"{args.components}); held-out 100 s stability {stability:.4e} deg/h "
          f"(raw {raw:.4e}); peak RSS of the main process {peak_mb:.0f} MB")
    result = {
        "tool": "sklearn", "wall_s": total, "stages_s": stages, "sigma": sigma, "c": c,
        "cv_rmse_dph": cv_rmse, "held_out_stability_dph": stability,
        "raw_held_out_stability_dph": raw, "train_end_s": train_end,
        "tune_block_s": tune_block, "tune_means": len(y_tune), "train_means": len(y_100),
        "held_out_samples": len(y_ho), "components": args.components,
        "peak_rss_main_mb": peak_mb, "rate_check": check,
    }
    print("RESULT " + json.dumps(result))


if __name__ == "__main__":
    main()
