/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of who may command the robot (docs/safety.md, "Threat model"):
 * PARAM_SET and the arm command are authenticated in the manner of AUTOSAR
 * SecOC (a PARAM_AUTH frame with the low bits of a freshness value and a
 * truncated AES-128-CMAC follows each PARAM_SET); a MAC-less, wrong-key,
 * replayed or stale one is refused (PARAM_VALUE result 4, unauthenticated)
 * and counted (AUTH_STATUS); odometry replayed from an earlier moment halts
 * the robot (STATUS_halt 6). The HAL is hal/fake.
 *
 * Expected MACs are not computed by the code under test: they come from
 * Python's `cryptography` (its CMAC over AES-128), written into this file,
 * for the published test key of RFC 4493 (tests/data/test.key, never a
 * device's) and for a second key.
 */
#include <errno.h>
#include <string.h>

#include "app/app.h"
#include "comm/mstc_dbc.h"
#include "hal_fake.h"
#include "test_frames.h"
#include "test_util.h"

static app_t app;

#define ID_AUTH_STATUS         COMM_ID_AUTH_STATUS
#define RESULT_UNAUTHENTICATED COMM_PARAM_UNAUTHENTICATED
#define HALT_ODOMETRY_REPLAYED COMM_HALT_ODOMETRY_IMPLAUSIBLE

#define DT_US 20000u

void setUp(void) { tf_app_start(&app, -ENOTSUP); }

void tearDown(void) {}

static int feed_rc(hal_can_frame_t f) { return app_on_frame(&app, &f); }
static void feed(hal_can_frame_t f) { TEST_ASSERT_EQUAL_INT(0, feed_rc(f)); }

/* The status the firmware sent last, both halves, read by hand from the
 * layout of mstc.dbc: AUTH_STATUS (outcome of the last decision, session,
 * refusals and their flag) and AUTH_CHALLENGE (freshness decided, MAC). */
typedef struct {
    unsigned last;
    uint32_t session;
    unsigned refused;
    bool saturated;
    uint32_t freshness;
    uint8_t mac[4];
} auth_status_t;

static auth_status_t last_auth_status(void)
{
    const hal_can_frame_t *f = tf_last_sent(ID_AUTH_STATUS);
    const hal_can_frame_t *c = tf_last_sent(COMM_ID_AUTH_CHALLENGE);
    auth_status_t st = {
        .last = (unsigned)f->data[1] >> 4,
        .session = (uint32_t)f->data[2] | (uint32_t)f->data[3] << 8 | (uint32_t)f->data[4] << 16 |
                   (uint32_t)f->data[5] << 24,
        .refused = (unsigned)f->data[6] | ((unsigned)f->data[7] & 0x7Fu) << 8,
        .saturated = (f->data[7] & 0x80u) != 0u,
        .freshness =
            (uint32_t)c->data[1] >> 4 | (uint32_t)c->data[2] << 4 | (uint32_t)c->data[3] << 12,
    };
    memcpy(st.mac, &c->data[4], 4);
    return st;
}

/* Whether a PARAM_VALUE of @p index with @p result was sent since the fake
 * was last cleared. */
static bool answered(uint8_t index, uint8_t result)
{
    for (unsigned i = 0; i < hal_fake.n_sent; i++) {
        struct mstc_dbc_param_value_t v;
        if (hal_fake.sent[i].id == COMM_ID_PARAM_VALUE &&
            mstc_dbc_param_value_unpack(&v, hal_fake.sent[i].data, 8) == 0 &&
            v.param_value_index == index && v.param_value_result == result) {
            return true;
        }
    }
    return false;
}

/* Whether an AUTH_STATUS with outcome @p last was sent since the fake was
 * last cleared. */
static bool sent_status_with(unsigned last)
{
    for (unsigned i = 0; i < hal_fake.n_sent; i++) {
        if (hal_fake.sent[i].id == ID_AUTH_STATUS && (hal_fake.sent[i].data[1] >> 4) == last) {
            return true;
        }
    }
    return false;
}

/* A genuine command for the firmware's current challenge, as a tool that
 * read the status sends it. */
static void genuine(uint8_t index, float value)
{
    hal_can_frame_t f[2];
    tf_freshness = app.auth.fv;
    tf_param_set_auth(index, value, f);
    feed(f[0]);
    feed(f[1]);
}

/* --------------------------------------------------------------- the loop */

/* A kinematic robot beside the firmware: it moves with the WHEEL_CMD of each
 * step (Euler, dt 20 ms), with the firmware's own wheel radius and track. */
static double px, py, pth;
static uint16_t k_step;
static uint32_t t_us;

static void send_odom(void)
{
    feed(tf_odom_xy(px, py));
    feed(tf_odom_theta(pth));
}

/* The reference: 5 m ahead on the x axis, 0.5 m/s along it. */
static void send_ref(void)
{
    feed(tf_ref_xy(5.0 + 0.5 * t_us * 1e-6, 0.0));
    feed(tf_ref_motion(0.0, 0.5, 0.0));
}

/* One control step; what the firmware sends is recorded from here on. */
static void run_step(void)
{
    hal_fake.n_sent = 0;
    feed(tf_step(k_step++, t_us));
    t_us += DT_US;
    const struct mstc_dbc_wheel_cmd_t w = tf_last_wheels();
    const double r = tu_dbl(app.ctl.p.kin.wheel_radius);
    const double l = tu_dbl(app.ctl.p.kin.track_width);
    const double wl = w.wheel_cmd_left / 1024.0;
    const double wr = w.wheel_cmd_right / 1024.0;
    const double v = r * (wl + wr) / 2.0;
    const double om = r * (wr - wl) / l;
    px += v * cos(pth) * DT_US * 1e-6;
    py += v * sin(pth) * DT_US * 1e-6;
    pth += om * DT_US * 1e-6;
}

static void preroll(void)
{
    px = py = pth = 0.0;
    k_step = 0;
    t_us = 0;
    for (unsigned k = 0; k < APP_REARM_FRAMES; k++) {
        send_odom();
        send_ref();
    }
}

/* A control step with every input fresh. */
static void full_step(void)
{
    send_odom();
    send_ref();
    run_step();
}

/* ------------------------------------------------------------- commands */

static void test_app_auth_a_mac_less_arm_is_refused_and_counted(void)
{
    preroll();
    (void)feed_rc(tf_param_set(COMM_PARAM_ARM, 1.0f));
    /* No PARAM_AUTH follows: refused at the latest at the second control
     * step after it. */
    full_step();
    bool refused = answered(COMM_PARAM_ARM, RESULT_UNAUTHENTICATED);
    full_step();
    refused = refused || answered(COMM_PARAM_ARM, RESULT_UNAUTHENTICATED);
    TEST_ASSERT_TRUE(refused);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, tf_last_status().status_halt);
    TEST_ASSERT_EQUAL_INT32(0, tf_last_wheels().wheel_cmd_left);
    const auth_status_t s = last_auth_status();
    TEST_ASSERT_EQUAL_UINT(1u, s.refused);
    TEST_ASSERT_EQUAL_UINT(1u, s.last); /* missing */
}

