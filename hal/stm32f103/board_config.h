/* SPDX-License-Identifier: MIT */
/**
 * @file board_config.h
 * @brief STM32F103 board: clocks, pins and peripheral choices. Edit the pin
 *        map here for another F103 board; the rest of the port follows.
 *
 * Target: STM32F103C8 (64 KB flash, 20 KB SRAM; LQFP48), as on the common
 * "blue pill" boards: 8 MHz crystal, LED on PC13 (active low). Clocked at
 * 72 MHz, the datasheet maximum. CAN on PB8/PB9 (remap 2): PA11/PA12 go to
 * the USB connector on those boards. Pins as on the F405 port where the
 * families allow:
 *
 *   signal         pin   function
 *   CAN_RX         PB8   input pull-up (CAN remap 2, RM0008 §9.3.3)
 *   CAN_TX         PB9   alternate push-pull
 *   PWM left       PA6   TIM3_CH1 (no remap), alternate push-pull
 *   PWM right      PA7   TIM3_CH2
 *   DIR left       PB0   output, high = forward
 *   DIR right      PB1   output, high = forward
 *   driver enable  PB12  output, high = enabled (fit a pull-down)
 *   status LED     PC13  output, low = on
 *   USART2_TX      PA2   alternate push-pull, slcan images only (CAN=slcan)
 *   USART2_RX      PA3   input pull-up, slcan images only
 *   encoder left   PB6   TIM4_CH1 (A, no remap), input pull-up
 *                  PB7   TIM4_CH2 (B)
 *   encoder right  PA8   TIM1_CH1 (A, no remap), input pull-up
 *                  PA9   TIM1_CH2 (B)
 */
#ifndef BOARD_CONFIG_H
#define BOARD_CONFIG_H

#include "stm32_regs.h"

#define BOARD_NAME "stm32f103"

/** @brief Crystal [Hz]. board.c's PLL settings assume 8 MHz. */
#define BOARD_HSE_HZ 8000000u
/** @brief LSI nominal frequency [Hz] (datasheet DS5319: 30..60 kHz). */
#define BOARD_LSI_HZ 40000u

/** @brief CAN bit rate [bit/s]: 500000 or 1000000 (any rate with an exact
 *         timing from 36 MHz works). */
#ifndef BOARD_CAN_BITRATE
#define BOARD_CAN_BITRATE 500000u
#endif
/** @brief Control period [µs]. */
#ifndef BOARD_CONTROL_PERIOD_US
#define BOARD_CONTROL_PERIOD_US 20000u
#endif
/** @brief Watchdog time-out [ms] at the nominal LSI: 5 control periods. At
 *         the fastest LSI (60 kHz) it is 67 ms, still over 3 periods. */
#ifndef BOARD_WATCHDOG_MS
#define BOARD_WATCHDOG_MS 100u
#endif
/** @brief Motor PWM frequency [Hz]: above hearing. */
#define BOARD_PWM_HZ 20000u

/* ST's F1 SVD names the controller CAN; the generator makes it CAN1. IRQ 19
 * and 20 are shared with USB (USB_HP_CAN_TX, USB_LP_CAN_RX0); USB is unused. */
#define BOARD_CAN                CAN1
#define BOARD_CAN_TX_IRQn        CAN1_TX_IRQn
#define BOARD_CAN_RX0_IRQn       CAN1_RX0_IRQn
#define BOARD_CAN_SCE_IRQn       CAN1_SCE_IRQn
#define BOARD_CAN_TX_IRQHandler  CAN1_TX_IRQHandler
#define BOARD_CAN_RX0_IRQHandler CAN1_RX0_IRQHandler
#define BOARD_CAN_SCE_IRQHandler CAN1_SCE_IRQHandler

#define BOARD_TICK_TIM        TIM2
#define BOARD_TICK_IRQn       TIM2_IRQn
#define BOARD_TICK_IRQHandler TIM2_IRQHandler

#define BOARD_PWM_TIM TIM3

/* Wheel encoders (hal/stm32/encoder.c): timers in encoder mode, ×4. The C8
 * has TIM1..TIM4 only, all 16 bits; TIM2 is the control tick and TIM3 the
 * PWM, so left on TIM4 and right on TIM1 (an advanced timer: the same
 * encoder interface, RM0008 §14.3.16). */
#define BOARD_ENC_LEFT_TIM   TIM4
#define BOARD_ENC_LEFT_BITS  16u
#define BOARD_ENC_RIGHT_TIM  TIM1
#define BOARD_ENC_RIGHT_BITS 16u
/** @brief Input filter ICxF of both channels (RM0008 §15.4.7): 8 = f_DTS/8,
 *         N = 6, an edge must hold 48 timer clocks (0.67 µs at 72 MHz): it
 *         passes the 94 µs between edges of a 64 CPR encoder at 10,000 rpm
 *         and rejects shorter glitches. */
#define BOARD_ENC_FILTER     8u
/** @brief Set where an encoder counts down while its wheel drives the robot
 *         forward (a mirrored motor), or swap its A and B wires. */
/** @brief 1: a board for CAN motor drivers (docs/wheel.md, "Two topologies"):
 *         no wheel loop, the motor outputs left disabled, the drives'
 *         WHEEL_SPEED frames the measured wheel speeds. 0 (the default): the
 *         integrated board, whose own wheel loop drives the H-bridges from
 *         the encoders and measures the wheels. */
#ifndef BOARD_WHEELS_EXTERNAL
#define BOARD_WHEELS_EXTERNAL 0
#endif
#ifndef BOARD_ENC_LEFT_INVERT
#define BOARD_ENC_LEFT_INVERT false
#endif
#ifndef BOARD_ENC_RIGHT_INVERT
#define BOARD_ENC_RIGHT_INVERT false
#endif

/* The slcan transport (CAN=slcan, hal/stm32/slcan.c): CAN frames as Lawicel
 * ASCII lines over USART2 (TX PA2, RX PA3), for a USB-serial adapter or
 * QEMU's serial port (docs/hil.md). 8 data bits, no parity, 1 stop bit. */
#define BOARD_SLCAN_UART       USART2
#define BOARD_SLCAN_IRQn       USART2_IRQn
#define BOARD_SLCAN_IRQHandler USART2_IRQHandler
/** @brief Baud rate of the slcan line [bit/s]. */
#ifndef BOARD_SLCAN_BAUD
#define BOARD_SLCAN_BAUD 460800u
#endif

#endif /* BOARD_CONFIG_H */
