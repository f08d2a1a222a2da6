/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the application's safety supervisor (app.h, docs/safety.md):
 * arming, the input timeouts in control steps and in time, the ramped stop
 * and its reason in STATUS, the latch and the re-arm, bus-off, corrupted,
 * duplicated and hostile frames, parameters at their limits, in lock-step
 * (STEP frames) and real-time (app_control_tick) modes. The HAL is hal/fake.
 *
 * Expected values: eq. (1)-(3) by hand for the wheel speeds, as in
 * test_app.c (robot at the origin heading east, reference 1 m ahead at
 * 0.5 m/s: both wheels 70 rad/s = 71680 lsb of 2^-10 rad/s); the ramp by
 * hand: the default max_wheel_decel, 125 rad/s², over 20 ms is 2.5 rad/s =
 * 2560 lsb a step.
 */
#include <errno.h>
#include <string.h>

#include "app/app.h"
#include "comm/mstc_dbc.h"
#include "hal_fake.h"
#include "test_frames.h"
#include "test_util.h"

static app_t app;

/* Raw wheel speed tolerance [lsb of 2^-10 rad/s]: test_app.c says why. */
#define TOL_WHEEL_RAW TU_TOL(1, 6)
/* The ramp: float exact to the raw rounding; fixed: dt = 0.02 s is Q16.16
 * 1311/65536 (5e-4 relative) times 125 rad/s², and the scaling factor's
 * rounding: a few lsb a step. */
#define TOL_RAMP_RAW  TU_TOL(2, 8)
#define DT_US         20000u

void setUp(void)
{
    tf_app_start(&app, -ENOTSUP); /* a port without a controller, unless a test says */
    tf_auth = &app.auth;
}

void tearDown(void) {}

static int feed_rc(hal_can_frame_t f) { return app_on_frame(&app, &f); }
static void feed(hal_can_frame_t f) { TEST_ASSERT_EQUAL_INT(0, feed_rc(f)); }

static void odom(void)
{
    feed(tf_odom_xy(0.0, 0.0));
    feed(tf_odom_theta(0.0));
}
static void ref(void)
{
    feed(tf_ref_xy(1.0, 0.0));
    feed(tf_ref_motion(0.0, 0.5, 0.0));
}

/* An authenticated PARAM_SET; the result it is answered with. */
static uint8_t set_param(uint8_t index, float value)
{
    hal_can_frame_t f[2];
    tf_param_set_auth(index, value, f);
    feed(f[0]);
    feed(f[1]);
    return tf_last_param_value().param_value_result;
}

static uint8_t arm_cmd(float value) { return set_param(COMM_PARAM_ARM, value); }

static uint16_t k_step;
static uint32_t t_us;

/* One lock-step control step at the next time (DT_US later). */
static void step(void)
{
    hal_fake.n_sent = 0;
    feed(tf_step(k_step++, t_us));
    t_us += DT_US;
}

/* A full step: inputs, then STEP. */
static void full_step(void)
{
    odom();
    ref();
    step();
}

/* Pre-roll and arm, as the plant does at the start of a run. */
static void arm(void)
{
    k_step = 0;
    t_us = 0;
    for (unsigned k = 0; k < APP_REARM_FRAMES; k++) {
        odom();
        ref();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f));
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, app.halt);
}

/* Drive at 70 rad/s for a few steps (robot at the origin, reference ahead). */
static void drive(unsigned steps)
{
    arm();
    for (unsigned k = 0; k < steps; k++) {
        full_step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
        TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_left);
    }
}

/* ------------------------------------------------------------------ arming */

static void test_app_safety_starts_halted_not_armed_and_stands_still(void)
{
    full_step();
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_right);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, tf_last_status().status_halt);
    TEST_ASSERT_EQUAL_UINT8(SUP_MODE_STOP, tf_last_status().status_mode);
}

static void test_app_safety_arm_needs_five_good_frames_of_every_input(void)
{
    for (unsigned k = 0; k + 1u < APP_REARM_FRAMES; k++) {
        odom();
        ref();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_REJECTED, arm_cmd(1.0f));
    TEST_ASSERT_EQUAL_FLOAT(0.0f, tf_last_param_value().param_value_value);
    odom();
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_REJECTED, arm_cmd(1.0f)); /* reference still 4 */
    ref();
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f));
    TEST_ASSERT_EQUAL_FLOAT(1.0f, tf_last_param_value().param_value_value);
    full_step();
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_right);
}

static void test_app_safety_arm_command_other_values_and_get(void)
{
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OUT_OF_RANGE, arm_cmd(2.0f));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OUT_OF_RANGE, arm_cmd(NAN));
    feed(tf_param_get(COMM_PARAM_ARM));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    TEST_ASSERT_EQUAL_FLOAT(0.0f, tf_last_param_value().param_value_value);
    arm();
    feed(tf_param_get(COMM_PARAM_ARM));
    TEST_ASSERT_EQUAL_FLOAT(1.0f, tf_last_param_value().param_value_value);
}

static void test_app_safety_disarm_halts_with_a_ramp(void)
{
    drive(2);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, tf_last_status().status_halt);
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 71680 - 2560, tf_last_wheels().wheel_cmd_left);
    /* Disarming again keeps the reason. */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
}

