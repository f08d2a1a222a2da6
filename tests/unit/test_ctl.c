/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/ctl: parameters (Table 1 defaults and their
 * check, the strategy), and the control step end to end (supervisor, active
 * controller, kinematics) on hand-derived cases. The cases that derive the
 * paper's behaviour select the "paper" strategy (paper_params()); the
 * "mstc" step has its own cases at the end, and its modules their own test
 * files (test_oset, test_rol, test_cbf, test_msw).
 *
 * Expected values: hand derivations written beside them, with the closed
 * forms of eq. (1)-(3), (21)-(24) and the kinematics of kin.h evaluated in
 * double inside the test where a number has many digits.
 */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "ctrl/ctl.h"
#include "test_util.h"
#include "unity.h"

/* ------------------------------------------------------------ tolerances */

/* Parameters as stored [m, gains]: conversion of values ≤ 100. float: the
 * literal to float, 1 ulp relative; fixed: half a Q16.16 lsb. */
#define TOL_PARAM     TU_TOL(1e-5, 1e-5)
/* e1, e2 [m], e3 [rad] for differences ≤ 0.2 m. float: a few roundings of
 * values ≤ 0.2 (7.5e-9) and sin/cos of 0.1 (7.5e-9); fixed: sin/cos error
 * 1e-4 times 0.2 m plus Q16.16 roundings, and 2e-5 for e3. */
#define TOL_ERR       TU_TOL(1e-6, 1e-4)
/* v [m/s], ω [rad/s] ≤ 9 in tracking: float: ~10 roundings of values ≤ 1
 * (6e-8) → 1e-6; fixed: cos/sin error 1e-4 times k3·v_r = 3 → 3e-4, plus
 * products. */
#define TOL_VW        TU_TOL(2e-6, 1e-3)
/* Wheel speeds [rad/s] ≤ 40: v and ω errors above divided by r = 0.05
 * (×20, ×3 for ω·L/2r). float: 8e-5 → 1e-4; fixed: 1e-3·(20 + 3) → 2.5e-2. */
#define TOL_WHEEL     TU_TOL(1e-4, 2.5e-2)
/* Avoidance ω [rad/s] ≤ 9: β̇ (|u| = 0.35) and k2 = 6 times e. float:
 * β̇ 2e-5 plus 6·1e-6; fixed: β̇ 3e-3 plus 6·3e-4. */
#define TOL_OMEGA_AVD TU_TOL(5e-5, 6e-3)
/* Avoidance wheel speeds ≤ 40: ω error times L/2r = 3 plus v error ×20.
 * float: 2e-4; fixed: 6e-3·3 + 1e-3·20 → 4e-2. */
#define TOL_WHEEL_AVD TU_TOL(2e-4, 4e-2)
/* Heading error e [rad] with |u| ≥ 0.35. float: atan2f and a subtraction
 * (≤ 5e-7); fixed: atan2 error ~1e-4 plus Q16.16 rounding of u ≈ 3e-5 over
 * |u| ≥ 0.35. */
#define TOL_E         TU_TOL(1e-6, 3e-4)
/* Distances [m] ≤ 1 in the status: float: hypotf, 1 ulp (1.2e-7); fixed:
 * Q16.16 root, 2 lsb. */
#define TOL_DIST      TU_TOL(5e-7, 4e-5)

static ctl_t c;
static ctl_output_t out;

/* Geometry of ctl.h's defaults. */
#define R_WHEEL    0.05
#define HALF_TRACK 0.15

/* Table 1 with the paper's switch strategy. */
static void paper_params(ctl_params_t *p)
{
    ctl_params_default(p);
    p->strategy = num_from_int(CTL_STRATEGY_PAPER);
}

void setUp(void)
{
    memset(&c, 0, sizeof c);
    memset(&out, 0, sizeof out);
    ctl_params_t p;
    paper_params(&p);
    TEST_ASSERT_EQUAL_INT(0, ctl_init(&c, &p));
}

void tearDown(void) {}

static ctl_input_t input(pose_t robot, pose_t ref, double v_r, double w_r,
                         const sup_obstacle_t *obs, size_t n, uint64_t t_us)
{
    ctl_input_t in = { .wheels_measured = false }; /* none measured: the firmware predicts */
    in.robot = robot;
    in.ref = ref;
    in.v_r = tu_num(v_r);
    in.w_r = tu_num(w_r);
    in.obstacles = obs;
    in.n_obstacles = n;
    in.t_us = t_us;
    return in;
}

static sup_obstacle_t obstacle(uint8_t id, double x, double y, double radius)
{
    sup_obstacle_t o;
    o.id = id;
    o.x = tu_num(x);
    o.y = tu_num(y);
    o.radius = tu_num(radius);
    o.vx = NUM_ZERO; /* static */
    o.vy = NUM_ZERO;
    return o;
}

/* ------------------------------------------------------------ parameters */

static void test_ctl_defaults_are_table_1(void)
{
    ctl_params_t p;
    memset(&p, 0, sizeof p);
    ctl_params_default(&p);
    /* Table 1: R_m 0.2, R_ob 0.1, D_det 3.5, D_act 0.5, D_s 0.35; tracking
     * gains 3, 12, 6; avoidance gains 3, 6. ctl.h: r 0.05, L 0.3, 100 rad/s. */
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.2, p.r_m);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.1, p.r_ob);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 3.5, p.d_det);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.5, p.d_act);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.35, p.d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 3.0, p.trk.k1);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 12.0, p.trk.k2);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 6.0, p.trk.k3);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 3.0, p.avd.k1);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 6.0, p.avd.k2);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.05, p.kin.wheel_radius);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.3, p.kin.track_width);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 100.0, p.kin.max_wheel_speed);
    /* The board images' strategy (ctl.h). */
    TEST_ASSERT_TRUE(ctl_is_mstc(&p));
    TEST_ASSERT_EQUAL_INT(0, ctl_params_check(&p));
}

