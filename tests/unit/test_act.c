/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/act (act.h): the rate limiter on the wheel
 * commands, the estimate of the wheel speeds, the prediction of the pose and
 * the braking time, in both numeric modes.
 *
 * Expected values by hand from the definitions in act.h (worked out beside
 * each), and for act_predict() against the exact arc computed here in double
 * with libm, within the error bound act.h states.
 */
#include <math.h>

#include "ctrl/act.h"
#include "test_util.h"
#include "unity.h"

/* Float: a few ulp of the values (< 100); Q16.16: a few lsb per operation. */
#define TOL     TU_TOL(1e-5, 1e-3)
#define TOL_POS TU_TOL(1e-5, 3e-4)

static act_t a;

void setUp(void) { act_init(&a); }
void tearDown(void) {}

static kin_wheels_t wheels(double l, double r) { return (kin_wheels_t){ tu_num(l), tu_num(r) }; }

static void test_act_limit_scales_both_changes_by_one_factor(void)
{
    /* From standstill to (10, 5) at 20 rad/s² over 0.02 s: at most 0.4 on a
     * wheel; the larger change (10) gives the factor 0.04: (0.4, 0.2), the
     * same direction in wheel space. */
    kin_wheels_t w = wheels(10.0, 5.0);
    TEST_ASSERT_TRUE(act_limit(&a, tu_num(20.0 * 0.02), &w));
    TEST_ASSERT_NUM_WITHIN(TOL, 0.4, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL, 0.2, w.right);
    TEST_ASSERT_NUM_WITHIN(TOL, 0.4, a.cmd.left); /* the next step's base */
    TEST_ASSERT_NUM_WITHIN(TOL, 0.2, a.cmd.right);
}

static void test_act_limit_keeps_a_command_within_reach(void)
{
    /* From (1, 1): changes +0.3 and −0.3 are within 0.4: unchanged. */
    act_sync(&a, &(kin_wheels_t){ tu_num(1.0), tu_num(1.0) });
    kin_wheels_t w = wheels(1.3, 0.7);
    TEST_ASSERT_FALSE(act_limit(&a, tu_num(20.0 * 0.02), &w));
    TEST_ASSERT_NUM_WITHIN(TOL, 1.3, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL, 0.7, w.right);
}

static void test_act_limit_reverses_a_turn_over_as_many_periods_as_it_needs(void)
{
    /* (2, −2) to (−2, 2): changes −4 and +4, factor 0.1 a period: (1.6, −1.6),
     * (1.2, −1.2), ... and (−2, 2) after ten periods, never beyond it. */
    act_sync(&a, &(kin_wheels_t){ tu_num(2.0), tu_num(-2.0) });
    for (int k = 1; k <= 12; k++) {
        kin_wheels_t w = wheels(-2.0, 2.0);
        (void)act_limit(&a, tu_num(20.0 * 0.02), &w);
        const double want = k < 10 ? 2.0 - 0.4 * k : -2.0;
        TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-3), want, w.left);
        TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-3), -want, w.right);
    }
}

static void test_act_limit_allows_nothing_over_no_time(void)
{
    kin_wheels_t w = wheels(5.0, 5.0);
    TEST_ASSERT_TRUE(act_limit(&a, NUM_ZERO, &w));
    TEST_ASSERT_NUM_WITHIN(TOL, 0.0, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL, 0.0, w.right);
}

static void test_act_estimate_follows_the_command_by_the_lag(void)
{
    /* Command 10 in force, estimate 0, τ = 0.06 s, dt = 0.02 s:
     * (0.06 × 0 + 0.02 × 10) / 0.08 = 2.5; then (0.06 × 2.5 + 0.2) / 0.08 =
     * 4.375. */
    act_sync(&a, &(kin_wheels_t){ tu_num(10.0), tu_num(-10.0) });
    a.est = wheels(0.0, 0.0);
    act_estimate(&a, tu_num(0.06), tu_num(0.02), NULL);
    TEST_ASSERT_NUM_WITHIN(TOL, 2.5, a.est.left);
    TEST_ASSERT_NUM_WITHIN(TOL, -2.5, a.est.right);
    act_estimate(&a, tu_num(0.06), tu_num(0.02), NULL);
    TEST_ASSERT_NUM_WITHIN(TOL, 4.375, a.est.left);
    /* Without a lag the wheels are at their command; a measurement wins. */
    act_estimate(&a, NUM_ZERO, tu_num(0.02), NULL);
    TEST_ASSERT_NUM_WITHIN(TOL, 10.0, a.est.left);
    const kin_wheels_t m = wheels(3.0, -4.0);
    act_estimate(&a, tu_num(0.06), tu_num(0.02), &m);
    TEST_ASSERT_NUM_WITHIN(TOL, 3.0, a.est.left);
    TEST_ASSERT_NUM_WITHIN(TOL, -4.0, a.est.right);
    /* No lag and no time: the command (the 0/0 case). */
    act_estimate(&a, NUM_ZERO, NUM_ZERO, NULL);
    TEST_ASSERT_NUM_WITHIN(TOL, 10.0, a.est.left);
}

static void test_act_brake_time_is_half_the_stop_and_half_a_period(void)
{
    /* The faster wheel 14 rad/s at 20 rad/s² (1/a = 0.05 s²/rad): stops in
     * 0.7 s; with the period 0.02 s: (0.7 + 0.02) / 2 = 0.36 s. */
    TEST_ASSERT_NUM_WITHIN(
        TOL, 0.36,
        act_brake_time(&(kin_wheels_t){ tu_num(10.0), tu_num(-14.0) }, tu_num(0.05), tu_num(0.02)));
}