static void test_app_safety_heartbeat_says_ready_when_not_armed_and_fault_when_halted(void)
{
    full_step(); /* t = 0: housekeeping */
    struct mstc_dbc_heartbeat_t h;
    TEST_ASSERT_EQUAL_INT(0,
                          mstc_dbc_heartbeat_unpack(&h, tf_last_sent(COMM_ID_HEARTBEAT)->data, 8));
    TEST_ASSERT_EQUAL_UINT8(COMM_STATE_INIT + 1u,
                            h.heartbeat_state); /* READY before the first step */
    TEST_ASSERT_EQUAL_INT(COMM_STATE_READY, app.state);
    drive(1);
    TEST_ASSERT_EQUAL_INT(COMM_STATE_RUNNING, app.state);
    step(); /* no inputs: still within the timeout */
    step();
    step(); /* third step without them: halted */
    TEST_ASSERT_EQUAL_INT(COMM_STATE_FAULT, app.state);
}

/* ---------------------------------------------------------------- timeouts */

static void test_app_safety_odometry_lost_halts_at_the_third_step(void)
{
    drive(5);
    /* Only the reference from now on: the last odometry came with the last
     * full step k; steps k+1 and k+2 still use it, k+3 halts. */
    ref();
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_left);
    ref();
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    ref();
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, tf_last_status().status_halt);
    TEST_ASSERT_EQUAL_UINT8(SUP_MODE_STOP, tf_last_status().status_mode);
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 71680 - 2560, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 71680 - 2560, tf_last_wheels().wheel_cmd_right);
}

static void test_app_safety_reference_lost_halts_with_its_reason(void)
{
    drive(5);
    for (unsigned k = 0; k < 3u; k++) {
        odom();
        step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_REFERENCE, tf_last_status().status_halt);
}

static void test_app_safety_one_theta_frame_lost_is_enough(void)
{
    drive(5);
    for (unsigned k = 0; k < 3u; k++) {
        feed(tf_odom_xy(0.0, 0.0));
        ref();
        step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, tf_last_status().status_halt);
}

static void test_app_safety_timeout_counts_time_too(void)
{
    /* Steps 40 ms apart: two periods without odometry are 80 ms >= 60 ms. */
    drive(5);
    t_us += DT_US; /* the next step comes 40 ms after the last */
    ref();
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt); /* 40 ms */
    t_us += DT_US;
    ref();
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, tf_last_status().status_halt); /* 80 ms */
}

static void test_app_safety_ramp_keeps_the_curvature_and_ends_at_zero(void)
{
    /* Reference to the left: wheels 28 and -8 rad/s (test_app.c). */
    arm();
    feed(tf_odom_xy(0.0, 0.0));
    feed(tf_odom_theta(0.0));
    feed(tf_ref_xy(0.0, 1.0));
    feed(tf_ref_motion(0.0, 0.5, 0.0));
    step();
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 28672, tf_last_wheels().wheel_cmd_right);
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, -8192, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    /* The larger wheel loses 2.5 rad/s a step, the other keeps the ratio
     * -8/28; from 28 rad/s, 11 steps leave 0.5 rad/s, the 12th stops. */
    int32_t prev_r = 28672;
    for (unsigned k = 1; k <= 11u; k++) {
        step();
        const struct mstc_dbc_wheel_cmd_t w = tf_last_wheels();
        const double want_r = 28672.0 - 2560.0 * k;
        TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW * (int32_t)k, (int32_t)want_r, w.wheel_cmd_right);
        TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW * (int32_t)k, (int32_t)(-want_r * 8.0 / 28.0),
                                 w.wheel_cmd_left);
        TEST_ASSERT_TRUE(w.wheel_cmd_right <= prev_r);
        prev_r = w.wheel_cmd_right;
    }
    for (unsigned k = 0; k < 2u; k++) { /* zero, and it stays there */
        step();
        TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_right);
        TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
    }
}

static void test_app_safety_deceleration_is_a_parameter(void)
{
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, set_param(COMM_PARAM_MAX_WHEEL_DECEL, 1000.0f));
    const float bad[] = { 0.0f, -1.0f, NAN, INFINITY, 10001.0f };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OUT_OF_RANGE,
                                set_param(COMM_PARAM_MAX_WHEEL_DECEL, bad[i]));
        TEST_ASSERT_EQUAL_FLOAT(1000.0f, tf_last_param_value().param_value_value);
    }
    feed(tf_param_get(COMM_PARAM_MAX_WHEEL_DECEL));
    TEST_ASSERT_EQUAL_FLOAT(1000.0f, tf_last_param_value().param_value_value);
    /* 1000 rad/s² over 20 ms: 20 rad/s a step, from 70: 50, 30, 10, 0. */
    drive(1);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    const int32_t want[] = { 51200, 30720, 10240, 0 };
    for (size_t i = 0; i < 4u; i++) {
        full_step();
        TEST_ASSERT_INT32_WITHIN(TU_TOL(2, 40), want[i], tf_last_wheels().wheel_cmd_left);
    }
}

static void test_app_safety_halt_latches_until_rearmed_after_five_good_frames(void)
{
    drive(5);
    for (unsigned k = 0; k < 3u; k++) {
        ref();
        step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, app.halt);
    /* Odometry is back: still halted, reason kept. */
    for (unsigned k = 0; k < 40u; k++) {
        full_step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, tf_last_status().status_halt);
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f));
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_left);
}

static void test_app_safety_rearm_refused_until_the_inputs_ran_five_steps(void)
{
    drive(5);
    for (unsigned k = 0; k < 3u; k++) {
        ref();
        step();
    }
    full_step(); /* odometry frames 1 */
    full_step(); /* 2 */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_REJECTED, arm_cmd(1.0f));
    full_step();
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_REJECTED, arm_cmd(1.0f)); /* 4 */
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f)); /* 5 */
}

/* -------------------------------------------------- corrupted and hostile */

