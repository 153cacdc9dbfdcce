#!/usr/bin/env bash
# Every test of the project, from a fresh Debian machine with Rust (README: "Run every test").
# Installs what is missing (thumb targets, qemu-system-arm) through tests/setup.sh first.
set -euo pipefail
cd "$(dirname "$0")/.."

step() { printf '\n==> %s\n' "$*"; }

step "setup (targets, qemu-system-arm)"
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

step "the firmware as a firmware engineer builds it first (plain release)"
cargo build -p firmware --release --target thumbv7em-none-eabihf

step "tests (host crates, firmware logic on the host, firmware in QEMU)"
cargo test --workspace

step "diagnosis benchmark, quick set (release; regression floors on detection and false alarms)"
cargo test --release -p rlg-benchmarks --lib quick_benchmark -- --ignored --nocapture
