/* SPDX-License-Identifier: MIT */
/**
 * @file wheel_cmd.h
 * @brief Wheel speed [rad/s] to the motors: the glue between the control
 *        step's wheel speeds, the wheel loop (firmware/wheel/whl.h) and the
 *        HAL's encoders and motor outputs. Both numeric modes; unit-tested
 *        on the host against hal/fake (tests/unit/test_stm32_calc.c).
 */
#ifndef STM32_WHEEL_CMD_H
#define STM32_WHEEL_CMD_H

#include <stdint.h>

#include "num/num.h"
#include "wheel/whl.h"

/**
 * @brief One period of the wheel loop on the board's own encoders and motor
 *        outputs: hal_encoder_read(), whl_step() towards @p left and
 *        @p right [rad/s], then hal_motor_set() with its commands, or
 *        hal_motor_stop() while the loop has a fault (driver disabled).
 *        Without encoders (hal_encoder_read() answers -ENODEV) the motors
 *        are driven open loop on the feed-forward alone,
 *        wheel_cmd_from_speed(speed, free_speed), and @p out holds those
 *        commands, no speeds and no faults. A counter that moved too far to
 *        be read (hal_encoder_read()'s -ERANGE) is that wheel's encoder
 *        fault (whl_latch_faults()): the motors stop.
 * @retval 0 closed loop. @retval -ENODEV open loop: no encoders.
 * Task context (the main loop), once per wheel period.
 */
int wheel_cmd_period(whl_t *w, num_t left, num_t right, whl_output_t *out);

/**
 * @brief Open-loop command for wheel speed @p speed:
 *        round(speed / max_speed · HAL_MOTOR_FULL_SCALE), clamped to
 *        ±HAL_MOTOR_FULL_SCALE. max_speed <= 0 or a non-finite ratio gives 0.
 * @param speed wheel angular speed [rad/s], positive forward.
 * @param max_speed the speed the wheel reaches at full drive [rad/s].
 */
int16_t wheel_cmd_from_speed(num_t speed, num_t max_speed);

#endif /* STM32_WHEEL_CMD_H */
