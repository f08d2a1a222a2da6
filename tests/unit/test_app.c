/* SPDX-License-Identifier: MIT */
/* Unity tests of the application layer (firmware/app): the lock-step
 * exchange, the safe stop before inputs arrive, parameters over the bus,
 * drop reporting and housekeeping. The HAL is hal/fake: received frames are
 * scripted, sent frames recorded.
 *
 * Frames are built and read by test_frames.h: the generated codec (mstc_dbc.c,
 * checked bit-exact against cantools by tests/python/test_codec.py) and a
 * CRC computed there from its definition, not comm.c's; the expected values
 * are derived by hand from the DBC's resolutions and eq. (1)-(3).
 */
#include <errno.h>
#include <string.h>

#include "app/app.h"
#include "comm/mstc_dbc.h"
#include "hal_fake.h"
#include "test_frames.h"
#include "test_util.h"

static app_t app;

/* Wheel speeds are sent at 2^-10 rad/s. float: exact up to the last
 * rounding of the raw value (1 lsb). fixed: Q16.16 r = 0.05 is 3277/65536,
 * 6.1e-5 relative too large, so 70 rad/s comes out 4.3e-3 rad/s (4.4 lsb)
 * low. */
#define TOL_WHEEL_RAW TU_TOL(1, 6)

void setUp(void)
{
    tf_app_start(&app, 0);
    tf_auth = &app.auth;
}

void tearDown(void) {}

static void feed(hal_can_frame_t f) { TEST_ASSERT_EQUAL_INT(0, app_on_frame(&app, &f)); }

static void send_odom(double x, double y, double theta)
{
    feed(tf_odom_xy(x, y));
    feed(tf_odom_theta(theta));
}

static void send_ref(double x, double y, double theta, double v, double w)
{
    feed(tf_ref_xy(x, y));
    feed(tf_ref_motion(theta, v, w));
}

static void send_obstacle(uint8_t id, double x, double y, uint8_t radius_cm)
{
    uint8_t p[8] = { 0 };
    /* x, y in 2^-11 m (mstc.dbc). */
    const struct mstc_dbc_obstacle_t o = { .obstacle_id = id,
                                           .obstacle_x = (int32_t)lround(x * 2048.0),
                                           .obstacle_y = (int32_t)lround(y * 2048.0),
                                           .obstacle_radius = radius_cm };
    mstc_dbc_obstacle_pack(p, &o, 8);
    feed(tf_seal(COMM_ID_OBSTACLE, p));
}

static void send_param(uint32_t id, uint8_t index, float value);

/* Arm the application as the plant does at the start of a run
 * (docs/safety.md): APP_REARM_FRAMES rounds of the inputs, then the arm
 * command, which must be accepted. No STEP: no control step runs. */
static void arm_at(double x, double y, double theta, double rx, double ry, double rtheta, double v,
                   double w)
{
    for (unsigned k = 0; k < APP_REARM_FRAMES; k++) {
        send_odom(x, y, theta);
        send_ref(rx, ry, rtheta, v, w);
    }
    send_param(COMM_ID_PARAM_SET, COMM_PARAM_ARM, 1.0f);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, app.halt);
    hal_fake.n_sent = 0; /* forget the PARAM_VALUE answer */
}

static void send_step(uint16_t step, uint32_t time_us) { feed(tf_step(step, time_us)); }

/* PARAM_SET (authenticated: with its PARAM_AUTH) or PARAM_GET. */
static void send_param(uint32_t id, uint8_t index, float value)
{
    if (id == COMM_ID_PARAM_SET) {
        hal_can_frame_t f[2];
        tf_param_set_auth(index, value, f);
        feed(f[0]);
        feed(f[1]);
    } else {
        feed(tf_param_get(index));
    }
}

/* PARAM_SET @p index to @p value: answered @p result, with @p now in force. */
static void expect_set(uint8_t index, float value, uint8_t result, float now)
{
    send_param(COMM_ID_PARAM_SET, index, value);
    const struct mstc_dbc_param_value_t v = tf_last_param_value();
    TEST_ASSERT_EQUAL_UINT8(index, v.param_value_index);
    TEST_ASSERT_EQUAL_UINT8(result, v.param_value_result);
    TEST_ASSERT_FLOAT_WITHIN(1e-4f, now, v.param_value_value);
}

