//! Board-only code: entry point, exit paths, SysTick cost measurement, semihosting output.

use core::sync::atomic::{AtomicBool, Ordering};

use compensator_core::SensorLimits;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use cortex_m_semihosting::hio::{self, HostStream};
use defmt_semihosting as _; // the global defmt logger

use firmware::control::ControlLoop;
use firmware::model_table::MODEL;
use firmware::replay::{self, ReplayData};
use firmware::summary::{Cost, STATUS_BITS};
use firmware::wire::{ByteSink, LineWriter};

/// The recording chosen at build time (`RLG_REPLAY_BIN`).
static REPLAY: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/replay.bin"));

/// SysTick reload: the full 24-bit range, so one update never wraps more than once.
const SYST_RELOAD: u32 = 0x00ff_ffff;

/// Loop count of the SysTick calibration: `asm::delay(n)` runs n + 1 iterations of a
/// two-instruction loop, 2·(n + 1) instructions.
const CALIBRATION_LOOPS: u32 = 20_000;

/// Build-time fault injection for the exit-path test (`RLG_FW_FAULT=panic|hardfault`);
/// unset in every normal build.
const INJECT_FAULT: Option<&str> = option_env!("RLG_FW_FAULT");

/// `f`'s result and the SysTick ticks it took (SysTick counts down).
fn timed<T>(f: impl FnOnce() -> T) -> (T, u32) {
    let t0 = SYST::get_current();
    let value = f();
    let t1 = SYST::get_current();
    (value, t0.wrapping_sub(t1) & SYST_RELOAD)
}

struct Stderr(HostStream);

impl ByteSink for Stderr {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), ()> {
        self.0.write_all(bytes)
    }
}

fn fail() -> ! {
    loop {
        debug::exit(EXIT_FAILURE);
    }
}

#[entry]
fn main() -> ! {
    let Some(cp) = cortex_m::Peripherals::take() else {
        fail()
    };
    let mut syst = cp.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYST_RELOAD);
    syst.clear_current();
    syst.enable_counter();

    let data = match ReplayData::parse(REPLAY) {
        Ok(d) => d,
        Err(_) => {
            // build.rs checked the file, so this is a corrupted image.
            defmt::error!("replay data is malformed");
            fail()
        }
    };
    let count = data.len();
    defmt::info!(
        "rlg firmware: model table N={=usize} D={=usize} ({=usize} bytes), replay of {=u32} samples",
        MODEL.support.len(),
        MODEL.spec.features.len(),
        core::mem::size_of_val(&MODEL),
        count
    );

    let ((), cal) = timed(|| cortex_m::asm::delay(CALIBRATION_LOOPS));
    defmt::info!(
        "calibration: instructions={=u32} ticks={=u32}",
        2 * (CALIBRATION_LOOPS + 1),
        cal
    );
    match INJECT_FAULT {
        Some("panic") => panic!("injected by RLG_FW_FAULT"),
        Some("hardfault") => cortex_m::asm::udf(), // UsageFault, escalated to HardFault
        _ => {}
    }

    let (temp, rate) = replay::channels(data);
    let mut ctl = ControlLoop::new(&MODEL, SensorLimits::DEFAULT, temp, rate);
    if !ctl.table_ok() {
        defmt::warn!("model table failed validation: raw rates pass through (TABLE_FAULT)");
    }
    let Ok(stderr) = hio::hstderr() else {
        defmt::error!("semihosting stderr unavailable");
        fail()
    };
    let mut out: LineWriter<Stderr, 2000> = LineWriter::begin(Stderr(stderr), count);
    let mut cost = Cost::default();
    for _ in 0..count {
        // The replay plays the role of the 1 Hz timer: no waiting between samples.
        let (record, t) = timed(|| ctl.step());
        cost.add(t);
        out.record(&record);
    }
    let (_, written) = out.end();

    let s = ctl.summary();
    defmt::info!(
        "summary: samples={=u32} ok={=u32} {=str}={=u32} {=str}={=u32} {=str}={=u32} {=str}={=u32} {=str}={=u32} temp_sensor_errors={=u32} rate_sensor_errors={=u32}",
        s.samples,
        s.ok,
        STATUS_BITS[0].1,
        s.per_bit[0],
        STATUS_BITS[1].1,
        s.per_bit[1],
        STATUS_BITS[2].1,
        s.per_bit[2],
        STATUS_BITS[3].1,
        s.per_bit[3],
        STATUS_BITS[4].1,
        s.per_bit[4],
        s.temp_sensor_errors,
        s.rate_sensor_errors
    );
    defmt::info!(
        "cost: step ticks min={=u32} mean={=u32} max={=u32} total={=u64} calls={=u32} (SysTick at the 25 MHz core clock; under -icount shift=0 one tick = 40 instructions)",
        cost.min,
        cost.mean(),
        cost.max,
        cost.total,
        cost.calls
    );
    if !written {
        defmt::error!("the host did not take every sample line");
        fail()
    }
    loop {
        debug::exit(EXIT_SUCCESS);
    }
}

/// Set once the first panic starts, so a panic inside the logger cannot recurse.
static PANICKING: AtomicBool = AtomicBool::new(false);

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!("panic: {}", defmt::Display2Format(info));
    }
    fail()
}

#[allow(unsafe_code)] // cortex-m-rt requires the handler to be an `unsafe fn`
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!("HardFault at pc={=u32:#010x}", frame.pc());
    }
    fail()
}

#[allow(unsafe_code)] // cortex-m-rt requires the handler to be an `unsafe fn`
#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!("unexpected exception or interrupt {=i16}", irqn);
    }
    fail()
}