/* Apply one change to the defaults and expect ctl_params_check's verdict. */
#define EXPECT_CHECK(expected, change)                                                             \
    do {                                                                                           \
        ctl_params_t p_;                                                                           \
        ctl_params_default(&p_);                                                                   \
        change;                                                                                    \
        TEST_ASSERT_EQUAL_INT_MESSAGE((expected), ctl_params_check(&p_), #change);                 \
    } while (0)

static void test_ctl_params_check_rejects_each_bad_parameter(void)
{
    /* D_s < D_act (Definition 4): D_s = D_act and D_s > D_act rejected. */
    EXPECT_CHECK(-EINVAL, p_.d_s = tu_num(0.5));
    EXPECT_CHECK(-EINVAL, p_.d_s = tu_num(0.6));
    EXPECT_CHECK(-EINVAL, p_.d_act = tu_num(0.3));
    /* D_s ≥ R_m (Definition 2, eq. (6)), and ≥ R_m + R_ob (docs/safety.md). */
    EXPECT_CHECK(-EINVAL, p_.d_s = tu_num(0.19));
    EXPECT_CHECK(-EINVAL, p_.r_m = tu_num(0.36));
    /* D_act ≤ D_det. */
    EXPECT_CHECK(-EINVAL, p_.d_det = tu_num(0.4));
    /* Every value > 0. */
    EXPECT_CHECK(-EINVAL, p_.r_m = NUM_ZERO);
    EXPECT_CHECK(-EINVAL, p_.r_m = tu_num(-0.2));
    EXPECT_CHECK(-EINVAL, p_.r_ob = NUM_ZERO);
    EXPECT_CHECK(-EINVAL, p_.r_ob = tu_num(-0.1));
    EXPECT_CHECK(-EINVAL, p_.trk.k1 = NUM_ZERO);
    EXPECT_CHECK(-EINVAL, p_.trk.k2 = tu_num(-12.0));
    EXPECT_CHECK(-EINVAL, p_.trk.k3 = NUM_ZERO);
    EXPECT_CHECK(-EINVAL, p_.avd.k1 = tu_num(-3.0));
    EXPECT_CHECK(-EINVAL, p_.avd.k2 = NUM_ZERO);
    EXPECT_CHECK(-EINVAL, p_.kin.wheel_radius = NUM_ZERO);
    EXPECT_CHECK(-EINVAL, p_.kin.track_width = tu_num(-0.3));
    EXPECT_CHECK(-EINVAL, p_.kin.max_wheel_speed = NUM_ZERO);
    /* The strategy is 0 (paper) or 1 (mstc). */
    EXPECT_CHECK(-EINVAL, p_.strategy = num_from_int(2));
    EXPECT_CHECK(-EINVAL, p_.strategy = num_from_int(255));
    EXPECT_CHECK(-EINVAL, p_.strategy = num_from_int(-1));
    /* An enumerated parameter: a whole number only. */
    EXPECT_CHECK(-EINVAL, p_.strategy = tu_num(0.5));
}

static void test_ctl_params_check_accepts_the_boundaries(void)
{
    /* D_s = R_m + R_ob is allowed (D_s ≥ R_m + R_ob, docs/safety.md: 0.25 +
     * 0.1 = 0.35 exactly as held, in both modes), D_act = D_det too
     * (D_act ≤ D_det). */
    EXPECT_CHECK(0, p_.r_m = tu_num(0.25));
    EXPECT_CHECK(0, p_.d_det = tu_num(0.5));
    /* Other valid values. */
    EXPECT_CHECK(0, (p_.trk.k1 = tu_num(0.5), p_.avd.k2 = tu_num(20.0)));
    EXPECT_CHECK(0, p_.strategy = num_from_int(CTL_STRATEGY_PAPER));
    EXPECT_CHECK(0, p_.strategy = num_from_int(CTL_STRATEGY_MSTC));
}

#ifndef NUM_FIXED
/* Float mode only: Q16.16 has no NaN or infinity, so these parameters cannot
 * be built in fixed mode. */
static void test_ctl_params_check_rejects_non_finite_values(void)
{
    EXPECT_CHECK(-EINVAL, p_.d_s = num_from_float(NAN));
    EXPECT_CHECK(-EINVAL, p_.d_act = num_from_float(NAN));
    EXPECT_CHECK(-EINVAL, p_.d_det = num_from_float(INFINITY));
    EXPECT_CHECK(-EINVAL, p_.r_m = num_from_float(NAN));
    EXPECT_CHECK(-EINVAL, p_.r_ob = num_from_float(INFINITY));
    EXPECT_CHECK(-EINVAL, p_.trk.k2 = num_from_float(NAN));
    EXPECT_CHECK(-EINVAL, p_.avd.k1 = num_from_float(INFINITY));
    EXPECT_CHECK(-EINVAL, p_.kin.wheel_radius = num_from_float(NAN));
    EXPECT_CHECK(-EINVAL, p_.kin.max_wheel_speed = num_from_float(INFINITY));
}
#endif

static void test_ctl_init_with_bad_parameters_falls_back_to_defaults(void)
{
    ctl_params_t p;
    ctl_params_default(&p);
    p.d_s = tu_num(0.6); /* ≥ D_act */
    p.trk.k1 = tu_num(-1.0);
    memset(&c, 0, sizeof c); /* nothing left over from setUp's ctl_init */
    TEST_ASSERT_EQUAL_INT(-EINVAL, ctl_init(&c, &p));
    /* ctl.h: left reset with default parameters. */
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.35, c.p.d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 3.0, c.p.trk.k1);
    TEST_ASSERT_EQUAL_INT(0, ctl_params_check(&c.p));
    /* A step stays safe: the tracking hand case below, same wheels. */
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.2, 0.0, 0.0), 0.0, 0.1, NULL, 0, 0);
    ctl_step(&c, &in, &out);
    /* v = 0 + 3·0.2 = 0.6 (default k1 = 3, not −1), ω = 0.1:
     * ω_R = (0.6 + 0.015)/0.05 = 12.3, ω_L = (0.6 − 0.015)/0.05 = 11.7; the
     * default strategy "mstc" with the default wheels (20 rad/s²) changes
     * them from standstill by at most 20 × 0.02 = 0.4 rad/s over the first
     * period (CTL_FIRST_DT), both by one factor 0.4/12.3: 0.4 and
     * 11.7 × 0.4/12.3 = 0.3804878. The prediction (wheel_tau 0.06 s) sees
     * standstill; the robot is aligned with its reference (e2 = 0, e3 =
     * 0.1 × T_p, a few hundredths: ctl_most_speed()), so the catch-up limit
     * is sqrt(2 × 0.75 × 0.05 × 20 × 0.2) = sqrt(0.3) = 0.5477226 m/s, and
     * it leaves v = 0.6 (its correction k1 e1 = 0.6 > 0.5477!): v =
     * 0.5477226, so ω_R = (0.5477226 + 0.015)/0.05 = 11.254452, ω_L =
     * 10.654452 before the limiter: 0.4 and 10.654452 × 0.4/11.254452 =
     * 0.3786751. */
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 0.4, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 0.3786751, out.wheels.left);
}

/* ---------------------------------------------------------------- tracking */

static void test_ctl_tracking_step_gives_eq2_eq3_wheel_speeds(void)
{
    /* Robot (0, 0, 0), ref (0.1, 0.05, 0.1), v_r 0.5, ω_r 0.1, no obstacles.
     * Eq. (1), θ = 0: e1 = 0.1, e2 = 0.05, e3 = 0.1.
     * Eq. (2): v = 0.5 cos 0.1 + 3·0.1 = 0.4975021 + 0.3 = 0.7975021.
     * Eq. (3): ω = 0.1 + 12·0.5·0.05 + 6·0.5·sin 0.1 = 0.1 + 0.3 + 0.2995002
     *        = 0.6995002.
     * Wheels: ω_R = (v + 0.15 ω)/0.05 = 18.0485, ω_L = (v − 0.15 ω)/0.05
     *        = 13.8515 (to 4 decimals; closed form in double below). */
    ctl_input_t in =
        input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.05, 0.1), 0.5, 0.1, NULL, 0, 123456);
    ctl_step(&c, &in, &out);
    const double e1 = tu_q(0.1), e2 = tu_q(0.05), e3 = tu_q(0.1);
    const double v = 0.5 * cos(e3) + 3.0 * e1;
    const double w = tu_q(0.1) + 12.0 * 0.5 * e2 + 6.0 * 0.5 * sin(e3);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.7975021, 0.5 * cos(0.1) + 0.3);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.6995002, 0.4 + 3.0 * sin(0.1));
    TEST_ASSERT_DOUBLE_WITHIN(1e-4, 18.0485, (0.7975021 + 0.15 * 0.6995002) / 0.05);
    TEST_ASSERT_DOUBLE_WITHIN(1e-4, 13.8515, (0.7975021 - 0.15 * 0.6995002) / 0.05);

    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, (v + HALF_TRACK * w) / R_WHEEL, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, (v - HALF_TRACK * w) / R_WHEEL, out.wheels.left);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, out.status.mode);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.active_obstacle);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_NONE, out.status.side);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.1, out.status.err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.05, out.status.err.e2);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.1, out.status.err.e3);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.0, out.status.e);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, v, out.status.v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, w, out.status.w);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.faults);
    TEST_ASSERT_EQUAL_size_t(0, out.n_events);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.n_obstacles);
}

static void test_ctl_tracking_in_a_rotated_frame(void)
{
    /* Robot (1, 2, π/2), ref (0.9, 2.2, π/2 + 0.05), v_r 0.4, ω_r −0.2.
     * Eq. (1), θ = π/2: e1 = Δy = 0.2, e2 = −Δx = 0.1, e3 = 0.05.
     * v = 0.4 cos 0.05 + 0.6 = 0.9995001; ω = −0.2 + 12·0.4·0.1 + 6·0.4·sin 0.05
     *   = −0.2 + 0.48 + 0.1199500 = 0.3999500. */
    ctl_input_t in = input(tu_pose(1.0, 2.0, TU_PI / 2), tu_pose(0.9, 2.2, TU_PI / 2 + 0.05), 0.4,
                           -0.2, NULL, 0, 0);
    ctl_step(&c, &in, &out);
    const double v = 0.4 * cos(0.05) + 0.6, w = -0.2 + 0.48 + 2.4 * sin(0.05);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.9995001, v);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.3999500, w);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.2, out.status.err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.1, out.status.err.e2);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.05, out.status.err.e3);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, (v + HALF_TRACK * w) / R_WHEEL, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, (v - HALF_TRACK * w) / R_WHEEL, out.wheels.left);
}

static void test_ctl_saturation_scales_wheels_and_reports_it(void)
{
    /* The first tracking case with a 10 rad/s limit: ω_R = 18.0485 is the
     * larger, factor k = 10/ω_R: right → 10, left → 13.8515·k = 7.6746.
     * The status reports v, ω after saturation: both times k. */
    ctl_params_t p;
    paper_params(&p);
    p.kin.max_wheel_speed = tu_num(10.0);
    TEST_ASSERT_EQUAL_INT(0, ctl_init(&c, &p));
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.05, 0.1), 0.5, 0.1, NULL, 0, 0);
    ctl_step(&c, &in, &out);
    const double v = 0.5 * cos(tu_q(0.1)) + 3.0 * tu_q(0.1);
    const double w = tu_q(0.1) + 12.0 * 0.5 * tu_q(0.05) + 3.0 * sin(tu_q(0.1));
    const double right = (v + HALF_TRACK * w) / R_WHEEL, left = (v - HALF_TRACK * w) / R_WHEEL;
    const double k = 10.0 / right;
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 10.0, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, left * k, out.wheels.left);
    TEST_ASSERT_TRUE(out.wheels.right <= p.kin.max_wheel_speed);
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_SATURATED) != 0);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, v * k, out.status.v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, w * k, out.status.w);
    /* Without saturation the bit is clear (previous test's case, limit 100). */
    setUp();
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_SATURATED) == 0);
}

