/* Bad input through the C API: every case prints one line
 *   <case> <rlg_error> <status> <rate bits hex> <correction bits hex>
 * (status and bits from the output written by the call, or "-" when the call writes none).
 * The test (tests/tests/c_api_host.rs) checks each line against the documented behaviour and
 * the sensor-fault samples against the Rust Compensator. Never traps: a trap fails the test. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rlg_compensator.h"
#include "rlg_model_table.h"

static uint32_t bits(float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static void line(const char *name, rlg_error e, const rlg_output *o) {
    if (o)
        printf("%s %d %u %08x %08x\n", name, (int)e, (unsigned)o->status, bits(o->rate_dph),
               bits(o->correction_dph));
    else
        printf("%s %d - - -\n", name, (int)e);
}

/* A writable copy of a table's arrays, for corrupting one number. */
static float alpha_copy[RLG_N];
static int32_t support_q24_copy[RLG_N][RLG_D];

int main(void) {
    static rlg_compensator never_initialised; /* zero-filled, like any static */
    static rlg_fixed_compensator fixed_never_initialised;
    static rlg_compensator s;
    static rlg_fixed_compensator fs;
    rlg_output o;
    const float gyro = -7.05f;

    line("init_null_state", rlg_init(NULL, &rlg_model), NULL);
    line("init_null_table", rlg_init(&s, NULL), NULL);
    line("update_after_null_table", rlg_update(&s, 30.0f, gyro, &o), &o);
    line("update_null_state", rlg_update(NULL, 30.0f, gyro, &o), &o);
    line("update_null_out", rlg_update(&s, 30.0f, gyro, NULL), NULL);
    line("update_before_init", rlg_update(&never_initialised, 30.0f, gyro, &o), &o);
    line("fixed_update_before_init",
         rlg_fixed_update(&fixed_never_initialised, 30.0f, gyro, &o), &o);
    /* A state one byte off its alignment. */
    static uint64_t raw[RLG_COMPENSATOR_SIZE / 8 + 1];
    rlg_compensator *misaligned = (rlg_compensator *)(void *)((char *)raw + 1);
    line("init_misaligned_state", rlg_init(misaligned, &rlg_model), NULL);

    /* One flipped bit in one coefficient, the stored CRC left as exported. */
    memcpy(alpha_copy, rlg_alpha_dph, sizeof alpha_copy);
    alpha_copy[RLG_N / 2] = -alpha_copy[RLG_N / 2];
    rlg_table corrupted = rlg_model;
    corrupted.alpha_dph = alpha_copy;
    line("init_corrupted_table", rlg_init(&s, &corrupted), NULL);
    line("update_corrupted_table", rlg_update(&s, 30.0f, gyro, &o), &o);

    rlg_table t = rlg_model;
    t.n_features = 9;
    line("init_too_many_features", rlg_init(&s, &t), NULL);
    t = rlg_model;
    t.n_support = 0;
    line("init_no_support_vectors", rlg_init(&s, &t), NULL);
    t = rlg_model;
    t.support = NULL;
    line("init_null_support", rlg_init(&s, &t), NULL);
    t = rlg_model;
    t.support = (const float *)(const void *)((const char *)t.support + 2);
    line("init_misaligned_support", rlg_init(&s, &t), NULL);
    static const rlg_feature unknown[RLG_D] = {{99u, 0u}, {1u, 0u}};
    t = rlg_model;
    t.features = unknown;
    line("init_unknown_feature", rlg_init(&s, &t), NULL);

    /* Sensor faults on a good table: warm up at 30 degC, then one bad sample of each kind. */
    line("init_good", rlg_init(&s, &rlg_model), NULL);
    for (int k = 0; k < 400; k++) rlg_update(&s, 30.0f, gyro, &o);
    line("warm", rlg_update(&s, 30.0f, gyro, &o), &o);
    line("temp_nan", rlg_update(&s, NAN, gyro, &o), &o);
    line("temp_out_of_range", rlg_update(&s, 150.0f, gyro, &o), &o);
    line("temp_below_range", rlg_update(&s, -80.0f, gyro, &o), &o);
    line("gyro_nan", rlg_update(&s, 30.0f, NAN, &o), &o);
    line("gyro_infinite", rlg_update(&s, 30.0f, INFINITY, &o), &o);
    line("both_nan", rlg_update(&s, NAN, NAN, &o), &o);
    line("recovered", rlg_update(&s, 30.0f, gyro, &o), &o);

    /* The fixed-point path. */
    line("fixed_init_null_table", rlg_fixed_init(&fs, NULL), NULL);
    line("fixed_update_after_null_table", rlg_fixed_update(&fs, 30.0f, gyro, &o), &o);
    rlg_fixed_table ft = rlg_fixed_model;
    ft.table = NULL;
    line("fixed_init_null_inner_table", rlg_fixed_init(&fs, &ft), NULL);
    memcpy(support_q24_copy, rlg_support_q24, sizeof support_q24_copy);
    support_q24_copy[RLG_N / 2][0] ^= 1;
    ft = rlg_fixed_model;
    ft.support_q24 = &support_q24_copy[0][0];
    line("fixed_init_mismatched_q24", rlg_fixed_init(&fs, &ft), NULL);
    ft = rlg_fixed_model;
    ft.table = &corrupted;
    line("fixed_init_corrupted_table", rlg_fixed_init(&fs, &ft), NULL);
    line("fixed_update_corrupted_table", rlg_fixed_update(&fs, 30.0f, gyro, &o), &o);
    line("fixed_init_good", rlg_fixed_init(&fs, &rlg_fixed_model), NULL);
    line("fixed_temp_nan", rlg_fixed_update(&fs, NAN, gyro, &o), &o);

    /* The multi-axis forms. */
    const rlg_table *tables[2] = {&rlg_model, &corrupted};
    rlg_compensator axes[2];
    rlg_error errors[2];
    line("axes_init_null_tables", rlg_init_axes(axes, NULL, 2, errors), NULL);
    line("axes_init_one_corrupted", rlg_init_axes(axes, tables, 2, errors), NULL);
    line("axes_errors_0", errors[0], NULL);
    line("axes_errors_1", errors[1], NULL);
    float temps[2] = {30.0f, 30.0f}, gyros[2] = {gyro, gyro};
    rlg_output outs[2];
    line("axes_update_null_temps", rlg_update_axes(axes, 2, NULL, gyros, outs), NULL);
    line("axes_update", rlg_update_axes(axes, 2, temps, gyros, outs), &outs[1]);
    line("fixed_axes_init_null_states", rlg_fixed_init_axes(NULL, NULL, 2, NULL), NULL);
    return 0;
}
