/* SPDX-License-Identifier: MIT */
/* Reset and vector table of the benchmark images for QEMU's mps2 boards
 * (link.ld). Reset enables the FPU when the image is built for one, then
 * hands over to newlib's crt0 (_start: .bss, semihosting, main, exit). A
 * fault ends QEMU through semihosting with a failure status instead of
 * hanging. */
#include <stdint.h>

extern uint32_t __stack_top;
extern void _start(void);

void Reset_Handler(void);
void Fault_Handler(void);

/* Semihosting SYS_EXIT with ADP_Stopped_RunTimeError. */
void Fault_Handler(void)
{
    __asm volatile("mov r0, #0x18\n\t"
                   "ldr r1, =0x20023\n\t"
                   "bkpt 0xab" ::
                       : "r0", "r1", "memory");
    for (;;) {
    }
}

void Reset_Handler(void)
{
#if defined(__ARM_FP)
    /* CPACR: full access to CP10 and CP11 (the FPU), before any FP code. */
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
    __asm volatile("dsb\n\tisb" ::: "memory");
#endif
    _start();
    for (;;) {
    }
}

__attribute__((section(".vectors"), used)) static const uintptr_t vectors[16] = {
    (uintptr_t)&__stack_top,  /* initial SP */
    (uintptr_t)Reset_Handler, /* reset */
    (uintptr_t)Fault_Handler, /* NMI */
    (uintptr_t)Fault_Handler, /* HardFault */
    (uintptr_t)Fault_Handler, /* MemManage */
    (uintptr_t)Fault_Handler, /* BusFault */
    (uintptr_t)Fault_Handler, /* UsageFault */
    0,
    0,
    0,
    0,
    (uintptr_t)Fault_Handler, /* SVCall */
    (uintptr_t)Fault_Handler, /* DebugMonitor */
    0,
    (uintptr_t)Fault_Handler, /* PendSV */
    (uintptr_t)Fault_Handler, /* SysTick (its interrupt stays disabled) */
};