static void test_app_auth_a_mac_less_parameter_is_refused_and_not_applied(void)
{
    const float d_s = num_to_float(app.ctl.p.d_s);
    hal_fake.n_sent = 0;
    (void)feed_rc(tf_param_set(COMM_PARAM_D_S, 0.4f));
    /* A second PARAM_SET before any PARAM_AUTH: the first was MAC-less. */
    (void)feed_rc(tf_param_set(COMM_PARAM_D_S, 0.41f));
    TEST_ASSERT_TRUE(answered(COMM_PARAM_D_S, RESULT_UNAUTHENTICATED));
    TEST_ASSERT_EQUAL_FLOAT(d_s, num_to_float(app.ctl.p.d_s));
    TEST_ASSERT_EQUAL_FLOAT(d_s, tf_last_param_value().param_value_value);
    TEST_ASSERT_EQUAL_UINT(1u, last_auth_status().refused);
}

static void test_app_auth_an_arm_under_another_key_is_refused(void)
{
    /* MAC of data ID 0x1120, PARAM_SET bytes 2..7 (index 128, 1.0f, 0),
     * session TF_SESSION and freshness 1 under the key 00 01 .. 0f, not the
     * firmware's (cryptography's CMAC). */
    static const uint8_t mac_other_key[4] = { 0x52, 0x8D, 0x90, 0x4D };
    preroll();
    hal_fake.n_sent = 0;
    (void)feed_rc(tf_param_set(COMM_PARAM_ARM, 1.0f));
    (void)feed_rc(tf_param_auth(1u, mac_other_key));
    TEST_ASSERT_TRUE(answered(COMM_PARAM_ARM, RESULT_UNAUTHENTICATED));
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
    const auth_status_t s = last_auth_status();
    TEST_ASSERT_EQUAL_UINT(1u, s.refused);
    TEST_ASSERT_EQUAL_UINT(AUTH_MAC, s.last);
    TEST_ASSERT_EQUAL_UINT32(1u, s.freshness); /* the challenge 1 is used up */
}

