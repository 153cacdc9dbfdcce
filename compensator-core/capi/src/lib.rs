//! C API over `compensator-core`: the board's 1 Hz compensator (Yu et al. 2011, Eq. 10, with
//! the recursive dT/dt estimator, the diagnosed features, the range guard, the fault flags and
//! the boot-time CRC check) for firmware written in C, as the static library
//! `librlg_compensator.a`, with the header `include/rlg_compensator.h` generated from this
//! source by cbindgen.
//!
//! * [`types`]: the `#[repr(C)]` types and constants the header declares.
//! * [`state`]: the states behind the opaque C types, in safe Rust.
//! * [`ffi`]: the `extern "C"` functions, the only place with `unsafe` (each pointer is checked,
//!   then turned into a reference or slice).
//!
//! Usage from C: `README.md` beside this crate. No heap, no panic: on the board the library is
//! `no_std`, and the QEMU test links it with a panic handler that exists nowhere.
#![cfg_attr(target_os = "none", no_std)]

#[cfg(not(any(
    feature = "inputs-1",
    feature = "inputs-2",
    feature = "inputs-3",
    feature = "inputs-4",
    feature = "inputs-5"
)))]
compile_error!(
    "the library accepts no table: enable at least one of the features inputs-1 … inputs-5"
);

pub mod ffi;
pub mod state;
pub mod types;

pub use ffi::*;
pub use types::*;

/// Never reached: every exported function is free of panics (proven by the link of the C
/// images in QEMU with `no-panic-proof`); should one be reached, the core stops here rather
/// than run on with a broken state.
#[cfg(all(target_os = "none", not(feature = "no-panic-proof")))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {
        core::hint::spin_loop();
    }
}

/// The link-time proof: a panic that survived optimisation anywhere on a path the C image
/// calls leaves a call to this handler, and the image then fails to link on the undefined
/// `rlg_panic_is_reachable`.
#[cfg(all(target_os = "none", feature = "no-panic-proof"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    extern "Rust" {
        /// Defined nowhere: referencing it makes any surviving panic a link error.
        fn rlg_panic_is_reachable() -> !;
    }
    #[allow(unsafe_code)] // the call never links; see the doc above
    // SAFETY: never executed; the image only links if this handler is unreachable.
    unsafe {
        rlg_panic_is_reachable()
    }
}
