/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the odometry plausibility check (firmware/app/odo.h).
 *
 * Expected values by hand from odo.h's rule: with wheels of radius 0.05 m on
 * a 0.3 m track, dt = 20 ms, allowance a step ODO_TOL_M = 0.02 m (heading
 * ODO_TOL_RAD = 0.02 rad) plus half the commanded travel (turn):
 *   both wheels 10 rad/s: v = 0.5 m/s, 0.01 m a step, allowance 0.025 m;
 *   both wheels 70 rad/s: v = 3.5 m/s, 0.07 m a step, allowance 0.055 m.
 */
#include "app/odo.h"
#include "test_util.h"
#include "unity.h"

static odo_t o;
static const kin_params_t kp = { NUM_C(0.05), NUM_C(0.3), NUM_C(100.0) };
#define DT NUM_C(0.02)

void setUp(void) { odo_init(&o); }
void tearDown(void) {}

static kin_wheels_t wheels(double l, double r) { return (kin_wheels_t){ tu_num(l), tu_num(r) }; }

/* One step with a fresh full pose. */
static bool step(const kin_wheels_t *w, double x, double y, double theta)
{
    const pose_t p = { tu_num(x), tu_num(y), tu_num(theta) };
    return odo_step(&o, &kp, w, DT, &p, true, true);
}

static void test_odo_odometry_that_follows_the_commands_is_plausible(void)
{
    const kin_wheels_t w = wheels(10.0, 10.0);
    for (unsigned k = 0; k < 200u; k++) {
        TEST_ASSERT_FALSE(step(&w, 0.01 * k, 1.0, 0.0));
    }
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tu_dbl(o.s_xy));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tu_dbl(o.s_theta));
}

static void test_odo_a_loop_starting_over_is_implausible(void)
{
    const kin_wheels_t w = wheels(10.0, 10.0);
    unsigned k = 0;
    for (; k < 20u; k++) {
        TEST_ASSERT_FALSE(step(&w, 0.01 * k, 0.0, 0.0));
    }
    /* The pose goes 15 steps back: 0.16 m from the prediction; s = 0.16 -
     * 0.025 = 0.135 m > 0.1 m. */
    TEST_ASSERT_TRUE(step(&w, 0.01 * (k - 16u), 0.0, 0.0));
    TEST_ASSERT_DOUBLE_WITHIN(TU_TOL(1e-6, 1e-4), 0.135, tu_dbl(o.s_xy));
}

static void test_odo_a_small_jump_is_forgiven_and_forgotten(void)
{
    const kin_wheels_t w = wheels(10.0, 10.0);
    TEST_ASSERT_FALSE(step(&w, 0.0, 0.0, 0.0));
    /* 0.12 m from the prediction: s = 0.12 - 0.025 = 0.095 m, below 0.1. */
    TEST_ASSERT_FALSE(step(&w, 0.13, 0.0, 0.0));
    TEST_ASSERT_DOUBLE_WITHIN(TU_TOL(1e-6, 1e-4), 0.095, tu_dbl(o.s_xy));
    /* Then as commanded: 0.025 m of allowance a step wears it off. */
    TEST_ASSERT_FALSE(step(&w, 0.14, 0.0, 0.0));
    TEST_ASSERT_DOUBLE_WITHIN(TU_TOL(1e-6, 1e-4), 0.07, tu_dbl(o.s_xy));
    for (unsigned k = 0; k < 3u; k++) {
        TEST_ASSERT_FALSE(step(&w, 0.15 + 0.01 * k, 0.0, 0.0));
    }
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tu_dbl(o.s_xy));
}

static void test_odo_a_pose_stuck_while_the_robot_drives_fast_is_implausible(void)
{
    /* 0.07 m a step not seen, 0.055 m allowed: s grows 0.015 m a step and
     * passes 0.1 m at the seventh (0.105 m). */
    const kin_wheels_t w = wheels(70.0, 70.0);
    TEST_ASSERT_FALSE(step(&w, 1.0, 1.0, 0.0)); /* the first pose starts the check */
    for (unsigned k = 1; k <= 6u; k++) {
        TEST_ASSERT_FALSE(step(&w, 1.0, 1.0, 0.0));
    }
    TEST_ASSERT_TRUE(step(&w, 1.0, 1.0, 0.0));
}