static void test_app_auth_an_authenticated_arm_is_accepted_once(void)
{
    /* MAC of data ID 0x1120, PARAM_SET bytes 2..7 (index 128, 1.0f, 0),
     * session TF_SESSION and freshness 1 under the test key (cryptography's
     * CMAC). */
    static const uint8_t mac[4] = { 0x3A, 0x4C, 0xB7, 0xE5 };
    preroll();
    const hal_can_frame_t set = tf_param_set(COMM_PARAM_ARM, 1.0f);
    const hal_can_frame_t auth = tf_param_auth(1u, mac);
    feed(set);
    TEST_ASSERT_EQUAL_UINT(0u, hal_fake.n_sent); /* nothing before its PARAM_AUTH */
    feed(auth);
    TEST_ASSERT_TRUE(answered(COMM_PARAM_ARM, COMM_PARAM_OK));
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, app.halt);
    TEST_ASSERT_EQUAL_UINT32(1u, last_auth_status().freshness);
    TEST_ASSERT_EQUAL_UINT(AUTH_OK, last_auth_status().last);
    TEST_ASSERT_EQUAL_UINT(0u, last_auth_status().refused);
    /* The pair recorded and played again, E2E counter and CRC made good:
     * refused as stale; disarm first, so that a wrong accept would show. */
    hal_can_frame_t f[2];
    tf_freshness = 1u;
    tf_param_set_auth(COMM_PARAM_ARM, 0.0f, f); /* freshness 2 */
    feed(f[0]);
    feed(f[1]);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
    hal_fake.n_sent = 0;
    feed(tf_seal(COMM_ID_PARAM_SET, set.data));
    feed(tf_seal(COMM_ID_PARAM_AUTH, auth.data));
    TEST_ASSERT_TRUE(answered(COMM_PARAM_ARM, RESULT_UNAUTHENTICATED));
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
    const auth_status_t st = last_auth_status();
    TEST_ASSERT_EQUAL_UINT(1u, st.refused);
    TEST_ASSERT_EQUAL_UINT(AUTH_STALE, st.last);
    TEST_ASSERT_EQUAL_UINT32(3u, st.freshness);
}

static void test_app_auth_the_status_is_authenticated(void)
{
    /* cryptography's CMAC under the test key over 11 87 | outcome 0 |
     * refused 00 00 | 00 00 00 | TF_SESSION | freshness 0, first 4 bytes:
     * the status at start, as HEARTBEAT's housekeeping sends it. */
    static const uint8_t want[4] = { 0x9A, 0x8F, 0xD4, 0x0D };
    hal_fake.n_sent = 0;
    app_housekeeping(&app, 0u);
    const auth_status_t st = last_auth_status();
    TEST_ASSERT_EQUAL_HEX32(TF_SESSION, st.session);
    TEST_ASSERT_EQUAL_UINT32(0u, st.freshness);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(want, st.mac, 4);
    /* The two halves go out together, AUTH_STATUS first. */
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_AUTH_STATUS, hal_fake.sent[hal_fake.n_sent - 2u].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_AUTH_CHALLENGE, hal_fake.sent[hal_fake.n_sent - 1u].id);
}