static void test_app_safety_corrupted_frames_are_never_used(void)
{
    drive(3);
    /* An odometry frame that says the robot is 1 m further, with one bit of
     * its CRC wrong: dropped; the step uses the last good pose (70 rad/s,
     * not the 10 rad/s of e1 = 0). */
    odom();
    hal_can_frame_t bad = tf_odom_xy(1.0, 0.0);
    bad.data[0] ^= 0x01u;
    TEST_ASSERT_EQUAL_INT(-EBADMSG, feed_rc(bad));
    ref();
    step();
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_EQUAL_UINT8(8u, tf_last_status().status_faults & 8u);
}

static void test_app_safety_two_corrupted_frames_in_the_window_halt_at_once(void)
{
    drive(5);
    for (unsigned k = 0; k < 2u; k++) {
        hal_can_frame_t bad = tf_odom_xy(0.0, 0.0);
        bad.data[6] ^= 0x20u;
        TEST_ASSERT_EQUAL_INT(-EBADMSG, feed_rc(bad));
        feed(tf_odom_theta(0.0));
        ref();
        step();
    }
    /* The second step: window [OK OK ERR ERR], INVALID before any timeout. */
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, tf_last_status().status_halt);
}

static void test_app_safety_duplicated_frames_are_tolerated(void)
{
    drive(2);
    /* The robot moves as commanded (straight ahead, the wheels equal), so
     * its odometry stays plausible over the ten steps (odo.h). */
    double x = 0.0;
    for (unsigned k = 0; k < 10u; k++) {
        const double v =
            tu_dbl(app.ctl.p.kin.wheel_radius) * tf_last_wheels().wheel_cmd_left / 1024.0;
        x += v * DT_US * 1e-6;
        const hal_can_frame_t f = tf_odom_xy(x, 0.0);
        feed(f);
        TEST_ASSERT_EQUAL_INT(-EALREADY, feed_rc(f)); /* the duplicate */
        feed(tf_odom_theta(0.0));
        ref();
        step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    }
}

static void test_app_safety_a_step_with_a_bad_step_history_halts(void)
{
    drive(5);
    for (unsigned k = 0; k < 2u; k++) {
        hal_can_frame_t bad = tf_step(99, t_us);
        bad.data[7] ^= 0x02u;
        TEST_ASSERT_EQUAL_INT(-EBADMSG, feed_rc(bad)); /* no step runs */
    }
    full_step(); /* [OK OK ERR ERR OK] → window [ERR ERR OK …]: INVALID */
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_STEP, tf_last_status().status_halt);
}

static void test_app_safety_replayed_step_runs_no_step(void)
{
    drive(2);
    const uint32_t steps = app.steps;
    odom();
    ref();
    const hal_can_frame_t s = tf_step(k_step, t_us);
    feed(s);
    TEST_ASSERT_EQUAL_INT(-EALREADY, feed_rc(s));
    TEST_ASSERT_EQUAL_UINT32(steps + 1u, app.steps);
}

static void test_app_safety_step_time_going_back_times_the_inputs_out(void)
{
    drive(5);
    /* A STEP whose time goes back is a wrap: 71.6 min later for the
     * firmware. The inputs of this step are fresh, so it still runs; the
     * ramp of a later halt uses at most APP_MAX_DT_US. */
    full_step();
    t_us = 0u;
    full_step();
    TEST_ASSERT_EQUAL_UINT32(1, app.time_wraps);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    t_us = 0xFFFFFFF0u; /* a huge step forward: the ramp saturates at 1 s: 100 rad/s */
    full_step();
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
}

/* ------------------------------------------------------------------ bus-off */

static void test_app_safety_bus_off_halts_and_blocks_the_rearm(void)
{
    hal_fake.can_status_rc = 0;
    hal_fake.can_status.state = HAL_CAN_STATE_ERROR_ACTIVE;
    drive(3);
    hal_fake.can_status.state = HAL_CAN_STATE_BUS_OFF;
    hal_fake.can_status.bus_off = 1;
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_BUS_OFF, tf_last_status().status_halt);
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 71680 - 2560, tf_last_wheels().wheel_cmd_left);
    for (unsigned k = 0; k < 5u; k++) {
        full_step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_REJECTED, arm_cmd(1.0f));
    hal_fake.can_status.state = HAL_CAN_STATE_ERROR_ACTIVE; /* recovered */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f));
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
}

static void test_app_safety_a_bus_off_between_steps_halts_too(void)
{
    /* Bus-off and automatic recovery between two looks: the count moved. */
    hal_fake.can_status_rc = 0;
    hal_fake.can_status.state = HAL_CAN_STATE_ERROR_ACTIVE;
    hal_fake.can_status.bus_off = 7;
    drive(3);
    hal_fake.can_status.bus_off = 8;
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_BUS_OFF, tf_last_status().status_halt);
}

/* ------------------------------------------------------------ parameters */

static void test_app_safety_every_parameter_reads_back_its_default(void)
{
    /* Table 1, the default geometry and the halt's deceleration (125 rad/s²:
     * 100 rad/s stopped within 0.8 s), in index order; then index 14, the
     * strategy: 1, "mstc", the board images' default; 15 and 16 the wheels
     * of a 37D-class gearmotor, 20 rad/s² and 0.06 s (ctl_params.toml). */
    TEST_ASSERT_EQUAL_INT(0, app_init(&app, NULL));
    const float want[COMM_PARAM_COUNT] = { 0.2f, 0.1f, 3.5f, 0.5f,  0.35f, 3.0f,   12.0f,
                                           6.0f, 3.0f, 6.0f, 0.05f, 0.3f,  100.0f, 125.0f };
    for (uint8_t i = 0; i < COMM_PARAM_COUNT; i++) {
        feed(tf_param_get(i));
        TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
        TEST_ASSERT_FLOAT_WITHIN(1e-4f, want[i], tf_last_param_value().param_value_value);
    }
    feed(tf_param_get(14));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    TEST_ASSERT_EQUAL_FLOAT(1.0f, tf_last_param_value().param_value_value);
    feed(tf_param_get(15));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    TEST_ASSERT_FLOAT_WITHIN(1e-4f, 20.0f, tf_last_param_value().param_value_value);
    feed(tf_param_get(16));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    TEST_ASSERT_FLOAT_WITHIN(1e-4f, 0.06f, tf_last_param_value().param_value_value);
    feed(tf_param_get(26)); /* 17..25: the wheel loop's (firmware/wheel) */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_UNKNOWN_INDEX, tf_last_param_value().param_value_result);
}

