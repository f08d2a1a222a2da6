/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/trk: tracking errors, eq. (1), and the
 * Kanayama control law, eq. (2)-(3).
 *
 * Expected values: hand derivations written beside them, or eq. (1)-(3)
 * evaluated in double with libm inside the test (ref_errors, ref_control):
 * the same closed form, computed independently of the code under test.
 */
#include <stdio.h>

#include "ctrl/trk.h"
#include "test_util.h"
#include "unity.h"

/* ------------------------------------------------------------ tolerances */

/* e1, e2 [m] for position differences ≤ 4 m. float: eq. (1) rounds ~5 times
 * on values ≤ 4 (ulp/2 = 2.4e-7 each); fixed: sin/cos error ≤ 1e-4 times
 * |Δ| ≤ 4 m in each of two terms, plus Q16.16 rounding. */
#define TOL_E12      TU_TOL(2e-6, 1e-3)
/* e3 [rad]: one subtraction and one wrap of angles ≤ 2π. float: ulp(2π)/2
 * = 2.4e-7 twice plus float(2π)'s error; fixed: Q16.16 2π off by ≤ 7.6e-6
 * and two roundings of 1.5e-5. */
#define TOL_E3       TU_TOL(1e-6, 5e-5)
/* e3 for a heading given as θ + 3 turns (≈ 19 rad). float: ulp(19)/2 =
 * 9.5e-7 on the input, and the wrap's reduction of 3 turns; fixed: 3 turns of
 * the 2π error (2.3e-5) plus roundings. */
#define TOL_E3_TURNS TU_TOL(5e-6, 1e-4)
/* v [m/s] and ω [rad/s] of eq. (2)-(3) for gains ≤ 12, speeds ≤ 2, errors
 * ≤ 0.5. float: ~8 roundings of values ≤ 4 (2.4e-7 each); fixed: cos/sin
 * error 1e-4 times k3·v_r ≤ 6, plus Q16.16 products (1.5e-5 each). */
#define TOL_VW       TU_TOL(3e-6, 1e-3)

void setUp(void) {}
void tearDown(void) {}

/* Eq. (1) in double on the values the inputs hold. */
static void ref_errors(double x, double y, double th, double xr, double yr, double thr, double *e1,
                       double *e2, double *e3)
{
    x = tu_q(x), y = tu_q(y), th = tu_q(th), xr = tu_q(xr), yr = tu_q(yr), thr = tu_q(thr);
    *e1 = cos(th) * (xr - x) + sin(th) * (yr - y);
    *e2 = -sin(th) * (xr - x) + cos(th) * (yr - y);
    *e3 = tu_wrap(thr - th);
}

static void check_errors(double x, double y, double th, double xr, double yr, double thr)
{
    pose_t robot = tu_pose(x, y, th), ref = tu_pose(xr, yr, thr);
    trk_err_t err;
    double e1, e2, e3;
    char msg[96];
    trk_errors(&robot, &ref, &err);
    ref_errors(x, y, th, xr, yr, thr, &e1, &e2, &e3);
    snprintf(msg, sizeof msg, "robot (%g, %g, %g) ref (%g, %g, %g)", x, y, th, xr, yr, thr);
    TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_E12, e1, err.e1, msg);
    TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_E12, e2, err.e2, msg);
    TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_E3, e3, err.e3, msg);
}

/* ------------------------------------------------------------ eq. (1) */

static void test_trk_errors_robot_at_origin_heading_east(void)
{
    /* θ = 0: the body frame is the world frame, e1 = Δx = 1, e2 = Δy = 2. */
    pose_t robot = tu_pose(0.0, 0.0, 0.0), ref = tu_pose(1.0, 2.0, 0.0);
    trk_err_t err;
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 1.0, err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 2.0, err.e2);
    TEST_ASSERT_NUM_WITHIN(TOL_E3, 0.0, err.e3);
}