static void test_app_auth_a_param_set_slipped_in_uses_the_tool_s_challenge_up(void)
{
    /* Issue 21, case 2: another node's PARAM_SET between the tool's PARAM_SET
     * arm = 1 and its PARAM_AUTH. The tool's command is refused (missing),
     * its PARAM_AUTH is checked against the other frame and refused; the
     * tool's pair, played again a second later, is stale. */
    preroll();
    hal_can_frame_t tool[2];
    tf_param_set_auth(COMM_PARAM_ARM, 1.0f, tool);
    feed(tool[0]);
    feed(tf_param_set(COMM_PARAM_D_S, 0.4f));
    feed(tool[1]);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
    for (unsigned k = 0; k < 50u; k++) {
        full_step();
    }
    hal_fake.n_sent = 0;
    feed(tf_seal(COMM_ID_PARAM_SET, tool[0].data));
    feed(tf_seal(COMM_ID_PARAM_AUTH, tool[1].data));
    TEST_ASSERT_TRUE(answered(COMM_PARAM_ARM, RESULT_UNAUTHENTICATED));
    TEST_ASSERT_EQUAL_UINT(AUTH_STALE, last_auth_status().last);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
}

static void test_app_auth_an_unused_challenge_expires_after_half_a_second(void)
{
    /* A pair signed for the challenge and held back by a node on the bus:
     * played 0.5 s (plus up to one housekeeping period) later, stale. */
    preroll();
    hal_can_frame_t pair[2];
    tf_param_set_auth(COMM_PARAM_ARM, 1.0f, pair);
    unsigned steps = 0;
    bool expired = false;
    while (!expired && steps < 100u) {
        full_step();
        steps++;
        expired = sent_status_with(AUTH_EXPIRED);
    }
    /* Housekeeping every 100 ms (5 steps), expiry at 500 ms: the step at
     * t = 0.5 s, the 26th from t = 0. */
    TEST_ASSERT_EQUAL_UINT(26u, steps);
    TEST_ASSERT_EQUAL_UINT32(1u, last_auth_status().freshness);
    feed(pair[0]);
    feed(pair[1]);
    TEST_ASSERT_TRUE(answered(COMM_PARAM_ARM, RESULT_UNAUTHENTICATED));
    TEST_ASSERT_EQUAL_UINT(AUTH_STALE, last_auth_status().last);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
}

static void test_app_auth_failed_checks_lock_out_and_the_lock_ends(void)
{
    /* Four forged MACs for the current challenge lock the firmware for 10 s
     * of its time: the genuine command is refused (locked) until then. */
    static const uint8_t junk[4] = { 1, 2, 3, 4 };
    preroll();
    for (unsigned k = 0; k < AUTH_LOCK_TRIES; k++) {
        feed(tf_param_set(COMM_PARAM_ARM, 1.0f));
        feed(tf_param_auth(app.auth.fv + 1u, junk));
        TEST_ASSERT_EQUAL_UINT(AUTH_MAC, last_auth_status().last);
    }
    genuine(COMM_PARAM_ARM, 1.0f);
    TEST_ASSERT_EQUAL_UINT(AUTH_LOCKED, last_auth_status().last);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NOT_ARMED, app.halt);
    /* 10 s of control steps later (500 at 20 ms), accepted. */
    for (unsigned k = 0; k < 501u; k++) {
        full_step();
    }
    hal_fake.n_sent = 0;
    genuine(COMM_PARAM_ARM, 1.0f);
    TEST_ASSERT_TRUE(answered(COMM_PARAM_ARM, COMM_PARAM_OK));
    TEST_ASSERT_EQUAL_UINT(5u, last_auth_status().refused);
}

