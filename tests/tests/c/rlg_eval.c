/* Reference C evaluator of the exported table (Yu et al. 2011, Eq. 10), for readout boards
 * whose firmware is C. Include the generated header (rlg_model_table.h) and call
 * rlg_predict_dph() with the raw features (clamped to the trained range here) and
 * rlg_table_crc32() once at boot, comparing with rlg_crc32.
 *
 * Test driver (when compiled with -DRLG_EVAL_MAIN): prints "crc <computed> <stored>", then
 * reads lines of D raw feature values from stdin and prints f(x) in deg/h with 9 significant
 * digits, one per line. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rlg_model_table.h"

/* Eq. (10) in float with compensated (Neumaier) summation, plus the linear terms. */
float rlg_predict_dph(const float x_raw[RLG_D]) {
    float z[RLG_D];
    float linear = 0.0f;
    for (int d = 0; d < RLG_D; d++) {
        float x = x_raw[d];
        if (!(x >= rlg_input_lo[d])) x = rlg_input_lo[d]; /* also catches NaN */
        if (x > rlg_input_hi[d]) x = rlg_input_hi[d];
        z[d] = (x - rlg_input_mean[d]) * rlg_input_inv_scale[d];
        linear += rlg_linear_dph[d] * (x - rlg_input_mean[d]);
    }
    float sum = 0.0f, carry = 0.0f;
    for (int i = 0; i < RLG_N; i++) {
        float d2 = 0.0f;
        for (int d = 0; d < RLG_D; d++) {
            float diff = z[d] - rlg_support[i][d];
            d2 += diff * diff;
        }
        float term = rlg_alpha_dph[i] * expf(-rlg_gamma * d2);
        float t = sum + term;
        if (fabsf(sum) >= fabsf(term)) carry += (sum - t) + term;
        else carry += (term - t) + sum;
        sum = t;
    }
    return sum + carry + rlg_bias_dph + linear;
}

/* Bitwise CRC-32/ISO-HDLC (reflected 0xEDB88320). */
static uint32_t crc_u32(uint32_t c, uint32_t v) {
    for (int b = 0; b < 4; b++) {
        c ^= (v >> (8 * b)) & 0xffu;
        for (int k = 0; k < 8; k++) c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
    }
    return c;
}

static uint32_t bits(float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* The CRC over the stream defined in compensator_core::crc. */
uint32_t rlg_table_crc32(void) {
    uint32_t c = 0xFFFFFFFFu;
    c = crc_u32(c, RLG_N);
    c = crc_u32(c, RLG_D);
    for (int d = 0; d < RLG_D; d++) {
        c = crc_u32(c, rlg_feature_code[d]);
        if (rlg_feature_has_param[d]) c = crc_u32(c, rlg_feature_param[d]);
    }
    const float *vecs[5] = {rlg_input_mean, rlg_input_inv_scale, rlg_linear_dph, rlg_input_lo,
                            rlg_input_hi};
    for (int v = 0; v < 5; v++)
        for (int d = 0; d < RLG_D; d++) c = crc_u32(c, bits(vecs[v][d]));
    c = crc_u32(c, bits(rlg_gamma));
    c = crc_u32(c, bits(rlg_bias_dph));
    c = crc_u32(c, bits(rlg_reference_dph));
    c = crc_u32(c, bits(rlg_rate_alpha));
    c = crc_u32(c, bits(rlg_rate_beta));
    c = crc_u32(c, bits(rlg_rate_dt_s));
    c = crc_u32(c, rlg_rate_warmup_samples);
    for (int i = 0; i < RLG_N; i++)
        for (int d = 0; d < RLG_D; d++) c = crc_u32(c, bits(rlg_support[i][d]));
    for (int i = 0; i < RLG_N; i++) c = crc_u32(c, bits(rlg_alpha_dph[i]));
    return ~c;
}

#ifdef RLG_EVAL_MAIN
int main(void) {
    printf("crc %u %u\n", (unsigned)rlg_table_crc32(), (unsigned)rlg_crc32);
    float x[RLG_D];
    for (;;) {
        for (int d = 0; d < RLG_D; d++)
            if (scanf("%f", &x[d]) != 1) return 0;
        printf("%.9e\n", (double)rlg_predict_dph(x));
    }
}
#endif
