/* SPDX-License-Identifier: MIT */
/* Processor in the loop: hal_encoder and hal_motor over two DC motor models
 * (sim/dcmotor/dcm.h) in place of the timers, so that under QEMU, which
 * counts no encoder edges, the wheel loop closes on the image's own PWM
 * commands: the counts it reads come from motors its drives turn, on the
 * target CPU, at its own rate (docs/hil.md, "The wheels in the loop").
 *
 * Linked instead of encoder.c and motor_pwm.c into the PIL images only
 * (build/firmware/<board>-pil, mk/firmware.mk; `make pil`), never into an
 * image that is flashed: a board's motors are real. The motors' time is the
 * wheel loop's: each encoder read moves them on by one loop period
 * (stm32_wheels_period()) under the drives the previous period set, as the
 * simulation's wheels do (hal/sil/mstc_sil_wheel.c); hal_motor_stop() opens
 * the windings (dcm_coast()). The model is double precision, the firmware's
 * cost is not: its cycles are counted apart (stm32_wheels_model_cycles()).
 *
 * stm32_pil_trace holds each wheel's true speed at the first
 * STM32_PIL_TRACE_N periods of lock-step, for the harness to compare the
 * loop's response with the simulation's (mstc hil --qemu). */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>

#include "dcm.h"
#include "hal/hal_encoder.h"
#include "hal/hal_motor.h"
#include "stm32_hal.h"

static dcm_params_t mp;
static dcm_t motor[2];
static int16_t cmd[2]; /* the commands in force (hal_motor_set()) */
static bool enabled;   /* the driver: false, the windings open */
static bool ready;
static uint32_t period_us; /* the wheel loop's, set by the main loop */
static uint32_t model_cycles;
static bool tracing; /* lock-step: the trace fills */

volatile stm32_pil_trace_t stm32_pil_trace;

int hal_motor_init(void)
{
    dcm_params_default(&mp);
    dcm_init(&motor[0]);
    dcm_init(&motor[1]);
    cmd[0] = cmd[1] = 0;
    enabled = false;
    ready = true;
    return 0;
}

int hal_motor_set(int16_t left, int16_t right)
{
    if (!ready) {
        return -ENODEV;
    }
    /* Kept as they come: the model's arithmetic is in its own cycles. */
    cmd[0] = left;
    cmd[1] = right;
    enabled = true;
    return 0;
}

void hal_motor_stop(void)
{
    enabled = false;
    cmd[0] = cmd[1] = 0;
}

int hal_encoder_init(void) { return 0; }

uint8_t hal_encoder_overran(void) { return 0u; } /* a model's counts are exact */

/* Speed [rad/s] as the trace holds it: 1/512 rad/s, rounded, saturated. */
static int16_t trace_speed(double w)
{
    const double s = w * STM32_PIL_TRACE_SCALE;
    if (s >= 32767.0) {
        return 32767;
    }
    if (s <= -32768.0) {
        return -32768;
    }
    return (int16_t)(s >= 0.0 ? (int32_t)(s + 0.5) : -(int32_t)(0.5 - s));
}

int hal_encoder_read(int32_t *left, int32_t *right)
{
    const uint32_t c0 = stm32_time_cycles();
    const double dt = (double)period_us * 1e-6;
    for (unsigned i = 0; i < 2u; i++) {
        if (enabled) {
            dcm_step(&motor[i], &mp, (double)cmd[i] / HAL_MOTOR_FULL_SCALE, dt);
        } else {
            dcm_coast(&motor[i], &mp, dt);
        }
    }
    volatile stm32_pil_trace_t *t = &stm32_pil_trace;
    if (tracing && t->n < STM32_PIL_TRACE_N) {
        t->speed[t->n][0] = trace_speed(motor[0].omega);
        t->speed[t->n][1] = trace_speed(motor[1].omega);
        t->n = t->n + 1u;
    }
    *left = dcm_count(&motor[0], &mp);
    *right = dcm_count(&motor[1], &mp);
    model_cycles = stm32_time_cycles() - c0;
    return 0;
}

bool stm32_wheels_period(uint32_t us)
{
    period_us = us;
    return true;
}

void stm32_wheels_lockstep(void) { tracing = true; }

uint32_t stm32_wheels_model_cycles(void) { return model_cycles; }
