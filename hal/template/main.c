/* SPDX-License-Identifier: MIT */
/* The blank port's main loop: the same shape as every board's (hal/stm32/
 * main.c is the complete one). Real-time mode: a timer counts control
 * periods, the loop runs the control step with the period's time, sends the
 * wheel speeds to the motors and kicks the watchdog only after a step. */
#include <stdint.h>

#include "app/app.h"
#include "hal/hal_can.h"
#include "hal/hal_encoder.h"
#include "hal/hal_motor.h"
#include "hal/hal_sys.h"
#include "template.h"
#include "wheel/whl.h"

/* TODO: the control period [µs] and the watchdog time-out [ms] (several
 * periods, at the watchdog oscillator's fastest tolerance). */
#define CONTROL_PERIOD_US 20000u
#define WATCHDOG_MS       100u

static app_t app; /* static: no heap, and its size shows in the RAM budget */
static whl_t wheels;

/* The wheel loop (firmware/wheel/whl.h, docs/wheel.md): the encoders, the
 * last control step's wheel speeds, the motors. TODO: run it every
 * 1000/wheel_rate ms from a millisecond tick, not once per control period
 * (hal/stm32/main.c and wheel_cmd.c do). Without encoders the motors are
 * driven open loop on the feed-forward. */
static void wheel_period(void)
{
    const kin_wheels_t *sp = app_last_wheels(&app);
    int32_t left;
    int32_t right;
    if (hal_encoder_read(&left, &right) != 0) {
        const whl_params_t *p = &app.ctl.p.wheel;
        (void)hal_motor_set(whl_motor_cmd(num_div(sp->left, p->free_speed)),
                            whl_motor_cmd(num_div(sp->right, p->free_speed)));
        return;
    }
    const whl_input_t in = { { sp->left, sp->right }, { left, right } };
    whl_output_t out;
    whl_step(&wheels, &in, &out);
    if (out.faults != 0u) {
        hal_motor_stop();
    } else {
        (void)hal_motor_set(out.cmd[0], out.cmd[1]);
    }
}

int main(void)
{
    template_board_init();
    (void)hal_motor_init();
    if (hal_can_open(NULL) == 0) {
        /* TODO: the protocol's receive identifiers, as hal/stm32/main.c does. */
        (void)hal_can_set_filters(NULL, 0u);
    }
    (void)hal_encoder_init();
    (void)app_init(&app, NULL);
    whl_init(&wheels, &app.ctl.p.wheel, app_wheel_accel(&app));
    (void)template_tick_start(CONTROL_PERIOD_US);
    (void)hal_sys_watchdog_start(WATCHDOG_MS);

    uint64_t t_us = 0u;
    for (;;) {
        (void)app_poll(&app, 0u);
        const uint32_t periods = template_tick_take();
        if (periods > 0u) {
            t_us += (uint64_t)periods * CONTROL_PERIOD_US;
            app_control_tick(&app, t_us);
            whl_set_params(&wheels, &app.ctl.p.wheel, app_wheel_accel(&app));
            wheel_period();
            hal_sys_watchdog_kick();
        }
        template_wait_for_event();
    }
}