static void test_app_safety_an_obstacle_reported_twice_in_a_step_counts_once(void)
{
    arm();
    odom();
    ref();
    uint8_t p[8] = { 0 };
    /* x raw 4096: 2 m at 2^-11 m (mstc.dbc), within D_det. */
    const struct mstc_dbc_obstacle_t o = { .obstacle_id = 4,
                                           .obstacle_x = 4096,
                                           .obstacle_radius = 10 };
    (void)mstc_dbc_obstacle_pack(p, &o, 8);
    feed(tf_seal(COMM_ID_OBSTACLE, p));
    feed(tf_seal(COMM_ID_OBSTACLE, p));
    TEST_ASSERT_EQUAL_UINT8(1, app.n_reports);
    step();
    TEST_ASSERT_EQUAL_UINT8(1, app.ctl.sup.n_obs);
}

/* OBSTACLE @p id at x = 2 m + id·2^-11 m (raw 4096 + id, mstc.dbc), of
 * radius @p radius_cm. */
static void obstacle_frame(uint8_t id, uint8_t radius_cm)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_obstacle_t o = { .obstacle_id = id,
                                           .obstacle_x = 4096 + id,
                                           .obstacle_radius = radius_cm };
    (void)mstc_dbc_obstacle_pack(p, &o, 8);
    feed(tf_seal(COMM_ID_OBSTACLE, p));
}

static void test_app_safety_at_most_a_table_of_obstacles_a_step(void)
{
    arm();
    odom();
    ref();
    /* Every id OBSTACLE carries, 1..48: one report each, as many as the
     * table holds. */
    TEST_ASSERT_EQUAL_UINT(48u, SUP_MAX_OBSTACLES);
    for (uint8_t id = 1; id <= 48u; id++) {
        obstacle_frame(id, (uint8_t)(10 + id));
    }
    TEST_ASSERT_EQUAL_UINT8(48, app.n_reports);
    TEST_ASSERT_EQUAL_UINT8(48, app.reports[47].id);
    /* Id 49 fits the 6-bit field but not the DBC's range: the 49th distinct
     * id of the step finds no room and is dropped; id 1 again replaces the
     * first report (radius 0.99 m). */
    obstacle_frame(49, 10);
    TEST_ASSERT_EQUAL_UINT8(48, app.n_reports);
    TEST_ASSERT_EQUAL_UINT8(48, app.reports[47].id);
    obstacle_frame(1, 99);
    TEST_ASSERT_EQUAL_UINT8(48, app.n_reports);
    TEST_ASSERT_EQUAL_UINT8(99, (uint8_t)lround(tu_dbl(app.reports[0].radius) * 100.0));
    /* The step takes all 48 into the table (each 2 m ahead, within D_det). */
    step();
    TEST_ASSERT_EQUAL_UINT8(48, app.ctl.sup.n_obs);
}

/* OBSTACLE_VEL of id @p id: vx raw @p vx_raw (2^-10 m/s), vy 0. */
static void velocity_frame(uint8_t id, int16_t vx_raw)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_obstacle_vel_t v = { .obstacle_vel_id = id, .obstacle_vel_vx = vx_raw };
    (void)mstc_dbc_obstacle_vel_pack(p, &v, 8);
    feed(tf_seal(COMM_ID_OBSTACLE_VEL, p));
}

/* docs/protocol.md, OBSTACLE_VEL: each OBSTACLE frame sets its id's velocity
 * to zero, the OBSTACLE_VEL after it gives it. Obstacle 4 at 2 m with 0.25
 * m/s (raw 256) after it: the table's entry moves at 0.25 m/s ("mstc", the
 * default strategy, keeps velocities). The next step the same OBSTACLE
 * without its OBSTACLE_VEL: static (an id given to another obstacle carries
 * no velocity over). An OBSTACLE_VEL before its OBSTACLE: zeroed by it. */
static void test_app_safety_an_obstacle_without_its_velocity_frame_is_static(void)
{
    arm();
    odom();
    ref();
    obstacle_frame(4, 10);
    velocity_frame(4, 256);
    step();
    TEST_ASSERT_EQUAL_UINT8(1, app.ctl.sup.n_obs);
    TEST_ASSERT_TRUE(app.ctl.sup.obs[0].o.vx == NUM_C(0.25));
    odom();
    ref();
    obstacle_frame(4, 10);
    step();
    TEST_ASSERT_TRUE(app.ctl.sup.obs[0].o.vx == NUM_ZERO);
    odom();
    ref();
    velocity_frame(4, 256);
    obstacle_frame(4, 10);
    step();
    TEST_ASSERT_TRUE(app.ctl.sup.obs[0].o.vx == NUM_ZERO);
}

static void test_app_safety_standing_reference_is_stop_not_a_halt(void)
{
    /* v_r = ω_r = 0: the supervisor's p3, mode STOP, heartbeat STOPPED. */
    arm();
    feed(tf_odom_xy(0.0, 0.0));
    feed(tf_odom_theta(0.0));
    feed(tf_ref_xy(1.0, 0.0));
    feed(tf_ref_motion(0.0, 0.0, 0.0));
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    TEST_ASSERT_EQUAL_UINT8(SUP_MODE_STOP, tf_last_status().status_mode);
    TEST_ASSERT_EQUAL_INT(COMM_STATE_STOPPED, app.state);
}

