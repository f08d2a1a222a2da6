/* SPDX-License-Identifier: MIT */
/**
 * @file template.h
 * @brief The board-specific functions the template's main loop calls: what a
 *        port provides besides the HAL services (hal/stm32/board.h and
 *        stm32_hal.h are the STM32 boards' version of this).
 */
#ifndef TEMPLATE_H
#define TEMPLATE_H

#include <stdint.h>

/** @brief Clocks, flash wait states, GPIO at safe levels. First thing in main. */
void template_board_init(void);

/** @brief Start the control-period timer. @retval 0 started. */
int template_tick_start(uint32_t period_us);

/** @brief Control periods elapsed since the last call (0 when none). */
uint32_t template_tick_take(void);

/** @brief Sleep until an interrupt unless work is already waiting. */
void template_wait_for_event(void);

#endif /* TEMPLATE_H */
