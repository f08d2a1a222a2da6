/* SPDX-License-Identifier: MIT */
/**
 * @file hal_encoder.h
 * @brief Encoder service of the HAL: each wheel's quadrature encoder, read as
 *        a signed running count, for the wheel loop (firmware/wheel/whl.h).
 *
 * A count is one edge of either channel (×4 quadrature): 1,920 a wheel
 * revolution for a 64 CPR encoder on the motor of a 30:1 gearbox. Positive
 * when the wheel turns the robot forward (a port swaps the channels, or
 * inverts one, where the wiring counts the other way). The running count
 * starts at 0 at hal_encoder_init() and wraps modulo 2^32, which the wheel
 * loop's differences survive.
 *
 * Counters in hardware are narrower (16 bits on most MCU timers): a port
 * extends them in hal_encoder_read() by adding the signed difference since
 * the previous read, so it must be called before either wheel has moved
 * HAL_ENCODER_MAX_STEP counts since (docs/porting.md gives the bound in
 * time for the STM32 boards). The wheel loop reads every period (1 ms). A
 * counter that did move that far is not read as a motion (past half its
 * range the difference would even come out the other way): the read says so
 * (-ERANGE, hal_encoder_overran()) and the wheel loop stops the motors with
 * that wheel's encoder fault.
 *
 * A port without encoders (the host ports, the blank template) returns
 * -ENODEV from both functions, and zero counts; the board then drives its
 * motors open loop (docs/porting.md). Plain types only.
 */
#ifndef HAL_ENCODER_H
#define HAL_ENCODER_H

#include <stdint.h>

/** @brief Largest motion between two reads [counts] of a 16-bit counter
 *         that is taken: a quarter of its range, so that a motion past half
 *         of it, which its difference would read as one the other way, is
 *         caught (up to three quarters of the range; docs/porting.md). */
#define HAL_ENCODER_MAX_STEP 16383

/**
 * @brief Set up both encoders; their running counts start at 0.
 * @retval 0 ready. @retval -ENODEV this port has no encoders.
 * Task context; does not block.
 */
int hal_encoder_init(void);

/**
 * @brief Each wheel's running count now.
 * @param[out] left  left wheel's count.
 * @param[out] right right wheel's count.
 * @retval 0 read. @retval -ENODEV no encoders (hal_encoder_init() failed or
 *         was not called): both counts 0.
 * @retval -ERANGE a counter moved more than HAL_ENCODER_MAX_STEP counts (of
 *         its width's: a quarter of its range) since the last read: that
 *         wheel's count is left as it was (hal_encoder_overran() says which);
 *         the other's is read.
 * Task context (one caller: the wheel loop); does not block. Must be called
 * at least once per HAL_ENCODER_MAX_STEP counts of either wheel.
 */
int hal_encoder_read(int32_t *left, int32_t *right);

/**
 * @brief The wheels whose counter moved too far at the last
 *        hal_encoder_read() (which returned -ERANGE): bit 0 left, bit 1 right.
 * Task context; does not block.
 */
uint8_t hal_encoder_overran(void);

#endif /* HAL_ENCODER_H */