/* ------------------------------------------------------------------- stop */

static void test_ctl_p3_gives_zero_wheel_speeds(void)
{
    /* v_r = ω_r = 0 with the robot 0.2 m behind the reference: the tracking
     * law alone would give v = k1·e1 = 0.6; p3 gives v = ω = 0. */
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.2, 0.1, 0.3), 0.0, 0.0, NULL, 0, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_STOP, out.status.mode);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 0.0, out.wheels.left);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 0.0, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, out.status.v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, out.status.w);
}

/* ------------------------------------------------------------- non-finite */

#ifndef NUM_FIXED
/* Float mode only: Q16.16 has no NaN or infinity, so a non-finite input
 * cannot be built in fixed mode and the guard has nothing to catch there. */
static void test_ctl_non_finite_input_stops_the_robot(void)
{
    const pose_t robot = tu_pose(0.0, 0.0, 0.0), ref = tu_pose(0.1, 0.05, 0.1);
    const num_t q_nan = num_from_float(NAN), q_inf = num_from_float(INFINITY);
    for (int k = 0; k < 8; k++) {
        setUp();
        ctl_input_t in = input(robot, ref, 0.5, 0.1, NULL, 0, 0);
        const char *what = "";
        switch (k) {
        case 0:
            in.robot.x = q_nan;
            what = "robot.x NaN";
            break;
        case 1:
            in.robot.y = q_inf;
            what = "robot.y inf";
            break;
        case 2:
            in.robot.theta = q_nan;
            what = "robot.theta NaN";
            break;
        case 3:
            in.ref.x = num_neg(q_inf);
            what = "ref.x -inf";
            break;
        case 4:
            in.ref.y = q_nan;
            what = "ref.y NaN";
            break;
        case 5:
            in.ref.theta = q_inf;
            what = "ref.theta inf";
            break;
        case 6:
            in.v_r = q_inf;
            what = "v_r inf";
            break;
        default:
            in.w_r = q_nan;
            what = "w_r NaN";
            break;
        }
        ctl_step(&c, &in, &out);
        TEST_ASSERT_EQUAL_INT_MESSAGE(SUP_MODE_STOP, out.status.mode, what);
        TEST_ASSERT_TRUE_MESSAGE(out.wheels.left == 0.0f && out.wheels.right == 0.0f, what);
        TEST_ASSERT_TRUE_MESSAGE((out.status.faults & CTL_FAULT_INPUT_NONFINITE) != 0, what);
    }
}

static void test_ctl_non_finite_input_leaves_the_supervisor_untouched(void)
{
    /* Step 1: obstacle 1 detected 2 m away. Step 2: NaN pose, and a new
     * obstacle 2 reported: no event, the table unchanged. Step 3: valid
     * again: obstacle 2 is new, so it is detected now. */
    sup_obstacle_t o[2] = { obstacle(1, 2.0, 0.0, 0.1), obstacle(2, 0.0, 2.0, 0.1) };
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), 0.5, 0.0, o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(1, out.n_events);
    in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), 0.5, 0.0, o, 2, 20000);
    in.robot.x = num_from_float(NAN);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(0, out.n_events);
    TEST_ASSERT_EQUAL_UINT8(1, c.sup.n_obs);
    in.robot.x = NUM_ZERO;
    in.t_us = 40000;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(1, out.n_events);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_DETECT, out.events[0].kind);
    TEST_ASSERT_EQUAL_UINT8(2, out.events[0].obstacle);
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_INPUT_NONFINITE) == 0);
}
#endif

/* ----------------------------------------------------------- avoidance */

static void test_ctl_avoidance_step_on_the_safe_circle(void)
{
    /* Robot (0, 0, 0.3); ref beside it, 0.1 m to its left:
     * (−0.1 sin 0.3, 0.1 cos 0.3), θ_r = 0.3 → e1 = 0, e2 = 0.1, e3 = 0.
     * Obstacle 6 at (0.35, 0): D_r = 0.35 < 0.5; u2 = (−0.0296 − 0.35,
     * 0.0955), |u2| = 0.39 < 0.5 → p1 false → p2 → ACTIVATE; φ = 0,
     * θ − φ = 0.3 → LEFT.
     * Eq. (23): v = 0.5 cos 0 + 3·0 = 0.5 (= v_r, so β̇ below is the same
     * whichever of v and v_r the step feeds it).
     * On the safe circle, LEFT, obstacle east: β = π/2;
     * e = π/2 − 0.3 = 1.2707963;
     * β̇ = v (cos θ − sin θ)/D_s = 0.5 (0.9553365 − 0.2955202)/0.35 = 0.9425947
     * (derived in test_avd.c: u̇ = (−q̇_x + q̇_y, −q̇_x), β̇ = −u̇_x/D_s);
     * ω = β̇ + 6 e = 0.9425947 + 7.6247780 = 8.5673727.
     * Wheels: ω_R = (0.5 + 0.15 ω)/0.05 = 35.702118,
     *         ω_L = (0.5 − 0.15 ω)/0.05 = −15.702118. */
    const double th = 0.3;
    sup_obstacle_t o = obstacle(6, 0.35, 0.0, 0.1);
    ctl_input_t in = input(tu_pose(0.0, 0.0, th), tu_pose(-0.1 * sin(th), 0.1 * cos(th), th), 0.5,
                           0.0, &o, 1, 7000000);
    ctl_step(&c, &in, &out);

    TEST_ASSERT_EQUAL_size_t(2, out.n_events);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_DETECT, out.events[0].kind);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_ACTIVATE, out.events[1].kind);
    TEST_ASSERT_EQUAL_UINT8(6, out.events[1].obstacle);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, out.events[1].side);
    TEST_ASSERT_EQUAL_UINT64(7000000, out.events[1].t_us);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
    TEST_ASSERT_EQUAL_UINT8(6, out.status.active_obstacle);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, out.status.side);
    TEST_ASSERT_EQUAL_UINT8(1, out.status.n_obstacles);
    TEST_ASSERT_EQUAL_UINT8(6, out.status.obstacle_id[0]);
    TEST_ASSERT_NUM_WITHIN(TOL_DIST, 0.35, out.status.distance[0]);

    const double t = tu_q(th);
    const double e = TU_PI / 2 - t;
    const double w = 0.5 * (cos(t) - sin(t)) / 0.35 + 6.0 * e;
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 8.5673727,
                              0.5 * (cos(0.3) - sin(0.3)) / 0.35 + 6.0 * (TU_PI / 2 - 0.3));
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.0, out.status.err.e1);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.1, out.status.err.e2);
    TEST_ASSERT_NUM_WITHIN(TOL_ERR, 0.0, out.status.err.e3);
    TEST_ASSERT_NUM_WITHIN(TOL_E, e, out.status.e);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.5, out.status.v);
    TEST_ASSERT_NUM_WITHIN(TOL_OMEGA_AVD, w, out.status.w);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL_AVD, (0.5 + HALF_TRACK * w) / R_WHEEL, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL_AVD, (0.5 - HALF_TRACK * w) / R_WHEEL, out.wheels.left);
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, 35.702118, (0.5 + 0.15 * 8.5673727) / 0.05);
}

static void test_ctl_avoidance_uses_the_obstacle_own_safe_distance(void)
{
    /* sup.h: an obstacle of radius 0.3 has D_s = 0.35 + 0.2 = 0.55 and
     * D_act = 0.7. Robot (0, 0, 0.3) at 0.55 from obstacle 8 at (0.55, 0);
     * ref as above (e1 = e3 = 0). 0.55 < 0.7 → ACTIVATE LEFT.
     * On its safe circle: β = π/2 (with D_s = 0.35 it would be
     * atan2(0.55, 0.2) = 1.22), e = π/2 − 0.3,
     * β̇ = 0.5 (cos 0.3 − sin 0.3)/0.55 = 0.5998330, ω = β̇ + 6e = 8.2246110. */
    const double th = 0.3;
    sup_obstacle_t o = obstacle(8, 0.55, 0.0, 0.3);
    ctl_input_t in = input(tu_pose(0.0, 0.0, th), tu_pose(-0.1 * sin(th), 0.1 * cos(th), th), 0.5,
                           0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, out.status.side);
    const double t = tu_q(th);
    const double e = TU_PI / 2 - t;
    const double w = 0.5 * (cos(t) - sin(t)) / 0.55 + 6.0 * e;
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 8.2246110,
                              0.5 * (cos(0.3) - sin(0.3)) / 0.55 + 6.0 * (TU_PI / 2 - 0.3));
    TEST_ASSERT_NUM_WITHIN(TOL_E, e, out.status.e);
    TEST_ASSERT_NUM_WITHIN(TOL_OMEGA_AVD, w, out.status.w);
}

