/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/kin: differential-drive kinematics and the
 * saturation that keeps the curvature.
 *
 * Expected values: hand derivations from ω_R = (v + ωL/2)/r,
 * ω_L = (v − ωL/2)/r (kin.h) written beside them; for sweeps, the same closed
 * forms evaluated in double inside the test.
 */
#include <stdio.h>

#include "kin/kin.h"
#include "test_util.h"
#include "unity.h"

/* ------------------------------------------------------------ tolerances */

/* Wheel speeds [rad/s] ≤ 40 from (v, ω). float: two roundings on values ≤ 40
 * (ulp/2 = 1.9e-6) and one on ωL/2; fixed: Q16.16 products and the division
 * by r = 0.05 (×20) of a 1.5e-5 rounding → 3e-4, with margin. */
#define TOL_WHEEL  TU_TOL(1e-5, 1e-3)
/* v [m/s] and ω [rad/s] back from wheels, values ≤ 8, absolute part.
 * float: a few roundings of values ≤ 2 (1.2e-7 each); fixed: Q16.16 products
 * and the division by L = 0.3 of a 1.5e-5 rounding. */
#define TOL_VW     TU_TOL(1e-6, 2e-4)
/* Relative part for a round trip. float: a few roundings of values ≤ 8
 * (6e-8 relative each); fixed: L/2 = 0.15 in Q16.16 is held to 7.6e-6, 5e-5
 * relative, and a round trip that uses L/2 one way and L the other way keeps
 * that ratio (r cancels). */
#define TOL_VW_REL TU_TOL(3e-7, 6e-5)
/* A wheel after scaling, values ≤ 100. float: one multiply by the common
 * factor, ulp(100)/2 = 3.8e-6 plus the factor's rounding (6e-8 relative);
 * fixed: the factor max/|w| in Q16.16 is off by ≤ 1.5e-5, times |w| ≤ 40. */
#define TOL_SCALED TU_TOL(2e-5, 1e-3)
/* Ratio of the wheels and curvature ω/v after scaling. float: two scaled
 * values each off by 1.2e-7 relative; fixed: each wheel off by 1e-3 on values
 * ≥ 2, i.e. 5e-4 relative. */
#define TOL_RATIO  TU_TOL(1e-6, 2e-3)

/* Geometry of the brief and of ctl.h's defaults. */
#define R_WHEEL 0.05
#define TRACK   0.3

static kin_params_t params(double max_wheel_speed)
{
    kin_params_t p;
    p.wheel_radius = tu_num(R_WHEEL);
    p.track_width = tu_num(TRACK);
    p.max_wheel_speed = tu_num(max_wheel_speed);
    return p;
}

static kin_wheels_t wheels(double left, double right)
{
    kin_wheels_t w;
    w.left = tu_num(left);
    w.right = tu_num(right);
    return w;
}

void setUp(void) {}
void tearDown(void) {}

/* ---------------------------------------------------------- (v, ω) ↔ wheels */

static void test_kin_wheels_from_vw_hand_values(void)
{
    kin_params_t p = params(100.0);
    kin_wheels_t w;
    /* v = 0.5, ω = 1: ω_R = (0.5 + 1·0.15)/0.05 = 13, ω_L = (0.5 − 0.15)/0.05 = 7. */
    kin_wheels_from_vw(&p, tu_num(0.5), tu_num(1.0), &w);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 13.0, w.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 7.0, w.left);
    /* Straight: v = 0.4, ω = 0 → both 0.4/0.05 = 8. */
    kin_wheels_from_vw(&p, tu_num(0.4), NUM_ZERO, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 8.0, w.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 8.0, w.left);
    /* Pure rotation: v = 0, ω = 2 → ω_R = 0.3/0.05 = 6, ω_L = −6. */
    kin_wheels_from_vw(&p, NUM_ZERO, tu_num(2.0), &w);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 6.0, w.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, -6.0, w.left);
    /* Reverse and turning clockwise: v = −0.25, ω = −0.5:
     * ω_R = (−0.25 − 0.075)/0.05 = −6.5, ω_L = (−0.25 + 0.075)/0.05 = −3.5. */
    kin_wheels_from_vw(&p, tu_num(-0.25), tu_num(-0.5), &w);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, -6.5, w.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, -3.5, w.left);
}

static void test_kin_wheels_from_vw_other_geometry(void)
{
    /* r = 0.1, L = 0.5, v = 1, ω = 2: ω_R = (1 + 0.5)/0.1 = 15,
     * ω_L = (1 − 0.5)/0.1 = 5. Catches r and L swapped or L used for L/2. */
    kin_params_t p = { tu_num(0.1), tu_num(0.5), tu_num(100.0) };
    kin_wheels_t w;
    kin_wheels_from_vw(&p, tu_num(1.0), tu_num(2.0), &w);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 15.0, w.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 5.0, w.left);
}

