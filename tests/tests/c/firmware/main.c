/* C firmware image: replays the recording compiled in (replay.S) through the C API in QEMU and
 * writes every output over semihosting, as the Rust image does (firmware/src/board.rs):
 *   stderr: "B count", one "S index temp gyro rate correction status" line per sample (hex
 *           bit patterns, firmware/src/wire.rs), "E count";
 *   stdout: text lines "key: name=value ..." (calibration, checks, init, cost, stack).
 * Built with -DRLG_FIXED it runs the fixed-point compensator instead of the f32 one.
 * Before the replay it exercises bad input on every function of its path (NULL pointers, a
 * corrupted table, an update before init, the multi-axis forms): any trap ends QEMU with
 * exit code 1. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "rlg_compensator.h"
#include "rlg_model_table.h"
#include "semihosting.h"

extern const uint8_t rlg_replay[], rlg_replay_end[];

#ifdef RLG_FIXED
typedef rlg_fixed_compensator state_t;
typedef rlg_fixed_table table_t;
#define MODEL rlg_fixed_model
#define INIT rlg_fixed_init
#define UPDATE rlg_fixed_update
#define INIT_AXES rlg_fixed_init_axes
#define UPDATE_AXES rlg_fixed_update_axes
#else
typedef rlg_compensator state_t;
typedef rlg_table table_t;
#define MODEL rlg_model
#define INIT rlg_init
#define UPDATE rlg_update
#define INIT_AXES rlg_init_axes
#define UPDATE_AXES rlg_update_axes
#endif

/* SysTick at the core clock; under -icount shift=0 one tick is 40 instructions. */
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define SYST_RELOAD 0x00FFFFFFu
#define CALIBRATION_LOOPS 20000u

/* Stack high-water mark: paint below the stack pointer at boot, find the lowest changed word. */
#define PAINT 0xC5ACCE55u
#define PAINT_WINDOW (32u * 1024u)
#define PAINT_GUARD 256u
extern uint32_t _ebss, _stack_top;
static uint32_t *paint_lo, *paint_hi;

__attribute__((noinline)) static void paint_stack(void) {
    uint32_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    uint32_t hi = (sp - PAINT_GUARD) & ~3u;
    uint32_t lo = hi - PAINT_WINDOW;
    if (lo < (uint32_t)(uintptr_t)&_ebss) lo = ((uint32_t)(uintptr_t)&_ebss + 3u) & ~3u;
    paint_lo = (uint32_t *)(uintptr_t)lo;
    paint_hi = (uint32_t *)(uintptr_t)hi;
    for (volatile uint32_t *p = paint_lo; p < paint_hi; p++) *p = PAINT;
}

static uint32_t stack_high_water(void) {
    volatile uint32_t *p = paint_lo;
    while (p < paint_hi && *p == PAINT) p++;
    return (uint32_t)((uintptr_t)&_stack_top - (uintptr_t)p);
}

/* Decimal and hex text without printf. */
static char *put_u64(char *o, uint64_t v) {
    char tmp[20];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v);
    while (n) *o++ = tmp[--n];
    return o;
}

static char *put_hex(char *o, uint32_t v, int digits) {
    static const char d[] = "0123456789abcdef";
    for (int i = digits - 1; i >= 0; i--) *o++ = d[(v >> (4 * i)) & 0xFu];
    return o;
}

static char *put_str(char *o, const char *s) {
    while (*s) *o++ = *s++;
    return o;
}

/* "<key>: a=1 b=2\n" on stdout. */
static void log_fields(const char *key, int n, const char *const *names, const uint64_t *vals) {
    char line[256], *o = put_str(line, key);
    *o++ = ':';
    for (int i = 0; i < n; i++) {
        *o++ = ' ';
        o = put_str(o, names[i]);
        *o++ = '=';
        o = put_u64(o, vals[i]);
    }
    *o++ = '\n';
    *o = 0;
    sh_log(line);
}

/* The sample stream, buffered into semihosting writes of about 2 kB (the buffer on main's
 * stack, as the Rust image's is). */
#define STREAM_BYTES 2000u
static char *stream;
static size_t stream_len;
static int stream_ok = 1;

static void stream_flush(void) {
    if (stream_len && sh_err_write(stream, stream_len) != 0) stream_ok = 0;
    stream_len = 0;
}

static void stream_line(const char *s, size_t n) {
    if (stream_len + n > STREAM_BYTES) stream_flush();
    memcpy(stream + stream_len, s, n);
    stream_len += n;
}

static void mark(char tag, uint32_t count) {
    char line[11];
    line[0] = tag;
    line[1] = ' ';
    put_hex(line + 2, count, 8);
    line[10] = '\n';
    stream_line(line, sizeof line);
}

