/* SPDX-License-Identifier: MIT */
/**
 * @file board.h
 * @brief What each STM32 board (hal/stm32f405, hal/stm32f103) provides to the
 *        shared STM32 code (hal/stm32): the parts that differ between the F1
 *        and F4 families (RCC, GPIO, flash wait states) behind a few
 *        functions, and its pin and peripheral choices as macros in its own
 *        board_config.h.
 *
 * Called from the main loop's start-up, in this order: board_clock_init(),
 * board_gpio_init(), then the drivers enable their peripherals through
 * board_can_enable() (bxCAN) or board_slcan_enable() (slcan),
 * board_timers_enable() and board_encoder_enable().
 */
#ifndef STM32_BOARD_H
#define STM32_BOARD_H

#include <stdbool.h>
#include <stdint.h>

#include "board_config.h"

/** @brief Clock tree in force. */
typedef struct {
    uint32_t sysclk_hz;   /**< core (HCLK = SYSCLK) */
    uint32_t apb1_hz;     /**< APB1: bxCAN, IWDG interface, TIM2..TIM7 bus */
    uint32_t apb1_tim_hz; /**< TIM2..TIM7 kernel clock: 2 × APB1 when APB1 is divided */
    bool hse;             /**< true: from the crystal via the PLL; false: the HSE
                               did not start and the clock is the internal RC */
} board_clocks_t;

/**
 * @brief Clock tree at the datasheet maximum from the HSE crystal, flash wait
 *        states first. When the HSE does not start within its time-out, stay
 *        on the internal RC oscillator (HSI) and say so in hse = false: the
 *        firmware still runs, and CAN bit timing is computed from the clock
 *        in force (but HSI's 1 % is outside CAN's oscillator tolerance at
 *        1 Mbit/s: expect errors).
 * Runs before anything else, interrupts masked; blocks up to a few ms.
 */
void board_clock_init(void);

/** @brief The clock tree set by board_clock_init(). */
const board_clocks_t *board_clocks(void);

/** @brief GPIO: LED off, motor pins at their safe levels (driver disabled,
 *         PWM low) before their alternate functions, CAN pins. */
void board_gpio_init(void);

/** @brief Clock (and, on the F1, pin remap) of the CAN controller. */
void board_can_enable(void);

/** @brief Clock and pins of the slcan UART (board_config.h: BOARD_SLCAN_UART,
 *         USART2 on PA2/PA3): the slcan transport's board_can_enable(). */
void board_slcan_enable(void);

/** @brief Clocks of the control-period and PWM timers. */
void board_timers_enable(void);

/** @brief Clocks of the encoder timers (BOARD_ENC_*_TIM) and their pins, as
 *         inputs with pull-ups. */
void board_encoder_enable(void);

/** @brief Status LED on or off. ISR or task; never blocks. */
void board_led(bool on);

/** @brief Direction pin of wheel @p wheel (0 left, 1 right): true = forward. */
void board_motor_dir(unsigned wheel, bool forward);

/** @brief Driver enable pin. */
void board_motor_enable(bool on);

/** @brief RCC_CSR as it was at reset; clears the flags (RMVF) on the first
 *         call and returns the same value afterwards. */
uint32_t board_reset_flags(void);

/** @brief Freeze the watchdog and timers while a debugger halts the core, and
 *         keep the debug port alive in sleep (DBGMCU). */
void board_debug_init(void);

#endif /* STM32_BOARD_H */
