/* SPDX-License-Identifier: MIT */
/**
 * @file hal_sys.h
 * @brief System service of the HAL: watchdog and reset cause.
 */
#ifndef HAL_SYS_H
#define HAL_SYS_H

#include <stdint.h>

/** @brief Why the MCU last started. */
typedef enum {
    HAL_RESET_POWER_ON = 0,
    HAL_RESET_WATCHDOG = 1,
    HAL_RESET_SOFTWARE = 2,
    HAL_RESET_PIN = 3,
    HAL_RESET_OTHER = 4,
} hal_reset_cause_t;

/**
 * @brief Start the watchdog with a timeout.
 * @retval 0 started. @retval -ENOTSUP no watchdog on this port (host ports).
 * Task context.
 */
int hal_sys_watchdog_start(uint32_t timeout_ms);

/** @brief Kick the watchdog. ISR or task context; never blocks. */
void hal_sys_watchdog_kick(void);

/** @brief Cause of the last reset. Task context. */
hal_reset_cause_t hal_sys_reset_cause(void);

#endif /* HAL_SYS_H */
