#!/usr/bin/env bash
# Coverage-guided fuzzing (libFuzzer via cargo-fuzz) of the recording reader, the model-file
# loader and exporter, and the board's Compensator::update, for a bounded time each:
#   bash tests/fuzz/run.sh [SECONDS_PER_TARGET]      # default 60
# Installs cargo-fuzz when missing (a few minutes once). cargo-fuzz needs nightly compiler
# flags (sanitizer instrumentation); RUSTC_BOOTSTRAP=1 lets the stable toolchain accept them.
# New corpus entries land in tests/fuzz/corpus/<target>/ (minimised afterwards); a crash is
# written to tests/fuzz/artifacts/<target>/ and must be copied to
# tests/fuzz/regressions/<target>/ once fixed, where `cargo test` replays it for good.
set -euo pipefail
cd "$(dirname "$0")"
secs="${1:-60}"
command -v cargo-fuzz >/dev/null 2>&1 || cargo install cargo-fuzz
export RUSTC_BOOTSTRAP=1
for t in recording model_file core_update; do
    mkdir -p "corpus/$t"
    echo "== $t: ${secs} s"
    cargo fuzz run --fuzz-dir . "$t" "corpus/$t" -- -max_total_time="$secs" -rss_limit_mb=2048 2>&1 \
        | grep -E "^(Done|#[0-9]+ +DONE)|ERROR|panicked" || true
    cargo fuzz cmin --fuzz-dir . "$t" "corpus/$t" >/dev/null 2>&1
    echo "   corpus after minimisation: $(ls "corpus/$t" | wc -l) inputs"
done
if ls artifacts/*/crash-* >/dev/null 2>&1; then
    echo "CRASHES found: see tests/fuzz/artifacts/"
    exit 1
fi
echo "no crash"