/* ------------------------------------------------------------ WHEEL_SPEED */

static void test_app_safety_wheel_speeds_never_sent_are_not_needed(void)
{
    /* drive() sends none: the firmware predicts them (app.h). */
    drive(5);
}

static void test_app_safety_wheel_speeds_lost_while_moving_halt_at_the_third_step(void)
{
    arm();
    /* WHEEL_SPEED with the first steps, then only odometry and reference: as
     * odometry, the steps k+1 and k+2 after the last still run, k+3 halts
     * with reason 7 (six steps: fewer than odometry that stands while the
     * wheels turn needs to be implausible, odo.h). */
    for (unsigned k = 0; k < 3u; k++) {
        feed(tf_wheel_speed(70.0, 70.0));
        full_step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    }
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, tf_last_status().status_halt);
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 71680 - 2560, tf_last_wheels().wheel_cmd_left);
}

static void test_app_safety_odometry_follows_the_measured_speeds_not_the_commands(void)
{
    /* Wheels that lag: the firmware commands about 70 rad/s (0.07 m a step
     * at r = 0.05 m), the wheels have not moved yet and say so (0 rad/s),
     * and odometry stands at the origin. Judged against the commands, each
     * step disagrees by 0.07 m, 0.015 m beyond its allowance (0.02 + 0.5 ×
     * 0.07, odo.h), so the sum passes 0.1 m within 20 steps; judged against
     * the measured speeds it agrees at every step. */
    arm();
    for (unsigned k = 0; k < 20u; k++) {
        feed(tf_wheel_speed(0.0, 0.0));
        full_step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    }
    TEST_ASSERT_GREATER_THAN_INT32(60 * 1024, tf_last_wheels().wheel_cmd_left);
    /* Without WHEEL_SPEED from the start, the same odometry halts. */
    setUp();
    arm();
    for (unsigned k = 0; k < 20u; k++) {
        full_step();
        if (tf_last_status().status_halt != COMM_HALT_NONE) {
            break;
        }
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY_IMPLAUSIBLE, tf_last_status().status_halt);
}

static void test_app_safety_wheel_speeds_lost_while_standing_do_not_halt(void)
{
    /* The reference stands (v_r = ω_r = 0) on the robot: p3, the wheels at
     * zero; measured zero, then no more WHEEL_SPEED: nothing moves, no
     * halt. */
    arm();
    for (unsigned k = 0; k < 4u; k++) {
        feed(tf_wheel_speed(0.0, 0.0));
        feed(tf_odom_xy(0.0, 0.0));
        feed(tf_odom_theta(0.0));
        feed(tf_ref_xy(0.0, 0.0));
        feed(tf_ref_motion(0.0, 0.0, 0.0));
        step();
    }
    for (unsigned k = 0; k < 6u; k++) {
        feed(tf_odom_xy(0.0, 0.0));
        feed(tf_odom_theta(0.0));
        feed(tf_ref_xy(0.0, 0.0));
        feed(tf_ref_motion(0.0, 0.0, 0.0));
        step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
        TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
    }
}

/* Three steps with WHEEL_SPEED (@p left, @p right) and the reference
 * (@p v_r, @p w_r) standing on the robot at the origin, then three without
 * WHEEL_SPEED: the halt the last of them gives (as odometry: the steps k+1
 * and k+2 after the last frame run, k+3 decides). */
static uint8_t wheel_speeds_lost(double left, double right, double v_r, double w_r)
{
    for (unsigned k = 0; k < 6u; k++) {
        if (k < 3u) {
            feed(tf_wheel_speed(left, right));
        }
        feed(tf_odom_xy(0.0, 0.0));
        feed(tf_odom_theta(0.0));
        feed(tf_ref_xy(0.0, 0.0));
        feed(tf_ref_motion(0.0, v_r, w_r));
        step();
        if (k < 5u) {
            TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
        }
    }
    return tf_last_status().status_halt;
}

static void test_app_safety_wheel_speeds_lost_while_only_measured_moving_halt(void)
{
    /* The reference stands on the robot (p3): both wheels commanded 0. But
     * the last WHEEL_SPEED said one wheel turned (1 rad/s: the robot pushed,
     * or coasting), on the left, then on the right: the wheels move ("last
     * measured", app.c), so losing WHEEL_SPEED halts, as while driving. (At
     * 0.05 m/s the pose that stands still is within odometry's allowance,
     * 1 mm a step against 20 mm: no odometry halt.) */
    arm();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, wheel_speeds_lost(1.0, 0.0, 0.0, 0.0));
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_right);
    setUp();
    arm();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, wheel_speeds_lost(0.0, 1.0, 0.0, 0.0));
}

