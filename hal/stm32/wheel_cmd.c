/* SPDX-License-Identifier: MIT */
/* Wheel speed to motor command (see wheel_cmd.h). */
#include "wheel_cmd.h"

#include <errno.h>

#include "hal/hal_encoder.h"
#include "hal/hal_motor.h"

int16_t wheel_cmd_from_speed(num_t speed, num_t max_speed)
{
    if (!(max_speed > NUM_ZERO)) {
        return 0;
    }
    /* In float: no NaN survives the comparisons below (each is false for
     * NaN, so it falls through to 0). Once a ratio per 50 Hz step, the float
     * arithmetic costs nothing worth a fixed-point path on the F1. */
    const float ratio = num_to_float(speed) / num_to_float(max_speed);
    const float full = (float)HAL_MOTOR_FULL_SCALE;
    if (ratio >= 1.0f) {
        return (int16_t)HAL_MOTOR_FULL_SCALE;
    }
    if (ratio <= -1.0f) {
        return (int16_t)-HAL_MOTOR_FULL_SCALE;
    }
    if (ratio > 0.0f) {
        return (int16_t)(ratio * full + 0.5f);
    }
    if (ratio < 0.0f) {
        return (int16_t)(ratio * full - 0.5f);
    }
    return 0;
}

int wheel_cmd_period(whl_t *w, num_t left, num_t right, whl_output_t *out)
{
    int32_t count[2];
    const int rc = hal_encoder_read(&count[0], &count[1]);
    if (rc == -ENODEV) {
        const int16_t l = wheel_cmd_from_speed(left, w->p.free_speed);
        const int16_t r = wheel_cmd_from_speed(right, w->p.free_speed);
        *out = (whl_output_t){ .cmd = { l, r } };
        (void)hal_motor_set(l, r);
        return -ENODEV;
    }
    if (rc != 0) {
        /* A counter moved too far to be read (-ERANGE): that wheel's
         * encoder fault, which stops both (whl.h). */
        const uint8_t bad = hal_encoder_overran();
        whl_latch_faults(w, (uint8_t)(((bad & 1u) != 0u ? WHL_FAULT_ENCODER_LEFT : 0u) |
                                      ((bad & 2u) != 0u ? WHL_FAULT_ENCODER_RIGHT : 0u)));
    }
    const whl_input_t in = { { left, right }, { count[0], count[1] } };
    whl_step(w, &in, out);
    if (out->faults != 0u) {
        hal_motor_stop();
    } else {
        (void)hal_motor_set(out->cmd[0], out->cmd[1]);
    }
    return 0;
}
