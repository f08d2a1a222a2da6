/* SPDX-License-Identifier: MIT */
/* The blank port's main loop: the same shape as every board's (hal/stm32/
 * main.c is the complete one). Real-time mode: a timer counts control
 * periods, the loop runs the control step with the period's time, sends the
 * wheel speeds to the motors and kicks the watchdog only after a step. */
#include <stdint.h>

#include "app/app.h"
#include "hal/hal_can.h"
#include "hal/hal_motor.h"
#include "hal/hal_sys.h"
#include "template.h"

/* TODO: the control period [µs] and the watchdog time-out [ms] (several
 * periods, at the watchdog oscillator's fastest tolerance). */
#define CONTROL_PERIOD_US 20000u
#define WATCHDOG_MS       100u

static app_t app; /* static: no heap, and its size shows in the RAM budget */

int main(void)
{
    template_board_init();
    (void)hal_motor_init();
    if (hal_can_open(NULL) == 0) {
        /* TODO: the protocol's receive identifiers, as hal/stm32/main.c does. */
        (void)hal_can_set_filters(NULL, 0u);
    }
    (void)app_init(&app, NULL);
    (void)template_tick_start(CONTROL_PERIOD_US);
    (void)hal_sys_watchdog_start(WATCHDOG_MS);

    uint64_t t_us = 0u;
    for (;;) {
        (void)app_poll(&app, 0u);
        const uint32_t periods = template_tick_take();
        if (periods > 0u) {
            t_us += (uint64_t)periods * CONTROL_PERIOD_US;
            app_control_tick(&app, t_us);
            /* TODO: wheel speeds to motor commands, as hal/stm32/main.c
             * does with app_last_wheels() and wheel_cmd_from_speed(). */
            (void)hal_motor_set(0, 0);
            hal_sys_watchdog_kick();
        }
        template_wait_for_event();
    }
}
