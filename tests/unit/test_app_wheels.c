/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of where the application's measured wheel speeds come from
 * (app.h, docs/wheel.md "Two topologies"): the integrated board's own wheel
 * loop (APP_WHEELS_OWN, app_wheels_measured()) or the external drives'
 * WHEEL_SPEED frames (APP_WHEELS_EXTERNAL), the halt rules of each, and the
 * WHEEL_SPEED the integrated board sends. The HAL is hal/fake.
 *
 * What the control step took is read where "mstc" keeps it: its wheel
 * estimate (ctl_t::act.est) is the measured speeds when a step has them
 * (act.h), the prediction from its commands otherwise. Expected values by
 * hand: the robot at the origin heading east, the reference 1 m ahead at
 * 0.5 m/s, both wheels commanded 70 rad/s (test_app.c); WHEEL_SPEED's scale
 * 2^-10 rad/s.
 */
#include <errno.h>
#include <string.h>

#include "app/app.h"
#include "comm/mstc_dbc.h"
#include "hal_fake.h"
#include "test_frames.h"
#include "test_util.h"
#include "wheel/whl.h"

static app_t app;
static uint16_t k_step;
static uint32_t t_us;

#define DT_US     20000u
/* A wheel loop's estimate at a step: half its 10 ms window, 1 ms after its
 * last period. */
#define AGE_US    6000u
/* Measured speeds cross no frame here: exact in float, within Q16.16. */
#define TOL_SPEED TU_TOL(1e-6, 2e-5)

void setUp(void)
{
    tf_app_start(&app, -ENOTSUP);
    tf_auth = &app.auth;
    k_step = 0;
    t_us = 0;
}

void tearDown(void) {}

static void feed(hal_can_frame_t f) { TEST_ASSERT_EQUAL_INT(0, app_on_frame(&app, &f)); }

static void inputs(void)
{
    feed(tf_odom_xy(0.0, 0.0));
    feed(tf_odom_theta(0.0));
    feed(tf_ref_xy(1.0, 0.0));
    feed(tf_ref_motion(0.0, 0.5, 0.0));
}

static void arm(float value)
{
    hal_can_frame_t f[2];
    tf_param_set_auth(COMM_PARAM_ARM, value, f);
    feed(f[0]);
    feed(f[1]);
}

static void start(app_wheel_source_t source)
{
    app_set_wheel_source(&app, source);
    for (unsigned k = 0; k < APP_REARM_FRAMES; k++) {
        inputs();
    }
    arm(1.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, app.halt);
}

/* Inputs, then a STEP; what the firmware sent is that step's. */
static void step(void)
{
    inputs();
    hal_fake.n_sent = 0;
    feed(tf_step(k_step++, t_us));
    t_us += DT_US;
}

static void own(double left, double right, uint8_t faults)
{
    const kin_wheels_t w = { tu_num(left), tu_num(right) };
    app_wheels_measured(&app, &w, faults, AGE_US);
}

static uint8_t halt(void) { return tf_last_status().status_halt; }

/* The WHEEL_SPEED the firmware sent at the last step, unpacked. */
static struct mstc_dbc_wheel_speed_t sent_wheel_speed(void)
{
    struct mstc_dbc_wheel_speed_t s;
    TEST_ASSERT_EQUAL_INT(
        0, mstc_dbc_wheel_speed_unpack(&s, tf_last_sent(COMM_ID_WHEEL_SPEED)->data, 8));
    return s;
}

/* Where the first frame @p id is among those sent at the last step;
 * hal_fake.n_sent when none. */
static unsigned index_of(uint32_t id)
{
    unsigned i = 0;
    while (i < hal_fake.n_sent && hal_fake.sent[i].id != id) {
        i++;
    }
    return i;
}

static bool sent(uint32_t id) { return index_of(id) < hal_fake.n_sent; }

/* ---------------------------------------------------------- the source */