static void test_act_horizon_adds_half_a_period_for_a_measurement(void)
{
    TEST_ASSERT_NUM_WITHIN(TOL, 0.06, act_horizon(tu_num(0.06), tu_num(0.02), NUM_ZERO, false));
    TEST_ASSERT_NUM_WITHIN(TOL, 0.07, act_horizon(tu_num(0.06), tu_num(0.02), NUM_ZERO, true));
    /* A measurement of a given age (a board's own wheel loop: half its 10 ms
     * window, 1 ms after its last period): 0.06 + 0.006 s. */
    TEST_ASSERT_NUM_WITHIN(TOL, 0.066,
                           act_horizon(tu_num(0.06), tu_num(0.02), tu_num(0.006), true));
    TEST_ASSERT_NUM_WITHIN(TOL, 0.06,
                           act_horizon(tu_num(0.06), tu_num(0.02), tu_num(0.006), false));
}

static void test_act_predict_is_the_arc_within_its_bound(void)
{
    /* From (1, 2, 0.3) at 0.5 m/s, 1 rad/s, over 0.1 s: δ = 0.1 rad, the
     * exact arc ends at heading 0.4 and at (1, 2) + 0.05 sinc(0.05)
     * (cos 0.35, sin 0.35). act.h: the heading's cos and sin within δ⁴/24 =
     * 4.2e-6; the position within l δ²/4 = 1.25e-4 m (the mid heading to
     * first order: cos and sin each off by (δ/2)²/2 and the direction's
     * length by as much, times the length l = 0.05 m; the chord shorter than
     * the arc by l δ²/24). */
    const pose_t p0 = tu_pose(1.0, 2.0, 0.3);
    act_pose_t out;
    act_predict(&p0, num_cos(p0.theta), num_sin(p0.theta), tu_num(0.5), tu_num(1.0), tu_num(0.1),
                &out);
    const double chord = 0.05 * sin(0.05) / 0.05;
    TEST_ASSERT_NUM_WITHIN(TU_TOL(5e-6, 2e-4), cos(0.4), out.c);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(5e-6, 2e-4), sin(0.4), out.s);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1.3e-4, 4e-4), 1.0 + chord * cos(0.35), out.p.x);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1.3e-4, 4e-4), 2.0 + chord * sin(0.35), out.p.y);
    TEST_ASSERT_NUM_WITHIN(TOL, 0.4, out.p.theta);
    /* Standing still: the same pose. */
    act_predict(&p0, num_cos(p0.theta), num_sin(p0.theta), NUM_ZERO, NUM_ZERO, tu_num(0.1), &out);
    TEST_ASSERT_NUM_WITHIN(TOL_POS, 1.0, out.p.x);
    TEST_ASSERT_NUM_WITHIN(TOL_POS, cos(0.3), out.c);
}

static void test_act_configure_derives_the_limits_once(void)
{
    /* r = 0.05 m, L = 0.3 m, 20 rad/s²: 1/a = 0.05, a_v = r a = 1 m/s² so
     * 1/a_v = 1; the laws' share (ACT_LAW_SHARE 0.5): a' = 0.5 m/s²,
     * γ' = 2 × 0.5 / 0.3 = 3.3333 rad/s², sqrt(γ') = 1.8257. */
    const kin_params_t kin = { tu_num(0.05), tu_num(0.3), tu_num(100.0) };
    act_configure(&a, &kin, tu_num(20.0), tu_num(0.05));
    TEST_ASSERT_NUM_WITHIN(TOL, 0.05, a.lim.inv_accel);
    TEST_ASSERT_NUM_WITHIN(TOL, 1.0, a.lim.inv_av);
    TEST_ASSERT_NUM_WITHIN(TOL, 0.5, a.lim.law_accel);
    TEST_ASSERT_NUM_WITHIN(TOL, 10.0 / 3.0, a.lim.gamma);
    TEST_ASSERT_NUM_WITHIN(TOL, sqrt(10.0 / 3.0), a.lim.sqrt_gamma);
    /* A point 0.05 m ahead of the axle: across the heading 2 × 0.05 / 0.3 of
     * r a; a lever beyond half the track is capped at 1. */
    TEST_ASSERT_NUM_WITHIN(TOL, 1.0 / 3.0, a.lim.side);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-6, 2e-3), 3.0, a.lim.inv_side);
    act_configure(&a, &kin, tu_num(20.0), tu_num(0.2));
    TEST_ASSERT_NUM_WITHIN(TOL, 1.0, a.lim.side);
}

static void test_act_sync_sets_command_and_estimate(void)
{
    act_sync(&a, &(kin_wheels_t){ tu_num(3.0), tu_num(4.0) });
    TEST_ASSERT_NUM_WITHIN(TOL, 3.0, a.cmd.left);
    TEST_ASSERT_NUM_WITHIN(TOL, 4.0, a.est.right);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_act_limit_scales_both_changes_by_one_factor);
    RUN_TEST(test_act_limit_keeps_a_command_within_reach);
    RUN_TEST(test_act_limit_reverses_a_turn_over_as_many_periods_as_it_needs);
    RUN_TEST(test_act_limit_allows_nothing_over_no_time);
    RUN_TEST(test_act_estimate_follows_the_command_by_the_lag);
    RUN_TEST(test_act_brake_time_is_half_the_stop_and_half_a_period);
    RUN_TEST(test_act_horizon_adds_half_a_period_for_a_measurement);
    RUN_TEST(test_act_predict_is_the_arc_within_its_bound);
    RUN_TEST(test_act_configure_derives_the_limits_once);
    RUN_TEST(test_act_sync_sets_command_and_estimate);
    return UNITY_END();
}
