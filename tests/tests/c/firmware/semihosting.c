#include "semihosting.h"

static int call(int op, void *arg) {
    register int r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

/* ":tt" opened for writing is the host's stdout (mode 4), for appending its stderr (mode 8). */
static int open_tt(int mode) {
    uint32_t block[3] = {(uint32_t)(uintptr_t)":tt", (uint32_t)mode, 3};
    return call(0x01, block);
}

static int write_handle(int handle, const void *buf, size_t len) {
    uint32_t block[3] = {(uint32_t)handle, (uint32_t)(uintptr_t)buf, (uint32_t)len};
    return call(0x05, block);
}

void sh_log(const char *s) {
    static int out = -1;
    if (out < 0) out = open_tt(4);
    size_t n = 0;
    while (s[n]) n++;
    write_handle(out, s, n);
}

int sh_err_write(const void *buf, size_t len) {
    static int err = -1;
    if (err < 0) err = open_tt(8);
    return write_handle(err, buf, len);
}

void sh_exit(int success) {
    /* ADP_Stopped_ApplicationExit: exit code 0; ADP_Stopped_RunTimeErrorUnknown: 1. */
    for (;;) call(0x18, (void *)(uintptr_t)(success ? 0x20026u : 0x20023u));
}
