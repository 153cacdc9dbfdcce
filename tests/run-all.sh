#!/usr/bin/env bash
# Every test of the project, from a fresh Debian machine with Rust (the top README's second
# command).
# Installs what is missing (thumb targets, qemu-system-arm, the C compilers) through
# tests/setup.sh first.
set -euo pipefail
cd "$(dirname "$0")/.."

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
cargo test --workspace

# The workspace's test build already holds it: `--workspace` keeps the features of the shared
# dependencies unified as above (`-p rlg-benchmarks` alone would rebuild them, minutes of the
# command).
step "diagnosis benchmark, quick set (regression floors on detection and false alarms)"
cargo test --workspace --lib quick_benchmark -- --ignored --nocapture

printf '\n==> every test passed in %d s\n' "$SECONDS"
