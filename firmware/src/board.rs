//! Board-only code: entry point, exit paths, SysTick cost measurement, semihosting output.

use core::hint::black_box;
use core::sync::atomic::{AtomicBool, Ordering};

use compensator_core::fixed::{FixedModel, FixedTrace};
use compensator_core::{ModelTable, SensorLimits, TableError};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
use cortex_m_semihosting::hio::{self, HostStream};
use defmt_semihosting as _;
use firmware::sensor::{RateSensor, TemperatureSensor}; // the global defmt logger

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

/// `RLG_FW_FAULT=table`: the image runs a copy of the table with one bit of one coefficient
/// flipped and the stored CRC left as exported, to test the boot-time check.
const CORRUPT_TABLE: bool = match INJECT_FAULT {
    Some(v) => bytes_eq(v.as_bytes(), b"table"),
    None => false,
};

/// Byte-wise equality usable in a constant (`str` cannot be compared in const context).
const fn bytes_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// `t` with the lowest mantissa bit of its middle coefficient flipped: a still-finite, still
/// well-shaped table that only the CRC can tell from the original.
const fn corrupted<const N: usize, const D: usize>(mut t: ModelTable<N, D>) -> ModelTable<N, D> {
    let k = N / 2;
    t.alpha_dph[k] = f32::from_bits(t.alpha_dph[k].to_bits() ^ 1);
    t
}

/// `RLG_FW_FIXED` (any value): after the f32 replay, the image replays the temperatures again
/// through the integer evaluator ([`compensator_core::fixed`]) and logs the digest of its
/// outputs and its cost, for the bit-for-bit comparison with the host and the budgets.
const FIXED_PASS: bool = option_env!("RLG_FW_FIXED").is_some();

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

/// Stack high-water mark: the stack below the entry frame is painted with a pattern at boot,
/// and at the end the lowest overwritten word tells how deep the stack went.
mod stack {
    use core::ptr::{addr_of, read_volatile, write_volatile};

    /// The paint pattern; a stack word equal to it by chance would make the figure too low by
    /// at most the words below it, which is why the scan looks for the lowest changed word.
    const PAINT: u32 = 0xC5AC_CE55;
    /// Painted window below the stack pointer at boot, bytes; a deeper stack reads as "at
    /// least" this much.
    pub const WINDOW: usize = 32 * 1024;
    /// Words left unpainted just below the stack pointer (the painting loop's own spills).
    const GUARD: usize = 64;

    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }

    /// The painted region: `[lo, hi)` and the stack top.
    pub struct Painted {
        lo: usize,
        hi: usize,
        top: usize,
    }

    /// Paints the free stack below the current stack pointer.
    #[allow(unsafe_code)] // raw writes to stack memory no Rust object owns yet
    pub fn paint() -> Painted {
        // Only the addresses of the linker symbols are taken (safe since Rust 1.82).
        let (top, end) = (
            addr_of!(_stack_start) as usize,
            addr_of!(_stack_end) as usize,
        );
        let sp = cortex_m::register::msp::read() as usize;
        let hi = sp.saturating_sub(GUARD) & !3;
        let lo = end
            .max(sp.saturating_sub(WINDOW))
            .next_multiple_of(4)
            .min(hi);
        let mut a = lo;
        while a < hi {
            // SAFETY: [lo, hi) lies between the end of static RAM and below the live stack
            // frame, word aligned; nothing else uses it (no interrupts are enabled).
            unsafe { write_volatile(a as *mut u32, PAINT) };
            a += 4;
        }
        Painted { lo, hi, top }
    }

    /// Deepest stack use since [`paint`], bytes below the stack top.
    #[allow(unsafe_code)] // reads of the painted region
    pub fn high_water(p: &Painted) -> u32 {
        let mut a = p.lo;
        while a < p.hi {
            // SAFETY: the painted region, word aligned, still RAM.
            if unsafe { read_volatile(a as *const u32) } != PAINT {
                break;
            }
            a += 4;
        }
        u32::try_from(p.top - a).unwrap_or(u32::MAX)
    }
}

