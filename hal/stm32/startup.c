/* SPDX-License-Identifier: MIT */
/* Start-up of the STM32 ports: reset handler and the fault path. */
#include "startup.h"

#include "cortex_m.h"
#include "hal/hal_motor.h"

void Reset_Handler(void)
{
#if defined(__ARM_FP)
    /* The M4F's FPU is off after reset; the first float instruction would
     * fault. Enable it before any code (or .data copy) can use it
     * (ARMv7-M ARM B3.2.20; ARM's Cortex-M4 TRM §7.1.2). */
    CM_SCB_CPACR |= CM_CPACR_CP10_CP11_FULL;
    cm_dsb();
    cm_isb();
#endif
    const uint32_t *src = &__data_load__;
    for (uint32_t *dst = &__data_start__; dst < &__data_end__;) {
        *dst++ = *src++;
    }
    for (uint32_t *dst = &__bss_start__; dst < &__bss_end__;) {
        *dst++ = 0u;
    }
    /* Booting from flash aliases it at 0, so the table is found either way;
     * VTOR makes that explicit (and right under a bootloader). */
    CM_SCB_VTOR = (uint32_t)(uintptr_t)&stm32_vectors;
    (void)main();
    for (;;) {
    }
}

/* A fault, or an interrupt enabled without a handler. The wheels must not
 * keep their last command: stop them, then spin until the independent
 * watchdog resets the MCU (a debugger attached here sees the faulting state;
 * before the watchdog is started this waits for one). */
void stm32_unhandled(void)
{
    hal_motor_stop();
    for (;;) {
    }
}
