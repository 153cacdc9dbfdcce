/* Start-up of the C firmware image: vector table, reset (data copy, bss clear, FPU enable on
 * the Cortex-M4F build), and exits through semihosting so that QEMU never hangs. */
#include <stdint.h>

#include "semihosting.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _stack_top;
int main(void);

void Reset_Handler(void) {
    uint32_t *src = &_sidata, *dst = &_sdata;
    while (dst < &_edata) *dst++ = *src++;
    for (dst = &_sbss; dst < &_ebss; dst++) *dst = 0;
#if defined(__ARM_FP)
    /* CP10 and CP11 full access (the hard-float code uses the FPU from here on). */
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
    __asm__ volatile("dsb\n isb" ::: "memory");
#endif
    sh_exit(main() == 0);
}

/* HardFault, and every other exception: say so and exit with failure. */
void Fault_Handler(void) {
    sh_log("HardFault or unexpected exception\n");
    sh_exit(0);
}

__attribute__((section(".vector_table"), used)) static const void *const vectors[16] = {
    &_stack_top,   Reset_Handler, Fault_Handler, Fault_Handler, Fault_Handler, Fault_Handler,
    Fault_Handler, 0,             0,             0,             0,             Fault_Handler,
    Fault_Handler, 0,             Fault_Handler, Fault_Handler,
};