static void test_app_auth_a_spent_session_is_followed_by_a_new_one(void)
{
    /* The last value of the session decided: nothing is accepted until the
     * next housekeeping starts a new session. */
    hal_fake.boot_nonce = 0xABCD0000u;
    app.auth.fv = AUTH_FV_MAX - 1u;
    feed(tf_param_set(COMM_PARAM_D_S, 0.4f));
    feed(tf_param_auth(AUTH_FV_MAX, (const uint8_t[4]){ 0, 0, 0, 0 }));
    TEST_ASSERT_EQUAL_UINT32(AUTH_FV_MAX, last_auth_status().freshness);
    app_housekeeping(&app, 0u);
    const auth_status_t st = last_auth_status();
    TEST_ASSERT_EQUAL_HEX32(0xABCD0000u, st.session);
    TEST_ASSERT_EQUAL_UINT32(0u, st.freshness);
    /* No value for a new one: nothing is accepted any more (no_key). */
    hal_fake.boot_nonce_rc = -EIO;
    app.auth.fv = AUTH_FV_MAX - 1u;
    feed(tf_param_set(COMM_PARAM_D_S, 0.4f));
    feed(tf_param_auth(AUTH_FV_MAX, (const uint8_t[4]){ 0, 0, 0, 0 }));
    app_housekeeping(&app, APP_HOUSEKEEPING_PERIOD_US);
    TEST_ASSERT_EQUAL_HEX32(0xABCD0000u, last_auth_status().session);
    genuine(COMM_PARAM_D_S, 0.4f);
    TEST_ASSERT_EQUAL_UINT(AUTH_NO_KEY, last_auth_status().last);
}

static void test_app_auth_a_param_auth_alone_is_counted(void)
{
    static const uint8_t mac[4] = { 0x3A, 0x4C, 0xB7, 0xE5 };
    hal_fake.n_sent = 0;
    feed(tf_param_auth(1u, mac));
    TEST_ASSERT_FALSE(answered(COMM_PARAM_ARM, COMM_PARAM_OK));
    const auth_status_t st = last_auth_status();
    TEST_ASSERT_EQUAL_UINT(1u, st.refused);
    TEST_ASSERT_EQUAL_UINT(AUTH_MISSING, st.last);
    TEST_ASSERT_EQUAL_UINT32(1u, st.freshness);
}

static void test_app_auth_a_param_set_waits_one_control_step_for_its_auth(void)
{
    /* Real-time mode: a tick may fall between PARAM_SET and PARAM_AUTH. */
    hal_can_frame_t f[2];
    tf_param_set_auth(COMM_PARAM_D_S, 0.4f, f);
    feed(f[0]);
    app_control_tick(&app, 20000u);
    TEST_ASSERT_FALSE(answered(COMM_PARAM_D_S, RESULT_UNAUTHENTICATED));
    feed(f[1]);
    TEST_ASSERT_TRUE(answered(COMM_PARAM_D_S, COMM_PARAM_OK));
    TEST_ASSERT_DOUBLE_WITHIN(TU_TOL(1e-7, 1.0 / 65536.0), 0.4, tu_dbl(app.ctl.p.d_s));
}

static void test_app_auth_status_goes_with_the_heartbeat(void)
{
    hal_fake.n_sent = 0;
    app_housekeeping(&app, 0u);
    TEST_ASSERT_EQUAL_UINT(0u, last_auth_status().refused);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_AUTH_STATUS, hal_fake.sent[hal_fake.n_sent - 2u].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_AUTH_CHALLENGE, hal_fake.sent[hal_fake.n_sent - 1u].id);
}

