/* SPDX-License-Identifier: MIT */
/* The board functions (hal/stm32/board.h) for the drivers on the host: the
 * STM32F405 board's configuration (hal/stm32f405/board_config.h), its clock
 * tree as board_clock_init() leaves it with the crystal, and the GPIO the
 * drivers touch through the board recorded (board_host.h). */
#include "board_host.h"

#include <errno.h>
#include <string.h>

#include "hal/hal_sys.h"

board_host_t board_host;

static const board_clocks_t hse = {
    .sysclk_hz = 168000000u, .apb1_hz = 42000000u, .apb1_tim_hz = 84000000u, .hse = true
};

void board_host_reset(void)
{
    memset(&board_host, 0, sizeof board_host);
    board_host.clocks = hse;
}

void board_clock_init(void) {}
const board_clocks_t *board_clocks(void) { return &board_host.clocks; }
void board_gpio_init(void) {}
void board_can_enable(void) { board_host.can_enabled++; }
void board_slcan_enable(void) {}
void board_timers_enable(void) { board_host.timers_enabled++; }
void board_encoder_enable(void) { board_host.encoders_enabled++; }
void board_led(bool on) { board_host.led = on; }

void board_motor_dir(unsigned wheel, bool forward)
{
    if (wheel < 2u) {
        board_host.forward[wheel] = forward;
    }
}

void board_motor_enable(bool on) { board_host.motor_enabled = on; }
uint32_t board_reset_flags(void) { return board_host.reset_flags; }
void board_debug_init(void) {}

/* The session of the application's authenticated commands: no source here
 * (the application then takes none, as a board whose TRNG failed). */
int hal_sys_boot_nonce(uint32_t *nonce)
{
    *nonce = 0u;
    return -EIO;
}
