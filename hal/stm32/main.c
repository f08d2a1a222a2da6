/* SPDX-License-Identifier: MIT */
/* The main loop of the STM32 boards. Real-time mode: a timer counts control
 * periods; this loop drains received frames into the application, runs one
 * control step per period with the time of that period, sends the wheel
 * speeds to the motor outputs, and kicks the watchdog only when a step has
 * run, so a stuck loop or a dead timer resets the MCU. Interrupts only queue
 * frames and count periods (events up, no control code in an ISR).
 *
 * Lock-step (a plant in the loop, docs/hil.md): a STEP frame runs one control
 * step in the application (app.h). From the first one on, the STEP frames
 * are the board's clock and the timer runs no more steps, so that each STEP
 * gives exactly one step, as in the host builds. The watchdog is then fed by
 * those steps: a plant that stops stepping for longer than its timeout
 * resets the board, which starts again in real-time mode, not armed.
 *
 * The wheel loop (firmware/wheel, docs/wheel.md) runs in both modes on the
 * millisecond tick of hal_time (SysTick), every 1000/wheel_rate ms: the
 * encoders, the control step's last wheel speeds as setpoints, the motors
 * (wheel_cmd.h). This is the integrated board (docs/wheel.md, "Two
 * topologies"): before every control step the loop's estimate, with its
 * age, is the step's measured wheel speeds (app_wheels_measured()), and the
 * application reports it as WHEEL_SPEED. A wheel fault stops the motors and
 * halts the application until it is armed again. Built with
 * BOARD_WHEELS_EXTERNAL (board_config.h), the board drives CAN motor
 * drivers instead: no wheel loop, the motor outputs off, WHEEL_SPEED from
 * the drives. */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "app/app.h"
#include "board.h"
#include "comm/comm.h"
#include "comm/mstc_dbc.h"
#include "cortex_m.h"
#include "hal/hal_can.h"
#include "hal/hal_encoder.h"
#include "hal/hal_motor.h"
#include "hal/hal_sys.h"
#include "hal/hal_time.h"
#include "stm32_hal.h"
#include "wheel/whl.h"
#include "wheel_cmd.h"

/* Static, not on the stack: its size is then in the RAM budget, not the
 * stack's. No heap anywhere. */
static app_t app;

volatile stm32_loop_stats_t stm32_loop_stats;

/* The frames the firmware receives (comm.h); the controller's filters drop
 * every other identifier in hardware, so the bus's other traffic (our own
 * telemetry echoed by nobody, other nodes) never reaches the queue. */
static const hal_can_filter_t rx_filters[] = {
    { COMM_ID_ODOM_XY, HAL_CAN_MAX_STD_ID },
    { COMM_ID_ODOM_THETA, HAL_CAN_MAX_STD_ID },
    { COMM_ID_REF_XY, HAL_CAN_MAX_STD_ID },
    { COMM_ID_REF_MOTION, HAL_CAN_MAX_STD_ID },
    { COMM_ID_STEP, HAL_CAN_MAX_STD_ID },
    { COMM_ID_OBSTACLE, HAL_CAN_MAX_STD_ID },
    { COMM_ID_OBSTACLE_VEL, HAL_CAN_MAX_STD_ID },
    { COMM_ID_PARAM_SET, HAL_CAN_MAX_STD_ID },
    { COMM_ID_PARAM_GET, HAL_CAN_MAX_STD_ID },
    { COMM_ID_PARAM_AUTH, HAL_CAN_MAX_STD_ID },
#if BOARD_WHEELS_EXTERNAL
    /* The drives' measured speeds: the input of this topology only. */
    { COMM_ID_WHEEL_SPEED, HAL_CAN_MAX_STD_ID },
#endif
};

/* The device key, in a section of its own that sections.ld fills with 0xFF
 * (erased flash): not in the image as built (build/firmware/ holds no key).
 * `make flash` writes the device key into a private copy of the image
 * (tools/setup/install-key), `make pil` the simulations' key (docs/safety.md,
 * "The key"). Defined by the linker, so the compiler cannot take the 0xFF it
 * will not see for the key. Readable by anyone with the debug port: the
 * threat model says what that means. */
extern const uint32_t mstc_device_key[AUTH_KEY_LEN / 4u];

/* Give the application the key in flash, if one was installed (all 0xFF: none,
 * every command refused, AUTH_STATUS last no_key), with a session of its own
 * for this start (docs/safety.md, "Sessions"): every command signed before
 * the reset is refused. A source that failed gives session 0, which the
 * status shows. */
