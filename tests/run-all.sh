#!/usr/bin/env bash
# Every test of the project, from a fresh Debian machine with Rust (the top README's second
# command).
# Installs what is missing (thumb targets, qemu-system-arm, the C compilers) through
# tests/setup.sh first.
set -euo pipefail
cd "$(dirname "$0")/.."

# A clean build is a fifth faster without incremental compilation (measured on the test
# build's workspace crates: 288 s of compile time against 360 s), and this command mostly
# builds from clean. A later plain `cargo test` rebuilds the workspace's own crates once.
export CARGO_INCREMENTAL=0

# Each step says when it starts, so the slow ones show in every CI log.
step() { printf '\n==> %s (at %d s)\n' "$*" "$SECONDS"; }

step "setup (targets, qemu-system-arm, cc, arm-none-eabi-gcc)"
bash tests/setup.sh

step "format"
cargo fmt --all -- --check

step "clippy, host crates and the firmware's host build"
cargo clippy --workspace --all-targets -- -D warnings

step "compensator-core builds for the board (no std can creep in)"
cargo build -p compensator-core --target thumbv7em-none-eabihf
cargo build -p compensator-core --target thumbv7m-none-eabi

step "clippy, firmware for the board"
cargo clippy -p firmware --target thumbv7em-none-eabihf --profile firmware --features no-panic-proof -- -D warnings

step "the C API's library for the boards, as a C team builds it (clippy, then librlg_compensator.a)"
for target in thumbv7em-none-eabihf thumbv7m-none-eabi; do
    cargo clippy -p compensator-capi --target "$target" --profile firmware -- -D warnings
    cargo build -p compensator-capi --target "$target" --profile firmware
done

step "the firmware as a firmware engineer builds it first (plain release)"
cargo build -p firmware --release --target thumbv7em-none-eabihf

step "tests (host crates, firmware logic on the host, firmware in QEMU, the C API from C)"
# The corpus of wrong recordings is the longest test (minutes of child processes, mostly one
# 10⁷-sample file at a time, so one core) and cargo runs test binaries one after another: its
# binary runs beside the others, its output kept and shown after them. It is run directly, as
# cargo would (from its package's folder): a second cargo selecting it alone would resolve the
# dependencies' features anew and rebuild part of them, holding the build lock meanwhile.
built=$(mktemp)
cargo test --workspace --no-run --message-format json-render-diagnostics > "$built"
corpus_exe=$(grep -o '"executable":"[^"]*/corpus-[0-9a-f]*"' "$built" | cut -d'"' -f4 | head -n 1)
rm -f "$built"
if [ -z "$corpus_exe" ] || [ ! -x "$corpus_exe" ]; then
    echo "the corpus test's executable was not found in cargo's output" >&2
    exit 1
fi
corpus_log=$(mktemp)
(cd host-trainer && "$corpus_exe") > "$corpus_log" 2>&1 &
corpus_pid=$!
rest=0
cargo test --workspace -- --skip corpus_of_wrong_recordings || rest=$?
corpus=0
wait "$corpus_pid" || corpus=$?
step "the corpus of wrong recordings (run beside the tests above)"
cat "$corpus_log"
rm -f "$corpus_log"
if [ "$rest" -ne 0 ] || [ "$corpus" -ne 0 ]; then
    echo "tests failed (the others: exit $rest; the corpus: exit $corpus)" >&2
    exit 1
fi

# The workspace's test build already holds it: `--workspace` keeps the features of the shared
# dependencies unified as above (`-p rlg-benchmarks` alone would rebuild them, minutes of the
# command).
step "diagnosis benchmark, quick set (regression floors on detection and false alarms)"
cargo test --workspace --lib quick_benchmark -- --ignored --nocapture

printf '\n==> every test passed in %d s\n' "$SECONDS"
