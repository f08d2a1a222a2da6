/* SPDX-License-Identifier: MIT */
/**
 * @file test_frames.h
 * @brief Frames as a sender builds them, and the firmware's answers as the
 *        recording HAL fake saw them, for the application, E2E and safety
 *        tests. Sent frames: the
 *        payload packed by the generated codec (checked bit-exact against
 *        cantools by tests/python/test_codec.py), then the alive counter and
 *        a CRC-8H2F computed here from its definition, independently of
 *        comm.c (test_comm.c checks both against AUTOSAR's vectors).
 */
#ifndef MSTC_TEST_FRAMES_H
#define MSTC_TEST_FRAMES_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "app/app.h"
#include "auth/auth.h"
#include "comm/comm.h"
#include "comm/mstc_dbc.h"
#include "hal/hal_can.h"
#include "hal_fake.h"
#include "unity.h"

/**
 * @brief The defaults with wheels that follow their command at once
 *        (wheel_accel 10000 rad/s², wheel_tau 0): "mstc" commands what its
 *        laws give, as before real wheels, for the tests of the application
 *        that are about something else (the wheels' own tests: test_act.c,
 *        test_ctl.c).
 */
static inline ctl_params_t tf_instant_wheels(void)
{
    ctl_params_t p;
    ctl_params_default(&p);
    p.wheel_accel = num_from_int(10000);
    p.wheel_tau = NUM_ZERO;
    return p;
}

/** @brief Next alive counter per identifier (a sender's). */
static uint8_t tf_counters[0x800];

/** @brief CRC-8H2F from its definition: MSB first, poly 0x2F, init and xorout 0xFF. */
static inline uint8_t tf_crc(const uint8_t *d, size_t n)
{
    unsigned crc = 0xFFu;
    for (size_t i = 0; i < n; i++) {
        for (int bit = 7; bit >= 0; bit--) {
            const unsigned in = ((unsigned)d[i] >> bit) & 1u;
            const unsigned top = (crc >> 7) & 1u;
            crc = (crc << 1) & 0xFFu;
            if ((top ^ in) != 0u) {
                crc ^= 0x2Fu;
            }
        }
    }
    return (uint8_t)(crc ^ 0xFFu);
}

/** @brief The E2E CRC byte of a payload under @p id: data ID 0x1000 + id (the DBC). */
static inline uint8_t tf_frame_crc(uint32_t id, const uint8_t data[8])
{
    const uint16_t did = (uint16_t)(0x1000u + id);
    uint8_t buf[9] = { (uint8_t)(did & 0xFFu), (uint8_t)(did >> 8) };
    memcpy(&buf[2], &data[1], 7);
    return tf_crc(buf, sizeof buf);
}

/** @brief A frame with alive counter @p counter and a correct CRC. */
static inline hal_can_frame_t tf_seal_with(uint32_t id, const uint8_t payload[8], uint8_t counter)
{
    hal_can_frame_t f = { .id = id, .dlc = 8 };
    memcpy(f.data, payload, 8);
    f.data[1] = (uint8_t)((f.data[1] & 0xF0u) | (counter & 0x0Fu));
    f.data[0] = tf_frame_crc(id, f.data);
    return f;
}

/** @brief A frame with the identifier's next alive counter. */
static inline hal_can_frame_t tf_seal(uint32_t id, const uint8_t payload[8])
{
    const uint8_t counter = tf_counters[id & 0x7FFu];
    tf_counters[id & 0x7FFu] = (uint8_t)((counter + 1u) & 0x0Fu);
    return tf_seal_with(id, payload, counter);
}

static inline hal_can_frame_t tf_odom_xy(double x, double y)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_odom_xy_t s = { .odom_xy_x = (int32_t)lround(x * 65536.0),
                                          .odom_xy_y = (int32_t)lround(y * 65536.0) };
    (void)mstc_dbc_odom_xy_pack(p, &s, 8);
    return tf_seal(COMM_ID_ODOM_XY, p);
}

