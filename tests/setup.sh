#!/usr/bin/env bash
# Installs what the firmware build and the QEMU replay test need on a Debian machine with Rust:
# the thumbv7em-none-eabihf target and qemu-system-arm. Idempotent: installs only what is
# missing and says what it did.
set -euo pipefail

cd "$(dirname "$0")/.."
target=thumbv7em-none-eabihf

if rustup target list --installed 2>/dev/null | grep -qx "$target"; then
    echo "setup: rust target $target already installed"
else
    echo "setup: installing rust target $target"
    rustup target add "$target"
fi

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