static void test_app_safety_wheel_speeds_lost_while_pivoting_on_the_left_wheel_halt(void)
{
    /* A pivot about the left wheel: "paper" tracking with the robot on its
     * reference (e = 0) commands v = v_r, ω = ω_r (eq. 2-3); with L = 0.25 m,
     * ω_r = 1 rad/s and v_r = ω_r L/2 = 0.125 m/s the left wheel is
     * (v − ω L/2)/r = 0 exactly and the right (v + ω L/2)/r = 5 rad/s
     * (5120 lsb; every value a power of two or exact in both modes). The
     * wheels measured standing: only the command moves, on the right wheel
     * alone; losing WHEEL_SPEED halts. */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, set_param((uint8_t)CTL_P_STRATEGY, 0.0f));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, set_param(COMM_PARAM_TRACK_WIDTH, 0.25f));
    k_step = 0;
    t_us = 0;
    for (unsigned k = 0; k < APP_REARM_FRAMES; k++) {
        feed(tf_odom_xy(0.0, 0.0));
        feed(tf_odom_theta(0.0));
        feed(tf_ref_xy(0.0, 0.0));
        feed(tf_ref_motion(0.0, 0.125, 1.0));
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f));
    for (unsigned k = 0; k < 3u; k++) {
        feed(tf_wheel_speed(0.0, 0.0));
        feed(tf_odom_xy(0.0, 0.0));
        feed(tf_odom_theta(0.0));
        feed(tf_ref_xy(0.0, 0.0));
        feed(tf_ref_motion(0.0, 0.125, 1.0));
        step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
        TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
        TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 5120, tf_last_wheels().wheel_cmd_right);
    }
    for (unsigned k = 0; k < 3u; k++) {
        feed(tf_odom_xy(0.0, 0.0));
        feed(tf_odom_theta(0.0));
        feed(tf_ref_xy(0.0, 0.0));
        feed(tf_ref_motion(0.0, 0.125, 1.0));
        step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, tf_last_status().status_halt);
}

/* Issue 30, C1: three WHEEL_SPEED frames from a node without the key (good
 * CRC and counter need no key) while the robot stands, not armed, then
 * nothing more from it. Whatever they set must end when the node stops
 * (docs/safety.md, "Threat model"): ten quiet steps later the robot is armed
 * and drives as if they had never come (70 rad/s, no halt), where the flag
 * they once set made every later arm halt with reason 7 after one step. */
static void test_app_safety_wheel_speeds_from_a_node_gone_quiet_do_not_halt_a_later_arm(void)
{
    k_step = 0;
    t_us = 0;
    for (unsigned k = 0; k < 3u; k++) {
        feed(tf_wheel_speed(5.0, 5.0));
        full_step();
    }
    for (unsigned k = 0; k < 10u; k++) {
        full_step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, tf_last_status().status_halt);
    for (unsigned k = 0; k < APP_REARM_FRAMES; k++) {
        odom();
        ref();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f));
    for (unsigned k = 0; k < 5u; k++) {
        full_step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
        TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_left);
    }
}

static void test_app_safety_ref_motion_alone_lost_is_a_reference_halt(void)
{
    drive(5);
    for (unsigned k = 0; k < 3u; k++) {
        odom();
        feed(tf_ref_xy(1.0, 0.0));
        step();
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_REFERENCE, tf_last_status().status_halt);
}

static void test_app_safety_a_step_at_the_same_time_ramps_nothing_and_long_halts_saturate(void)
{
    drive(3);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    t_us -= DT_US; /* the same time as the last step: dt = 0 */
    full_step();
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_left);
    for (unsigned k = 0; k < 300u; k++) { /* no inputs: the miss counts saturate */
        step();
    }
    TEST_ASSERT_EQUAL_UINT8(UINT8_MAX, app.in[APP_IN_ODOM_XY].missed);
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
}

/* ------------------------------------------------------------- real time */

static void test_app_safety_real_time_mode_needs_no_step_and_times_out(void)
{
    arm();
    uint64_t now = 1000000u;
    for (unsigned k = 0; k < 5u; k++) {
        odom();
        ref();
        hal_fake.n_sent = 0;
        app_control_tick(&app, now);
        now += DT_US;
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
        TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, tf_last_wheels().wheel_cmd_left);
    }
    for (unsigned k = 0; k < 3u; k++) {
        hal_fake.n_sent = 0;
        app_control_tick(&app, now);
        now += DT_US;
    }
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, tf_last_status().status_halt);
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 71680 - 2560, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(2e-3, 1e-2), 70.0 - 2.5, app_last_wheels(&app)->left);
}

/* ---------------------------------------------------------------- issue 13 */

/* Case 1: a deceleration that cannot stop the wheels in time. A halt must
 * ramp the wheels from max_wheel_speed (100 rad/s) to zero within 0.8 s, so
 * max_wheel_decel >= 100 / 0.8 = 125 rad/s². 1e-6 is below every bound (and
 * rounds to 0 in Q16.16): out of range. 124 is within its own range but not
 * enough for this wheel limit: rejected. Either way the value in force is
 * kept. 125 is accepted. */
