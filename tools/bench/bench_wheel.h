/* SPDX-License-Identifier: MIT */
/**
 * @file bench_wheel.h
 * @brief The wheel loop's benchmark (make bench): whl_step for both wheels
 *        against two DC motor models (sim/dcmotor/dcm.h) at 1 kHz, the default
 *        motor and parameters with docs/wheel.md's ramp, through a start, a
 *        turn under a 30 %-of-stall load, a reversal and a stop, recorded
 *        once, then replayed through whl_step alone and timed (bench_target.c
 *        counts the instructions under qemu -icount).
 */
#ifndef MSTC_BENCH_WHEEL_H
#define MSTC_BENCH_WHEEL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ctrl/ctl.h"
#include "wheel/whl.h"

/** @brief Periods recorded: 3 s at 1 kHz. */
#define BENCH_WHEEL_PERIODS 3000u

/** @brief One recorded period: the step's input and the commands it gave. */
typedef struct {
    whl_input_t in;
    int16_t cmd[2];
} bench_wheel_period_t;

/** @brief The benchmark's parameters into @p p. @return its setpoint ramp
 *         (wheel_accel) [rad/s²]. */
num_t bench_wheel_params(whl_params_t *p);

/** @brief Record @p n periods of the closed loop. @return @p n. */
size_t bench_wheel_record(bench_wheel_period_t *rec, size_t n);

/** @brief Replay and compare the commands. @return periods that differ (0). */
size_t bench_wheel_verify(const bench_wheel_period_t *rec, size_t n);

/**
 * @brief Replay, timing each period with @p ticks: whl_step, or (@p empty)
 *        the same loop around a step that does nothing.
 * @param[out] total sum of the periods' ticks. @param[out] largest the largest.
 */
void bench_wheel_replay(const bench_wheel_period_t *rec, size_t n, bool empty,
                        uint64_t (*ticks)(void), uint64_t *total, uint64_t *largest);

#endif /* MSTC_BENCH_WHEEL_H */
