//! Link-time proof that the 1 Hz path has no reachable panic.
//!
//! The board's control loop (`ControlLoop::step`: sensor reads, `Compensator::update` with the
//! table CRC check, the dT/dt estimator, the recursive features, the range clamps and the
//! kernel sum) and the replay reader run over the replay compiled in, in the release
//! `firmware` profile, with a panic handler that calls a function that exists nowhere. A
//! panic that survived optimisation anywhere on that path would leave a call to the handler,
//! and the link would fail on the undefined `rlg_panic_is_reachable`; the image linking is
//! the proof. (The QEMU image's logging transport, defmt over semihosting, keeps its own
//! reentrancy panics; it is not on this path and not linked here.)
//!
//! `cargo build -p firmware --profile firmware --target thumbv7em-none-eabihf --bin no-panic
//! --features no-panic-proof`
//! (run by `tests/tests/no_panic.rs`, which also builds the negative control,
//! `RLG_NO_PANIC_CONTROL=1`, and checks that its link fails).
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod image {
    use compensator_core::SensorLimits;
    use cortex_m_rt::entry;
    use firmware::control::ControlLoop;
    use firmware::model_table::MODEL;
    use firmware::replay::{self, ReplayData};

    /// `RLG_NO_PANIC_CONTROL` set: the negative control, one out-of-bounds index per step, so
    /// the test can show that a reachable panic does fail the link.
    const CONTROL: bool = option_env!("RLG_NO_PANIC_CONTROL").is_some();

    /// The recording chosen at build time (`RLG_REPLAY_BIN`).
    static REPLAY: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/replay.bin"));

    #[entry]
    fn main() -> ! {
        // black_box: the optimiser must not see the compiled-in data and fold the checks.
        let Ok(data) = ReplayData::parse(core::hint::black_box(REPLAY)) else {
            loop {
                cortex_m::asm::wfi();
            }
        };
        let (temp, rate) = replay::channels(data);
        let table = core::hint::black_box(&MODEL);
        let mut ctl = ControlLoop::new(table, SensorLimits::DEFAULT, temp, rate);
        loop {
            core::hint::black_box(ctl.step());
            if CONTROL {
                let v: &[u8] = core::hint::black_box(&[1, 2]);
                core::hint::black_box(v[core::hint::black_box(5)]);
            }
        }
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        extern "Rust" {
            /// Defined nowhere: referencing it makes any surviving panic a link error.
            fn rlg_panic_is_reachable() -> !;
        }
        #[allow(unsafe_code)] // the call never links; see the module doc
        // SAFETY: never executed; the image only links if this handler is unreachable.
        unsafe {
            rlg_panic_is_reachable()
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {}