static void install_key(void)
{
    const uint32_t *k = mstc_device_key;
    if ((k[0] & k[1] & k[2] & k[3]) != UINT32_MAX) {
        uint32_t session;
        if (hal_sys_boot_nonce(&session) != 0) {
            session = 0u;
        }
        app_set_key(&app, (const uint8_t *)mstc_device_key, session);
    }
}

/* Status LED: toggles every LED_SLOW_MS while all is well, every LED_FAST_MS
 * while something needs a look (the crystal did not start, CAN is not up,
 * error-passive or bus-off). It follows the control steps, so a dark or
 * frozen LED means the loop stopped. */
#define LED_SLOW_MS 500u
#define LED_FAST_MS 100u

static bool degraded(bool can_ok)
{
    hal_can_status_t st;
    if (!can_ok || hal_can_status(&st) != 0 || !board_clocks()->hse) {
        return true;
    }
    return st.state == HAL_CAN_STATE_ERROR_PASSIVE || st.state == HAL_CAN_STATE_BUS_OFF;
}

static void led_step(uint32_t steps, bool can_ok)
{
    const uint32_t half_ms = degraded(can_ok) ? LED_FAST_MS : LED_SLOW_MS;
    const uint32_t half_steps = half_ms * 1000u / BOARD_CONTROL_PERIOD_US;
    const uint32_t k = half_steps > 0u ? half_steps : 1u;
    board_led(((steps / k) & 1u) != 0u);
}

/* ------------------------------------------------------------ wheel loop */

static whl_t wheels;
static whl_output_t wheel_out; /* of the last wheel period */
static bool wheel_measured;    /* it read the encoders (not open loop) */
volatile stm32_wheel_stats_t stm32_wheel_stats;

static struct {
    uint64_t next_ms;   /* the next period is due at this millisecond */
    uint64_t last_us;   /* when the last period read the encoders */
    uint32_t period_ms; /* 1000 / wheel_rate, rounded, at least 1 */
    uint32_t period_us; /* whl_period_us() */
    uint8_t halt;       /* the application's halt at the last period */
    /* The motors are a model (a PIL image, pil_wheels.c), whose time is the
     * loop's: in lock-step their periods run on the plant's time, the
     * STEP frames' (on_steps), not on the millisecond tick. */
    bool simulated;
    bool on_steps;
    uint32_t step_time_us; /* the last STEP's time */
    uint32_t owed_us;      /* the plant's time the periods have not run yet */
} wheel_sched;

/* The wheel parameters in force in the application (PARAM_SET changes them
 * between control steps). */
static void wheel_params(void)
{
    const whl_params_t *p = &app.ctl.p.wheel;
    const num_t accel = app_wheel_accel(&app);
    if (memcmp(p, &wheels.p, sizeof *p) != 0 || accel != wheels.accel) {
        whl_set_params(&wheels, p, accel);
    }
    wheel_sched.period_us = whl_period_us(p);
    const uint32_t ms = (wheel_sched.period_us + 500u) / 1000u;
    wheel_sched.period_ms = ms > 0u ? ms : 1u;
    wheel_sched.simulated = stm32_wheels_period(wheel_sched.period_us);
}

static bool wheel_due(void)
{
    return !wheel_sched.on_steps && hal_time_now_us() / 1000u >= wheel_sched.next_ms;
}

/* One wheel period: the last control step's wheel speeds, the encoders, the
 * motors. A re-arm (the halt cleared) clears the wheel loop's faults. The
 * cycles counted are the firmware's: a simulated motor's are not. */