static void test_ctl_reports_dropped_obstacles(void)
{
    /* An id-0 report is rejected: CTL_FAULT_OBSTACLE_DROPPED, the step still
     * runs (tracking). */
    sup_obstacle_t o = obstacle(0, 1.0, 0.0, 0.1);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_OBSTACLE_DROPPED) != 0);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, out.status.mode);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.n_obstacles);
    /* v = 0.5 + 3·0.1 = 0.8, ω = 0: both wheels 0.8/0.05 = 16. */
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 16.0, out.wheels.left);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 16.0, out.wheels.right);
    /* Next step without the bad report: the bit is of this step only. */
    in.n_obstacles = 0;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_OBSTACLE_DROPPED) == 0);
}

static void test_ctl_reset_forgets_obstacles(void)
{
    sup_obstacle_t o = obstacle(6, 0.35, 0.0, 0.1);
    ctl_input_t in =
        input(tu_pose(0.0, 0.0, 0.3), tu_pose(-0.0296, 0.0955, 0.3), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
    ctl_reset(&c);
    in.n_obstacles = 0;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, out.status.mode);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.n_obstacles);
    /* Parameters are kept. */
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.35, c.p.d_s);
}

static void test_ctl_set_params_rejects_bad_values_and_changes_nothing(void)
{
    /* Avoiding obstacle 6 (as in the safe-circle case); then a bad set
     * (D_s = D_act) is rejected and changes neither parameters nor state. */
    sup_obstacle_t o = obstacle(6, 0.35, 0.0, 0.1);
    ctl_input_t in =
        input(tu_pose(0.0, 0.0, 0.3), tu_pose(-0.0296, 0.0955, 0.3), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
    ctl_params_t p;
    paper_params(&p);
    p.d_s = tu_num(0.5);
    p.trk.k1 = tu_num(7.0);
    TEST_ASSERT_EQUAL_INT(-EINVAL, ctl_set_params(&c, &p));
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.35, c.p.d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 3.0, c.p.trk.k1);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.35, c.sup.p.d_s);
    TEST_ASSERT_EQUAL_UINT8(1, c.sup.n_obs);
    TEST_ASSERT_EQUAL_UINT8(1, c.sup.avoiding);
}

static void test_ctl_set_params_applies_and_keeps_the_supervisor_state(void)
{
    /* Same avoidance; a valid set with D_s 0.3, D_act 0.6 and tracking k1 5
     * is applied, the obstacle and the avoidance with its side are kept, and
     * the obstacle's thresholds follow (radius 0.1 = R_ob: 0.3, 0.6). */
    sup_obstacle_t o = obstacle(6, 0.35, 0.0, 0.1);
    ctl_input_t in =
        input(tu_pose(0.0, 0.0, 0.3), tu_pose(-0.0296, 0.0955, 0.3), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, out.status.side);
    ctl_params_t p;
    paper_params(&p);
    p.d_s = tu_num(0.3);
    p.d_act = tu_num(0.6);
    p.trk.k1 = tu_num(5.0);
    TEST_ASSERT_EQUAL_INT(0, ctl_set_params(&c, &p));
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.3, c.p.d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 5.0, c.p.trk.k1);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.6, c.sup.p.d_act);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.3, c.sup.obs[0].d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.6, c.sup.obs[0].d_act);
    in.t_us = 20000;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(0, out.n_events);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, out.status.side);
    /* The new D_s is the one the avoidance uses: robot at 0.35 from the
     * obstacle, D_s 0.3: u_mo = (0.35, 0), u_p = (0.05, 0), LEFT u_f =
     * (0, 0.35): β = atan2(0.35, 0.05) = atan 7 = 1.4288993, e = β − 0.3. */
    TEST_ASSERT_NUM_WITHIN(TOL_E, atan(7.0) - tu_q(0.3), out.status.e);
}

/* ------------------------------------------------------------------ mstc */

/* Table 1 with the "mstc" strategy (the default), and wheels that follow at
 * once (wheel_accel 10000 rad/s², wheel_tau 0): the strategy's own decisions,
 * which the wheels' limits (test_act.c, and the tests below that set them)
 * would only delay. */
static void mstc_init(void)
{
    ctl_params_t p;
    ctl_params_default(&p);
    p.wheel_accel = num_from_int(10000);
    p.wheel_tau = NUM_ZERO;
    TEST_ASSERT_EQUAL_INT(0, ctl_init(&c, &p));
}

static void test_ctl_mstc_tracks_as_the_paper_away_from_obstacles(void)
{
    /* The hand case of test_ctl_tracking_step_gives_eq2_eq3_wheel_speeds:
     * no obstacle, so nothing of "mstc" acts. */
    mstc_init();
    ctl_input_t in =
        input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.05, 0.1), 0.5, 0.1, NULL, 0, 123456);
    ctl_step(&c, &in, &out);
    const double e1 = tu_q(0.1), e2 = tu_q(0.05), e3 = tu_q(0.1);
    const double v = 0.5 * cos(e3) + 3.0 * e1;
    const double w = tu_q(0.1) + 12.0 * 0.5 * e2 + 6.0 * 0.5 * sin(e3);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, (v + HALF_TRACK * w) / R_WHEEL, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, (v - HALF_TRACK * w) / R_WHEEL, out.wheels.left);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, out.status.mode);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.faults);
    TEST_ASSERT_EQUAL_size_t(0, out.n_events);
    /* Far behind the reference (e1 = 1: v = 0.5 + 3 = 3.5) and far from any
     * obstacle (10 m): not regulated either. */
    sup_obstacle_t o = obstacle(3, 10.0, 10.0, 0.1);
    in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(1.0, 0.0, 0.0), 0.5, 0.0, &o, 1, 143456);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 3.5 / R_WHEEL, out.wheels.right);
}

static void test_ctl_mstc_filter_brakes_and_says_so(void)
{
    /* Robot (0, 0, 0), reference 1 m ahead at 0.5 m/s: eq. (2) gives
     * v = 0.5 + 3·1 = 3.5, ω = 0; an obstacle at (0.52, 0) is within
     * D_act + MSW_REGULATE, so the speed is regulated to v_r + MSW_CATCH_UP
     * = 1.5. 0.52 > D_act: no activation. The filter (cbf.h): p_l = (0.05, 0),
     * h = 0.47² − 0.4² = 0.0609, a = (−0.94, 0): ḣ = −0.94 v >= −20·0.0609
     * = −1.218 needs v <= 1.2957. Both wheels 1.2957 / 0.05 = 25.915. */
    mstc_init();
    sup_obstacle_t o = obstacle(7, 0.52, 0.0, 0.1);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(1.0, 0.0, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    const double v = 20.0 * (0.47 * 0.47 - 0.16) / 0.94;
    TEST_ASSERT_DOUBLE_WITHIN(1e-4, 1.2957, v);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, out.status.mode);
    TEST_ASSERT_EQUAL_UINT8(CTL_FAULT_FILTER, out.status.faults);
    TEST_ASSERT_EQUAL_size_t(2, out.n_events);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_DETECT, out.events[0].kind);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_FILTER, out.events[1].kind);
    TEST_ASSERT_EQUAL_UINT8(7, out.events[1].obstacle);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_NONE, out.events[1].side);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-4, 2e-2), v / R_WHEEL, out.wheels.left);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-4, 2e-2), v / R_WHEEL, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-3), v, out.status.v);
    /* The same step again: still filtered, but the episode goes on: no
     * event. */
    in.t_us = 20000;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(CTL_FAULT_FILTER, out.status.faults);
    TEST_ASSERT_EQUAL_size_t(0, out.n_events);
    /* The "paper" strategy has no filter: 3.5 m/s straight on. */
    setUp();
    in.t_us = 0;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.faults);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, 3.5 / R_WHEEL, out.wheels.left);
}

static void test_ctl_mstc_blocked_stops_the_wheels(void)
{
    /* Obstacle at (0.45, 0) straight ahead: activation. The reference waits
     * inside its D_act (no p1, no release), and the robot is then found
     * going round it on a 0.41 circle, turning 0.5 rad a step: after 14
     * steps (7 rad) the strategy calls it blocked: mode BLOCKED, wheels 0,
     * event BLOCKED naming the obstacle. */
    mstc_init();
    sup_obstacle_t o = obstacle(5, 0.45, 0.0, 0.1);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.45, 0.3, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
    TEST_ASSERT_EQUAL_UINT8(5, out.status.active_obstacle);
    for (int i = 1; i <= 14; i++) {
        const double th = 0.5 * i;
        in.robot = tu_pose(0.45 - 0.41 * sin(th), 0.41 * cos(th), th);
        /* The reference on its schedule, creeping on (one that stood still
         * would wait for the robot, and circling is then no block). */
        in.ref = tu_pose(0.45 + 0.001 * i, 0.3, 0.0);
        in.t_us = (uint64_t)i * 20000u;
        ctl_step(&c, &in, &out);
        if (i < 14) {
            TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
        }
    }
    TEST_ASSERT_EQUAL_INT(SUP_MODE_BLOCKED, out.status.mode);
    TEST_ASSERT_EQUAL_size_t(1, out.n_events);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_BLOCKED, out.events[0].kind);
    TEST_ASSERT_EQUAL_UINT8(5, out.events[0].obstacle);
    TEST_ASSERT_TRUE(out.wheels.left == NUM_ZERO && out.wheels.right == NUM_ZERO);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.active_obstacle);
}

