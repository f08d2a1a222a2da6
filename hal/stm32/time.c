/* SPDX-License-Identifier: MIT */
/* HAL time on the STM32 ports: SysTick at 1 kHz from the core clock, read to
 * the microsecond. The same code runs on any ARMv7-M core. */
#include <stdint.h>

#include "board.h"
#include "cortex_m.h"
#include "hal/hal_time.h"
#include "stm32_calc.h"
#include "stm32_hal.h"

static volatile uint64_t ms_count; /* written by SysTick_Handler only */
static uint32_t reload;
static uint32_t cycles_per_us;

void stm32_time_init(uint32_t sysclk_hz)
{
    reload = stm32_systick_reload(sysclk_hz);
    cycles_per_us = sysclk_hz / 1000000u;
    CM_SYST_CSR = 0u;
    CM_SYST_RVR = reload;
    CM_SYST_CVR = 0u;
    /* Lowest priority: a late tick only delays a wake-up, and now_us()
     * accounts for a tick that is pending. */
    CM_SCB_SHPR3 = (CM_SCB_SHPR3 & 0x00FFFFFFu) | (0xF0u << 24);
    CM_SYST_CSR = CM_SYST_CSR_CLKSOURCE | CM_SYST_CSR_TICKINT | CM_SYST_CSR_ENABLE;
}

void SysTick_Handler(void) { ms_count = ms_count + 1u; }

/* Milliseconds and SysTick counts into the current one, read as one. */
static uint32_t now_counts(uint64_t *ms)
{
    /* With interrupts masked the count and the counter are read as one; if
     * the counter wrapped but the tick is not yet handled (PENDSTSET, as in
     * an ISR of equal or higher priority), count it here and re-read the
     * counter, which now belongs to the new millisecond. */
    const uint32_t primask = cm_irq_save();
    uint64_t m = ms_count;
    uint32_t val = CM_SYST_CVR;
    if ((CM_SCB_ICSR & CM_ICSR_PENDSTSET) != 0u) {
        m++;
        val = CM_SYST_CVR;
    }
    cm_irq_restore(primask);
    *ms = m;
    return reload - val; /* counts down from reload */
}

uint64_t hal_time_now_us(void)
{
    uint64_t ms;
    const uint32_t elapsed = now_counts(&ms);
    return ms * 1000u + (cycles_per_us != 0u ? elapsed / cycles_per_us : 0u);
}

uint32_t stm32_time_cycles(void)
{
    uint64_t ms;
    const uint32_t elapsed = now_counts(&ms);
    return (uint32_t)(ms * (reload + 1u)) + elapsed;
}

void hal_time_sleep_until_us(uint64_t t_us)
{
    /* SysTick wakes the core every millisecond at least. */
    while (hal_time_now_us() < t_us) {
        cm_wfi();
    }
}
