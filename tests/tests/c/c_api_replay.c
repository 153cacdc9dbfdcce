/* Host replay through the C API (librlg_compensator.a, rlg_compensator.h).
 *
 * c_api_replay REPLAY MODE
 *   REPLAY: a replay file (tests/src/replay.rs: "RLGR", u16 version 1, u16 0, u32 count, then
 *           count x (temp_c f32, gyro_dph f32), little-endian).
 *   MODE:   f32        rlg_init / rlg_update with rlg_model (rlg_model_table.h)
 *           fixed      rlg_fixed_init / rlg_fixed_update with rlg_fixed_model
 *           axes       rlg_init_axes / rlg_update_axes over gyro_x, gyro_y, gyro_z (one table
 *                      each; axis k sees the gyro rate plus k * 0.5 deg/h)
 *           fixed_axes the same with the fixed-point states and tables
 * Writes, per sample and axis, three little-endian u32: the output rate's bits, the
 * correction's bits and the status; exit 2 when an init fails (with its code on stderr). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rlg_compensator.h"
#include "rlg_model_table.h"
#include "gyro_x_table.h"
#include "gyro_y_table.h"
#include "gyro_z_table.h"

static uint32_t bits(float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static void put(const rlg_output *o) {
    uint32_t w[3] = {bits(o->rate_dph), bits(o->correction_dph), o->status};
    fwrite(w, sizeof w, 1, stdout);
}

int main(int argc, char **argv) {
    if (argc != 3) return 64;
    FILE *f = fopen(argv[1], "rb");
    if (!f) return 66;
    static unsigned char buf[1 << 20];
    size_t len = fread(buf, 1, sizeof buf, f);
    fclose(f);
    uint32_t count;
    memcpy(&count, buf + 8, 4);
    if (len < 12 || memcmp(buf, "RLGR", 4) != 0 || len != 12 + 8 * (size_t)count) return 65;
    const char *mode = argv[2];

    static rlg_compensator one, three[3];
    static rlg_fixed_compensator fone, fthree[3];
    const rlg_table *tables[3] = {&gyro_x_model, &gyro_y_model, &gyro_z_model};
    const rlg_fixed_table *ftables[3] = {&gyro_x_fixed_model, &gyro_y_fixed_model,
                                         &gyro_z_fixed_model};
    rlg_error errors[3] = {RLG_OK, RLG_OK, RLG_OK};
    rlg_error e;
    if (strcmp(mode, "f32") == 0) e = rlg_init(&one, &rlg_model);
    else if (strcmp(mode, "fixed") == 0) e = rlg_fixed_init(&fone, &rlg_fixed_model);
    else if (strcmp(mode, "axes") == 0) e = rlg_init_axes(three, tables, 3, errors);
    else if (strcmp(mode, "fixed_axes") == 0) e = rlg_fixed_init_axes(fthree, ftables, 3, errors);
    else return 64;
    if (e != RLG_OK) {
        fprintf(stderr, "init: %d (axes %d %d %d)\n", (int)e, (int)errors[0], (int)errors[1],
                (int)errors[2]);
        return 2;
    }
    for (uint32_t k = 0; k < count; k++) {
        float t, g;
        memcpy(&t, buf + 12 + 8 * (size_t)k, 4);
        memcpy(&g, buf + 16 + 8 * (size_t)k, 4);
        rlg_output out[3];
        if (strcmp(mode, "f32") == 0 || strcmp(mode, "fixed") == 0) {
            e = mode[0] == 'f' && mode[1] == '3' ? rlg_update(&one, t, g, &out[0])
                                                  : rlg_fixed_update(&fone, t, g, &out[0]);
            put(&out[0]);
        } else {
            float temps[3] = {t, t, t};
            float gyros[3] = {g, g + 0.5f, g + 1.0f};
            e = strcmp(mode, "axes") == 0 ? rlg_update_axes(three, 3, temps, gyros, out)
                                          : rlg_fixed_update_axes(fthree, 3, temps, gyros, out);
            for (int a = 0; a < 3; a++) put(&out[a]);
        }
        if (e != RLG_OK) {
            fprintf(stderr, "update %u: %d\n", k, (int)e);
            return 3;
        }
    }
    return 0;
}