static void test_app_answers_a_step_with_telemetry_then_the_wheel_command_last(void)
{
    arm_at(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0);
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    TEST_ASSERT_EQUAL_UINT(0, hal_fake.n_sent); /* inputs alone send nothing */
    send_step(7, 20000u);
    /* Housekeeping (first step: HEARTBEAT, STATUS_COUNTERS and the two
     * halves of the authentication status), then STATUS, STATUS_TRK and
     * WHEEL_CMD. */
    TEST_ASSERT_EQUAL_UINT(7, hal_fake.n_sent);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_HEARTBEAT, hal_fake.sent[0].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_STATUS_COUNTERS, hal_fake.sent[1].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_AUTH_STATUS, hal_fake.sent[2].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_AUTH_CHALLENGE, hal_fake.sent[3].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_STATUS, hal_fake.sent[4].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_STATUS_TRK, hal_fake.sent[5].id);
    TEST_ASSERT_EQUAL_HEX32(COMM_ID_WHEEL_CMD, hal_fake.sent[6].id);
    TEST_ASSERT_EQUAL_UINT16(7, tf_last_wheels().wheel_cmd_step);
}

static void test_app_step_drives_the_wheels_by_eq_2_and_3(void)
{
    /* Robot at the origin heading east, reference 1 m ahead: e1 = 1, e2 = 0,
     * e3 = 0, so v = 0.5 + 3·1 = 3.5 m/s, ω = 0; both wheels 3.5/0.05 =
     * 70 rad/s = 71680 lsb of 2^-10 rad/s. */
    arm_at(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0);
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    send_step(0, 0u);
    struct mstc_dbc_wheel_cmd_t w = tf_last_wheels();
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, w.wheel_cmd_left);
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 71680, w.wheel_cmd_right);
    TEST_ASSERT_EQUAL_UINT8(SUP_MODE_TRACK, tf_last_status().status_mode);

    /* Reference 1 m to the left: e1 = 0, e2 = 1, e3 = 0, so v = 0.5,
     * ω = 12·0.5·1 = 6 rad/s; ω_R = (0.5 + 6·0.15)/0.05 = 28 rad/s (28672
     * lsb), ω_L = (0.5 − 0.9)/0.05 = −8 rad/s (−8192 lsb). */
    send_odom(0.0, 0.0, 0.0);
    send_ref(0.0, 1.0, 0.0, 0.5, 0.0);
    send_step(1, 20000u);
    w = tf_last_wheels();
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, 28672, w.wheel_cmd_right);
    TEST_ASSERT_INT32_WITHIN(TOL_WHEEL_RAW, -8192, w.wheel_cmd_left);
}

static void test_app_stands_still_until_every_input_has_arrived(void)
{
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    /* A fresh application that has only the odometry. */
    const ctl_params_t p = tf_instant_wheels();
    TEST_ASSERT_EQUAL_INT(0, app_init(&app, &p));
    memset(tf_counters, 0, sizeof tf_counters);
    send_odom(0.0, 0.0, 0.0);
    send_step(3, 0u);
    const struct mstc_dbc_wheel_cmd_t w = tf_last_wheels();
    TEST_ASSERT_EQUAL_INT32(0, w.wheel_cmd_left);
    TEST_ASSERT_EQUAL_INT32(0, w.wheel_cmd_right);
    TEST_ASSERT_EQUAL_UINT16(3, w.wheel_cmd_step);
    TEST_ASSERT_EQUAL_UINT8(SUP_MODE_STOP, tf_last_status().status_mode);
}