static void test_odo_a_pose_stuck_while_the_robot_creeps_is_not_noticed(void)
{
    /* The limit of a model check (odo.h): 0.01 m a step is within the
     * allowance. */
    const kin_wheels_t w = wheels(10.0, 10.0);
    for (unsigned k = 0; k < 500u; k++) {
        TEST_ASSERT_FALSE(step(&w, 0.0, 0.0, 0.0));
    }
}

static void test_odo_a_heading_jump_is_implausible(void)
{
    const kin_wheels_t still = wheels(0.0, 0.0);
    TEST_ASSERT_FALSE(step(&still, 0.0, 0.0, 0.5));
    /* 0.15 rad: s = 0.15 - 0.02 = 0.13 rad, below 0.2. */
    TEST_ASSERT_FALSE(step(&still, 0.0, 0.0, 0.65));
    /* 0.1 more: s = 0.13 + 0.1 - 0.02 = 0.21 rad. */
    TEST_ASSERT_TRUE(step(&still, 0.0, 0.0, 0.75));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tu_dbl(o.s_xy));
}

static void test_odo_a_turn_across_pi_is_followed(void)
{
    /* Turning left in place at 1/3 rad a step... wheels -10, 10:
     * w = 0.05 * 20 / 0.3 = 3.333 rad/s, 0.0667 rad a step, heading
     * through pi and on from -pi. */
    const kin_wheels_t w = wheels(-10.0, 10.0);
    double th = 3.0;
    for (unsigned k = 0; k < 10u; k++) {
        const double wrapped = th > TU_PI ? th - TU_TWO_PI : th;
        TEST_ASSERT_FALSE(step(&w, 0.0, 0.0, wrapped));
        th += 0.05 * 20.0 / 0.3 * 0.02;
    }
    TEST_ASSERT_DOUBLE_WITHIN(TU_TOL(1e-5, 1e-3), 0.0, tu_dbl(o.s_theta));
}

static void test_odo_missed_frames_widen_the_allowance(void)
{
    const kin_wheels_t w = wheels(10.0, 10.0);
    TEST_ASSERT_FALSE(step(&w, 0.0, 0.0, 0.0));
    /* Two steps without a position (nor a heading), the robot moving on. */
    const pose_t stale = { NUM_ZERO, NUM_ZERO, NUM_ZERO };
    TEST_ASSERT_FALSE(odo_step(&o, &kp, &w, DT, &stale, false, false));
    TEST_ASSERT_FALSE(odo_step(&o, &kp, &w, DT, &stale, false, true));
    /* Then a position 3 steps on: as predicted. */
    TEST_ASSERT_FALSE(step(&w, 0.03, 0.0, 0.0));
    TEST_ASSERT_DOUBLE_WITHIN(TU_TOL(1e-6, 1e-4), 0.0, tu_dbl(o.s_xy));
}

static void test_odo_the_check_starts_with_a_full_pose(void)
{
    const kin_wheels_t w = wheels(70.0, 70.0);
    const pose_t p = { NUM_ZERO, NUM_ZERO, NUM_ZERO };
    /* A position alone does not start it; a heading alone neither. */
    TEST_ASSERT_FALSE(odo_step(&o, &kp, &w, DT, &p, true, false));
    TEST_ASSERT_FALSE(o.have);
    TEST_ASSERT_FALSE(odo_step(&o, &kp, &w, DT, &p, false, true));
    TEST_ASSERT_FALSE(o.have);
    TEST_ASSERT_FALSE(odo_step(&o, &kp, &w, DT, &p, true, true));
    TEST_ASSERT_TRUE(o.have);
    /* A 10 m jump right after a reset is no disagreement: nothing predicted. */
    odo_reset(&o);
    TEST_ASSERT_FALSE(step(&w, 10.0, 0.0, 0.0));
    TEST_ASSERT_FALSE(step(&w, 10.07, 0.0, 0.0));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_odo_odometry_that_follows_the_commands_is_plausible);
    RUN_TEST(test_odo_a_loop_starting_over_is_implausible);
    RUN_TEST(test_odo_a_small_jump_is_forgiven_and_forgotten);
    RUN_TEST(test_odo_a_pose_stuck_while_the_robot_drives_fast_is_implausible);
    RUN_TEST(test_odo_a_pose_stuck_while_the_robot_creeps_is_not_noticed);
    RUN_TEST(test_odo_a_heading_jump_is_implausible);
    RUN_TEST(test_odo_a_turn_across_pi_is_followed);
    RUN_TEST(test_odo_missed_frames_widen_the_allowance);
    RUN_TEST(test_odo_the_check_starts_with_a_full_pose);
    return UNITY_END();
}
