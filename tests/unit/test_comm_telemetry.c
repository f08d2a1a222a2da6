/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of telemetry clipping (comm.h, docs/safety.md; issue 13, case
 * 4): a value the firmware sends beyond its field's range goes out as the
 * field's end, and the next STATUS says so in faults bit 5, once. A value
 * within the range, and the "no obstacle" distance (the field's maximum by
 * definition), are not flagged.
 *
 * Expected values by hand from the DBC: WHEEL_CMD left/right 18 bits of
 * 2^-10 rad/s (-128 .. 127.9990234375), STATUS_distance 16 unsigned bits of
 * 2^-10 m (0 .. 63.9990234375), STATUS_e 14 bits of 2^-11 rad
 * (-4 .. 3.99951171875), STATUS_TRK_e3 16 bits of 2^-13 rad
 * (-4 .. 3.9998779296875), STATUS_TRK_e1/e2 16 bits of 2^-10 m
 * (-32 .. 31.9990234375).
 */
#include <string.h>

#include "comm/comm.h"
#include "comm/mstc_dbc.h"
#include "test_util.h"

#define CLIPPED 0x20u

static comm_t c;

void setUp(void) { comm_init(&c); }
void tearDown(void) {}

/* The faults field of a STATUS encoded now from @p st. */
static uint8_t status_faults(const ctl_status_t *st)
{
    hal_can_frame_t f;
    TEST_ASSERT_EQUAL_INT(0, comm_encode_status(&c, st, 0u, false, 0u, &f));
    struct mstc_dbc_status_t s;
    TEST_ASSERT_EQUAL_INT(0, mstc_dbc_status_unpack(&s, f.data, 8));
    return s.status_faults;
}

/* A quiet step's status: no obstacle, e = 0. */
static uint8_t quiet_status_faults(void)
{
    const ctl_status_t st = { .mode = SUP_MODE_TRACK };
    return status_faults(&st);
}

static struct mstc_dbc_wheel_cmd_t wheel_cmd(double left, double right)
{
    const kin_wheels_t w = { tu_num(left), tu_num(right) };
    hal_can_frame_t f;
    TEST_ASSERT_EQUAL_INT(0, comm_encode_wheel_cmd(&c, 1u, &w, &f));
    struct mstc_dbc_wheel_cmd_t s;
    TEST_ASSERT_EQUAL_INT(0, mstc_dbc_wheel_cmd_unpack(&s, f.data, 8));
    return s;
}

static void test_comm_telemetry_a_wheel_command_beyond_wheel_cmd_is_flagged_once(void)
{
    /* 300 rad/s goes out as 127.999 (131071 lsb): the next STATUS says it
     * was clipped; the one after does not. */
    const struct mstc_dbc_wheel_cmd_t w = wheel_cmd(300.0, 10.0);
    TEST_ASSERT_EQUAL_INT32(131071, w.wheel_cmd_left);
    TEST_ASSERT_EQUAL_UINT8(CLIPPED, quiet_status_faults() & CLIPPED);
    TEST_ASSERT_EQUAL_UINT8(0u, quiet_status_faults() & CLIPPED);
    (void)wheel_cmd(10.0, -300.0);
    TEST_ASSERT_EQUAL_UINT8(CLIPPED, quiet_status_faults() & CLIPPED);
}

static void test_comm_telemetry_wheel_commands_within_the_field_are_not_flagged(void)
{
    /* The ends of the field are values, not clips. */
    const struct mstc_dbc_wheel_cmd_t w = wheel_cmd(-128.0, 127.9990234375);
    TEST_ASSERT_EQUAL_INT32(-131072, w.wheel_cmd_left);
    TEST_ASSERT_EQUAL_INT32(131071, w.wheel_cmd_right);
    TEST_ASSERT_EQUAL_UINT8(0u, quiet_status_faults() & CLIPPED);
    (void)wheel_cmd(127.99, -127.99);
    TEST_ASSERT_EQUAL_UINT8(0u, quiet_status_faults() & CLIPPED);
}