static void test_ctl_mstc_tracks_the_aim_while_its_reference_waits(void)
{
    /* Obstacle 5 at (0.45, 0) activated from the origin, the reference at
     * (0.1, 0) heading +x at v_r = 0.5 and staying there (it waits). At
     * 0.6 s the robot is at (0.9, 0.3): 0.8 past the reference along its
     * line, and the segment to the foot (0.9, 0) keeps 0.45 from the centre,
     * more than D_s + 0.08 = 0.43, within D_det: the strategy aims at the
     * line, taken from the reference at (0.1, 0) (test_msw has the rule).
     * The next step, the reference unchanged, tracks the aim, (1.2, 0),
     * 0.3 ahead: it drives on (eq. (2): v = 0.5 + 3 · 0.3 > 0.2) and turns
     * right towards the line (ω < 0); tracking the waiting reference, 0.8
     * behind, eq. (2) would give v = 0.5 − 3 · 0.8 < 0, held at 0. When the reference moves on
     * to (0.2, 0), the aim taken from the old one is dropped. */
    mstc_init();
    sup_obstacle_t o = obstacle(5, 0.45, 0.0, 0.1);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, out.status.mode);
    in.robot = tu_pose(0.9, 0.3, 0.0);
    in.t_us = 600000u;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE(c.msw.held);
    TEST_ASSERT_TRUE(c.msw.aimed);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.1, c.msw.aim_rx);
    in.t_us = 620000u;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE(out.status.v > tu_num(0.2));
    TEST_ASSERT_TRUE(out.status.w < NUM_ZERO);
    /* Its roll-out clear, the aim's command also ends the avoidance. */
    TEST_ASSERT_EQUAL_size_t(1, out.n_events);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_COMPLETE, out.events[0].kind);
    in.ref = tu_pose(0.2, 0.0, 0.0);
    in.t_us = 640000u;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_FALSE(c.msw.aimed);
}

static void test_ctl_obstacle_velocity_is_screened_by_mstc_and_ignored_by_paper(void)
{
    /* A report with vx = 101 m/s (beyond CTL_MAX_ABS_SPEED): "mstc" drops it;
     * "paper" ignores velocities and takes it. */
    sup_obstacle_t o = obstacle(2, 1.0, 1.0, 0.1);
    o.vx = tu_num(101.0);
    o.vy = NUM_ZERO;
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(1, out.status.n_obstacles);
    TEST_ASSERT_TRUE(c.sup.obs[0].o.vx == NUM_ZERO);
    mstc_init();
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.n_obstacles);
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_OBSTACLE_DROPPED) != 0);
    /* vy likewise. */
    o.vx = NUM_ZERO;
    o.vy = tu_num(-101.0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.n_obstacles);
    /* Within range it is kept, velocity and all. */
    o.vx = tu_num(-0.5);
    o.vy = tu_num(100.0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(1, out.status.n_obstacles);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, -0.5, c.sup.obs[0].o.vx);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 100.0, c.sup.obs[0].o.vy);
    /* Beside a report that is dropped (screened one by one), a good one
     * keeps its velocity under "mstc". */
    mstc_init();
    sup_obstacle_t two[2] = { obstacle(2, 1.0, 1.0, 0.1), obstacle(3, -1.0, 1.0, 0.1) };
    two[0].vx = tu_num(101.0);
    two[1].vx = tu_num(0.25);
    in.obstacles = two;
    in.n_obstacles = 2;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(1, out.status.n_obstacles);
    TEST_ASSERT_EQUAL_UINT8(3, c.sup.obs[0].o.id);
    TEST_ASSERT_NUM_WITHIN(TOL_PARAM, 0.25, c.sup.obs[0].o.vx);
}

static void test_ctl_mstc_drops_reports_beyond_the_table(void)
{
    /* Seventeen reports in one step: the 17th is dropped (ctl.h), as in
     * "paper". */
    mstc_init();
    sup_obstacle_t o[SUP_MAX_OBSTACLES + 1u];
    for (uint8_t i = 0; i <= SUP_MAX_OBSTACLES; i++) {
        o[i] = obstacle((uint8_t)(i + 1u), 2.0 + i, 3.0, 0.1);
    }
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), 0.5, 0.0, o,
                           SUP_MAX_OBSTACLES + 1u, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_OBSTACLE_DROPPED) != 0);
}

static void test_ctl_mstc_near_obstacles_never_reverses_and_caps_the_speed(void)
{
    /* An obstacle within D_act + MSW_REGULATE (1.5 m ahead, beside the
     * path). Robot 0.5 m ahead of its reference: eq. (2) would reverse,
     * v = 0.5 − 3·0.5 = −1.0; "mstc" waits: v = 0 (both wheels turn the
     * robot only: ω = 0 here, so both 0). */
    mstc_init();
    sup_obstacle_t o = obstacle(1, 1.5, 1.0, 0.1);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(-0.5, 0.0, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, out.status.v);
    /* A reference driving backwards (v_r = −0.5) 1 m behind the robot:
     * v = −0.5 − 3 = −3.5, held to −(0.5 + MSW_CATCH_UP) = −1.5; 0.3 m ahead
     * of it the other way: v = −0.5 + 0.9 > 0, held to 0. */
    in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(-1.0, 0.0, 0.0), -0.5, 0.0, &o, 1, 20000);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -1.5, out.status.v);
    in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.3, 0.0, 0.0), -0.5, 0.0, &o, 1, 40000);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, out.status.v);
}

/* One step of "mstc" near an obstacle (moving at @p ob_vx along x), its
 * wheels measured at @p wheel rad/s both (v̂ = 0.05 · wheel), the reference
 * 1 m to the left and @p ref_x ahead, heading @p ref_heading at @p v_r:
 * tracking, at v with wheels @p right and @p left. */
static void expect_behind_at(double v_r, double ref_x, double ref_heading, double wheel,
                             double ob_vx, double v, double right, double left)
{
    mstc_init();
    sup_obstacle_t o = obstacle(1, -1.5, -1.0, 0.1);
    o.vx = tu_num(ob_vx);
    ctl_input_t in =
        input(tu_pose(0.0, 0.0, 0.0), tu_pose(ref_x, 1.0, ref_heading), v_r, 0.0, &o, 1, 0);
    in.wheels_measured = true;
    in.wheels = (kin_wheels_t){ tu_num(wheel), tu_num(wheel) };
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, out.status.mode);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, v, out.status.v);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, right, out.wheels.right);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, left, out.wheels.left);
}

/* expect_behind_at() with the reference driving forwards at 0.5 m/s,
 * straight to the robot's left. */
static void expect_behind(double ref_heading, double wheel, double ob_vx, double v, double right,
                          double left)
{
    expect_behind_at(0.5, 0.0, ref_heading, wheel, ob_vx, v, right, left);
}