#[entry]
fn main() -> ! {
    let painted = stack::paint();
    let Some(cp) = cortex_m::Peripherals::take() else {
        fail()
    };
    start_systick(cp.SYST);
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
    let table = if CORRUPT_TABLE {
        const { &corrupted(MODEL) }
    } else {
        &MODEL
    };
    let mut ctl = ControlLoop::new(table, SensorLimits::DEFAULT, temp, rate);
    log_table_check(ctl.table_error(), table.crc32);
    let Ok(stderr) = hio::hstderr() else {
        defmt::error!("semihosting stderr unavailable");
        fail()
    };
    let costs = replay(&mut ctl, table, Stderr(stderr), count);
    // In an `RLG_FW_FIXED` build: the temperatures replayed again through the integer
    // evaluator, its outputs' digest and cost logged. Inline, not a function: the table's
    // input count is the generated MODEL's, which a function signature cannot name.
    // Evaluated at compile time only for an `RLG_FW_FIXED` build: a table without a Q24 form
    // (large coefficients, more inputs than the fixed path takes) must still build the f32
    // image, and a const block is evaluated whether or not its branch runs.
    if let Some(fixed) = &const {
        if FIXED_PASS {
            match FixedModel::from_table(&MODEL) {
                Ok(f) => Some(f),
                Err(_) => panic!("the model table has no Q24 form"),
            }
        } else {
            None
        }
    } {
        let (temps, _) = replay::channels(data);
        let mut trace = FixedTrace::new(table.as_model());
        let mut fcost = Cost::default();
        let mut temps = temps;
        for _ in 0..count {
            let t = temps.read_temp_c().unwrap_or(f32::NAN);
            if let Some(z) = trace.features(t) {
                let (y, ticks) = timed(|| fixed.predict(black_box(&z)));
                fcost.add(ticks);
                trace.fold(y);
            }
        }
        defmt::info!(
            "fixed: digest={=u32} outputs={=u32} predict_total={=u64} calls={=u32} (SysTick ticks of FixedModel::predict)",
            trace.digest(),
            trace.count(),
            fcost.total,
            fcost.calls
        );
    }
    log_summary(&ctl, &costs, &painted);
    if !costs.written {
        defmt::error!("the host did not take every sample line");
        fail()
    }
    loop {
        debug::exit(EXIT_SUCCESS);
    }
}

/// SysTick on the core clock over its full range.
fn start_systick(mut syst: SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYST_RELOAD);
    syst.clear_current();
    syst.enable_counter();
}

/// Logs the table's boot check: the CRC verified, or why raw rates pass through.
fn log_table_check(error: Option<TableError>, crc32: u32) {
    match error {
        None => defmt::info!("model table CRC-32 {=u32:#010x} verified", crc32),
        Some(TableError::Checksum { stored, computed }) => defmt::error!(
            "model table CRC-32 mismatch: stored {=u32:#010x}, computed {=u32:#010x}; raw rates pass through (TABLE_FAULT)",
            stored,
            computed
        ),
        Some(e) => defmt::error!(
            "model table failed validation: {}; raw rates pass through (TABLE_FAULT)",
            e
        ),
    }
}

/// What the replay measured.
struct ReplayCosts {
    /// SysTick ticks of each 1 Hz step.
    step: Cost,
    /// Ticks of the kernel sum alone with libm's exp.
    kernel_libm: Cost,
    /// Ticks of the kernel sum alone with the board's fast exp.
    kernel_fast: Cost,
    /// Largest |libm − fast| of the kernel sum, °/h.
    fast_max_dev_dph: f32,
    /// Whether the host took every sample line.
    written: bool,
}