static void test_comm_telemetry_a_status_value_beyond_its_field_flags_its_own_status(void)
{
    /* An obstacle 70 m away: STATUS_distance says 63.999 and the same STATUS
     * is flagged. */
    ctl_status_t st = { .mode = SUP_MODE_TRACK, .n_obstacles = 1u, .obstacle_id = { 3u } };
    st.distance[0] = tu_num(70.0);
    TEST_ASSERT_EQUAL_UINT8(CLIPPED, status_faults(&st) & CLIPPED);
    st.distance[0] = tu_num(63.0);
    TEST_ASSERT_EQUAL_UINT8(0u, status_faults(&st) & CLIPPED);
    /* An avoidance heading error beyond ±4 rad (an angle out of its range). */
    st.e = tu_num(-4.5);
    TEST_ASSERT_EQUAL_UINT8(CLIPPED, status_faults(&st) & CLIPPED);
}

static void test_comm_telemetry_no_obstacle_is_the_distance_maximum_not_a_clip(void)
{
    TEST_ASSERT_EQUAL_UINT8(0u, quiet_status_faults() & CLIPPED);
}

static void test_comm_telemetry_tracking_errors_beyond_status_trk_are_flagged(void)
{
    const trk_err_t errs[] = {
        { tu_num(40.0), NUM_ZERO, NUM_ZERO },
        { NUM_ZERO, tu_num(-32.5), NUM_ZERO },
        { NUM_ZERO, NUM_ZERO, tu_num(4.5) },
    };
    for (size_t i = 0; i < sizeof errs / sizeof errs[0]; i++) {
        hal_can_frame_t f;
        TEST_ASSERT_EQUAL_INT(0, comm_encode_status_trk(&c, &errs[i], 0u, &f));
        TEST_ASSERT_EQUAL_UINT8(CLIPPED, quiet_status_faults() & CLIPPED);
    }
    const trk_err_t fine = { tu_num(31.0), tu_num(-31.0), tu_num(3.14) };
    hal_can_frame_t f;
    TEST_ASSERT_EQUAL_INT(0, comm_encode_status_trk(&c, &fine, 0u, &f));
    TEST_ASSERT_EQUAL_UINT8(0u, quiet_status_faults() & CLIPPED);
}

#ifndef NUM_FIXED
/* Float mode: NaN has no raw value; it goes out as 0, flagged. */
static void test_comm_telemetry_nan_is_sent_as_zero_and_flagged(void)
{
    const struct mstc_dbc_wheel_cmd_t w = wheel_cmd((double)NAN, 1.0);
    TEST_ASSERT_EQUAL_INT32(0, w.wheel_cmd_left);
    TEST_ASSERT_EQUAL_UINT8(CLIPPED, quiet_status_faults() & CLIPPED);
}
#endif

/* The active obstacle's distance is the one sent, not the nearest. */
static void test_comm_telemetry_the_active_obstacle_distance_is_checked(void)
{
    ctl_status_t st = { .mode = SUP_MODE_AVOID, .active_obstacle = 4u, .n_obstacles = 2u };
    st.obstacle_id[0] = 3u;
    st.distance[0] = tu_num(1.0);
    st.obstacle_id[1] = 4u;
    st.distance[1] = tu_num(65.0);
    TEST_ASSERT_EQUAL_UINT8(CLIPPED, status_faults(&st) & CLIPPED);
    st.distance[1] = tu_num(2.0);
    hal_can_frame_t f;
    TEST_ASSERT_EQUAL_INT(0, comm_encode_status(&c, &st, 0u, false, 0u, &f));
    struct mstc_dbc_status_t s;
    TEST_ASSERT_EQUAL_INT(0, mstc_dbc_status_unpack(&s, f.data, 8));
    TEST_ASSERT_EQUAL_UINT16(2048, s.status_distance); /* 2 m, not the nearest 1 m */
    TEST_ASSERT_EQUAL_UINT8(0u, s.status_faults & CLIPPED);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_comm_telemetry_a_wheel_command_beyond_wheel_cmd_is_flagged_once);
    RUN_TEST(test_comm_telemetry_wheel_commands_within_the_field_are_not_flagged);
    RUN_TEST(test_comm_telemetry_a_status_value_beyond_its_field_flags_its_own_status);
    RUN_TEST(test_comm_telemetry_no_obstacle_is_the_distance_maximum_not_a_clip);
    RUN_TEST(test_comm_telemetry_tracking_errors_beyond_status_trk_are_flagged);
    RUN_TEST(test_comm_telemetry_the_active_obstacle_distance_is_checked);
#ifndef NUM_FIXED
    RUN_TEST(test_comm_telemetry_nan_is_sent_as_zero_and_flagged);
#endif
    return UNITY_END();
}
