/* Drives the README's example ("Using the compensator from C", extracted by the test into
 * readme_example.c) over a replay file: three axes, axis k seeing the gyro rate plus k * 0.5
 * deg/h; writes each axis's output rate bits (little-endian u32) per sample. */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "readme_example.c"

int main(int argc, char **argv) {
    if (argc != 2) return 64;
    FILE *f = fopen(argv[1], "rb");
    if (!f) return 66;
    static unsigned char buf[1 << 20];
    size_t len = fread(buf, 1, sizeof buf, f);
    fclose(f);
    uint32_t count;
    memcpy(&count, buf + 8, 4);
    if (len != 12 + 8 * (size_t)count) return 65;
    if (compensator_boot() != 0) return 2;
    for (uint32_t k = 0; k < count; k++) {
        float t, g, rate[3];
        memcpy(&t, buf + 12 + 8 * (size_t)k, 4);
        memcpy(&g, buf + 16 + 8 * (size_t)k, 4);
        const float temps[3] = {t, t, t};
        const float gyros[3] = {g, g + 0.5f, g + 1.0f};
        compensator_tick(temps, gyros, rate);
        fwrite(rate, sizeof rate, 1, stdout);
    }
    return 0;
}
