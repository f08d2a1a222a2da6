/* SPDX-License-Identifier: MIT */
/**
 * @file hal_time.h
 * @brief Time service of the HAL: a monotonic microsecond clock and a wait.
 *
 * The control code never reads the clock: in lock-step the simulator's time
 * arrives in frames; in real-time mode the application loop (outside the
 * controllers) reads this clock and passes `now` in.
 */
#ifndef HAL_TIME_H
#define HAL_TIME_H

#include <stdint.h>

/** @brief Monotonic time since start [µs]. ISR or task context; never blocks. */
uint64_t hal_time_now_us(void);

/** @brief Sleep until the monotonic time reaches @p t_us (returns at once if
 *         past). Task context; blocks. */
void hal_time_sleep_until_us(uint64_t t_us);

#endif /* HAL_TIME_H */