static void wheel_run(void)
{
    volatile stm32_wheel_stats_t *st = &stm32_wheel_stats;
    if (app.halt == (uint8_t)COMM_HALT_NONE && wheel_sched.halt != (uint8_t)COMM_HALT_NONE) {
        whl_clear_faults(&wheels);
    }
    wheel_sched.halt = app.halt;
    const kin_wheels_t *w = app_last_wheels(&app);
    wheel_sched.last_us = hal_time_now_us();
    const uint32_t c0 = stm32_time_cycles();
    wheel_measured = wheel_cmd_period(&wheels, w->left, w->right, &wheel_out) == 0;
    const uint32_t cycles = stm32_time_cycles() - c0 - stm32_wheels_model_cycles();
    st->cycles_max = cycles > st->cycles_max ? cycles : st->cycles_max;
    const uint32_t lo = st->cycles_sum_lo + cycles;
    st->cycles_sum_hi += lo < cycles ? 1u : 0u;
    st->cycles_sum_lo = lo;
    st->periods++;
    st->step_periods += wheel_sched.on_steps ? 1u : 0u;
    st->closed_loop = wheel_measured ? 1u : 0u;
    st->faults = wheel_out.faults;
    st->speed_mrad_s[0] = (int32_t)(num_to_float(wheel_out.speed[0]) * 1000.0f);
    st->speed_mrad_s[1] = (int32_t)(num_to_float(wheel_out.speed[1]) * 1000.0f);
}

/* The millisecond tick: one wheel period if one is due. */
static void wheel_period(void)
{
    if (wheel_sched.on_steps) {
        return; /* run by the STEP frames */
    }
    const uint64_t now_ms = hal_time_now_us() / 1000u;
    if (now_ms < wheel_sched.next_ms) {
        return;
    }
    const uint64_t late = (now_ms - wheel_sched.next_ms) / wheel_sched.period_ms;
    stm32_wheel_stats.overruns += (uint32_t)late;
    wheel_sched.next_ms += (late + 1u) * wheel_sched.period_ms;
    wheel_run();
}

/* Lock-step with simulated motors, before the control step of a STEP frame
 * @p f: the wheel periods that fall in the plant's time since the last STEP,
 * at the setpoints of the last control step, as the simulation's wheels run
 * over a period (mstc_sil_wheel.h). A board's real motors keep their
 * millisecond tick. The frame is read here as it came; the application may
 * yet drop it (then the plant's time has passed all the same). */
static void wheel_catch_up(const hal_can_frame_t *f)
{
    struct mstc_dbc_step_t s;
    if (!wheel_sched.simulated || mstc_dbc_step_unpack(&s, f->data, f->dlc) != 0) {
        return;
    }
    if (!wheel_sched.on_steps) {
        wheel_sched.on_steps = true; /* the first STEP: no time has passed */
        wheel_sched.step_time_us = s.step_time;
        stm32_wheels_lockstep();
        return;
    }
    /* Modulo 2^32, as the STEP time wraps. */
    wheel_sched.owed_us += s.step_time - wheel_sched.step_time_us;
    wheel_sched.step_time_us = s.step_time;
    while (wheel_sched.owed_us >= wheel_sched.period_us) {
        wheel_sched.owed_us -= wheel_sched.period_us;
        wheel_run();
    }
}

/* Before each control step, in both modes: the wheel loop's last estimate
 * and faults are the step's measured wheel speeds, their age half the speed
 * window and the time since that period (the application sends them as
 * WHEEL_SPEED). Open loop nothing is measured. */
static void hand_wheel_speeds(void)
{
    if (!wheel_measured) {
        return;
    }
    const kin_wheels_t w = { wheel_out.speed[0], wheel_out.speed[1] };
    /* On the plant's time the last period ran at the STEP's time. */
    const uint64_t since = wheel_sched.on_steps ? 0u : hal_time_now_us() - wheel_sched.last_us;
    const uint64_t age = whl_age_us(&wheels) + since;
    app_wheels_measured(&app, &w, wheel_out.faults, age < UINT32_MAX ? (uint32_t)age : UINT32_MAX);
}

/* The main loop's updates of stm32_loop_stats go between these two: the
 * sequence word is odd while any other word may be half updated (a seqlock,
 * stm32_hal.h). The barriers keep the compiler and the core from moving a
 * word's write across the sequence word's; the main loop is the only writer,
 * so no interrupt masking is needed. */
static void stats_begin(void)
{
    stm32_loop_stats.seq++;
    cm_dsb();
}

static void stats_end(void)
{
    cm_dsb();
    stm32_loop_stats.seq++;
}

/* After each control step, which took @p cycles (@p first: the first of its
 * mode, real-time or lock-step, which restarts the cycle statistics;
 * @p by_frame: run by a STEP frame): motors, LED, statistics, watchdog. */