static inline hal_can_frame_t tf_odom_theta(double theta)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_odom_theta_t s = { .odom_theta_theta = (int32_t)lround(theta * 65536.0) };
    (void)mstc_dbc_odom_theta_pack(p, &s, 8);
    return tf_seal(COMM_ID_ODOM_THETA, p);
}

static inline hal_can_frame_t tf_ref_xy(double x, double y)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_ref_xy_t s = { .ref_xy_x = (int32_t)lround(x * 65536.0),
                                         .ref_xy_y = (int32_t)lround(y * 65536.0) };
    (void)mstc_dbc_ref_xy_pack(p, &s, 8);
    return tf_seal(COMM_ID_REF_XY, p);
}

static inline hal_can_frame_t tf_ref_motion(double theta, double v, double w)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_ref_motion_t s = { .ref_motion_theta = (int32_t)lround(theta * 32768.0),
                                             .ref_motion_v = (int32_t)lround(v * 4096.0),
                                             .ref_motion_w = (int32_t)lround(w * 4096.0) };
    (void)mstc_dbc_ref_motion_pack(p, &s, 8);
    return tf_seal(COMM_ID_REF_MOTION, p);
}

static inline hal_can_frame_t tf_wheel_speed_faults(double left, double right, uint8_t faults)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_wheel_speed_t s = { .wheel_speed_left = (int32_t)lround(left * 1024.0),
                                              .wheel_speed_right = (int32_t)lround(right * 1024.0),
                                              .wheel_speed_faults = faults };
    (void)mstc_dbc_wheel_speed_pack(p, &s, 8);
    return tf_seal(COMM_ID_WHEEL_SPEED, p);
}

static inline hal_can_frame_t tf_wheel_speed(double left, double right)
{
    return tf_wheel_speed_faults(left, right, 0u);
}

static inline hal_can_frame_t tf_step(uint16_t step, uint32_t time_us)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_step_t s = { .step_step = step, .step_time = time_us };
    (void)mstc_dbc_step_pack(p, &s, 8);
    return tf_seal(COMM_ID_STEP, p);
}

static inline hal_can_frame_t tf_param_set(uint8_t index, float value)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_param_set_t s = { .param_set_index = index, .param_set_value = value };
    (void)mstc_dbc_param_set_pack(p, &s, 8);
    return tf_seal(COMM_ID_PARAM_SET, p);
}

static inline hal_can_frame_t tf_param_get(uint8_t index)
{
    uint8_t p[8] = { 0 };
    const struct mstc_dbc_param_get_t s = { .param_get_index = index };
    (void)mstc_dbc_param_get_pack(p, &s, 8);
    return tf_seal(COMM_ID_PARAM_GET, p);
}

/** @brief RFC 4493's example key (tests/data/test.key): the tests' device key. */
static const uint8_t tf_test_key[AUTH_KEY_LEN] = { 0x2b, 0x7e, 0x15, 0x16, 0x28, 0xae, 0xd2, 0xa6,
                                                   0xab, 0xf7, 0x15, 0x88, 0x09, 0xcf, 0x4f, 0x3c };

/** @brief Freshness value of the last command tf_param_set_auth() built:
 *         the firmware's last decided one, when every command since was
 *         built here and decided (a test that makes it decide others sets
 *         it from app.auth.fv). */
static uint32_t tf_freshness;

/** @brief The session the tests give the firmware with the key (the
 *         authenticators written into the tests are for it). */
#define TF_SESSION 0x5EC0A1D1u

/** @brief The firmware's authentication state, when a test sets it: then
 *         tf_param_set_auth() signs for its current challenge and session,
 *         as a tool that read the authenticated status does. */
static const auth_t *tf_auth;

/** @brief PARAM_AUTH: freshness (20 bits) at bits 12..31, the first four
 *         bytes of the CMAC in bytes 4..7, in order. */
static inline hal_can_frame_t tf_param_auth(uint32_t fv, const uint8_t mac[AUTH_MAC_LEN])
{
    uint8_t p[8] = { 0 };
    p[1] = (uint8_t)((fv & 0x0Fu) << 4);
    p[2] = (uint8_t)((fv >> 4) & 0xFFu);
    p[3] = (uint8_t)((fv >> 12) & 0xFFu);
    memcpy(&p[4], mac, AUTH_MAC_LEN);
    return tf_seal(COMM_ID_PARAM_AUTH, p);
}

