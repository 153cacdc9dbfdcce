#!/usr/bin/env bash
# `rlg calibrate` against the same LS-SVM job written with scikit-learn
# (calibrate_sklearn.py), on one simulated 12-day 1 Hz campaign, on the same machine:
#   REPS=1 host-trainer/benchmarks/reference/calibrate_bench.sh
# Creates a venv under target/bench-venv (numpy, scipy, scikit-learn from PyPI) as run.sh
# does, builds `rlg` in release, writes the yu2011-dynamic scenario with 37 cycles instead of 4
# (1 043 400 s, 12.1 days at 1 Hz) into target/calibrate-bench, simulates it with seed 3, then
# per repeat times `rlg calibrate` and the Python script (which reads rlg's summary.json for
# the train/held-out split, so it runs second) and prints the medians.
# COMPONENTS lists the Nystroem sizes M the Python side is run with, one row each (default
# "512 128": 512 is the size of rlg's own fixed-size LS-SVM beyond 4000 training means; the
# Python grid search's time grows steeply with M, and on this campaign 128 components reach the
# same held-out figure as 512).
# --results-md FILE also writes the summary to FILE (host-trainer/results/calibrate-bench.md),
# after a first line naming the command that wrote it.
set -euo pipefail
results_md=""
while [ $# -gt 0 ]; do
    case "$1" in
        --results-md) results_md="${2:?--results-md needs a file}"; shift 2 ;;
        --results-md=*) results_md="${1#*=}"; shift ;;
        *) echo "usage: [REPS=N] [COMPONENTS=\"M ...\"] $0 [--results-md FILE]" >&2; exit 2 ;;
    esac
done
# Checked before the run, which takes minutes.
if [ -n "$results_md" ] && [ ! -d "$(dirname "$results_md")" ]; then
    echo "--results-md $results_md: directory $(dirname "$results_md") does not exist" >&2
    exit 1
fi
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
venv="$root/target/bench-venv"
work="$root/target/calibrate-bench"
reps="${REPS:-1}"
components="${COMPONENTS:-512 128}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet numpy scipy scikit-learn
fi
py="$venv/bin/python"
cargo build --quiet --release -p host-trainer --bin rlg
rlg="$root/target/release/rlg"
mkdir -p "$work"

# 37 cycles of 28 200 s (two 3 h holds, two 55 min ramps): about 10^6 samples.
scenario="$work/yu2011-dynamic-12d.toml"
sed 's/^count = 4$/count = 37/' "$root/host-trainer/scenarios/yu2011-dynamic.toml" > "$scenario"
grep -q '^count = 37$' "$scenario" || { echo "scenario: no 'count = 4' line to raise" >&2; exit 1; }
data="$work/campaign.csv"
"$rlg" simulate --scenario "$scenario" --seed 3 --out "$data"

# Runs "$@", appends "wall_s peak_kb user_s sys_s" to $1's file ("nan" without GNU time).
timed() {
    local out="$1"; shift
    if [ -x /usr/bin/time ]; then
        /usr/bin/time -f "%e %M %U %S" -o "$out.time" "$@"
    else
        local t0 t1
        t0=$(date +%s.%N)
        "$@"
        t1=$(date +%s.%N)
        echo "$(echo "$t1 - $t0" | bc) nan nan nan" > "$out.time"
    fi
    cat "$out.time" >> "$out"
}

rm -f "$work"/rlg.times "$work"/py.*.times "$work"/py.*.results
for i in $(seq 1 "$reps"); do
    echo "repeat $i/$reps: rlg calibrate" >&2
    rm -rf "$work/rlg-out"
    timed "$work/rlg.times" "$rlg" calibrate --recording "$data" --out "$work/rlg-out" \
        > "$work/rlg.$i.log" 2>&1
    for m in $components; do
        echo "repeat $i/$reps: calibrate_sklearn.py, M = $m" >&2
        timed "$work/py.$m.times" "$py" "$here/calibrate_sklearn.py" "$data" \
            "$work/rlg-out/summary.json" --components "$m" > "$work/py.$m.$i.log" 2>&1
        grep '^RESULT ' "$work/py.$m.$i.log" | sed 's/^RESULT //' >> "$work/py.$m.results"
    done
done

"$py" - "$work" $components <<'EOF' | tee "$work/summary.txt"
import json, statistics, sys
work, comps = sys.argv[1], sys.argv[2:]
med = statistics.median
def times(name):
    rows = [[float(v) for v in l.split()] for l in open(f"{work}/{name}.times") if l.strip()]
    return (med(r[0] for r in rows), med(r[1] / 1024.0 for r in rows),
            med(r[2] + r[3] for r in rows), len(rows))
s = json.load(open(f"{work}/rlg-out/summary.json"))
row = {m["name"]: m for m in s["models"]}
rw, rp, rc, n = times("rlg")
print(f"\nrlg calibrate vs scikit-learn, {s['recording']['samples']} samples, median of {n}")
print(f"{'tool':<32} {'wall s':>7} {'CPU s':>7} {'peak MB':>7} {'sigma':>7} {'c':>8} "
      f"{'held-out 100 s °/h':>18} {'rlg/python time':>15}")
def line(name, w, c, p, sig, cc, st, ratio=""):
    f = lambda v, fmt: "" if v is None else format(v, fmt)
    print(f"{name:<32} {f(w, '7.1f'):>7} {f(c, '7.1f'):>7} {f(p, '7.0f'):>7} "
          f"{sig:7.4g} {cc:8.4g} {st:18.4e} {ratio:>15}")
line("rlg calibrate (LS-SVM row)", rw, rc, rp, s["tuning"]["sigma"], s["tuning"]["c"],
     row["LS-SVM on [T, dT/dt]"]["held_out"]["stability_dph"])
line("  same run: board table, 64 SV", None, None, None, s["board"]["sigma"], s["board"]["c"],
     row["board table (f32)"]["held_out"]["stability_dph"])
res = {}
for m in comps:
    res[m] = [json.loads(l) for l in open(f"{work}/py.{m}.results") if l.strip()]
    r = res[m][-1]
    pw, pp, pc, _ = times(f"py.{m}")
    line(f"scikit-learn, Nystroem M = {m}", pw, pc, pp, r["sigma"], r["c"],
         r["held_out_stability_dph"], f"{rw / pw:.2f}")
print(f"raw held-out 100 s stability {row['raw']['held_out']['stability_dph']:.4e} °/h")
for m in comps:
    print(f"python stages, M = {m} (median s):")
    for k in res[m][-1]["stages_s"]:
        print(f"  {k:<34} {med(x['stages_s'][k] for x in res[m]):8.2f}")
    print(f"  {'total (in-process)':<34} {med(x['wall_s'] for x in res[m]):8.2f}")
print("wall s and peak MB: GNU time (%e, %M: maxrss of the largest single process; rlg is one "
      "process, GridSearchCV's 2 workers are separate processes, not summed). CPU s: user + "
      "sys of the process and the children it waited for.")
EOF

if [ -n "$results_md" ]; then
    {
        printf 'Written by `REPS=%s COMPONENTS="%s" host-trainer/benchmarks/reference/calibrate_bench.sh --results-md FILE`.\n\n' \
            "$reps" "$components"
        echo '```text'
        sed '/./,$!d' "$work/summary.txt"
        echo '```'
    } > "$results_md.tmp"
    mv "$results_md.tmp" "$results_md"
fi