static void test_trk_errors_rotate_into_the_body_frame(void)
{
    /* θ = π/2 (facing +y): ahead is +y, left is −x.
     * e1 = cos·1 + sin·2 = 2, e2 = −sin·1 + cos·2 = −1. */
    pose_t robot = tu_pose(0.0, 0.0, TU_PI / 2.0), ref = tu_pose(1.0, 2.0, TU_PI / 2.0);
    trk_err_t err;
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 2.0, err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, -1.0, err.e2);
    TEST_ASSERT_NUM_WITHIN(TOL_E3, 0.0, err.e3);

    /* θ = π (facing −x), robot at (1, 1), ref at (0, 1.5): Δ = (−1, 0.5);
     * e1 = −1·(−1) + 0 = 1 (ahead), e2 = −0·(−1) + (−1)·0.5 = −0.5 (right). */
    robot = tu_pose(1.0, 1.0, TU_PI);
    ref = tu_pose(0.0, 1.5, TU_PI);
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 1.0, err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, -0.5, err.e2);
    TEST_ASSERT_ANGLE_WITHIN(TOL_E3, 0.0, err.e3);

    /* θ = −π/2 (facing −y), robot at (2, 3), ref at (2.5, 1): Δ = (0.5, −2);
     * e1 = 0·0.5 + (−1)(−2) = 2, e2 = 1·0.5 + 0 = 0.5. e3 = 0.3. */
    robot = tu_pose(2.0, 3.0, -TU_PI / 2.0);
    ref = tu_pose(2.5, 1.0, -TU_PI / 2.0 + 0.3);
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 2.0, err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 0.5, err.e2);
    TEST_ASSERT_NUM_WITHIN(TOL_E3, 0.3, err.e3);
}

static void test_trk_errors_general_poses(void)
{
    /* Eq. (1) in double for poses in every quadrant and headings of both
     * signs. */
    check_errors(2.0, -1.0, 0.5, 3.5, 0.2, 1.2);
    check_errors(-1.5, 2.5, 2.4, -3.0, 1.0, 2.0);
    check_errors(0.3, -0.7, -2.2, -1.1, -2.9, -1.9);
    check_errors(4.0, 6.4, 0.7, 4.5, 6.5, 0.8); /* the paper's circle start */
    check_errors(10.0, 20.0, -0.4, 8.0, 21.5, 0.25);
}

static void test_trk_errors_far_from_the_origin(void)
{
    /* Corners of a 100 m × 100 m field (issue 3: nothing may overflow there
     * in fixed point). Hand case: robot (99, 98, 0), ref (99.5, 98.25, 0):
     * e1 = 0.5, e2 = 0.25. Then eq. (1) in double for general poses, with
     * position differences up to 4 m. */
    pose_t robot = tu_pose(99.0, 98.0, 0.0), ref = tu_pose(99.5, 98.25, 0.0);
    trk_err_t err;
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 0.5, err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_E12, 0.25, err.e2);
    check_errors(95.0, 97.0, 0.7, 95.4, 96.8, 0.9);
    check_errors(-98.5, 99.0, -2.8, -101.0, 97.5, 2.9);
    check_errors(2.0, -99.0, 1.9, 0.5, -96.0, 1.2);
}

static void test_trk_e3_wraps_across_the_seam(void)
{
    /* θ_r = 3.0, θ = −3.0: θ_r − θ = 6 → 6 − 2π = −0.2831853 (a small turn
     * right across ±π, not a turn of 6 rad left). */
    pose_t robot = tu_pose(0.0, 0.0, -3.0), ref = tu_pose(0.0, 0.0, 3.0);
    trk_err_t err;
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E3, 6.0 - TU_TWO_PI, err.e3);
    /* The reverse: −6 → −6 + 2π = 0.2831853. */
    robot = tu_pose(0.0, 0.0, 3.0);
    ref = tu_pose(0.0, 0.0, -3.0);
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E3, -6.0 + TU_TWO_PI, err.e3);
    /* Heading any value (pose.h): θ = 0.1 + 3 turns, θ_r = 0.4 → e3 = 0.3. */
    robot = tu_pose(0.0, 0.0, 0.1 + 3.0 * TU_TWO_PI);
    ref = tu_pose(0.0, 0.0, 0.4);
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_NUM_WITHIN(TOL_E3_TURNS, 0.3, err.e3);
    TEST_ASSERT_NUM_ANGLE_IN_RANGE(err.e3);
}