static void test_app_reports_events_before_the_wheel_command(void)
{
    /* An obstacle 2 m ahead is within D_det = 3.5 m: detected at this step. */
    arm_at(0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.5, 0.0);
    send_odom(0.0, 0.0, 0.0);
    send_ref(0.1, 0.0, 0.0, 0.5, 0.0);
    send_obstacle(5, 2.0, 0.0, 10);
    send_step(0, 1234567u);
    const hal_can_frame_t *ev = tf_last_sent(COMM_ID_EVENT);
    struct mstc_dbc_event_t e;
    TEST_ASSERT_EQUAL_INT(0, mstc_dbc_event_unpack(&e, ev->data, 8));
    TEST_ASSERT_EQUAL_UINT8(SUP_EVENT_DETECT, e.event_kind);
    TEST_ASSERT_EQUAL_UINT8(5, e.event_obstacle);
    TEST_ASSERT_EQUAL_UINT32(1234567u, e.event_time);
    TEST_ASSERT_TRUE(ev < tf_last_sent(COMM_ID_WHEEL_CMD));
    /* Reported once per step only: the next step has no new detection. */
    const unsigned before = hal_fake.n_sent;
    send_odom(0.0, 0.0, 0.0);
    send_ref(0.1, 0.0, 0.0, 0.5, 0.0);
    send_obstacle(5, 2.0, 0.0, 10);
    send_step(1, 1254567u);
    for (unsigned i = before; i < hal_fake.n_sent; i++) {
        TEST_ASSERT_NOT_EQUAL(COMM_ID_EVENT, hal_fake.sent[i].id);
    }
}

static void test_app_sets_and_gets_parameters_over_the_bus(void)
{
    send_param(COMM_ID_PARAM_GET, COMM_PARAM_D_S, 0.0f);
    const struct mstc_dbc_param_value_t v = tf_last_param_value();
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_D_S, v.param_value_index);
    TEST_ASSERT_EQUAL_UINT8(COMM_PARAM_OK, v.param_value_result);
    TEST_ASSERT_FLOAT_WITHIN(1e-4f, 0.35f, v.param_value_value); /* Table 1 */

    expect_set(COMM_PARAM_D_S, 0.4f, COMM_PARAM_OK, 0.4f);
    /* D_s = 0.6 would not be < D_act = 0.5 (Definition 4): rejected, kept. */
    expect_set(COMM_PARAM_D_S, 0.6f, COMM_PARAM_REJECTED, 0.4f);

    expect_set(200, 1.0f, COMM_PARAM_UNKNOWN_INDEX, 0.0f); /* echoed, answered 0 */
}

static void test_app_reports_a_dropped_frame_in_the_next_status_only(void)
{
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    uint8_t p[8] = { 0 };
    hal_can_frame_t bad = tf_seal(COMM_ID_ODOM_XY, p);
    bad.data[4] ^= 0x10u; /* one flipped bit */
    TEST_ASSERT_EQUAL_INT(-EBADMSG, app_on_frame(&app, &bad));
    send_step(0, 0u);
    TEST_ASSERT_EQUAL_UINT8(8u, tf_last_status().status_faults & 8u);
    TEST_ASSERT_EQUAL_UINT16(1, app.comm.drops.crc);
    send_step(1, 20000u);
    TEST_ASSERT_EQUAL_UINT8(0u, tf_last_status().status_faults & 8u);
}

static void test_app_takes_an_obstacle_velocity_frame_without_a_drop(void)
{
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_obstacle_vel_t v = { .obstacle_vel_id = 1,
                                               .obstacle_vel_vx = 256, /* 0.25 m/s */
                                               .obstacle_vel_vy = 0 };
    mstc_dbc_obstacle_vel_pack(p, &v, 8);
    const unsigned before = hal_fake.n_sent;
    feed(tf_seal(COMM_ID_OBSTACLE_VEL, p)); /* app_on_frame() returns 0 */
    /* Accepted: not a PARAM_GET (no PARAM_VALUE answer), nothing dropped. */
    TEST_ASSERT_EQUAL_UINT(before, hal_fake.n_sent);
    TEST_ASSERT_EQUAL_UINT16(0, app.comm.drops.unknown);
    TEST_ASSERT_EQUAL_UINT16(0, app.comm.drops.crc);
    send_step(0, 0u);
    TEST_ASSERT_EQUAL_UINT8(0u, tf_last_status().status_faults & 8u);
}

static void test_app_housekeeping_runs_every_100_ms_of_step_time(void)
{
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    unsigned heartbeats[6] = { 0 };
    for (uint16_t k = 0; k < 6; k++) {
        const unsigned before = hal_fake.n_sent;
        send_step(k, (uint32_t)k * 20000u); /* 50 Hz */
        for (unsigned i = before; i < hal_fake.n_sent; i++) {
            heartbeats[k] += hal_fake.sent[i].id == COMM_ID_HEARTBEAT;
        }
    }
    /* At t = 0 and t = 100 ms (k = 5), nowhere between. */
    const unsigned want[6] = { 1, 0, 0, 0, 0, 1 };
    TEST_ASSERT_EQUAL_UINT_ARRAY(want, heartbeats, 6);
}

