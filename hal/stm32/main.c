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
 * (wheel_cmd.h). Its faults stop the motors until the application is armed
 * again; they do not halt the application (docs/wheel.md, "Design"), so a
 * board under QEMU, whose encoders never count, still runs the plant's
 * scenarios in lock-step (make pil). */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "app/app.h"
#include "board.h"
#include "comm/comm.h"
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
    { COMM_ID_ODOM_XY, HAL_CAN_MAX_STD_ID },      { COMM_ID_ODOM_THETA, HAL_CAN_MAX_STD_ID },
    { COMM_ID_REF_XY, HAL_CAN_MAX_STD_ID },       { COMM_ID_REF_MOTION, HAL_CAN_MAX_STD_ID },
    { COMM_ID_STEP, HAL_CAN_MAX_STD_ID },         { COMM_ID_OBSTACLE, HAL_CAN_MAX_STD_ID },
    { COMM_ID_OBSTACLE_VEL, HAL_CAN_MAX_STD_ID }, { COMM_ID_PARAM_SET, HAL_CAN_MAX_STD_ID },
    { COMM_ID_PARAM_GET, HAL_CAN_MAX_STD_ID },    { COMM_ID_PARAM_AUTH, HAL_CAN_MAX_STD_ID },
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
    uint32_t period_ms; /* 1000 / wheel_rate, rounded, at least 1 */
    uint8_t halt;       /* the application's halt at the last period */
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
    const uint32_t ms = (whl_period_us(p) + 500u) / 1000u;
    wheel_sched.period_ms = ms > 0u ? ms : 1u;
}

static bool wheel_due(void) { return hal_time_now_us() / 1000u >= wheel_sched.next_ms; }

/* One wheel period if one is due: the last control step's wheel speeds,
 * the encoders, the motors. A re-arm (the halt cleared) clears the wheel
 * loop's faults. */
static void wheel_period(void)
{
    const uint64_t now_ms = hal_time_now_us() / 1000u;
    if (now_ms < wheel_sched.next_ms) {
        return;
    }
    volatile stm32_wheel_stats_t *st = &stm32_wheel_stats;
    const uint64_t late = (now_ms - wheel_sched.next_ms) / wheel_sched.period_ms;
    st->overruns += (uint32_t)late;
    wheel_sched.next_ms += (late + 1u) * wheel_sched.period_ms;
    if (app.halt == (uint8_t)COMM_HALT_NONE && wheel_sched.halt != (uint8_t)COMM_HALT_NONE) {
        whl_clear_faults(&wheels);
    }
    wheel_sched.halt = app.halt;
    const kin_wheels_t *w = app_last_wheels(&app);
    const uint32_t c0 = stm32_time_cycles();
    wheel_measured = wheel_cmd_period(&wheels, w->left, w->right, &wheel_out) == 0;
    const uint32_t cycles = stm32_time_cycles() - c0;
    st->cycles_max = cycles > st->cycles_max ? cycles : st->cycles_max;
    st->periods++;
    st->closed_loop = wheel_measured ? 1u : 0u;
    st->faults = wheel_out.faults;
    st->speed_mrad_s[0] = (int32_t)(num_to_float(wheel_out.speed[0]) * 1000.0f);
    st->speed_mrad_s[1] = (int32_t)(num_to_float(wheel_out.speed[1]) * 1000.0f);
}

/* Real-time mode, before each control step: what the encoders measure and
 * the wheel loop's faults, on the bus (WHEEL_SPEED: the board sends it when
 * it runs the wheel loop, mstc.dbc). Not in lock-step, where the plant's
 * wheels are the robot's, and not open loop, where nothing is measured. */
static void send_wheel_speed(void)
{
    if (!wheel_measured) {
        return;
    }
    const kin_wheels_t w = { wheel_out.speed[0], wheel_out.speed[1] };
    hal_can_frame_t f;
    (void)comm_encode_wheel_speed_faults(&app.comm, &w, wheel_out.faults, &f);
    (void)hal_can_send(&f);
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
    (void)hal_motor_init();
    (void)hal_encoder_init();

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
        wheel_period();
        /* Every received frame into the application (app_poll(), one frame
         * at a time, so that a STEP's step can be timed). */
        hal_can_frame_t f;
        while (hal_can_recv(&f, 0u) == 0) {
            const uint32_t before = app.steps;
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
            send_wheel_speed();
            const uint32_t c0 = stm32_time_cycles();
            app_control_tick(&app, t_us);
            after_step(stm32_time_cycles() - c0, stm32_loop_stats.steps == 0u, false, can_ok);
        }
        /* Sleep until the next interrupt unless work arrived meanwhile. */
        const uint32_t primask = cm_irq_save();
        if (!stm32_can_rx_pending() && !stm32_tick_pending() && !wheel_due()) {
            cm_wfi();
        }
        cm_irq_restore(primask);
    }
}