static void test_trk_e3_of_opposite_headings_is_plus_pi(void)
{
    /* θ_r − θ = π exactly (as far as the inputs hold it): e3 ∈ (−π, π] so
     * it must be ≈ +π, whichever way round. */
    pose_t robot = tu_pose(0.0, 0.0, -TU_PI / 2.0), ref = tu_pose(0.0, 0.0, TU_PI / 2.0);
    trk_err_t err;
    trk_errors(&robot, &ref, &err);
    TEST_ASSERT_ANGLE_WITHIN(TOL_E3, TU_PI, err.e3);
    TEST_ASSERT_NUM_ANGLE_IN_RANGE(err.e3);
}

/* ---------------------------------------------------------- eq. (2)-(3) */

static void test_trk_control_zero_error_follows_the_reference(void)
{
    /* e = 0: v = v_r·cos 0 + 0 = v_r, ω = ω_r + 0 + 0 = ω_r. */
    trk_gains_t g = { tu_num(3.0), tu_num(12.0), tu_num(6.0) };
    trk_err_t err = { NUM_ZERO, NUM_ZERO, NUM_ZERO };
    num_t v, w;
    trk_control(&g, &err, tu_num(0.48), tu_num(-0.3), &v, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.48, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -0.3, w);
}

static void test_trk_control_hand_values(void)
{
    trk_gains_t g = { tu_num(3.0), tu_num(12.0), tu_num(6.0) };
    num_t v, w;
    /* e1 = 0.2, e2 = 0.1, e3 = 0, v_r = 1, ω_r = 0:
     * v = 1·1 + 3·0.2 = 1.6; ω = 0 + 12·1·0.1 + 6·1·0 = 1.2. */
    trk_err_t err = { tu_num(0.2), tu_num(0.1), NUM_ZERO };
    trk_control(&g, &err, tu_num(1.0), NUM_ZERO, &v, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 1.6, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 1.2, w);

    /* e3 = π/2 (cos 0, sin 1), e1 = e2 = 0, v_r = 0.5, ω_r = 0.2:
     * v = 0; ω = 0.2 + 0 + 6·0.5·1 = 3.2. */
    err = (trk_err_t){ NUM_ZERO, NUM_ZERO, tu_num(TU_PI / 2.0) };
    trk_control(&g, &err, tu_num(0.5), tu_num(0.2), &v, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 3.2, w);

    /* v_r = ω_r = 0, e1 = 0.2, e2 = 0.1, e3 = 0.3: every ω term has a factor
     * v_r or is ω_r, so ω = 0; v = 0·cos 0.3 + 3·0.2 = 0.6. */
    err = (trk_err_t){ tu_num(0.2), tu_num(0.1), tu_num(0.3) };
    trk_control(&g, &err, NUM_ZERO, NUM_ZERO, &v, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.6, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, w);
}

