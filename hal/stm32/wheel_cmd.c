/* SPDX-License-Identifier: MIT */
/* Wheel speed to motor command (see wheel_cmd.h). */
#include "wheel_cmd.h"

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
