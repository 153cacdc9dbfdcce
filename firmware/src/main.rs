//! The board image: replays the recording compiled in by `build.rs` through the 1 Hz loop in
//! QEMU (`mps2-an386`, Cortex-M4F) and writes every compensated sample over semihosting.
//!
//! Streams: defmt log frames on semihosting stdout, sample lines ([`firmware::wire`]) on
//! semihosting stderr. Exit code: 0 after the last sample, 1 on panic, HardFault, an
//! unexpected exception or a failed host write.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod board;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "the firmware runs on thumbv7em-none-eabihf: `cargo fw-build` builds it, `cargo fw-run` \
         runs it in QEMU; `cargo test -p firmware` tests its logic on the host"
    );
    std::process::exit(2);
}