static void test_app_extends_the_step_time_past_its_32_bit_wrap(void)
{
    send_step(0, 0xFFFFF000u);
    send_step(1, 0x00001000u);
    TEST_ASSERT_EQUAL_UINT32(1, app.time_wraps);
    TEST_ASSERT_EQUAL_UINT32(0x00001000u, app.time_raw);
}

static void test_app_poll_drains_the_queue_waiting_only_for_the_first_frame(void)
{
    hal_fake_push_rx(&(hal_can_frame_t){ .id = 0x7FF, .dlc = 8 });
    hal_fake_push_rx(&(hal_can_frame_t){ .id = 0x7FE, .dlc = 8 });
    TEST_ASSERT_EQUAL_UINT(2, app_poll(&app, 5000u));
    TEST_ASSERT_EQUAL_UINT(3, hal_fake.n_recv_calls);
    TEST_ASSERT_EQUAL_UINT32(0, hal_fake.last_timeout_us); /* only the first waits */
    TEST_ASSERT_EQUAL_UINT16(2, app.comm.drops.unknown);
}

/* The alive counter the sender (tf_seal) gave the last ODOM_XY frame. */
static uint8_t last_odom_counter(void)
{
    return (uint8_t)((tf_counters[COMM_ID_ODOM_XY] + 15u) & 0xFu);
}

static void test_app_status_trk_echoes_the_odometry_frame_the_lock_step_used(void)
{
    arm_at(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0);
    for (uint16_t k = 0; k < 20u; k++) { /* past the 4-bit wrap */
        send_odom(0.0, 0.0, 0.0);
        send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
        const uint8_t used = last_odom_counter();
        send_step(k, (uint32_t)k * 20000u);
        TEST_ASSERT_EQUAL_UINT8(used, tf_last_status_trk().status_trk_odom_counter);
    }
    /* A dropped ODOM_XY (bad CRC, then a repeat of the last counter) moves
     * no pose, so the echo stays on the frame the pose came from. */
    const uint8_t used = last_odom_counter();
    uint8_t p[8] = { 0 };
    hal_can_frame_t bad = tf_seal(COMM_ID_ODOM_XY, p);
    bad.data[5] ^= 0x01u;
    TEST_ASSERT_EQUAL_INT(-EBADMSG, app_on_frame(&app, &bad));
    const hal_can_frame_t again = tf_seal_with(COMM_ID_ODOM_XY, p, used);
    TEST_ASSERT_EQUAL_INT(-EALREADY, app_on_frame(&app, &again));
    send_step(20, 400000u);
    TEST_ASSERT_EQUAL_UINT8(used, tf_last_status_trk().status_trk_odom_counter);
}

static void test_app_status_trk_echoes_the_latest_odometry_frame_in_real_time(void)
{
    arm_at(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0);
    uint64_t now = 20000u;
    /* Two frames between ticks: the tick takes the second; none: the tick
     * reuses the last one and says so. */
    send_odom(0.0, 0.0, 0.0);
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    const uint8_t second = last_odom_counter();
    app_control_tick(&app, now);
    TEST_ASSERT_EQUAL_UINT8(second, tf_last_status_trk().status_trk_odom_counter);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_NONE, tf_last_status().status_halt);
    app_control_tick(&app, now + 20000u);
    TEST_ASSERT_EQUAL_UINT8(second, tf_last_status_trk().status_trk_odom_counter);
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    app_control_tick(&app, now + 40000u);
    TEST_ASSERT_EQUAL_UINT8((uint8_t)((second + 1u) & 0xFu),
                            tf_last_status_trk().status_trk_odom_counter);
}

static void test_app_rejects_bad_parameters_at_init_and_keeps_the_defaults(void)
{
    ctl_params_t p;
    ctl_params_default(&p);
    p.d_s = NUM_C(0.6); /* >= D_act */
    TEST_ASSERT_EQUAL_INT(-EINVAL, app_init(&app, &p));
    TEST_ASSERT_TRUE(app.ctl.p.d_s == NUM_C(0.35));
}

