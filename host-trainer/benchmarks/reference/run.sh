#!/usr/bin/env bash
# Speed of the exact LS-SVM path against numpy / scipy / scikit-learn, in one run on the same
# machine and the same data files:
#   host-trainer/benchmarks/reference/run.sh [DATA_DIR] [-- rlg bench-lssvm options, e.g. --sigma 0.2]
# Creates a venv under target/bench-venv (numpy, scipy, scikit-learn from PyPI), builds `rlg`
# in release, times the Rust path with faer sequential and on the rayon pool, then the Python
# reference, and prints the table of medians and ratios.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../../.." && pwd)"
data="${1:-$root/target/bench-data}"
shift $(( $# > 0 ? 1 : 0 ))
[ "${1:-}" = "--" ] && shift
venv="$root/target/bench-venv"
reps="${REPS:-7}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet numpy scipy scikit-learn
fi
cargo build --quiet --release -p host-trainer --bin rlg
rlg="$root/target/release/rlg"
"$rlg" bench-lssvm --data-dir "$data" --par seq --reps "$reps" "$@"
"$rlg" bench-lssvm --data-dir "$data" --par rayon --reps "$reps" "$@"
"$venv/bin/python" "$here/reference.py" "$data" --reps "$reps"
# Not run here (about 5 min): `rlg calibrate` vs scikit-learn on a 12-day record: calibrate_bench.sh