static void test_kin_vw_from_wheels_hand_values(void)
{
    kin_params_t p = params(100.0);
    num_t v, om;
    /* (ω_L, ω_R) = (7, 13): v = 0.05·20/2 = 0.5, ω = 0.05·6/0.3 = 1. */
    kin_wheels_t w = wheels(7.0, 13.0);
    kin_vw_from_wheels(&p, &w, &v, &om);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.5, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 1.0, om);
    /* (−6, 6): v = 0, ω = 0.05·12/0.3 = 2. */
    w = wheels(-6.0, 6.0);
    kin_vw_from_wheels(&p, &w, &v, &om);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 2.0, om);
}

static void test_kin_round_trip_recovers_v_and_omega(void)
{
    /* (v, ω) → wheels → (v, ω) for speeds of both signs and pure rotation. */
    const double c[][2] = { { 0.5, 1.0 },  { 0.5, 0.0 },   { 0.0, 2.0 },  { -0.3, 0.7 },
                            { 1.2, -3.0 }, { -0.8, -1.5 }, { 0.02, 8.0 }, { 0.0, 0.0 } };
    kin_params_t p = params(100.0);
    char msg[64];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        kin_wheels_t w;
        num_t v, om;
        kin_wheels_from_vw(&p, tu_num(c[i][0]), tu_num(c[i][1]), &w);
        kin_vw_from_wheels(&p, &w, &v, &om);
        snprintf(msg, sizeof msg, "v = %g, w = %g", c[i][0], c[i][1]);
        TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_VW + TOL_VW_REL * fabs(c[i][0]), c[i][0], v, msg);
        TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_VW + TOL_VW_REL * fabs(c[i][1]), c[i][1], om, msg);
    }
}

/* ------------------------------------------------------------ saturation */

static void test_kin_saturation_keeps_curvature(void)
{
    /* v = 0.5, ω = 1 → (7, 13); limit 10: factor 10/13, right = 10 exactly
     * at the limit, left = 70/13 = 5.3846154. The curvature ω/v = 2 and the
     * ratio left/right = 7/13 are kept. */
    kin_params_t p = params(10.0);
    kin_wheels_t w;
    num_t v, om;
    kin_wheels_from_vw(&p, tu_num(0.5), tu_num(1.0), &w);
    TEST_ASSERT_TRUE(kin_saturate(&p, &w));
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 10.0, w.right);
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 70.0 / 13.0, w.left);
    TEST_ASSERT_DOUBLE_WITHIN(TOL_RATIO, 7.0 / 13.0, tu_dbl(w.left) / tu_dbl(w.right));
    kin_vw_from_wheels(&p, &w, &v, &om);
    TEST_ASSERT_DOUBLE_WITHIN(TOL_RATIO, 2.0, tu_dbl(om) / tu_dbl(v));
    /* And the scaled speeds are the originals times 10/13: v = 0.3846154. */
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.5 * 10.0 / 13.0, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 10.0 / 13.0, om);
}

static void test_kin_saturation_leaves_in_range_speeds_untouched(void)
{
    kin_params_t p = params(10.0);
    /* (3, −4) is within ±10: unchanged, bit for bit, and false. */
    kin_wheels_t w = wheels(3.0, -4.0);
    kin_wheels_t before = w;
    TEST_ASSERT_FALSE(kin_saturate(&p, &w));
    TEST_ASSERT_TRUE(w.left == before.left && w.right == before.right);
    /* On the limit (10, −10) is within it too. */
    w = wheels(10.0, -10.0);
    before = w;
    TEST_ASSERT_FALSE(kin_saturate(&p, &w));
    TEST_ASSERT_TRUE(w.left == before.left && w.right == before.right);
    /* Zero stays zero. */
    w = wheels(0.0, 0.0);
    TEST_ASSERT_FALSE(kin_saturate(&p, &w));
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 0.0, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 0.0, w.right);
}

static void test_kin_saturation_pure_rotation(void)
{
    /* (20, −20) with limit 10: factor 1/2 → (10, −10); v stays 0. */
    kin_params_t p = params(10.0);
    kin_wheels_t w = wheels(20.0, -20.0);
    num_t v, om;
    TEST_ASSERT_TRUE(kin_saturate(&p, &w));
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 10.0, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, -10.0, w.right);
    kin_vw_from_wheels(&p, &w, &v, &om);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -0.05 * 20.0 / 0.3, om); /* r(ω_R − ω_L)/L = −3.3333333 */
}

static void test_kin_saturation_negative_speeds(void)
{
    kin_params_t p = params(10.0);
    /* Reversing: (−13, −7) → factor 10/13 → (−10, −5.3846154). */
    kin_wheels_t w = wheels(-13.0, -7.0);
    TEST_ASSERT_TRUE(kin_saturate(&p, &w));
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, -10.0, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, -70.0 / 13.0, w.right);
    /* Mixed signs, the negative one larger: (−30, 15) → factor 1/3 →
     * (−10, 5). */
    w = wheels(-30.0, 15.0);
    TEST_ASSERT_TRUE(kin_saturate(&p, &w));
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, -10.0, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 5.0, w.right);
    /* Only the smaller wheel would be in range on its own: (12, 2) → factor
     * 10/12 → (10, 1.6666667); both are scaled, not just the larger. */
    w = wheels(12.0, 2.0);
    TEST_ASSERT_TRUE(kin_saturate(&p, &w));
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 10.0, w.left);
    TEST_ASSERT_NUM_WITHIN(TOL_SCALED, 20.0 / 12.0, w.right);
}