/* OBSTACLE_VEL (protocol 2) is received and decoded (2^-10 m/s: raw 1024 is
 * 1 m/s, -512 is -0.5 m/s); the paper's strategy does not use it, so the
 * application only accepts it. */
static void test_app_accepts_an_obstacle_velocity_frame(void)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_obstacle_vel_t v = { .obstacle_vel_id = 2,
                                               .obstacle_vel_vx = 1024,
                                               .obstacle_vel_vy = -512 };
    (void)mstc_dbc_obstacle_vel_pack(p, &v, 8);
    const hal_can_frame_t f = tf_seal(COMM_ID_OBSTACLE_VEL, p);
    comm_t c;
    comm_init(&c);
    comm_msg_t m;
    TEST_ASSERT_EQUAL_INT(0, comm_decode(&c, &f, &m));
    TEST_ASSERT_EQUAL_UINT8(2, m.u.obstacle_vel.id);
    TEST_ASSERT_TRUE(m.u.obstacle_vel.vx == NUM_ONE);
    TEST_ASSERT_TRUE(m.u.obstacle_vel.vy == NUM_C(-0.5));
    TEST_ASSERT_EQUAL_INT(0, app_on_frame(&app, &f));
    TEST_ASSERT_EQUAL_UINT(0, hal_fake.n_sent);
}

/* ---------------------------------------------------------------- issue 35 */

/* FW_VERSION_GET is answered at once with FW_VERSION under the node's
 * identifier (0x191 + 0x100 x node), carrying the node id (bits 12..14) and
 * the protocol (bits 16..19: 1, the DBC's VERSION "mstc 1"). */
static void test_app_answers_fw_version_get_under_its_node_id(void)
{
    const uint8_t zeros[8] = { 0 };
    TEST_ASSERT_EQUAL_INT(-EINVAL, app_set_node(&app, 7));
    TEST_ASSERT_EQUAL_INT(0, app_set_node(&app, 3));
    hal_can_frame_t f = tf_seal(COMM_ID_FW_VERSION_GET, zeros);
    f.id += 0x300u;
    TEST_ASSERT_EQUAL_INT(0, app_on_frame(&app, &f));
    TEST_ASSERT_EQUAL_UINT(1, hal_fake.n_sent);
    TEST_ASSERT_EQUAL_HEX32(0x491u, hal_fake.sent[0].id);
    TEST_ASSERT_EQUAL_UINT8(3, (hal_fake.sent[0].data[1] >> 4) & 0x7u);
    TEST_ASSERT_EQUAL_UINT8(2, hal_fake.sent[0].data[2] & 0x0Fu); /* mstc.dbc: VERSION "mstc 2" */
}

/* Node 0's frames reach a board of node 1 on a shared bus: not its own, so
 * neither answered nor counted, nor flagged as a dropped frame. */
static void test_app_ignores_another_nodes_frames(void)
{
    const uint8_t zeros[8] = { 0 };
    TEST_ASSERT_EQUAL_INT(0, app_set_node(&app, 1));
    const hal_can_frame_t f = tf_seal(COMM_ID_FW_VERSION_GET, zeros);
    TEST_ASSERT_EQUAL_INT(-EXDEV, app_on_frame(&app, &f));
    TEST_ASSERT_EQUAL_UINT(0, hal_fake.n_sent);
    TEST_ASSERT_FALSE(app.frame_dropped);
    TEST_ASSERT_EQUAL_UINT16(0, app.comm.drops.unknown);
}

/* ---------------------------------------------------------------- issue 13 */

/* Case 2: an obstacle radius that switches avoidance off. D_s (0.35) must be
 * at least R_m + R_ob (0.2 + R_ob): R_ob = 1.0 would move the thresholds of a
 * 0.1 m obstacle to 0.35 + 0.1 − 1.0 = −0.55 m, below any distance, and is
 * refused (the relation, not its own range: result rejected); so is 0.25
 * (0.45 > 0.35). 0.12 (0.32 <= 0.35) is accepted. */
