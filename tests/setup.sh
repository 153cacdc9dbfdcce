#!/usr/bin/env bash
# Installs what the firmware build and the QEMU replay test need on a Debian machine with Rust:
# the thumb targets, rustfmt, clippy and qemu-system-arm; and what the C API's tests need: the
# host C compiler `cc` and the bare-metal Arm C toolchain (arm-none-eabi-gcc with newlib).
# Idempotent: installs only what is missing and says what it did.
set -euo pipefail

cd "$(dirname "$0")/.."
# /dev/null must be the null device. Found as a regular file on one machine: everything
# written to it (setup's own output, build scripts' probes) was read back as source by the
# `rustc -` query cargo makes to learn the target, and the board build stopped with "failed
# to run `rustc` to learn about target-specific information". Restored here when we may.
if [ ! -c /dev/null ]; then
    if [ "$(id -u)" -eq 0 ]; then
        echo "setup: /dev/null is not the null device (a $(stat -c %F /dev/null)): restoring it"
        rm -f /dev/null
        mknod -m 666 /dev/null c 1 3
    else
        echo "setup: /dev/null is not the null device (a $(stat -c %F /dev/null)); cargo's" \
            "target query reads it as source. Restore it as root: rm -f /dev/null &&" \
            "mknod -m 666 /dev/null c 1 3" >&2
        exit 1
    fi
fi
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

sudo=""
if [ "$(id -u)" -ne 0 ]; then
    sudo="sudo"
fi
apt_updated=""
# Installs Debian packages "$@" (apt-get update once per run).
apt_install() {
    if [ -z "$apt_updated" ]; then
        $sudo apt-get update
        apt_updated=1
    fi
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y --no-install-recommends "$@"
}

if command -v qemu-system-arm >/dev/null 2>&1; then
    echo "setup: qemu-system-arm already installed ($(qemu-system-arm --version | head -n1))"
else
    echo "setup: installing qemu-system-arm with apt-get"
    apt_install qemu-system-arm
    echo "setup: installed $(qemu-system-arm --version | head -n1)"
fi

# The C API's host test compiles C with the system compiler.
if command -v cc >/dev/null 2>&1; then
    echo "setup: cc already installed ($(cc --version | head -n1))"
else
    echo "setup: installing gcc (the host C compiler cc) with apt-get"
    apt_install gcc libc6-dev
fi

# The C API's QEMU test builds a C firmware image against the thumb library: arm-none-eabi-gcc
# and newlib's C library for it (memcpy and the like).
if command -v arm-none-eabi-gcc >/dev/null 2>&1 \
    && [ -f "$(arm-none-eabi-gcc -mthumb -mcpu=cortex-m4 -print-file-name=libc_nano.a)" ]; then
    echo "setup: arm-none-eabi-gcc and newlib already installed ($(arm-none-eabi-gcc --version | head -n1))"
else
    echo "setup: installing gcc-arm-none-eabi and libnewlib-arm-none-eabi with apt-get"
    apt_install gcc-arm-none-eabi libnewlib-arm-none-eabi
    echo "setup: installed $(arm-none-eabi-gcc --version | head -n1)"
fi
