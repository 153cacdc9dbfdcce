#!/usr/bin/env bash
# Installs what the firmware build and the QEMU replay test need on a Debian machine with Rust:
# the thumb targets, rustfmt, clippy and qemu-system-arm. Idempotent: installs only what is
# missing and says what it did.
set -euo pipefail

cd "$(dirname "$0")/.."
# The board targets (Cortex-M4F, and Cortex-M3 for the FPU-less build of the core) and the
# lint tools; rust-toolchain.toml names them too, but an already installed toolchain is not
# always completed from it.
for target in thumbv7em-none-eabihf thumbv7m-none-eabi; do
    if rustup target list --installed 2>/dev/null | grep -qx "$target"; then
        echo "setup: rust target $target already installed"
    else
        echo "setup: installing rust target $target"
        rustup target add "$target"
    fi
done
for component in rustfmt clippy; do
    if rustup component list --installed 2>/dev/null | grep -q "^$component"; then
        echo "setup: rust component $component already installed"
    else
        echo "setup: installing rust component $component"
        rustup component add "$component"
    fi
done

if command -v qemu-system-arm >/dev/null 2>&1; then
    echo "setup: qemu-system-arm already installed ($(qemu-system-arm --version | head -n1))"
else
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then
        sudo="sudo"
    fi
    echo "setup: installing qemu-system-arm with apt-get"
    $sudo apt-get update
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y --no-install-recommends qemu-system-arm
    echo "setup: installed $(qemu-system-arm --version | head -n1)"
fi