static void test_app_refuses_an_obstacle_radius_that_switches_avoidance_off(void)
{
    expect_set(COMM_PARAM_R_OB, 1.0f, COMM_PARAM_REJECTED, 0.1f);
    expect_set(COMM_PARAM_R_OB, 0.25f, COMM_PARAM_REJECTED, 0.1f);
    expect_set(COMM_PARAM_R_OB, 0.12f, COMM_PARAM_OK, 0.12f);
}

/* Case 4: WHEEL_CMD carries -128 to 127.999 rad/s (18 bits of 2^-10 rad/s),
 * so a wheel limit above it could command what the frame cannot say: 300
 * and 128 are out of range, the limit in force (100) kept. */
static void test_app_refuses_a_wheel_limit_that_wheel_cmd_cannot_carry(void)
{
    expect_set(COMM_PARAM_MAX_WHEEL_SPEED, 300.0f, COMM_PARAM_OUT_OF_RANGE, 100.0f);
    expect_set(COMM_PARAM_MAX_WHEEL_SPEED, 128.0f, COMM_PARAM_OUT_OF_RANGE, 100.0f);
}

/* Case 4: a telemetry value beyond its field is flagged in STATUS faults bit
 * 5, in the STATUS of the same step. The reference 100 m ahead gives
 * e1 = 100 m, beyond STATUS_TRK_e1's 31.999 m: sent clipped, flagged. 1 m
 * ahead (e1 = 1 m) is not flagged. */
static void test_app_flags_a_clipped_tracking_error_in_status_fault_bit_5(void)
{
    arm_at(0.0, 0.0, 0.0, 100.0, 0.0, 0.0, 0.5, 0.0);
    send_odom(0.0, 0.0, 0.0);
    send_ref(100.0, 0.0, 0.0, 0.5, 0.0);
    send_step(0, 0u);
    TEST_ASSERT_EQUAL_UINT8(0x20u, tf_last_status().status_faults & 0x20u);
    struct mstc_dbc_status_trk_t trk;
    TEST_ASSERT_EQUAL_INT(
        0, mstc_dbc_status_trk_unpack(&trk, tf_last_sent(COMM_ID_STATUS_TRK)->data, 8));
    TEST_ASSERT_EQUAL_INT16(32767, trk.status_trk_e1); /* 31.999 m: clipped */
    send_odom(0.0, 0.0, 0.0);
    send_ref(1.0, 0.0, 0.0, 0.5, 0.0);
    send_step(1, 20000u);
    TEST_ASSERT_EQUAL_UINT8(0u, tf_last_status().status_faults & 0x20u);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_app_answers_a_step_with_telemetry_then_the_wheel_command_last);
    RUN_TEST(test_app_step_drives_the_wheels_by_eq_2_and_3);
    RUN_TEST(test_app_stands_still_until_every_input_has_arrived);
    RUN_TEST(test_app_reports_events_before_the_wheel_command);
    RUN_TEST(test_app_sets_and_gets_parameters_over_the_bus);
    RUN_TEST(test_app_reports_a_dropped_frame_in_the_next_status_only);
    RUN_TEST(test_app_takes_an_obstacle_velocity_frame_without_a_drop);
    RUN_TEST(test_app_housekeeping_runs_every_100_ms_of_step_time);
    RUN_TEST(test_app_extends_the_step_time_past_its_32_bit_wrap);
    RUN_TEST(test_app_poll_drains_the_queue_waiting_only_for_the_first_frame);
    RUN_TEST(test_app_status_trk_echoes_the_odometry_frame_the_lock_step_used);
    RUN_TEST(test_app_status_trk_echoes_the_latest_odometry_frame_in_real_time);
    RUN_TEST(test_app_rejects_bad_parameters_at_init_and_keeps_the_defaults);
    RUN_TEST(test_app_accepts_an_obstacle_velocity_frame);
    RUN_TEST(test_app_answers_fw_version_get_under_its_node_id);
    RUN_TEST(test_app_ignores_another_nodes_frames);
    RUN_TEST(test_app_refuses_an_obstacle_radius_that_switches_avoidance_off);
    RUN_TEST(test_app_refuses_a_wheel_limit_that_wheel_cmd_cannot_carry);
    RUN_TEST(test_app_flags_a_clipped_tracking_error_in_status_fault_bit_5);
    return UNITY_END();
}