static void test_app_auth_without_a_key_every_command_is_refused(void)
{
    const ctl_params_t p = tf_instant_wheels();
    TEST_ASSERT_EQUAL_INT(0, app_init(&app, &p));
    hal_can_frame_t f[2];
    tf_param_set_auth(COMM_PARAM_D_S, 0.4f, f);
    feed(f[0]);
    feed(f[1]);
    TEST_ASSERT_TRUE(answered(COMM_PARAM_D_S, RESULT_UNAUTHENTICATED));
    TEST_ASSERT_EQUAL_UINT(AUTH_NO_KEY, last_auth_status().last);
}

/* ------------------------------------------------------------- odometry */

static void test_app_auth_a_replayed_16_frame_odometry_loop_halts(void)
{
    /* A recorder on the bus keeps 16 ODOM_XY and ODOM_THETA frames (one turn
     * of the alive counter), then, the real sensor silenced, plays them in a
     * loop: every frame has a good CRC and the next counter. */
    preroll();
    TEST_ASSERT_EQUAL_INT(0, app_arm(&app, true));
    for (unsigned k = 0; k < 10u; k++) {
        full_step();
    }
    hal_can_frame_t xy[16];
    hal_can_frame_t th[16];
    for (unsigned k = 0; k < 16u; k++) {
        xy[k] = tf_odom_xy(px, py);
        th[k] = tf_odom_theta(pth);
        feed(xy[k]);
        feed(th[k]);
        send_ref();
        run_step();
        TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    }
    /* The robot drives at its top speed: 16 steps span about a metre. */
    TEST_ASSERT_GREATER_THAN_INT32(60000, tf_last_wheels().wheel_cmd_left);
    unsigned halted_at = 0u;
    for (unsigned k = 0; k < 48u && halted_at == 0u; k++) {
        feed(xy[k % 16u]);
        feed(th[k % 16u]);
        send_ref();
        run_step();
        if (tf_last_status().status_halt != COMM_HALT_NONE) {
            halted_at = k + 1u;
        }
    }
    TEST_ASSERT_NOT_EQUAL_UINT(0u, halted_at);
    TEST_ASSERT_LESS_OR_EQUAL_UINT(16u, halted_at); /* within the first turn of the loop */
    TEST_ASSERT_EQUAL_UINT8(HALT_ODOMETRY_REPLAYED, tf_last_status().status_halt);
    /* The halt latches and the wheels ramp down. */
    const int32_t before = tf_last_wheels().wheel_cmd_left;
    feed(xy[halted_at % 16u]);
    feed(th[halted_at % 16u]);
    send_ref();
    run_step();
    TEST_ASSERT_EQUAL_UINT8(HALT_ODOMETRY_REPLAYED, tf_last_status().status_halt);
    TEST_ASSERT_LESS_THAN_INT32(before, tf_last_wheels().wheel_cmd_left);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_app_auth_a_mac_less_arm_is_refused_and_counted);
    RUN_TEST(test_app_auth_a_mac_less_parameter_is_refused_and_not_applied);
    RUN_TEST(test_app_auth_an_arm_under_another_key_is_refused);
    RUN_TEST(test_app_auth_an_authenticated_arm_is_accepted_once);
    RUN_TEST(test_app_auth_the_status_is_authenticated);
    RUN_TEST(test_app_auth_a_param_set_slipped_in_uses_the_tool_s_challenge_up);
    RUN_TEST(test_app_auth_an_unused_challenge_expires_after_half_a_second);
    RUN_TEST(test_app_auth_failed_checks_lock_out_and_the_lock_ends);
    RUN_TEST(test_app_auth_a_spent_session_is_followed_by_a_new_one);
    RUN_TEST(test_app_auth_a_param_auth_alone_is_counted);
    RUN_TEST(test_app_auth_a_param_set_waits_one_control_step_for_its_auth);
    RUN_TEST(test_app_auth_status_goes_with_the_heartbeat);
    RUN_TEST(test_app_auth_without_a_key_every_command_is_refused);
    RUN_TEST(test_app_auth_a_replayed_16_frame_odometry_loop_halts);
    return UNITY_END();
}