static void test_trk_control_general_values(void)
{
    /* Table 1 gains; e1 = 0.1, e2 = −0.2, e3 = 0.3, v_r = 0.5, ω_r = 0.1.
     * v = 0.5 cos 0.3 + 0.3 = 0.7776682, ω = 0.1 − 1.2 + 3 sin 0.3 = −0.2134394
     * (eq. (2)-(3) in double below). */
    trk_gains_t g = { tu_num(3.0), tu_num(12.0), tu_num(6.0) };
    trk_err_t err = { tu_num(0.1), tu_num(-0.2), tu_num(0.3) };
    num_t v, w;
    trk_control(&g, &err, tu_num(0.5), tu_num(0.1), &v, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.5 * cos(tu_q(0.3)) + 3.0 * tu_q(0.1), v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, tu_q(0.1) + 12.0 * 0.5 * tu_q(-0.2) + 6.0 * 0.5 * sin(tu_q(0.3)),
                           w);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.7776682, 0.5 * cos(0.3) + 0.3);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -0.2134394, 0.1 - 1.2 + 3.0 * sin(0.3));
}

static void test_trk_control_uses_each_gain_in_its_place(void)
{
    /* Distinct gains k1 = 1, k2 = 2, k3 = 3 catch a swap. e1 = 0.1, e2 = 0.2,
     * e3 = 0.5, v_r = 2, ω_r = −0.5:
     * v = 2 cos 0.5 + 1·0.1 = 1.8551651;
     * ω = −0.5 + 2·2·0.2 + 3·2·sin 0.5 = −0.5 + 0.8 + 2.8765534 = 3.1765534. */
    trk_gains_t g = { tu_num(1.0), tu_num(2.0), tu_num(3.0) };
    trk_err_t err = { tu_num(0.1), tu_num(0.2), tu_num(0.5) };
    num_t v, w;
    trk_control(&g, &err, tu_num(2.0), tu_num(-0.5), &v, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 2.0 * cos(0.5) + tu_q(0.1), v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -0.5 + 4.0 * tu_q(0.2) + 6.0 * sin(0.5), w);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 1.8551651, 2.0 * cos(0.5) + 0.1);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 3.1765534, -0.5 + 0.8 + 6.0 * sin(0.5));
}

static void test_trk_control_reverse_reference(void)
{
    /* v_r < 0 (reference driving backwards), Table 1 gains, e1 = −0.1,
     * e2 = 0.05, e3 = −0.2, v_r = −0.4, ω_r = 0.25:
     * v = −0.4 cos(−0.2) − 0.3 = −0.6920266;
     * ω = 0.25 + 12(−0.4)(0.05) + 6(−0.4) sin(−0.2) = 0.25 − 0.24 + 0.4768064
     *   = 0.4868064. */
    trk_gains_t g = { tu_num(3.0), tu_num(12.0), tu_num(6.0) };
    trk_err_t err = { tu_num(-0.1), tu_num(0.05), tu_num(-0.2) };
    num_t v, w;
    trk_control(&g, &err, tu_num(-0.4), tu_num(0.25), &v, &w);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -0.4 * cos(tu_q(-0.2)) + 3.0 * tu_q(-0.1), v);
    TEST_ASSERT_NUM_WITHIN(
        TOL_VW, 0.25 + 12.0 * tu_q(-0.4) * tu_q(0.05) + 6.0 * tu_q(-0.4) * sin(tu_q(-0.2)), w);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -0.6920266, -0.4 * cos(-0.2) - 0.3);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.4868064, 0.25 - 0.24 - 2.4 * sin(-0.2));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_trk_errors_robot_at_origin_heading_east);
    RUN_TEST(test_trk_errors_rotate_into_the_body_frame);
    RUN_TEST(test_trk_errors_general_poses);
    RUN_TEST(test_trk_errors_far_from_the_origin);
    RUN_TEST(test_trk_e3_wraps_across_the_seam);
    RUN_TEST(test_trk_e3_of_opposite_headings_is_plus_pi);
    RUN_TEST(test_trk_control_zero_error_follows_the_reference);
    RUN_TEST(test_trk_control_hand_values);
    RUN_TEST(test_trk_control_general_values);
    RUN_TEST(test_trk_control_uses_each_gain_in_its_place);
    RUN_TEST(test_trk_control_reverse_reference);
    return UNITY_END();
}