static void test_ctl_mstc_behind_its_reference_keeps_its_speed_while_it_turns(void)
{
    /* Hand derivation (docs/strategy.md "One step under real wheels", step
     * 2): ideal wheels (mstc_init) but measured, wheel_tau 0, so the horizon
     * is half the first period, T_p = 0.01 s; an obstacle 1.80 m away, behind
     * (within D_act + MSW_REGULATE = 2.5 m: regulated; not closing: no
     * activation, and too far for the filter or the guard to act).
     *
     * (a) Robot moving at v̂ = 0.4 (wheels 8 rad/s), the reference 1 m to
     * its left and 0.03 m ahead, heading e3 = 1.8 rad: ė1 = −v̂ + v_r cos e3
     * = −0.4 − 0.1136010 → e1 = 0.03 − 0.0051360 = 0.0248640; ė2 = v_r sin
     * e3 = 0.4869238 → e2 = 1.0048692. Eq. (2): v = v_r cos e3 + k1 e1 =
     * −0.1136010 + 0.0745920 < 0, held to 0 near obstacles; eq. (3): ω =
     * 0.5 (12 · 1.0048692 + 6 · 0.9738476) = 8.950758 (ideal wheels: no
     * bound). The robot is behind its reference: e1 cos e3 + e2 sin e3 =
     * −0.0056492 + 0.9785895 > 0, and the reference is not behind its
     * heading (e1 > 0), so it keeps the speed it has, up to |v_r|: wheels
     * 8 rad/s (v̂ = 0.4) give v = 0.4, wheels (v ± 0.15 ω)/0.05 = 34.852274
     * and −18.852274; wheels 12 rad/s (v̂ = 0.6, ė1 = −0.7136010 → e1 =
     * 0.0228640 > 0, v of eq. (2) −0.0450090, ω unchanged) give v = |v_r| =
     * 0.5: 36.852274 and −16.852274. (Before this rule: v = 0, wheels
     * ±26.852274.) */
    expect_behind_at(0.5, 0.03, 1.8, 8.0, 0.0, 0.4, 34.852274, -18.852274);
    expect_behind_at(0.5, 0.03, 1.8, 12.0, 0.0, 0.5, 36.852274, -16.852274);
    /* (a') The reference straight to its left instead: e1 = −0.0051360 < 0,
     * the reference behind its heading: no speed kept (the robot would drive
     * away from it while it turns), v = 0, ω as in (a): wheels ±26.852274. */
    expect_behind(1.8, 8.0, 0.0, 0.0, 26.852274, -26.852274);
    /* (b) The same standing (wheels 0): it has no speed to keep, v = 0 and
     * it turns in place: ė1 = −0.1136010 → e1 = −0.0011360, e2 as in (a)
     * (ė2 does not depend on v̂), so ω = 8.950758: wheels ±26.852274. */
    expect_behind(1.8, 0.0, 0.0, 0.0, 26.852274, -26.852274);
    /* (c) Moving, the reference heading e3 = −1.8 instead: it comes towards
     * the robot's side, the robot is ahead of it (ė2 = −0.4869238 → e2 =
     * 0.9951308; e1 cos e3 + e2 sin e3 = 0.0013941 − 0.9691057 < 0): it
     * waits as before, v = 0, ω = 0.5 (12 · 0.9951308 − 6 · 0.9738476) =
     * 3.049242: wheels ±9.147726. */
    expect_behind(-1.8, 10.0, 0.0, 0.0, 9.147726, -9.147726);
    /* (d) As (a), the obstacle moving at 0.1 m/s (> MSW_MOVING_SPEED; 1.80 m
     * away, beyond D_act + MSW_CPA_REACH = 1.5 m: no activation): the rule
     * is off near moving obstacles, v = 0, ω as in (a): wheels ±26.852274. */
    expect_behind(1.8, 8.0, 0.1, 0.0, 26.852274, -26.852274);
    /* (e) As (a), the reference heading e3 = 1.2 rad: eq. (2) drives on,
     * v = 0.5 cos 1.2 + 3 e1 = 0.1811789 − 0.0065646 = 0.1746142 > 0 (ė1 =
     * −0.4 + 0.1811789 → e1 = −0.0021882), and is kept, below the speed the
     * wheels have: the rule replaces only a stop. ė2 = 0.5 sin 1.2 →
     * e2 = 1.0046602, ω = 0.5 (12 · 1.0046602 + 6 · 0.9320391) = 8.824078:
     * wheels 29.964520 and −22.979950. */
    expect_behind(1.2, 8.0, 0.0, 0.1746142, 29.964520, -22.979950);
    /* (f) Mirrored: the reference drives backwards (v_r = −0.5) heading
     * e3 = −1.8 rad, 0.03 m behind the robot, the robot reversing at v̂ =
     * −0.4 (wheels −8 rad/s): ė1 = −v̂ + v_r cos e3 = 0.4 + 0.1136010 → e1 =
     * −0.03 + 0.0051360 = −0.0248640 (ahead along its motion: e1 < 0);
     * ė2 = v_r sin e3 = 0.4869238 → e2 = 1.0048692. Eq. (2): v = 0.1136010
     * − 0.0745920 > 0, held to 0 for a reference driving backwards; behind
     * it along its motion (e1 cos e3 + e2 sin e3 = 0.0056492 − 0.9785895 <
     * 0), so it keeps the speed it has backwards: v = −0.4; ω = v_r (12 e2 +
     * 6 sin e3) = −0.5 (12.0584309 − 5.8430857) = −3.1076725: wheels
     * (v ± 0.15 ω)/0.05 = −17.323018 and 1.323018. */
    expect_behind_at(-0.5, -0.03, -1.8, -8.0, 0.0, -0.4, -17.323018, 1.323018);
}

static void test_ctl_turn_first_spares_moving_obstacles_on_fast_wheels(void)
{
    /* cos e / 0.7 below 0.7, none below zero: cos e = 0.35 gives 0.5, cos e
     * = -0.2 (beyond a right angle) 0, 0.7 and 0.8 nothing. Round a moving
     * obstacle, wheels with a lag within 2/α = 2/20 = 0.1 s (the gearmotor
     * profile's 0.06 s, and 0.1 s itself) are not slowed; the sluggish
     * profile's 0.14 s is, as every static obstacle. */
    const num_t fast = NUM_C(0.06), edge = NUM_C(0.1), slow = NUM_C(0.14);
    TEST_ASSERT_NUM_WITHIN(1e-4, 0.5, ctl_turn_first(NUM_C(0.35), false, fast));
    TEST_ASSERT_NUM_WITHIN(1e-4, 0.5, ctl_turn_first(NUM_C(0.35), false, NUM_ZERO));
    TEST_ASSERT_NUM_WITHIN(1e-4, 0.0, ctl_turn_first(NUM_C(-0.2), false, fast));
    TEST_ASSERT_NUM_WITHIN(1e-4, 1.0, ctl_turn_first(NUM_C(0.7), false, slow));
    TEST_ASSERT_NUM_WITHIN(1e-4, 1.0, ctl_turn_first(NUM_C(0.8), true, slow));
    TEST_ASSERT_NUM_WITHIN(1e-4, 1.0, ctl_turn_first(NUM_C(0.35), true, fast));
    TEST_ASSERT_NUM_WITHIN(1e-4, 1.0, ctl_turn_first(NUM_C(-0.2), true, NUM_ZERO));
    TEST_ASSERT_NUM_WITHIN(1e-4, 1.0, ctl_turn_first(NUM_C(0.35), true, edge));
    TEST_ASSERT_NUM_WITHIN(1e-4, 0.5, ctl_turn_first(NUM_C(0.35), true, slow));
}

static void test_ctl_most_speed_is_a_steeper_curve_for_an_aligned_robot(void)
{
    /* The sluggish profile's share a' = 0.5 × 0.05 m × 10 rad/s² = 0.25
     * m/s², an error e1 of 2 m (behind or ahead): sqrt(2 × 0.25 × 2) = 1 m/s;
     * aligned (|e2| < 0.1 m, |sin e3| < 0.1, cos e3 > 0) at 1.5 a' = 0.375:
     * sqrt(2 × 0.375 × 2) = sqrt(1.5) = 1.2247449 m/s. Each bound is strict:
     * 0.1 itself is not aligned; facing away (cos e3 = -1) neither. */
    const num_t a = NUM_C(0.25);
    const num_t c09 = NUM_C(0.9959418); /* cos of the angle whose sine is 0.09 */
    const trk_err_t on = { .e1 = NUM_C(2.0), .e2 = NUM_ZERO, .e3 = NUM_ZERO };
    const trk_err_t ahead = { .e1 = NUM_C(-2.0), .e2 = NUM_C(-0.09), .e3 = NUM_ZERO };
    const trk_err_t near = { .e1 = NUM_C(2.0), .e2 = NUM_C(0.09), .e3 = NUM_ZERO };
    const trk_err_t beside = { .e1 = NUM_C(2.0), .e2 = NUM_C(0.1), .e3 = NUM_ZERO };
    TEST_ASSERT_NUM_WITHIN(1e-3, 1.2247449, ctl_most_speed(a, &on, NUM_ONE, NUM_ZERO));
    TEST_ASSERT_NUM_WITHIN(1e-3, 1.2247449, ctl_most_speed(a, &ahead, NUM_ONE, NUM_ZERO));
    TEST_ASSERT_NUM_WITHIN(1e-3, 1.2247449, ctl_most_speed(a, &near, NUM_ONE, NUM_ZERO));
    TEST_ASSERT_NUM_WITHIN(1e-3, 1.2247449, ctl_most_speed(a, &on, c09, NUM_C(-0.09)));
    TEST_ASSERT_NUM_WITHIN(1e-3, 1.0, ctl_most_speed(a, &beside, NUM_ONE, NUM_ZERO));
    TEST_ASSERT_NUM_WITHIN(1e-3, 1.0, ctl_most_speed(a, &on, NUM_C(0.9949874), NUM_C(0.1)));
    TEST_ASSERT_NUM_WITHIN(1e-3, 1.0, ctl_most_speed(a, &on, NUM_C(-1.0), NUM_ZERO));
}

