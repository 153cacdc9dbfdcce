/* Semihosting (Arm's host I/O through `bkpt 0xAB`, served by QEMU): text on the host's stdout,
 * the sample stream on its stderr, and the exit code. */
#ifndef RLG_SEMIHOSTING_H
#define RLG_SEMIHOSTING_H
#include <stddef.h>
#include <stdint.h>

/* Writes a NUL-terminated string to the host's stdout. */
void sh_log(const char *s);
/* Writes `len` bytes to the host's stderr; 0 if all were taken. */
int sh_err_write(const void *buf, size_t len);
/* Ends the program: exit code 0 when `success`, 1 otherwise. */
__attribute__((noreturn)) void sh_exit(int success);
#endif