static void test_app_wheels_external_by_default_the_bus_is_the_input(void)
{
    TEST_ASSERT_EQUAL_UINT8(APP_WHEELS_EXTERNAL, app.wheel_source);
    start(APP_WHEELS_EXTERNAL);
    /* Two frames at two steps: the first leaves WHEEL_SPEED's state machine
     * in INIT (not usable, forgotten), the second makes it VALID. */
    feed(tf_wheel_speed(5.0, -6.0));
    step();
    feed(tf_wheel_speed(5.0, -6.0));
    own(1.0, 2.0, 0u); /* ignored: no wheel loop of its own */
    step();
    TEST_ASSERT_NUM_WITHIN(TOL_SPEED, 5.0, app.ctl.act.est.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SPEED, -6.0, app.ctl.act.est.right);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, halt());
    TEST_ASSERT_FALSE(sent(COMM_ID_WHEEL_SPEED)); /* the drives report, not the board */
}

static void test_app_wheels_own_takes_the_wheel_loops_and_ignores_the_bus(void)
{
    start(APP_WHEELS_OWN);
    /* A wrong WHEEL_SPEED on the bus, then the wheel loop's measurement:
     * the step takes the wheel loop's. */
    feed(tf_wheel_speed(50.0, -60.0));
    own(1.0, 2.0, 0u);
    step();
    TEST_ASSERT_NUM_WITHIN(TOL_SPEED, 1.0, app.ctl.act.est.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SPEED, 2.0, app.ctl.act.est.right);
    /* The measurement after the frame: the same. */
    own(3.0, 4.0, 0u);
    feed(tf_wheel_speed(50.0, -60.0));
    step();
    TEST_ASSERT_NUM_WITHIN(TOL_SPEED, 3.0, app.ctl.act.est.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SPEED, 4.0, app.ctl.act.est.right);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, halt());
    TEST_ASSERT_EQUAL_UINT8(0u, app.wheel_faults);
}

static void test_app_wheels_own_sends_what_it_measured_first_with_the_faults(void)
{
    start(APP_WHEELS_OWN);
    own(12.5, -0.75, 0u);
    step();
    /* First of the step's frames (after the housekeeping's, which every
     * step may begin with): before STATUS. */
    TEST_ASSERT_TRUE(index_of(COMM_ID_WHEEL_SPEED) < index_of(COMM_ID_STATUS));
    struct mstc_dbc_wheel_speed_t s = sent_wheel_speed();
    TEST_ASSERT_EQUAL_INT32(12800, s.wheel_speed_left); /* 12.5 · 1024 */
    TEST_ASSERT_EQUAL_INT32(-768, s.wheel_speed_right);
    TEST_ASSERT_EQUAL_UINT8(0u, s.wheel_speed_faults);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_WHEEL_CMD, hal_fake.sent[hal_fake.n_sent - 1u].id);
    own(0.0, 0.0, (uint8_t)WHL_FAULT_ENCODER_RIGHT);
    step();
    s = sent_wheel_speed();
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_RIGHT, s.wheel_speed_faults);
    /* A step without a measurement sends none. */
    step();
    TEST_ASSERT_FALSE(sent(COMM_ID_WHEEL_SPEED));
}

/* The measurement's age reaches the control step: "mstc" carries the pose
 * over wheel_tau plus the age (act_horizon()), here 0 + 6 ms, where a
 * WHEEL_SPEED is taken as half the period old, 10 ms. The same step run by
 * hand through a copy of the controller, once with the age and once with
 * none: the application's commands are the first's, bit for bit, and the two
 * differ (so the check can tell). */
static void test_app_wheels_own_hands_the_age_to_the_control_step(void)
{
    start(APP_WHEELS_OWN);
    ctl_t with_age = app.ctl;
    ctl_t without = app.ctl;
    const ctl_input_t in = {
        .robot = { NUM_ZERO, NUM_ZERO, NUM_ZERO },
        .ref = { NUM_ONE, NUM_ZERO, NUM_ZERO },
        .v_r = tu_num(0.5),
        .t_us = 0u,
        .wheels = { tu_num(30.0), tu_num(40.0) },
        .wheels_measured = true,
        /* As the application holds a time: through float in both modes. */
        .wheels_age = num_from_float((float)AGE_US * 1.0e-6f),
    };
    ctl_output_t o_age;
    ctl_step(&with_age, &in, &o_age);
    ctl_input_t half = in;
    half.wheels_age = NUM_ZERO;
    ctl_output_t o_half;
    ctl_step(&without, &half, &o_half);
    TEST_ASSERT_TRUE(o_age.wheels.left != o_half.wheels.left ||
                     o_age.wheels.right != o_half.wheels.right);
    own(30.0, 40.0, 0u);
    step();
    TEST_ASSERT_EQUAL_MEMORY(&o_age.wheels, &app.wheels, sizeof app.wheels);
}