static void test_kin_saturation_never_exceeds_the_limit(void)
{
    /* kin.h: "limit both wheels to ±max_wheel_speed". Sweep wheel pairs over
     * (−40, 40) with limits that are not powers of two, so that the scaled
     * value is not exact in binary: after saturation |wheel| ≤ max exactly
     * (compared in num_t, no tolerance), the larger one at the limit, and the
     * ratio kept. Expected values: the pair times max/|larger| in double. */
    const double limits[] = { 7.3, 9.7, 12.345 };
    char msg[96];
    for (size_t k = 0; k < sizeof limits / sizeof limits[0]; k++) {
        kin_params_t p = params(limits[k]);
        const double max = tu_dbl(p.max_wheel_speed);
        for (int i = -9; i <= 9; i++) {
            for (int j = 0; j <= 6; j++) {
                const double big = max * (1.0 + 0.173 * (double)(j + 1) + 0.0137 * (double)i);
                const double other = big * 0.11 * (double)i; /* −0.99 … 0.99 times big */
                const bool left_big = (i + j) % 2 == 0;
                kin_wheels_t w = left_big ? wheels(j % 3 == 0 ? -big : big, other)
                                          : wheels(other, j % 3 == 0 ? -big : big);
                const double l0 = tu_dbl(w.left), r0 = tu_dbl(w.right);
                const double f = max / fmax(fabs(l0), fabs(r0));
                snprintf(msg, sizeof msg, "max %g, wheels (%.7g, %.7g)", max, l0, r0);
                TEST_ASSERT_TRUE_MESSAGE(kin_saturate(&p, &w), msg);
                TEST_ASSERT_TRUE_MESSAGE(num_abs(w.left) <= p.max_wheel_speed, msg);
                TEST_ASSERT_TRUE_MESSAGE(num_abs(w.right) <= p.max_wheel_speed, msg);
                TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_SCALED, l0 * f, w.left, msg);
                TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_SCALED, r0 * f, w.right, msg);
            }
        }
    }
}

static void test_kin_saturation_equal_magnitudes_both_end_at_the_limit(void)
{
    /* Straight driving (ω_L = ω_R) and pure rotation (ω_L = −ω_R): both wheels
     * are "the larger", so both must end exactly at ±max, never beyond it
     * (compared in num_t, no tolerance), and the ratio ±1 is kept. Sweep of
     * magnitudes 1.05 … 2.4 times limits that are not powers of two, where
     * w·(max/w) need not round back to max. */
    const double limits[] = { 7.3, 9.7, 12.345 };
    char msg[96];
    for (size_t k = 0; k < sizeof limits / sizeof limits[0]; k++) {
        kin_params_t p = params(limits[k]);
        const double max = tu_dbl(p.max_wheel_speed);
        for (int i = 0; i < 100; i++) {
            const double big = max * (1.05 + 0.0137 * (double)i);
            for (int pattern = 0; pattern < 3; pattern++) {
                /* (big, big), (big, −big), (−big, big) */
                kin_wheels_t w = wheels(pattern == 2 ? -big : big, pattern == 1 ? -big : big);
                const double l0 = tu_dbl(w.left), r0 = tu_dbl(w.right);
                snprintf(msg, sizeof msg, "max %g, wheels (%.9g, %.9g)", max, l0, r0);
                TEST_ASSERT_TRUE_MESSAGE(kin_saturate(&p, &w), msg);
                TEST_ASSERT_TRUE_MESSAGE(num_abs(w.left) <= p.max_wheel_speed, msg);
                TEST_ASSERT_TRUE_MESSAGE(num_abs(w.right) <= p.max_wheel_speed, msg);
                TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_SCALED, l0 > 0.0 ? max : -max, w.left, msg);
                TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_SCALED, r0 > 0.0 ? max : -max, w.right, msg);
            }
        }
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_kin_wheels_from_vw_hand_values);
    RUN_TEST(test_kin_wheels_from_vw_other_geometry);
    RUN_TEST(test_kin_vw_from_wheels_hand_values);
    RUN_TEST(test_kin_round_trip_recovers_v_and_omega);
    RUN_TEST(test_kin_saturation_keeps_curvature);
    RUN_TEST(test_kin_saturation_leaves_in_range_speeds_untouched);
    RUN_TEST(test_kin_saturation_pure_rotation);
    RUN_TEST(test_kin_saturation_negative_speeds);
    RUN_TEST(test_kin_saturation_never_exceeds_the_limit);
    RUN_TEST(test_kin_saturation_equal_magnitudes_both_end_at_the_limit);
    return UNITY_END();
}