static void after_step(uint32_t cycles, bool first, bool by_frame, bool can_ok)
{
    static uint32_t steps;
    volatile stm32_loop_stats_t *st = &stm32_loop_stats;
    wheel_params();
    led_step(++steps, can_ok);
    stats_begin();
    if (by_frame) {
        st->lockstep = 1u;
        st->frame_steps++;
    }
    if (first) {
        st->step_cycles_min = cycles;
        st->step_cycles_max = 0u;
        st->step_cycles_sum_lo = 0u;
        st->step_cycles_sum_hi = 0u;
    }
    st->step_cycles_min = cycles < st->step_cycles_min ? cycles : st->step_cycles_min;
    st->step_cycles_max = cycles > st->step_cycles_max ? cycles : st->step_cycles_max;
    const uint32_t lo = st->step_cycles_sum_lo + cycles;
    st->step_cycles_sum_hi += lo < cycles ? 1u : 0u;
    st->step_cycles_sum_lo = lo;
    st->steps = steps;
    st->overruns = stm32_tick_overruns();
    stats_end();
    hal_sys_watchdog_kick();
}

int main(void)
{
    board_clock_init();
    board_debug_init();
    board_gpio_init();
    stm32_time_init(board_clocks()->sysclk_hz);
    /* The motor outputs start disabled either way; an external-drives
     * board never enables them. */
    (void)hal_motor_init();
    const bool own_wheels = !BOARD_WHEELS_EXTERNAL && hal_encoder_init() == 0;

    stats_begin();
    stm32_loop_stats.reset_cause = (uint32_t)hal_sys_reset_cause();
    stm32_loop_stats.sysclk_hz = board_clocks()->sysclk_hz;
    stats_end();

    /* CAN failing to start is not fatal: the loop, the watchdog and the LED
     * still run, and the LED says so. */
    const int can_rc = hal_can_open(NULL);
    stats_begin();
    stm32_loop_stats.can_open = can_rc;
    stats_end();
    bool can_ok = can_rc == 0;
    if (can_ok) {
        can_ok = hal_can_set_filters(rx_filters, sizeof rx_filters / sizeof rx_filters[0]) == 0;
    }
    (void)app_init(&app, NULL);
    app_set_wheel_source(&app, own_wheels ? APP_WHEELS_OWN : APP_WHEELS_EXTERNAL);
    whl_init(&wheels, &app.ctl.p.wheel, app_wheel_accel(&app));
    wheel_params();
    wheel_sched.halt = app.halt;
    install_key();
    (void)stm32_tick_start(BOARD_CONTROL_PERIOD_US);
    (void)hal_sys_watchdog_start(BOARD_WATCHDOG_MS);

    uint64_t t_us = 0u;
    for (;;) {
        /* The wheel loop first: its period is the shortest, and its
         * encoder reads the more regular the better. */
        if (!BOARD_WHEELS_EXTERNAL) {
            wheel_period();
        }
        /* Every received frame into the application (app_poll(), one frame
         * at a time, so that a STEP's step can be timed). */
        hal_can_frame_t f;
        while (hal_can_recv(&f, 0u) == 0) {
            const uint32_t before = app.steps;
            if (f.id == COMM_ID_STEP && !BOARD_WHEELS_EXTERNAL) {
                /* A STEP runs a control step. */
                wheel_catch_up(&f);
                hand_wheel_speeds();
            }
            const uint32_t c0 = stm32_time_cycles();
            (void)app_on_frame(&app, &f);
            const uint32_t cycles = stm32_time_cycles() - c0;
            if (app.steps != before) {
                after_step(cycles, stm32_loop_stats.lockstep == 0u, true, can_ok);
            }
        }
        const uint32_t periods = stm32_tick_take();
        if (periods > 0u && stm32_loop_stats.lockstep == 0u) {
            /* The step's time is the end of the period that has elapsed, not
             * when this loop got to it: steps stay evenly spaced. Missed
             * periods are skipped (stm32_tick_overruns() counts them). */
            t_us += (uint64_t)periods * BOARD_CONTROL_PERIOD_US;
            hand_wheel_speeds();
            const uint32_t c0 = stm32_time_cycles();
            app_control_tick(&app, t_us);
            after_step(stm32_time_cycles() - c0, stm32_loop_stats.steps == 0u, false, can_ok);
        }
        /* Sleep until the next interrupt unless work arrived meanwhile. */
        const uint32_t primask = cm_irq_save();
        if (!stm32_can_rx_pending() && !stm32_tick_pending() &&
            (BOARD_WHEELS_EXTERNAL || !wheel_due())) {
            cm_wfi();
        }
        cm_irq_restore(primask);
    }
}