static uint32_t bits(float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static void record(uint32_t index, float t, float g, const rlg_output *out) {
    char line[50];
    char *o = line;
    *o++ = 'S';
    const uint32_t words[5] = {index, bits(t), bits(g), bits(out->rate_dph),
                               bits(out->correction_dph)};
    for (int k = 0; k < 5; k++) {
        *o++ = ' ';
        o = put_hex(o, words[k], 8);
    }
    *o++ = ' ';
    o = put_hex(o, out->status, 2);
    *o = '\n';
    stream_line(line, sizeof line);
}

/* Bad input on every function of this image's path; returns the number of failed checks. Its
 * states live on its own stack frame (only the replay's state is static). */
__attribute__((noinline)) static uint32_t check_bad_input(uint32_t *passed) {
    state_t never_initialised, s, axes[2];
    float alpha_copy[RLG_N];
    memset(&never_initialised, 0, sizeof never_initialised);
    uint32_t failed = 0;
    rlg_output o;
#define CHECK(cond) ((cond) ? (void)(*passed += 1) : (void)(failed += 1))
    CHECK(INIT(NULL, &MODEL) == RLG_ERR_NULL);
    CHECK(INIT(&s, NULL) == RLG_ERR_NULL);
    CHECK(UPDATE(&s, 30.0f, -7.0f, &o) == RLG_OK && o.status == RLG_STATUS_TABLE_FAULT &&
          o.rate_dph == -7.0f);
    CHECK(UPDATE(&never_initialised, 30.0f, -7.0f, &o) == RLG_ERR_NOT_INITIALIZED &&
          o.status == RLG_STATUS_TABLE_FAULT && o.rate_dph == -7.0f);
    CHECK(UPDATE(&s, 30.0f, -7.0f, NULL) == RLG_ERR_NULL);
    CHECK(UPDATE(NULL, NAN, NAN, &o) == RLG_ERR_NULL && o.rate_dph == 0.0f);
    memcpy(alpha_copy, rlg_alpha_dph, sizeof alpha_copy);
    alpha_copy[RLG_N / 2] = -alpha_copy[RLG_N / 2];
    rlg_table corrupted = rlg_model;
    corrupted.alpha_dph = alpha_copy;
#ifdef RLG_FIXED
    rlg_fixed_table bad = rlg_fixed_model;
    bad.table = &corrupted;
    const table_t *tables[2] = {&MODEL, &bad};
#else
    const table_t *tables[2] = {&MODEL, &corrupted};
#endif
    CHECK(INIT(&s, tables[1]) == RLG_ERR_TABLE_CRC);
    CHECK(UPDATE(&s, 30.0f, -7.0f, &o) == RLG_OK && o.status == RLG_STATUS_TABLE_FAULT);
    rlg_error errors[2];
    CHECK(INIT_AXES(axes, NULL, 2, errors) == RLG_ERR_NULL);
    CHECK(INIT_AXES(axes, tables, 2, errors) == RLG_ERR_TABLE_CRC && errors[0] == RLG_OK &&
          errors[1] == RLG_ERR_TABLE_CRC);
    float temps[2] = {30.0f, NAN}, gyros[2] = {-7.0f, -7.0f};
    rlg_output outs[2];
    CHECK(UPDATE_AXES(axes, 2, temps, NULL, outs) == RLG_ERR_NULL);
    CHECK(UPDATE_AXES(axes, 2, temps, gyros, outs) == RLG_OK &&
          (outs[0].status & RLG_STATUS_WARMING_UP) && outs[1].status == RLG_STATUS_TABLE_FAULT);
#undef CHECK
    return failed;
}

int main(void) {
    char stream_buffer[STREAM_BYTES];
    stream = stream_buffer;
    SYST_RVR = SYST_RELOAD;
    SYST_CVR = 0;
    SYST_CSR = 5u; /* enable, core clock, no interrupt */

    /* Calibration: a two-instruction loop of known length against SysTick. */
    uint32_t t0 = SYST_CVR;
    uint32_t n = CALIBRATION_LOOPS + 1u;
    __asm__ volatile("1: subs %0, #1\n bne 1b" : "+r"(n) : : "cc");
    uint32_t cal = (t0 - SYST_CVR) & SYST_RELOAD;
    {
        static const char *const k[] = {"instructions", "ticks"};
        const uint64_t v[] = {2u * (CALIBRATION_LOOPS + 1u), cal};
        log_fields("calibration", 2, k, v);
    }

    uint32_t passed = 0, failed = check_bad_input(&passed);
    {
        static const char *const k[] = {"passed", "failed"};
        const uint64_t v[] = {passed, failed};
        log_fields("checks", 2, k, v);
    }
    /* The high-water mark is that of init, the replay and the output (the checks above are a
     * test harness, not the board's work). */
    paint_stack();

    static state_t state;
    rlg_error e = INIT(&state, &MODEL);
    {
        static const char *const k[] = {"error", "n", "d"};
        const uint64_t v[] = {(uint64_t)e, RLG_N, RLG_D};
        log_fields("init", 3, k, v);
    }

    uint32_t count;
    memcpy(&count, rlg_replay + 8, 4);
    if ((size_t)(rlg_replay_end - rlg_replay) != 12u + 8u * (size_t)count) {
        sh_log("replay data is malformed\n");
        return 1;
    }
    mark('B', count);
    uint64_t total = 0;
    uint32_t min = 0xFFFFFFFFu, max = 0;
    for (uint32_t k = 0; k < count; k++) {
        float t, g;
        rlg_output out;
        uint32_t c0 = SYST_CVR;
        /* One step: both readings (from the replay) and the update, as the Rust image times. */
        memcpy(&t, rlg_replay + 12u + 8u * k, 4);
        memcpy(&g, rlg_replay + 16u + 8u * k, 4);
        UPDATE(&state, t, g, &out);
        uint32_t ticks = (c0 - SYST_CVR) & SYST_RELOAD;
        total += ticks;
        if (ticks < min) min = ticks;
        if (ticks > max) max = ticks;
        record(k, t, g, &out);
    }
    mark('E', count);
    stream_flush();
    {
        static const char *const k[] = {"min", "max", "total", "calls"};
        const uint64_t v[] = {min, max, total, count};
        log_fields("cost", 4, k, v);
    }
    {
        static const char *const k[] = {"high_water_bytes"};
        const uint64_t v[] = {stack_high_water()};
        log_fields("stack", 1, k, v);
    }
    if (!stream_ok) {
        sh_log("the host did not take every sample line\n");
        return 1;
    }
    return failed == 0 ? 0 : 1;
}
