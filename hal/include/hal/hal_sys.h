/* SPDX-License-Identifier: MIT */
/**
 * @file hal_sys.h
 * @brief System service of the HAL: watchdog, reset cause, and a value that
 *        tells this start from every other (the authenticated commands'
 *        session, docs/safety.md "Sessions").
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

/**
 * @brief A value for this start of the device: from a random source
 *        (unpredictable), or a counter kept across resets (never the same
 *        twice while it is kept). Each call gives a new one. What each port
 *        uses, and what that guarantees, is in docs/safety.md ("Sessions").
 * @param[out] nonce the value.
 * @retval 0 a value. @retval -EIO the source failed (a TRNG that never became
 *         ready). @retval -ENOTSUP no source on this port.
 * Task context; may wait a few microseconds (a TRNG's first value), never blocks.
 */
int hal_sys_boot_nonce(uint32_t *nonce);

#endif /* HAL_SYS_H */
