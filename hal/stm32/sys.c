/* SPDX-License-Identifier: MIT */
/* HAL system service on the STM32 ports: the independent watchdog (IWDG,
 * RM0090 §21, RM0008 §19; the same IP on the F1 and F4) and the reset cause. */
#include <errno.h>

#include "board.h"
#include "hal/hal_sys.h"
#include "stm32_calc.h"

/* IWDG_KR keys (RM0090 §21.4.1). */
#define KEY_RELOAD 0xAAAAu
#define KEY_ACCESS 0x5555u
#define KEY_START  0xCCCCu

/* Bounded wait for the prescaler and reload to reach the LSI domain: up to 5
 * LSI periods after each write (~160 µs); a loop count keeps this free of
 * the clock, which it may be asked to watch over. */
#define SR_SPINS 200000u

int hal_sys_watchdog_start(uint32_t timeout_ms)
{
    stm32_iwdg_t cfg;
    if (stm32_iwdg_config(timeout_ms, BOARD_LSI_HZ, &cfg) != 0) {
        return -EINVAL;
    }
    /* Starting it also starts the LSI. From here on it cannot be stopped
     * except by a reset. */
    IWDG->KR = KEY_START;
    IWDG->KR = KEY_ACCESS;
    IWDG->PR = cfg.pr;
    IWDG->RLR = cfg.rlr;
    for (uint32_t i = 0; i < SR_SPINS && IWDG->SR != 0u; i++) {
    }
    IWDG->KR = KEY_RELOAD;
    return 0;
}

void hal_sys_watchdog_kick(void) { IWDG->KR = KEY_RELOAD; }

hal_reset_cause_t hal_sys_reset_cause(void) { return stm32_reset_cause(board_reset_flags()); }

/* hal_sys_boot_nonce(): in each board's board.c (a TRNG, or a counter). */