static void test_app_safety_a_deceleration_too_small_to_stop_in_time_is_refused(void)
{
    feed(tf_param_get(COMM_PARAM_MAX_WHEEL_DECEL));
    const float before = tf_last_param_value().param_value_value;
    (void)set_param(COMM_PARAM_MAX_WHEEL_DECEL, 1e-6f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OUT_OF_RANGE, tf_last_param_value().param_value_result);
    TEST_ASSERT_EQUAL_FLOAT(before, tf_last_param_value().param_value_value);
    (void)set_param(COMM_PARAM_MAX_WHEEL_DECEL, 124.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_REJECTED, tf_last_param_value().param_value_result);
    TEST_ASSERT_EQUAL_FLOAT(before, tf_last_param_value().param_value_value);
    (void)set_param(COMM_PARAM_MAX_WHEEL_DECEL, 125.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    TEST_ASSERT_EQUAL_FLOAT(125.0f, tf_last_param_value().param_value_value);
}

/* Cases 1 and 7: the figures of README.md and docs/safety.md, by hand. With
 * the reference 2 m ahead both wheels want 130 rad/s and run at the limit,
 * 100 rad/s (102400 lsb). The last odometry frame comes with step k; steps
 * k+1 and k+2 still run, k+3 flags the halt (3 control periods) and ramps:
 * 125 rad/s² × 20 ms = 2.5 rad/s a step, 40 steps from 100 rad/s, the
 * first at k+3: zero at step k+42, 0.84 s after the last frame, within
 * 1 s. */
static void test_app_safety_a_halt_stops_the_wheels_from_their_limit_within_1_s(void)
{
    arm();
    for (unsigned k = 0; k < 3u; k++) {
        feed(tf_odom_xy(0.0, 0.0));
        feed(tf_odom_theta(0.0));
        feed(tf_ref_xy(2.0, 0.0));
        feed(tf_ref_motion(0.0, 0.5, 0.0));
        step();
        TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 102400, tf_last_wheels().wheel_cmd_left);
    }
    int32_t prev = tf_last_wheels().wheel_cmd_left;
    for (unsigned n = 1; n <= 45u; n++) { /* step k + n: no odometry */
        feed(tf_ref_xy(2.0, 0.0));
        feed(tf_ref_motion(0.0, 0.5, 0.0));
        step();
        const struct mstc_dbc_wheel_cmd_t w = tf_last_wheels();
        const uint8_t halt = tf_last_status().status_halt;
        TEST_ASSERT_EQUAL_UINT8(n < 3u ? COMM_HALT_NONE : COMM_HALT_ODOMETRY, halt);
        TEST_ASSERT_EQUAL_INT32(w.wheel_cmd_left, w.wheel_cmd_right); /* straight on */
        TEST_ASSERT_TRUE(w.wheel_cmd_left <= prev);
        if (n >= 3u && n <= 42u) { /* 100 − 2.5 (n − 2) rad/s */
            const int32_t want = 102400 - 2560 * (int32_t)(n - 2u);
            TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW * (int32_t)n, want, w.wheel_cmd_left);
        }
        if (n >= 43u) {
            TEST_ASSERT_EQUAL_INT32(0, w.wheel_cmd_left);
        }
        prev = w.wheel_cmd_left;
    }
}

/* While armed, a parameter of the control law is refused with result armed
 * (5) and the value in force kept; max_wheel_decel, safety and not control
 * law, is accepted (within its bound); reading is always allowed. Disarmed
 * again, the same set is accepted. */
static void test_app_safety_control_law_parameters_are_refused_while_armed(void)
{
    drive(2);
    for (uint8_t i = 0; i < COMM_PARAM_MAX_WHEEL_DECEL; i++) {
        feed(tf_param_get(i));
        const float before = tf_last_param_value().param_value_value;
        (void)set_param(i, before * 1.01f);
        TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_ARMED, tf_last_param_value().param_value_result);
        TEST_ASSERT_EQUAL_FLOAT(before, tf_last_param_value().param_value_value);
    }
    (void)set_param(COMM_PARAM_MAX_WHEEL_DECEL, 500.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    full_step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt); /* still driving */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    (void)set_param(COMM_PARAM_D_S, 0.4f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    TEST_ASSERT_FLOAT_WITHIN(1e-4f, 0.4f, tf_last_param_value().param_value_value);
}

/* A halt ramps at the deceleration in force when it began: lowering the
 * wheel limit and then the deceleration while halted (both allowed then)
 * cannot slow the stop under way. Disarmed at 70 rad/s with 125 rad/s²
 * (2.5 rad/s a step); then max_wheel_speed 10 and max_wheel_decel 12.5
 * (0.25 rad/s a step): the wheels still lose 2.5 rad/s a step, and are at
 * zero 28 steps after the disarm. The next halt uses 12.5. */
static void test_app_safety_a_halt_keeps_the_deceleration_it_began_with(void)
{
    drive(2);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    full_step();
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 71680 - 2560, tf_last_wheels().wheel_cmd_left);
    (void)set_param(COMM_PARAM_MAX_WHEEL_SPEED, 10.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    (void)set_param(COMM_PARAM_MAX_WHEEL_DECEL, 12.5f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, tf_last_param_value().param_value_result);
    for (unsigned k = 2; k <= 27u; k++) {
        full_step();
        TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW * (int32_t)k, 71680 - 2560 * (int32_t)k,
                                 tf_last_wheels().wheel_cmd_left);
    }
    full_step(); /* 28: 0.0 left, as 70 = 28 × 2.5 */
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
    /* Re-armed, the robot runs at the new limit, 10 rad/s; the next halt
     * ramps at 12.5 rad/s²: 0.25 rad/s (256 lsb) a step. */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(1.0f));
    full_step();
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 10240, tf_last_wheels().wheel_cmd_left);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    full_step();
    TEST_ASSERT_INT32_WITHIN(TOL_RAMP_RAW, 10240 - 256, tf_last_wheels().wheel_cmd_left);
}

/* A value that is not a number is out of range for every parameter. */
static void test_app_safety_a_non_finite_parameter_value_is_out_of_range(void)
{
    const float bad[] = { NAN, INFINITY, -INFINITY };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        (void)set_param(COMM_PARAM_TRK_K1, bad[i]);
        TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OUT_OF_RANGE, tf_last_param_value().param_value_result);
        TEST_ASSERT_EQUAL_FLOAT(3.0f, tf_last_param_value().param_value_value);
    }
    /* The strategy (14) is a whole 0 or 1: 0.5 and 2 are out of range. */
    (void)set_param(14, 0.5f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OUT_OF_RANGE, tf_last_param_value().param_value_result);
    (void)set_param(14, 2.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OUT_OF_RANGE, tf_last_param_value().param_value_result);
    TEST_ASSERT_EQUAL_FLOAT(1.0f, tf_last_param_value().param_value_value);
    /* And an index the table does not hold. */
    (void)set_param(26, 0.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_UNKNOWN_INDEX, tf_last_param_value().param_value_result);
}

/* Index 24 was wheel_ramp, folded into wheel_accel (15): reserved, so an old
 * tool's PARAM_SET 24 is refused and sets nothing, nor is it read. */
