/* SPDX-License-Identifier: MIT */
/**
 * @file board_host.h
 * @brief The STM32F405 board on the host, for its drivers' tests: its
 *        board_config.h as it is, board.h's functions recording what the
 *        drivers ask of the board (pins, clocks).
 */
#ifndef BOARD_HOST_H
#define BOARD_HOST_H

#include <stdbool.h>
#include <stdint.h>

#include "board.h"

/** @brief What the drivers did to the board. */
typedef struct {
    board_clocks_t clocks;     /**< what board_clocks() answers: the HSE tree by default */
    unsigned can_enabled;      /**< board_can_enable() calls */
    unsigned timers_enabled;   /**< board_timers_enable() calls */
    unsigned encoders_enabled; /**< board_encoder_enable() calls */
    bool led;
    bool forward[2];      /**< the direction pins, left and right */
    bool motor_enabled;   /**< the driver-enable pin */
    uint32_t reset_flags; /**< what board_reset_flags() answers */
} board_host_t;

extern board_host_t board_host;

/** @brief The HSE clock tree (168, 42, 84 MHz), every pin low. */
void board_host_reset(void);

#endif /* BOARD_HOST_H */
