/* SPDX-License-Identifier: MIT */
/**
 * @file wheel_cmd.h
 * @brief Wheel speed [rad/s] to hal_motor command: the glue between the
 *        control step's output and hal_motor.h. Pure, in both numeric modes;
 *        unit-tested on the host (tests/unit/test_stm32_calc.c).
 */
#ifndef STM32_WHEEL_CMD_H
#define STM32_WHEEL_CMD_H

#include <stdint.h>

#include "num/num.h"

/**
 * @brief Open-loop command for wheel speed @p speed:
 *        round(speed / max_speed · HAL_MOTOR_FULL_SCALE), clamped to
 *        ±HAL_MOTOR_FULL_SCALE. max_speed <= 0 or a non-finite ratio gives 0.
 * @param speed wheel angular speed [rad/s], positive forward.
 * @param max_speed the controller's max_wheel_speed [rad/s]: the speed the
 *        wheel reaches at full drive.
 */
int16_t wheel_cmd_from_speed(num_t speed, num_t max_speed);

#endif /* STM32_WHEEL_CMD_H */