static void test_app_safety_the_reserved_index_of_wheel_ramp_is_unknown(void)
{
    const ctl_params_t before = app.ctl.p;
    (void)set_param(24, 125.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_UNKNOWN_INDEX, tf_last_param_value().param_value_result);
    TEST_ASSERT_EQUAL_MEMORY(&before, &app.ctl.p, sizeof before);
    feed(tf_param_get(24));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_UNKNOWN_INDEX, tf_last_param_value().param_value_result);
}

/* The wheel loop's ramp (app_wheel_accel()): wheel_accel while running;
 * while halted at least the halt's deceleration, so that a halt's ramp
 * reaches the wheels unslowed. By hand: wheel_accel 20 against the default
 * max_wheel_decel, 125 rad/s². */
static void test_app_safety_the_wheel_loop_ramps_at_wheel_accel_and_passes_a_halt(void)
{
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, set_param(15, 20.0f)); /* not armed: accepted */
    TEST_ASSERT_NUM_WITHIN(1e-3, 125.0, app_wheel_accel(&app));   /* halted: not armed */
    arm();
    TEST_ASSERT_NUM_WITHIN(1e-3, 20.0, app_wheel_accel(&app));
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, arm_cmd(0.0f));
    TEST_ASSERT_NUM_WITHIN(1e-3, 125.0, app_wheel_accel(&app));
    /* Wheels faster than the halt: their own figure. */
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, set_param(15, 400.0f));
    TEST_ASSERT_NUM_WITHIN(1e-2, 400.0, app_wheel_accel(&app));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_app_safety_starts_halted_not_armed_and_stands_still);
    RUN_TEST(test_app_safety_arm_needs_five_good_frames_of_every_input);
    RUN_TEST(test_app_safety_arm_command_other_values_and_get);
    RUN_TEST(test_app_safety_disarm_halts_with_a_ramp);
    RUN_TEST(test_app_safety_heartbeat_says_ready_when_not_armed_and_fault_when_halted);
    RUN_TEST(test_app_safety_odometry_lost_halts_at_the_third_step);
    RUN_TEST(test_app_safety_reference_lost_halts_with_its_reason);
    RUN_TEST(test_app_safety_one_theta_frame_lost_is_enough);
    RUN_TEST(test_app_safety_timeout_counts_time_too);
    RUN_TEST(test_app_safety_ramp_keeps_the_curvature_and_ends_at_zero);
    RUN_TEST(test_app_safety_deceleration_is_a_parameter);
    RUN_TEST(test_app_safety_halt_latches_until_rearmed_after_five_good_frames);
    RUN_TEST(test_app_safety_rearm_refused_until_the_inputs_ran_five_steps);
    RUN_TEST(test_app_safety_corrupted_frames_are_never_used);
    RUN_TEST(test_app_safety_two_corrupted_frames_in_the_window_halt_at_once);
    RUN_TEST(test_app_safety_duplicated_frames_are_tolerated);
    RUN_TEST(test_app_safety_a_step_with_a_bad_step_history_halts);
    RUN_TEST(test_app_safety_replayed_step_runs_no_step);
    RUN_TEST(test_app_safety_step_time_going_back_times_the_inputs_out);
    RUN_TEST(test_app_safety_bus_off_halts_and_blocks_the_rearm);
    RUN_TEST(test_app_safety_a_bus_off_between_steps_halts_too);
    RUN_TEST(test_app_safety_every_parameter_reads_back_its_default);
    RUN_TEST(test_app_safety_an_obstacle_reported_twice_in_a_step_counts_once);
    RUN_TEST(test_app_safety_at_most_a_table_of_obstacles_a_step);
    RUN_TEST(test_app_safety_an_obstacle_without_its_velocity_frame_is_static);
    RUN_TEST(test_app_safety_standing_reference_is_stop_not_a_halt);
    RUN_TEST(test_app_safety_ref_motion_alone_lost_is_a_reference_halt);
    RUN_TEST(test_app_safety_wheel_speeds_never_sent_are_not_needed);
    RUN_TEST(test_app_safety_wheel_speeds_lost_while_moving_halt_at_the_third_step);
    RUN_TEST(test_app_safety_odometry_follows_the_measured_speeds_not_the_commands);
    RUN_TEST(test_app_safety_wheel_speeds_lost_while_standing_do_not_halt);
    RUN_TEST(test_app_safety_wheel_speeds_lost_while_only_measured_moving_halt);
    RUN_TEST(test_app_safety_wheel_speeds_lost_while_pivoting_on_the_left_wheel_halt);
    RUN_TEST(test_app_safety_wheel_speeds_from_a_node_gone_quiet_do_not_halt_a_later_arm);
    RUN_TEST(test_app_safety_a_step_at_the_same_time_ramps_nothing_and_long_halts_saturate);
    RUN_TEST(test_app_safety_real_time_mode_needs_no_step_and_times_out);
    RUN_TEST(test_app_safety_a_deceleration_too_small_to_stop_in_time_is_refused);
    RUN_TEST(test_app_safety_a_halt_stops_the_wheels_from_their_limit_within_1_s);
    RUN_TEST(test_app_safety_control_law_parameters_are_refused_while_armed);
    RUN_TEST(test_app_safety_a_halt_keeps_the_deceleration_it_began_with);
    RUN_TEST(test_app_safety_a_non_finite_parameter_value_is_out_of_range);
    RUN_TEST(test_app_safety_the_reserved_index_of_wheel_ramp_is_unknown);
    RUN_TEST(test_app_safety_the_wheel_loop_ramps_at_wheel_accel_and_passes_a_halt);
    return UNITY_END();
}