static void test_ctl_changing_the_strategy_restarts_the_mstc_state(void)
{
    /* Avoiding under "mstc"; a parameter set that switches to "paper" and
     * back leaves "mstc" tracking (its state restarted), the obstacle
     * remembered. */
    mstc_init();
    sup_obstacle_t o = obstacle(5, 0.45, 0.0, 0.1);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.45, 0.3, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(MSW_AVOID, c.msw.state);
    ctl_params_t p = c.p;
    p.strategy = num_from_int(CTL_STRATEGY_PAPER);
    TEST_ASSERT_EQUAL_INT(0, ctl_set_params(&c, &p));
    p.strategy = num_from_int(CTL_STRATEGY_MSTC);
    TEST_ASSERT_EQUAL_INT(0, ctl_set_params(&c, &p));
    TEST_ASSERT_EQUAL_UINT8(MSW_TRACK, c.msw.state);
    TEST_ASSERT_EQUAL_UINT8(1, c.sup.n_obs);
    /* The same strategy set again keeps the state. */
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_UINT8(MSW_AVOID, c.msw.state);
    TEST_ASSERT_EQUAL_INT(0, ctl_set_params(&c, &p));
    TEST_ASSERT_EQUAL_UINT8(MSW_AVOID, c.msw.state);
    /* ctl_reset forgets everything. */
    ctl_reset(&c);
    TEST_ASSERT_EQUAL_UINT8(MSW_TRACK, c.msw.state);
    TEST_ASSERT_EQUAL_UINT8(0, c.sup.n_obs);
}

/* Events of @p kind naming obstacle @p id in the last step's output. */
static size_t events_of(int kind, uint8_t id)
{
    size_t n = 0;
    for (size_t i = 0; i < out.n_events; i++) {
        if (out.events[i].kind == kind && out.events[i].obstacle == id) {
            n++;
        }
    }
    return n;
}

static void test_ctl_mstc_guard_holds_a_robot_that_would_back_into_the_margin(void)
{
    /* Wheels of 100 rad/s², no lag; D_act 0.36, just above D_s = 0.35, so
     * that obstacle 4, static 0.37 m behind the robot, is beyond D_act (and
     * reach, 0 from rest): no avoidance. The robot rests at the origin heading
     * +x on its reference, which drives backwards at 0.2 m/s: eq. (2)-(3)
     * give v = −0.2, ω = 0 (e = 0), within the near-obstacle bound
     * [−0.7, 0]: wheels (−4, −4).
     * Filter: p_l − c = (0.42, 0), h = 0.42² − 0.4² = 0.0164, a = (0.84, 0),
     * no braking margin (the command in force is 0): 0.84 v >= −20 × 0.0164
     * needs v >= −0.39: −0.2 passes unchanged, the filter names nobody.
     * Rate limiter: 100 × 0.02 = 2 rad/s from 0: (−2, −2), v = −0.1 m/s.
     * Guard (cbf.h): its braking path is |v| (dt + T_s/2) = 0.1 × (0.02 +
     * 0.01) = 3 mm straight back, to 0.367 m of obstacle 4, which is already
     * inside D_s + 0.04 = 0.39: no closer than 0.37 − 0.001. It fails; the
     * same turn braked, (0, 0), passes: the wheels stay at 0, the step is
     * filtered and its FILTER event names the nearest obstacle, 4 (9 and 6
     * are 2.5 m and 2 m away). */
    ctl_params_t p;
    ctl_params_default(&p);
    p.wheel_accel = num_from_int(100);
    p.wheel_tau = NUM_ZERO;
    p.d_act = tu_num(0.36);
    TEST_ASSERT_EQUAL_INT(0, ctl_init(&c, &p));
    sup_obstacle_t o[3] = { obstacle(9, 0.0, 2.5, 0.1), obstacle(4, -0.37, 0.0, 0.1),
                            obstacle(6, 2.0, 0.0, 0.1) };
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.0, 0.0, 0.0), -0.2, 0.0, o, 3, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, out.status.mode);
    TEST_ASSERT_TRUE(out.wheels.left == NUM_ZERO && out.wheels.right == NUM_ZERO);
    TEST_ASSERT_EQUAL_UINT8(CTL_FAULT_FILTER, out.status.faults & CTL_FAULT_FILTER);
    TEST_ASSERT_EQUAL_size_t(1, events_of(SUP_EVENT_FILTER, 4));
    TEST_ASSERT_EQUAL_size_t(4, out.n_events); /* three DETECT, one FILTER */
    /* The next step, the same: held again. */
    in.t_us = 20000;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE(out.wheels.left == NUM_ZERO && out.wheels.right == NUM_ZERO);
    TEST_ASSERT_EQUAL_UINT8(CTL_FAULT_FILTER, out.status.faults & CTL_FAULT_FILTER);
    TEST_ASSERT_EQUAL_size_t(0, out.n_events); /* the same episode: no new FILTER */
    /* A reference backing at 1 m/s: the filter itself brakes the command to
     * v = −0.39; the guard then holds the robot as above. */
    TEST_ASSERT_EQUAL_INT(0, ctl_init(&c, &p));
    in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.0, 0.0, 0.0), -1.0, 0.0, o, 3, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_TRUE(out.wheels.left == NUM_ZERO && out.wheels.right == NUM_ZERO);
    TEST_ASSERT_EQUAL_UINT8(CTL_FAULT_FILTER, out.status.faults & CTL_FAULT_FILTER);
    TEST_ASSERT_EQUAL_size_t(1, events_of(SUP_EVENT_FILTER, 4)); /* its episode's first step */
    /* Without obstacle 4 the rate-limited command goes out: (−2, −2). */
    in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.0, 0.0, 0.0), -0.2, 0.0, o, 3, 0);
    TEST_ASSERT_EQUAL_INT(0, ctl_init(&c, &p));
    o[1] = obstacle(4, -2.37, 0.0, 0.1);
    in.t_us = 0;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, -2.0, out.wheels.left);
    TEST_ASSERT_NUM_WITHIN(TOL_WHEEL, -2.0, out.wheels.right);
    TEST_ASSERT_EQUAL_UINT8(0, out.status.faults & CTL_FAULT_FILTER);
}

static void test_ctl_mstc_reports_once_an_obstacle_closing_faster_than_the_wheels_brake(void)
{
    /* The default wheels (20 rad/s²: the look-ahead point's speed changes
     * by r a = 1 m/s² at most), no lag. The robot rests at the origin
     * heading +x; obstacle 3 comes at it from (0.6, 0) at 3 m/s. Nulling
     * 3 m/s takes 3 s and 4.5 m; the bodies touch (R_m + R_ob = 0.3) within
     * 0.6 − 0.05 − 0.3 = 0.25 m of the look-ahead point: no command within
     * the wheels' limits keeps it away (cbf_unreachable). The INFEASIBLE
     * event names it, at the first step only; the step is filtered. */
    ctl_params_t p;
    ctl_params_default(&p);
    p.wheel_tau = NUM_ZERO;
    TEST_ASSERT_EQUAL_INT(0, ctl_init(&c, &p));
    sup_obstacle_t o = obstacle(3, 0.6, 0.0, 0.1);
    o.vx = tu_num(-3.0);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.0, 0.0, 0.0), 0.5, 0.0, &o, 1, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(1, events_of(SUP_EVENT_INFEASIBLE, 3));
    TEST_ASSERT_TRUE((out.status.faults & CTL_FAULT_FILTER) != 0);
    /* 20 ms later it is 6 cm nearer: still infeasible, not reported again. */
    o.x = tu_num(0.54);
    in.t_us = 20000;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(0, events_of(SUP_EVENT_INFEASIBLE, 3));
    TEST_ASSERT_TRUE(c.cbf.infeasible);
}

static void test_ctl_mstc_reports_a_squeeze_once_by_its_most_violated_obstacle(void)
{
    /* test_cbf's squeeze in the control step: obstacles 1 and 2 close on the
     * robot at 3 m/s from either side across its heading (0.45 m away): no
     * (v, ω) meets both constraints (the look-ahead point cannot move
     * sideways, both push it). Wheels that follow at once brake and turn
     * fast enough that neither is beyond reach on its own (not doomed: with
     * a_v = 500 m/s² braking 3 m/s covers 1 cm across the heading), so the
     * INFEASIBLE event names the filter's most violated obstacle, once. */
    mstc_init();
    sup_obstacle_t o[2] = { obstacle(1, 0.05, 0.45, 0.1), obstacle(2, 0.05, -0.45, 0.1) };
    o[0].vy = tu_num(-3.0);
    o[1].vy = tu_num(3.0);
    ctl_input_t in = input(tu_pose(0.0, 0.0, 0.0), tu_pose(0.0, 0.0, 0.0), 0.5, 0.0, o, 2, 0);
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(1, events_of(SUP_EVENT_INFEASIBLE, 1) +
                                    events_of(SUP_EVENT_INFEASIBLE, 2));
    in.t_us = 20000;
    ctl_step(&c, &in, &out);
    TEST_ASSERT_EQUAL_size_t(0, events_of(SUP_EVENT_INFEASIBLE, 1) +
                                    events_of(SUP_EVENT_INFEASIBLE, 2));
}