/**
 * @brief PARAM_SET of @p index = @p value, and the PARAM_AUTH that
 *        authenticates it under tf_test_key in session TF_SESSION with the
 *        next freshness value.
 *        The MAC is auth_mac()'s: test_auth.c checks it against RFC 4493's
 *        examples, tests/python/test_auth.py against `cryptography`.
 */
static inline void tf_param_set_auth(uint8_t index, float value, hal_can_frame_t out[2])
{
    out[0] = tf_param_set(index, value);
    auth_t s;
    auth_init(&s);
    const uint32_t session = tf_auth != NULL ? tf_auth->session : TF_SESSION;
    auth_set_key(&s, tf_test_key, session);
    uint8_t mac[AUTH_MAC_LEN];
    if (tf_auth != NULL) {
        tf_freshness = tf_auth->fv;
    }
    tf_freshness++;
    auth_mac(&s, COMM_PARAM_SET_DATA_ID, &out[0].data[2], session, tf_freshness, mac);
    out[1] = tf_param_auth(tf_freshness, mac);
}

/** @brief The last frame with @p id that the firmware sent, or fail the test. */
static inline const hal_can_frame_t *tf_last_sent(uint32_t id)
{
    for (unsigned i = hal_fake.n_sent; i-- > 0;) {
        if (hal_fake.sent[i].id == id) {
            return &hal_fake.sent[i];
        }
    }
    TEST_FAIL_MESSAGE("frame not sent");
    return NULL;
}

/** @brief The last WHEEL_CMD the firmware sent, unpacked. */
static inline struct mstc_dbc_wheel_cmd_t tf_last_wheels(void)
{
    struct mstc_dbc_wheel_cmd_t w;
    TEST_ASSERT_EQUAL_INT(0,
                          mstc_dbc_wheel_cmd_unpack(&w, tf_last_sent(COMM_ID_WHEEL_CMD)->data, 8));
    return w;
}

/** @brief The last STATUS the firmware sent, unpacked. */
static inline struct mstc_dbc_status_t tf_last_status(void)
{
    struct mstc_dbc_status_t s;
    TEST_ASSERT_EQUAL_INT(0, mstc_dbc_status_unpack(&s, tf_last_sent(COMM_ID_STATUS)->data, 8));
    return s;
}

/** @brief The last STATUS_TRK the firmware sent, unpacked. */
static inline struct mstc_dbc_status_trk_t tf_last_status_trk(void)
{
    struct mstc_dbc_status_trk_t s;
    TEST_ASSERT_EQUAL_INT(
        0, mstc_dbc_status_trk_unpack(&s, tf_last_sent(COMM_ID_STATUS_TRK)->data, 8));
    return s;
}

/** @brief The last PARAM_VALUE the firmware sent, unpacked. */
static inline struct mstc_dbc_param_value_t tf_last_param_value(void)
{
    struct mstc_dbc_param_value_t v;
    TEST_ASSERT_EQUAL_INT(
        0, mstc_dbc_param_value_unpack(&v, tf_last_sent(COMM_ID_PARAM_VALUE)->data, 8));
    return v;
}

/**
 * @brief A test's start: the HAL fake reset (its CAN status then @p can_rc),
 *        every sender's counter at 0, @p app initialised with
 *        tf_instant_wheels() and keyed with tf_test_key in TF_SESSION, the
 *        commands' freshness at 0.
 */
static inline void tf_app_start(app_t *app, int can_rc)
{
    hal_fake_reset();
    hal_fake.can_status_rc = can_rc;
    memset(tf_counters, 0, sizeof tf_counters);
    const ctl_params_t p = tf_instant_wheels();
    TEST_ASSERT_EQUAL_INT(0, app_init(app, &p));
    app_set_key(app, tf_test_key, TF_SESSION);
    tf_freshness = 0u;
}

#endif /* MSTC_TEST_FRAMES_H */