/// Runs the 1 Hz loop over the `count` replayed samples, each output line to `sink`. The
/// kernel sum alone, per exp choice, at each sample's (clamped) temperature and the mean of
/// the other features is timed too: what a different exp would save on each update. Measured
/// after the step, outside its timing, so the step figures are those of the shipped path.
fn replay<T: TemperatureSensor, R: RateSensor, const N: usize, const D: usize>(
    ctl: &mut ControlLoop<'_, T, R, D>,
    table: &ModelTable<N, D>,
    sink: Stderr,
    count: u32,
) -> ReplayCosts {
    let mut out: LineWriter<Stderr, 2000> = LineWriter::begin(sink, count);
    let mut cost = Cost::default();
    let model = table.as_model();
    let (mut k_libm, mut k_fast) = (Cost::default(), Cost::default());
    let mut fast_dev = 0.0f32;
    for _ in 0..count {
        // The replay plays the role of the 1 Hz timer: no waiting between samples.
        let (record, t) = timed(|| ctl.step());
        cost.add(t);
        out.record(&record);
        let onset = ctl.fault_onset();
        if !onset.is_ok() {
            defmt::warn!(
                "sample {=u32}: fault {=u8:#04x} set (temperature {=f32} °C, rate {=f32} °/h; status {=u8:#04x})",
                record.index,
                onset.0,
                record.temp_c,
                record.gyro_dph,
                record.out.status.0
            );
        }

        let s = model.spec;
        let t_c = record.temp_c;
        let t_c = if t_c >= s.input_lo[0] && t_c <= s.input_hi[0] {
            t_c
        } else {
            s.input_mean[0]
        };
        let x: [f32; _] = core::array::from_fn(|d| if d == 0 { t_c } else { s.input_mean[d] });
        let z = model.standardise(&x);
        let (a, t) = timed(|| model.predict_standardised_dph_libm(black_box(&z)));
        k_libm.add(t);
        let (b, t) = timed(|| model.predict_standardised_dph(black_box(&z)));
        k_fast.add(t);
        let dev = (black_box(a) - black_box(b)).abs();
        if dev > fast_dev {
            fast_dev = dev;
        }
    }
    let (_, written) = out.end();
    ReplayCosts {
        step: cost,
        kernel_libm: k_libm,
        kernel_fast: k_fast,
        fast_max_dev_dph: fast_dev,
        written,
    }
}

/// Logs the run's summary: the status counts, the costs and the stack's high-water mark.
fn log_summary<T: TemperatureSensor, R: RateSensor, const D: usize>(
    ctl: &ControlLoop<'_, T, R, D>,
    c: &ReplayCosts,
    painted: &stack::Painted,
) {
    let s = ctl.summary();
    defmt::info!(
        "summary: samples={=u32} ok={=u32} {=str}={=u32} {=str}={=u32} {=str}={=u32} {=str}={=u32} {=str}={=u32} {=str}={=u32} temp_sensor_errors={=u32} rate_sensor_errors={=u32}",
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
        STATUS_BITS[5].1,
        s.per_bit[5],
        s.temp_sensor_errors,
        s.rate_sensor_errors
    );
    defmt::info!(
        "cost: step ticks min={=u32} mean={=u32} max={=u32} total={=u64} calls={=u32} (SysTick at the 25 MHz core clock; under -icount shift=0 one tick = 40 instructions)",
        c.step.min,
        c.step.mean(),
        c.step.max,
        c.step.total,
        c.step.calls
    );
    defmt::info!(
        "kernel: libm_total={=u64} fast_total={=u64} calls={=u32} fast_max_dev_dph={=f32} (SysTick ticks of predict_standardised_dph per exp choice)",
        c.kernel_libm.total,
        c.kernel_fast.total,
        c.kernel_libm.calls,
        c.fast_max_dev_dph
    );
    defmt::info!(
        "stack: high_water_bytes={=u32} (painted window {=usize} bytes)",
        stack::high_water(painted),
        stack::WINDOW
    );
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
