/* SPDX-License-Identifier: MIT */
/**
 * @file hal_motor.h
 * @brief Motor service of the HAL: the two wheel outputs of a board.
 *
 * A board drives each wheel's motor driver with a PWM duty cycle and a
 * direction (sign-magnitude): the command is a fraction of full drive, not
 * a speed. The board's wheel loop (firmware/wheel/whl.h) turns the control
 * step's wheel speeds into commands on its encoders' counts; a board without
 * encoders drives open loop, speed / wheel_free_speed (docs/porting.md).
 * Why PWM rather than a CAN frame to a motor driver: the control step
 * already puts WHEEL_CMD on the bus, which a CAN motor driver can follow
 * directly; what the bus cannot do is drive an H-bridge.
 *
 * Host ports (linux, sil, fake) need no motor: their plant reads WHEEL_CMD.
 * Plain types only.
 */
#ifndef HAL_MOTOR_H
#define HAL_MOTOR_H

#include <stdint.h>

/** @brief Full drive: a command of ±HAL_MOTOR_FULL_SCALE is 100 % duty. */
#define HAL_MOTOR_FULL_SCALE 10000

/**
 * @brief Set up the outputs, driver disabled and duty 0 (the state after
 *        reset too, through the board's pull-downs).
 * @retval 0 ready. @retval -ENODEV this port has no motor outputs.
 * Task context; does not block.
 */
int hal_motor_init(void);

/**
 * @brief Command both wheels and enable the driver.
 * @param left  left wheel, -HAL_MOTOR_FULL_SCALE..HAL_MOTOR_FULL_SCALE
 *              (clamped); positive drives the robot forward, 0 is no drive.
 * @param right right wheel, same range and sign.
 * @retval 0 applied (from the next PWM period on).
 * @retval -ENODEV hal_motor_init() has not succeeded.
 * Task context; does not block.
 */
int hal_motor_set(int16_t left, int16_t right);

/**
 * @brief Stop driving at once: duty 0 and driver disabled, until the next
 *        hal_motor_set(). For faults: safe to call from any context,
 *        including a fault handler; never blocks.
 */
void hal_motor_stop(void);

#endif /* HAL_MOTOR_H */