/* ---------------------------------------------------------- halt rules */

static void test_app_wheels_own_missing_while_moving_halts_standing_does_not(void)
{
    start(APP_WHEELS_OWN);
    /* The first step stands (the wheels at zero so far): no measurement
     * needed. */
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, halt());
    own(0.0, 0.0, 0u);
    step(); /* now commanded to move */
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, halt());
    TEST_ASSERT_GREATER_THAN_INT32(60 * 1024, tf_last_wheels().wheel_cmd_left);
    /* The wheel loop stops handing its measurement: a fault at once (a board
     * hands one before every step). */
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, halt());
}

static void test_app_wheels_own_fault_halts_and_a_rearm_forgets_it(void)
{
    start(APP_WHEELS_OWN);
    own(0.0, 0.0, 0u);
    step();
    own(0.0, 0.0, (uint8_t)WHL_FAULT_ENCODER_LEFT); /* a dead encoder */
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, halt());
    arm(1.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, app.halt);
    TEST_ASSERT_EQUAL_UINT8(0u, app.wheel_faults);
    own(0.0, 0.0, 0u);
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, halt());
    own(0.0, 0.0, (uint8_t)WHL_FAULT_STALL_RIGHT);
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, halt());
}

static void test_app_wheels_own_bus_frames_that_stop_do_not_halt(void)
{
    /* WHEEL_SPEED frames on the bus, valid, then none: in the integrated
     * topology they are nobody's input, so their loss halts nothing (the
     * external topology halts at the third step, test_app_safety.c). */
    start(APP_WHEELS_OWN);
    for (unsigned k = 0; k < 3u; k++) {
        feed(tf_wheel_speed(70.0, 70.0));
        own(70.0, 70.0, 0u);
        step();
    }
    for (unsigned k = 0; k < 4u; k++) {
        own(70.0, 70.0, 0u);
        step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, halt());
    }
}

static void test_app_wheels_external_fault_bits_halt(void)
{
    start(APP_WHEELS_EXTERNAL);
    feed(tf_wheel_speed(0.0, 0.0));
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, halt());
    /* A drive reports its encoder dead. */
    feed(tf_wheel_speed_faults(0.0, 0.0, (uint8_t)WHL_FAULT_ENCODER_RIGHT));
    step();
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_WHEEL_SPEED, halt());
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_RIGHT, app.wheel_faults);
}

static void test_app_wheels_the_measurement_is_taken_once(void)
{
    /* A measurement serves the step after it only: the next predicts again
     * (the estimate moves from 1 rad/s towards the command, 70). */
    start(APP_WHEELS_OWN);
    own(1.0, 1.0, 0u);
    step();
    TEST_ASSERT_NUM_WITHIN(TOL_SPEED, 1.0, app.ctl.act.est.left);
    TEST_ASSERT_FALSE(app.wheels_handed);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_app_wheels_external_by_default_the_bus_is_the_input);
    RUN_TEST(test_app_wheels_own_takes_the_wheel_loops_and_ignores_the_bus);
    RUN_TEST(test_app_wheels_own_sends_what_it_measured_first_with_the_faults);
    RUN_TEST(test_app_wheels_own_hands_the_age_to_the_control_step);
    RUN_TEST(test_app_wheels_own_missing_while_moving_halts_standing_does_not);
    RUN_TEST(test_app_wheels_own_fault_halts_and_a_rearm_forgets_it);
    RUN_TEST(test_app_wheels_own_bus_frames_that_stop_do_not_halt);
    RUN_TEST(test_app_wheels_external_fault_bits_halt);
    RUN_TEST(test_app_wheels_the_measurement_is_taken_once);
    return UNITY_END();
}