/* ------------------------------------------------ the paper's scenarios */

/* The closed loop of sim/scenarios/paper-*.toml (forward Euler at 0.02 s,
 * the plant in double, obstacles reported within D_det), and the events it
 * produced: kind, obstacle, side, step index. */
typedef struct {
    double robot[3], ref[3], v_r, w_r, duration;
    double obs[2][2];
} scene_t;

typedef struct {
    int kind, obstacle, side;
    double t;
} expect_t;

static const scene_t k_line = {
    { 0.0, 2.5, 0.5 }, { 0.1, 2.6, 0.7 }, 0.5, 0.0, 20.0, { { 3.0, 5.2 }, { 4.0, 5.8 } }
};
static const scene_t k_circle = {
    { 4.3, 6.4, 0.7 }, { 4.5, 6.5, 0.8 }, 0.48, -0.3, 21.0, { { 6.9, 6.2 }, { 4.9, 3.8 } }
};
/* The paper's times (section 5; the scenario files' [[expected]]). */
static const expect_t k_line_events[] = {
    { 1, 1, 0, 0.82 }, { 1, 2, 0, 3.10 }, { 2, 1, -1, 6.82 },
    { 3, 1, 0, 8.76 }, { 2, 2, 1, 9.36 }, { 3, 2, 0, 11.10 },
};
static const expect_t k_circle_events[] = {
    { 1, 1, 0, 0.0 },  { 1, 2, 0, 0.0 },    { 2, 1, 1, 4.94 },
    { 3, 1, 0, 7.06 }, { 2, 2, -1, 13.68 }, { 3, 2, 0, 15.58 },
};

static size_t closed_loop(const scene_t *sc, sup_event_t *events, size_t max, double *min_d)
{
    double x = sc->robot[0], y = sc->robot[1], th = sc->robot[2];
    double xr = sc->ref[0], yr = sc->ref[1], thr = sc->ref[2];
    const size_t n = (size_t)(sc->duration / 0.02 + 0.5);
    size_t n_ev = 0;
    *min_d = INFINITY;
    for (size_t k = 0; k <= n; k++) {
        sup_obstacle_t obs[2];
        size_t m = 0;
        for (uint8_t i = 0; i < 2; i++) {
            const double d = hypot(sc->obs[i][0] - x, sc->obs[i][1] - y);
            *min_d = fmin(*min_d, d);
            if (d <= 3.5) {
                obs[m++] = obstacle((uint8_t)(i + 1u), sc->obs[i][0], sc->obs[i][1], 0.1);
            }
        }
        ctl_input_t in = input(tu_pose(x, y, th), tu_pose(xr, yr, thr), sc->v_r, sc->w_r, obs, m,
                               (uint64_t)k * 20000u);
        ctl_step(&c, &in, &out);
        for (size_t j = 0; j < out.n_events && n_ev < max; j++) {
            events[n_ev++] = out.events[j];
        }
        const double wl = tu_dbl(out.wheels.left), wr = tu_dbl(out.wheels.right);
        const double v = R_WHEEL * (wr + wl) / 2.0, w = R_WHEEL * (wr - wl) / (2.0 * HALF_TRACK);
        x += v * cos(th) * 0.02;
        y += v * sin(th) * 0.02;
        th += w * 0.02;
        xr += sc->v_r * cos(thr) * 0.02;
        yr += sc->v_r * sin(thr) * 0.02;
        thr += sc->w_r * 0.02;
    }
    return n_ev;
}

/* The events against the paper's, each within @p steps control periods. */
static void check_events(const sup_event_t *ev, size_t n, const expect_t *want, size_t n_want,
                         unsigned steps)
{
    char msg[96];
    TEST_ASSERT_EQUAL_size_t(n_want, n);
    for (size_t i = 0; i < n; i++) {
        snprintf(msg, sizeof msg, "event %zu at %.2f s", i, (double)ev[i].t_us * 1e-6);
        TEST_ASSERT_EQUAL_INT_MESSAGE(want[i].kind, ev[i].kind, msg);
        TEST_ASSERT_EQUAL_INT_MESSAGE(want[i].obstacle, ev[i].obstacle, msg);
        TEST_ASSERT_EQUAL_INT_MESSAGE(want[i].side, ev[i].side, msg);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(0.02 * steps + 1e-9, want[i].t, (double)ev[i].t_us * 1e-6,
                                          msg);
    }
}

static void test_ctl_paper_strategy_reproduces_the_papers_times(void)
{
    /* "paper": every switching time of section 5 to the control step. */
    sup_event_t ev[16];
    double min_d;
    size_t n = closed_loop(&k_line, ev, 16, &min_d);
    check_events(ev, n, k_line_events, 6, 0);
    TEST_ASSERT_TRUE(min_d >= 0.35);
    setUp();
    n = closed_loop(&k_circle, ev, 16, &min_d);
    check_events(ev, n, k_circle_events, 6, 0);
    TEST_ASSERT_TRUE(min_d >= 0.35);
}

static void test_ctl_mstc_on_the_papers_scenarios(void)
{
    /* "mstc" (docs/strategy.md): the same events, on the same obstacles,
     * sides and order, each within 3 control periods of the paper's (it goes
     * round on D_s + 0.08 instead of D_s and releases once the roll-out
     * clears D_s + 0.045, which shifts the later switches by up to three
     * steps); no filter, no block; D_s kept with room. */
    sup_event_t ev[16];
    double min_d;
    mstc_init();
    size_t n = closed_loop(&k_line, ev, 16, &min_d);
    check_events(ev, n, k_line_events, 6, 3);
    TEST_ASSERT_TRUE(min_d >= 0.39);
    mstc_init();
    n = closed_loop(&k_circle, ev, 16, &min_d);
    check_events(ev, n, k_circle_events, 6, 3);
    TEST_ASSERT_TRUE(min_d >= 0.39);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_ctl_defaults_are_table_1);
    RUN_TEST(test_ctl_params_check_rejects_each_bad_parameter);
    RUN_TEST(test_ctl_params_check_accepts_the_boundaries);
#ifndef NUM_FIXED
    RUN_TEST(test_ctl_params_check_rejects_non_finite_values);
#endif
    RUN_TEST(test_ctl_init_with_bad_parameters_falls_back_to_defaults);
    RUN_TEST(test_ctl_tracking_step_gives_eq2_eq3_wheel_speeds);
    RUN_TEST(test_ctl_tracking_in_a_rotated_frame);
    RUN_TEST(test_ctl_saturation_scales_wheels_and_reports_it);
    RUN_TEST(test_ctl_p3_gives_zero_wheel_speeds);
#ifndef NUM_FIXED
    RUN_TEST(test_ctl_non_finite_input_stops_the_robot);
    RUN_TEST(test_ctl_non_finite_input_leaves_the_supervisor_untouched);
#endif
    RUN_TEST(test_ctl_avoidance_step_on_the_safe_circle);
    RUN_TEST(test_ctl_avoidance_uses_the_obstacle_own_safe_distance);
    RUN_TEST(test_ctl_reports_dropped_obstacles);
    RUN_TEST(test_ctl_reset_forgets_obstacles);
    RUN_TEST(test_ctl_set_params_rejects_bad_values_and_changes_nothing);
    RUN_TEST(test_ctl_set_params_applies_and_keeps_the_supervisor_state);
    RUN_TEST(test_ctl_mstc_tracks_as_the_paper_away_from_obstacles);
    RUN_TEST(test_ctl_mstc_filter_brakes_and_says_so);
    RUN_TEST(test_ctl_mstc_blocked_stops_the_wheels);
    RUN_TEST(test_ctl_mstc_tracks_the_aim_while_its_reference_waits);
    RUN_TEST(test_ctl_obstacle_velocity_is_screened_by_mstc_and_ignored_by_paper);
    RUN_TEST(test_ctl_mstc_drops_reports_beyond_the_table);
    RUN_TEST(test_ctl_mstc_near_obstacles_never_reverses_and_caps_the_speed);
    RUN_TEST(test_ctl_mstc_behind_its_reference_keeps_its_speed_while_it_turns);
    RUN_TEST(test_ctl_turn_first_spares_moving_obstacles_on_fast_wheels);
    RUN_TEST(test_ctl_most_speed_is_a_steeper_curve_for_an_aligned_robot);
    RUN_TEST(test_ctl_changing_the_strategy_restarts_the_mstc_state);
    RUN_TEST(test_ctl_mstc_guard_holds_a_robot_that_would_back_into_the_margin);
    RUN_TEST(test_ctl_mstc_reports_once_an_obstacle_closing_faster_than_the_wheels_brake);
    RUN_TEST(test_ctl_mstc_reports_a_squeeze_once_by_its_most_violated_obstacle);
    RUN_TEST(test_ctl_paper_strategy_reproduces_the_papers_times);
    RUN_TEST(test_ctl_mstc_on_the_papers_scenarios);
    return UNITY_END();
}
