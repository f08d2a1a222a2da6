/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/avd: the side of eq. (11)-(12) on the wrapped
 * difference, the blending vector's direction β of eq. (9)-(14), its rate β̇
 * of eq. (22) with eq. (15) as corrected in docs/equations.md, and the control law of
 * eq. (21)-(24).
 *
 * Expected values: hand derivations written beside them, and three
 * independent computations in double inside this file:
 *  - ref_beta: eq. (9)-(14) with libm;
 *  - ref_beta_dot: eq. (15) corrected (docs/equations.md, erratum 1), (16), (17), (22);
 *  - ref_beta_dot with misprint = true: the paper's printed eq. (15),
 *    "+ D_s (ẋ cos φ + ẏ sin φ) u_mo", kept to show that it is wrong;
 * and a finite difference of β along straight-line motion, with β taken from
 * avd_direction() itself, which needs no formula for β̇ at all.
 */
#include <stdio.h>

#include "ctrl/avd.h"
#include "test_util.h"
#include "unity.h"

/* ------------------------------------------------------------ tolerances */

/* β [rad] at distances ≥ 0.2 m from the obstacle, positions ≤ 3 m. float:
 * atan2f within 2 ulp, and u = u_p + u_f rounded on values ≤ 3 (2.4e-7),
 * divided by |u| ≥ 0.2: ≤ 2e-6; fixed: atan2 error ~1e-4 rad (issue 3
 * target) plus Q16.16 rounding of u (≈ 3e-5 m) over |u| ≥ 0.2 m. */
#define TOL_BETA        TU_TOL(3e-6, 3e-4)
/* |u| [m]. float: a few roundings of values ≤ 3 (2.4e-7 each); fixed:
 * Q16.16 rounding of the components and of the root, 1.5e-5 each. */
#define TOL_UNORM       TU_TOL(1e-6, 1e-4)
/* β̇ [rad/s] against the double formula, |β̇| ≤ 3, |u| ≥ 0.2. float: ~20
 * roundings of values ≤ 3 (≤ 1.8e-7 each) divided by |u| ≥ 0.2 → 2e-5;
 * fixed: cos/sin/atan2 errors 1e-4 times terms ≤ 3, plus Q16.16 products,
 * divided by |u| ≥ 0.2. */
#define TOL_BETA_DOT    TU_TOL(2e-5, 3e-3)
/* Half step of the finite difference [s]. float: 0.01 s (5 mm at 0.5 m/s)
 * keeps truncation small; fixed: 0.02 s, so that the β quantisation noise
 * divided by 2h stays below the tolerance. */
#define FD_H            TU_TOL(0.01, 0.02)
/* Finite difference of β against β̇ [rad/s]. Truncation h²/6·|β'''| was
 * measured in double at these points: ≤ 2e-4 (h = 0.01) and ≤ 8e-4
 * (h = 0.02). float: plus β's rounding 2·2e-6/(2h) = 2e-4 → 1e-3; fixed:
 * plus β's error 2·3e-4/(2h) = 1.5e-2 → 2e-2. */
#define TOL_FD          TU_TOL(1e-3, 2e-2)
/* By how much the misprinted eq. (15) must miss the finite difference for
 * the test to call it wrong: ten times the tolerance. At the points used the
 * miss is ≥ 0.46 rad/s (computed in double). */
#define MISPRINT_MARGIN (10.0 * TOL_FD)
/* ω and v of eq. (23)-(24), |ω| ≤ 15. float: β̇ error 2e-5 plus k2 = 5 times
 * e's error 1e-6, and roundings of 15 (ulp/2 = 1e-6); fixed: β̇'s 3e-3 plus
 * k2 times e's 3e-4. */
#define TOL_OMEGA       TU_TOL(5e-5, 6e-3)
#define TOL_V           TU_TOL(1e-6, 1e-3)

/* Table 1 safe distance, and a typical speed. */
#define DS 0.35
#define V  0.5

void setUp(void) {}
void tearDown(void) {}

/* ------------------------------------------------ reference computations */

/* Eq. (9)-(14) in double: β and |u| for a robot at (x, y). R(α) with
 * α = side·π/2 is written exactly: R u = (−s·u_y, s·u_x). */
static double ref_beta(double x, double y, double ox, double oy, double ds, int side,
                       double *u_norm)
{
    const double s = (double)side;
    const double mx = ox - x, my = oy - y, r = hypot(mx, my);
    const double ux = (1.0 - ds / r) * mx - s * my;
    const double uy = (1.0 - ds / r) * my + s * mx;
    if (u_norm) {
        *u_norm = hypot(ux, uy);
    }
    return atan2(uy, ux);
}

/* Eq. (22) with u̇ = u̇_p + u̇_f, eq. (16) u̇_f = −R q̇, for the robot moving
 * at q̇ = (xd, yd) relative to the obstacle, and eq. (15) either as
 * corrected in docs/equations.md or as the paper prints it (misprint = true):
 *   corrected: u̇_p = (D_s/r − 1) q̇ − (D_s/r)(ẋ cos φ + ẏ sin φ) û
 *   misprint:  u̇_p = (D_s/r − 1) q̇ + D_s (ẋ cos φ + ẏ sin φ) u_mo      */
static double ref_beta_dot_q(double x, double y, double xd, double yd, double ox, double oy,
                             double ds, int side, bool misprint)
{
    const double s = (double)side;
    const double mx = ox - x, my = oy - y, r = hypot(mx, my);
    const double cphi = mx / r, sphi = my / r;
    const double proj = xd * cphi + yd * sphi;
    double upx, upy;
    if (misprint) {
        upx = (ds / r - 1.0) * xd + ds * proj * mx;
        upy = (ds / r - 1.0) * yd + ds * proj * my;
    } else {
        upx = (ds / r - 1.0) * xd - (ds / r) * proj * cphi;
        upy = (ds / r - 1.0) * yd - (ds / r) * proj * sphi;
    }
    const double ufx = s * yd, ufy = -s * xd; /* −R q̇ */
    const double udx = upx + ufx, udy = upy + ufy;
    double un;
    const double b = ref_beta(x, y, ox, oy, ds, side, &un);
    return (udy * cos(b) - udx * sin(b)) / un;
}

/* The same for a robot at heading th and speed v: q̇ = v [cos θ, sin θ]. */
static double ref_beta_dot(double x, double y, double th, double v, double ox, double oy, double ds,
                           int side, bool misprint)
{
    return ref_beta_dot_q(x, y, v * cos(th), v * sin(th), ox, oy, ds, side, misprint);
}

static const char *side_name(avd_side_t s)
{
    return s == AVD_SIDE_LEFT ? "LEFT" : s == AVD_SIDE_RIGHT ? "RIGHT" : "NONE";
}

static void check_side(double x, double y, double th, double ox, double oy, avd_side_t expected)
{
    pose_t robot = tu_pose(x, y, th);
    char msg[128];
    avd_side_t got = avd_choose_side(&robot, tu_num(ox), tu_num(oy));
    snprintf(msg, sizeof msg, "robot (%g, %g, %g) obstacle (%g, %g): expected %s, got %s", x, y, th,
             ox, oy, side_name(expected), side_name(got));
    TEST_ASSERT_EQUAL_INT_MESSAGE((int)expected, (int)got, msg);
}

/* ------------------------------------------------------- eq. (11)-(12) */

static void test_avd_side_in_all_four_quadrants(void)
{
    /* Robot at the origin; φ = atan2(y0, x0). LEFT iff wrap(θ − φ) ≥ 0.
     * Each quadrant with a heading π/4 either side of φ. */
    /* Quadrant I, φ = π/4: θ = π/2 → +π/4 LEFT; θ = 0 → −π/4 RIGHT. */
    check_side(0, 0, TU_PI / 2, 1, 1, AVD_SIDE_LEFT);
    check_side(0, 0, 0.0, 1, 1, AVD_SIDE_RIGHT);
    /* Quadrant II, φ = 3π/4: θ = π − 0.1 → π/4 − 0.1 LEFT; θ = π/2 → −π/4 RIGHT. */
    check_side(0, 0, TU_PI - 0.1, -1, 1, AVD_SIDE_LEFT);
    check_side(0, 0, TU_PI / 2, -1, 1, AVD_SIDE_RIGHT);
    /* Quadrant III, φ = −3π/4: θ = −π/2 → +π/4 LEFT; θ = −π + 0.1 → −π/4 + 0.1
     * RIGHT. */
    check_side(0, 0, -TU_PI / 2, -1, -1, AVD_SIDE_LEFT);
    check_side(0, 0, -TU_PI + 0.1, -1, -1, AVD_SIDE_RIGHT);
    /* Quadrant IV, φ = −π/4: θ = 0 → +π/4 LEFT; θ = −π/2 → −π/4 RIGHT. */
    check_side(0, 0, 0.0, 1, -1, AVD_SIDE_LEFT);
    check_side(0, 0, -TU_PI / 2, 1, -1, AVD_SIDE_RIGHT);
}

static void test_avd_side_across_the_pi_seam(void)
{
    /* θ = 3.1, φ = −3.1 (obstacle almost straight behind-left along −x):
     * wrap(3.1 − (−3.1)) = 6.2 − 2π = −0.083 < 0 → RIGHT. The naive θ ≥ φ of
     * eq. (12) as printed would say LEFT. */
    check_side(0, 0, 3.1, 2.0 * cos(-3.1), 2.0 * sin(-3.1), AVD_SIDE_RIGHT);
    /* Mirror: θ = −3.1, φ = 3.1 → wrap(−6.2) = +0.083 → LEFT (naive: RIGHT). */
    check_side(0, 0, -3.1, 2.0 * cos(3.1), 2.0 * sin(3.1), AVD_SIDE_LEFT);
    /* Quadrant III obstacle, φ = −3π/4, heading θ = π: naive θ ≥ φ says LEFT;
     * wrap(π + 3π/4) = −π/4 → RIGHT. */
    check_side(0, 0, TU_PI, -1, -1, AVD_SIDE_RIGHT);
    /* Heading given with extra turns: θ = π/2 + 2π, obstacle at (1, 1):
     * wrap(θ − π/4) = π/4 → LEFT. */
    check_side(0, 0, TU_PI / 2 + TU_TWO_PI, 1, 1, AVD_SIDE_LEFT);
}

static void test_avd_side_uses_the_robot_to_obstacle_vector(void)
{
    /* Robot at (1, 1) facing north (θ = π/2), obstacle at (0, 2):
     * u_mo = (−1, 1), φ = 3π/4, θ − φ = −π/4 → RIGHT. With the vector the
     * other way (obstacle → robot, −π/4) it would be LEFT. */
    check_side(1, 1, TU_PI / 2, 0, 2, AVD_SIDE_RIGHT);
    /* Robot at (5, −3), θ = −2.0, obstacle at (4, −4): φ = −3π/4 = −2.356,
     * θ − φ = 0.356 → LEFT. */
    check_side(5, -3, -2.0, 4, -4, AVD_SIDE_LEFT);
}

static void test_avd_side_straight_ahead_is_left(void)
{
    /* θ = φ exactly (obstacle dead ahead on the x axis, both 0): wrap = 0,
     * and eq. (12) gives α = +π/2 for θ ≥ φ → LEFT. */
    check_side(0, 0, 0.0, 2.0, 0.0, AVD_SIDE_LEFT);
}

/* ---------------------------------------------------------- eq. (9)-(14) */

static void test_avd_beta_on_the_safe_circle_is_phi_plus_or_minus_half_pi(void)
{
    /* |u_mo| = D_s → u_p = 0, u = u_f = R(α) u_mo: β = φ + α, |u| = D_s.
     * Several φ, including ones where φ ± π/2 crosses the seam. */
    const double phis[] = { 0.0, TU_PI / 2, 2.5, -2.0, 3.0, -TU_PI / 2 };
    const double x = 1.0, y = -2.0;
    char msg[96];
    for (size_t i = 0; i < sizeof phis / sizeof phis[0]; i++) {
        const double ox = x + DS * cos(phis[i]), oy = y + DS * sin(phis[i]);
        pose_t robot = tu_pose(x, y, 0.7);
        avd_dir_t dir;
        snprintf(msg, sizeof msg, "phi = %g LEFT", phis[i]);
        avd_direction(&robot, tu_num(ox), tu_num(oy), tu_num(DS), AVD_SIDE_LEFT, tu_num(V), &dir);
        TEST_ASSERT_ANGLE_WITHIN_MESSAGE(TOL_BETA, phis[i] + TU_PI / 2, dir.beta, msg);
        TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(dir.beta, msg);
        TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_UNORM, DS, dir.u_norm, msg);
        snprintf(msg, sizeof msg, "phi = %g RIGHT", phis[i]);
        avd_direction(&robot, tu_num(ox), tu_num(oy), tu_num(DS), AVD_SIDE_RIGHT, tu_num(V), &dir);
        TEST_ASSERT_ANGLE_WITHIN_MESSAGE(TOL_BETA, phis[i] - TU_PI / 2, dir.beta, msg);
        TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(dir.beta, msg);
        TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_UNORM, DS, dir.u_norm, msg);
    }
}

static void test_avd_beta_off_the_safe_circle(void)
{
    avd_dir_t dir;
    /* Robot at (1.6, 1), obstacle at (2, 1): u_mo = (0.4, 0), r = 0.4,
     * u_p = (1 − 0.35/0.4)(0.4, 0) = (0.05, 0); LEFT u_f = (0, 0.4):
     * β = atan2(0.4, 0.05) = atan 8 = 1.4464413, |u| = √0.1625 = 0.4031129.
     * RIGHT u_f = (0, −0.4): β = −1.4464413. */
    pose_t robot = tu_pose(1.6, 1.0, 0.0);
    avd_direction(&robot, tu_num(2.0), tu_num(1.0), tu_num(DS), AVD_SIDE_LEFT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, atan(8.0), dir.beta);
    TEST_ASSERT_NUM_WITHIN(TOL_UNORM, sqrt(0.1625), dir.u_norm);
    avd_direction(&robot, tu_num(2.0), tu_num(1.0), tu_num(DS), AVD_SIDE_RIGHT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, -atan(8.0), dir.beta);

    /* Inside the safe circle, u_p points away: robot at (1.8, 1), r = 0.2,
     * u_p = (1 − 1.75)(0.2, 0) = (−0.15, 0); LEFT u_f = (0, 0.2):
     * β = atan2(0.2, −0.15) = π − atan(4/3) = 2.2142974, |u| = 0.25. */
    robot = tu_pose(1.8, 1.0, 0.0);
    avd_direction(&robot, tu_num(2.0), tu_num(1.0), tu_num(DS), AVD_SIDE_LEFT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, TU_PI - atan(4.0 / 3.0), dir.beta);
    TEST_ASSERT_NUM_WITHIN(TOL_UNORM, 0.25, dir.u_norm);

    /* General positions against eq. (9)-(14) in double, two of them at the
     * corners of a 100 m field. */
    const double c[][4] = { { 1.7, 1.3, 2.0, 1.0 },     { 2.3, 0.6, 2.0, 1.0 },
                            { -0.4, 3.1, 0.1, 2.9 },    { 5.0, -1.0, 4.5, -0.6 },
                            { 98.4, 97.0, 98.8, 97.3 }, { -99.0, 99.5, -99.3, 99.9 } };
    char msg[96];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        for (int side = -1; side <= 1; side += 2) {
            double un;
            const double b = ref_beta(tu_q(c[i][0]), tu_q(c[i][1]), tu_q(c[i][2]), tu_q(c[i][3]),
                                      tu_q(DS), side, &un);
            robot = tu_pose(c[i][0], c[i][1], 0.3);
            avd_direction(&robot, tu_num(c[i][2]), tu_num(c[i][3]), tu_num(DS), (avd_side_t)side,
                          tu_num(V), &dir);
            snprintf(msg, sizeof msg, "robot (%g, %g) obstacle (%g, %g) side %d", c[i][0], c[i][1],
                     c[i][2], c[i][3], side);
            TEST_ASSERT_ANGLE_WITHIN_MESSAGE(TOL_BETA, b, dir.beta, msg);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_UNORM, un, dir.u_norm, msg);
        }
    }
}

/* ------------------------------------------------------------ eq. (22) */

static void test_avd_beta_dot_hand_values_on_the_safe_circle(void)
{
    /* Robot at the origin, obstacle east at (D_s, 0): û = (1, 0), β = ±π/2,
     * |u| = D_s. Corrected (15) on the circle: u̇_p = −(q̇·û) û.
     * (16): u̇_f = −R q̇; LEFT: −R q̇ = (q̇_y, −q̇_x). */
    avd_dir_t dir;
    pose_t robot;

    /* θ = π/2, LEFT (circling clockwise, obstacle on the right):
     * q̇ = (0, v), q̇·û = 0 → u̇_p = 0; u̇_f = (v, 0); β = π/2:
     * β̇ = (u̇_y cos β − u̇_x sin β)/|u| = (0 − v)/D_s = −v/D_s = −1.4285714. */
    robot = tu_pose(0.0, 0.0, TU_PI / 2);
    avd_direction(&robot, tu_num(DS), NUM_ZERO, tu_num(DS), AVD_SIDE_LEFT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA_DOT, -V / DS, dir.beta_dot);

    /* θ = 0, LEFT (heading at the obstacle): q̇ = (v, 0), q̇·û = v →
     * u̇_p = (−v, 0); u̇_f = (0, −v); u̇ = (−v, −v); β = π/2:
     * β̇ = (−v·0 − (−v)·1)/D_s = +v/D_s = 1.4285714.
     * (The printed (15) gives u̇_p = 0·q̇ + D_s·v·(D_s, 0), u̇ = (D_s² v, −v),
     * β̇ = −D_s v = −0.175: wrong sign and size.) */
    robot = tu_pose(0.0, 0.0, 0.0);
    avd_direction(&robot, tu_num(DS), NUM_ZERO, tu_num(DS), AVD_SIDE_LEFT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA_DOT, V / DS, dir.beta_dot);

    /* θ = 0, RIGHT: −R(−π/2) q̇ = (−q̇_y, q̇_x) = (0, v); u̇ = (−v, v);
     * β = −π/2: β̇ = (v·0 − (−v)(−1))/D_s = −v/D_s. */
    avd_direction(&robot, tu_num(DS), NUM_ZERO, tu_num(DS), AVD_SIDE_RIGHT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA_DOT, -V / DS, dir.beta_dot);

    /* v = 0: nothing moves, β̇ = 0. */
    avd_direction(&robot, tu_num(DS), NUM_ZERO, tu_num(DS), AVD_SIDE_LEFT, NUM_ZERO, &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA_DOT, 0.0, dir.beta_dot);
}

static void test_avd_beta_dot_matches_corrected_eq15_at_many_points(void)
{
    /* Poses around an obstacle at (2, 1), inside and outside the safe circle,
     * both sides, speeds of both signs. */
    const double c[][4] = {
        /* x, y, θ, v */
        { 1.6, 1.0, 0.3, 0.5 },  { 2.0, 0.55, 1.2, 0.5 }, { 2.3, 1.35, -2.5, 0.5 },
        { 1.7, 1.3, 2.8, 0.5 },  { 1.75, 0.8, 0.9, 0.4 }, { 2.45, 1.1, 2.6, 0.6 },
        { 1.8, 1.0, -0.4, 0.5 }, { 2.2, 1.5, 3.1, -0.3 }, { 1.5, 0.9, -3.0, 0.45 }
    };
    char msg[96];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        for (int side = -1; side <= 1; side += 2) {
            pose_t robot = tu_pose(c[i][0], c[i][1], c[i][2]);
            avd_dir_t dir;
            avd_direction(&robot, tu_num(2.0), tu_num(1.0), tu_num(DS), (avd_side_t)side,
                          tu_num(c[i][3]), &dir);
            const double expected = ref_beta_dot(tu_q(c[i][0]), tu_q(c[i][1]), tu_q(c[i][2]),
                                                 tu_q(c[i][3]), 2.0, 1.0, tu_q(DS), side, false);
            snprintf(msg, sizeof msg, "pose (%g, %g, %g) v %g side %d", c[i][0], c[i][1], c[i][2],
                     c[i][3], side);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_BETA_DOT, expected, dir.beta_dot, msg);
        }
    }
}

/* Straight lines past an obstacle at (2, 1): start, heading, side, and the
 * sample times (distance to the obstacle between 0.3 and 0.65 m, so that
 * β is smooth at the scale of the step and q̇·û is not small). */
typedef struct {
    double x0, y0, th;
    avd_side_t side;
    double t[5];
    size_t n;
} fd_line_t;

static const fd_line_t k_lines[] = {
    { 1.2, 0.75, 0.25, AVD_SIDE_LEFT, { 0.4, 0.8, 1.2, 2.4 }, 4 },
    { 1.3, 1.45, -0.3, AVD_SIDE_RIGHT, { 0.4, 0.8, 1.2, 2.0, 2.4 }, 5 },
    { 2.6, 0.4, 2.3, AVD_SIDE_LEFT, { 0.4, 0.8, 1.2, 2.4 }, 4 },
};

/* β of avd_direction() at time t on a line. */
static double beta_on_line(const fd_line_t *l, double t)
{
    pose_t robot = tu_pose(l->x0 + V * t * cos(l->th), l->y0 + V * t * sin(l->th), l->th);
    avd_dir_t dir;
    avd_direction(&robot, tu_num(2.0), tu_num(1.0), tu_num(DS), l->side, tu_num(V), &dir);
    return tu_dbl(dir.beta);
}

static void test_avd_beta_dot_matches_finite_difference_along_a_line(void)
{
    char msg[96];
    for (size_t k = 0; k < sizeof k_lines / sizeof k_lines[0]; k++) {
        const fd_line_t *l = &k_lines[k];
        for (size_t i = 0; i < l->n; i++) {
            const double t = l->t[i];
            const double fd =
                tu_wrap(beta_on_line(l, t + FD_H) - beta_on_line(l, t - FD_H)) / (2.0 * FD_H);
            pose_t robot = tu_pose(l->x0 + V * t * cos(l->th), l->y0 + V * t * sin(l->th), l->th);
            avd_dir_t dir;
            avd_direction(&robot, tu_num(2.0), tu_num(1.0), tu_num(DS), l->side, tu_num(V), &dir);
            snprintf(msg, sizeof msg, "line %zu t = %g: finite difference %.6f", k, t, fd);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_FD, fd, dir.beta_dot, msg);
        }
    }
}

static void test_avd_misprinted_eq15_fails_the_finite_difference(void)
{
    /* The same finite differences as above. The corrected eq. (15) in double
     * agrees with them (so the test's own β̇ code is right), and the paper's
     * printed eq. (15), differing only in the one term, misses every one of
     * them by more than MISPRINT_MARGIN: the finite difference tells the two
     * apart, and the misprint fails it. */
    char msg[128];
    for (size_t k = 0; k < sizeof k_lines / sizeof k_lines[0]; k++) {
        const fd_line_t *l = &k_lines[k];
        for (size_t i = 0; i < l->n; i++) {
            const double t = l->t[i];
            const double fd =
                tu_wrap(beta_on_line(l, t + FD_H) - beta_on_line(l, t - FD_H)) / (2.0 * FD_H);
            const double x = tu_q(l->x0 + V * t * cos(l->th)), y = tu_q(l->y0 + V * t * sin(l->th));
            const double th = tu_q(l->th);
            const double good = ref_beta_dot(x, y, th, V, 2.0, 1.0, tu_q(DS), (int)l->side, false);
            const double bad = ref_beta_dot(x, y, th, V, 2.0, 1.0, tu_q(DS), (int)l->side, true);
            snprintf(msg, sizeof msg, "line %zu t = %g: fd %.6f corrected %.6f misprint %.6f", k, t,
                     fd, good, bad);
            TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(TOL_FD, fd, good, msg);
            TEST_ASSERT_TRUE_MESSAGE(fabs(bad - fd) > MISPRINT_MARGIN, msg);
        }
    }
}

/* ---------------------------------------------------- degenerate case */

static void test_avd_robot_at_obstacle_centre_commands_no_turn(void)
{
    /* avd.h: |u_mo| below 1 mm → β = θ, β̇ = 0. */
    avd_dir_t dir;
    pose_t robot = tu_pose(1.0, 1.0, 0.7);
    avd_direction(&robot, tu_num(1.0), tu_num(1.0), tu_num(DS), AVD_SIDE_LEFT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, 0.7, dir.beta);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA_DOT, 0.0, dir.beta_dot);
    /* 0.5 mm away, still below 1 mm; heading −2.9, side RIGHT. */
    robot = tu_pose(1.0005, 1.0, -2.9);
    avd_direction(&robot, tu_num(1.0), tu_num(1.0), tu_num(DS), AVD_SIDE_RIGHT, tu_num(V), &dir);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, -2.9, dir.beta);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA_DOT, 0.0, dir.beta_dot);

    /* The law then commands ω = 0 + k2·wrap(θ − θ) = 0 and e = 0, whatever
     * the gains; v = v_r cos e3 + k1 e1 = 0.5 (e = 0). */
    avd_gains_t g = { tu_num(3.0), tu_num(6.0) };
    trk_err_t err = { NUM_ZERO, NUM_ZERO, NUM_ZERO };
    num_t v, w, e;
    robot = tu_pose(1.0, 1.0, 0.7);
    avd_control(&g, &robot, &err, tu_num(0.5), tu_num(1.0), tu_num(1.0), tu_num(DS), AVD_SIDE_LEFT,
                &v, &w, &e);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, 0.0, e);
    TEST_ASSERT_NUM_WITHIN(TOL_OMEGA, 0.0, w);
    TEST_ASSERT_NUM_WITHIN(TOL_V, 0.5, v);
}

/* ------------------------------------------------------ eq. (21)-(24) */

static void test_avd_control_wraps_e_and_adds_beta_dot(void)
{
    /* Robot at the origin, obstacle at (D_s, 0), LEFT, θ = −2.5, v_r = 0.5,
     * e1 = e3 = 0 (so v = v_r and q̇ = v_r [cos θ, sin θ] whichever speed the
     * law feeds into β̇). Gains k1 = 2, k2 = 5 (not Table 1's, so that a mix
     * with the tracking gains shows).
     * β = π/2 (on the safe circle). e = wrap(π/2 + 2.5) = π/2 + 2.5 − 2π
     * = −2.2123890 (unwrapped it would be +4.07).
     * β̇ on the circle with û = (1, 0), LEFT: u̇ = (−q̇_x + q̇_y, −q̇_x), β = π/2:
     * β̇ = −u̇_x/D_s = v (cos θ − sin θ)/D_s = 0.5(−0.8011436 + 0.5984721)/0.35
     * = −0.2895307. ω = β̇ + 5 e = −0.2895307 − 11.0619449 = −11.3514756.
     * v = 0.5 cos 0 + 2·0 = 0.5. */
    avd_gains_t g = { tu_num(2.0), tu_num(5.0) };
    trk_err_t err = { NUM_ZERO, tu_num(0.1), NUM_ZERO };
    pose_t robot = tu_pose(0.0, 0.0, -2.5);
    num_t v, w, e;
    avd_control(&g, &robot, &err, tu_num(0.5), tu_num(DS), NUM_ZERO, tu_num(DS), AVD_SIDE_LEFT, &v,
                &w, &e);
    const double th = tu_q(-2.5);
    const double e_exp = TU_PI / 2 - th - TU_TWO_PI;
    const double bd_exp = 0.5 * (cos(th) - sin(th)) / DS;
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, e_exp, e);
    TEST_ASSERT_NUM_WITHIN(TOL_OMEGA, bd_exp + 5.0 * e_exp, w);
    TEST_ASSERT_NUM_WITHIN(TOL_V, 0.5, v);
    /* The hand numbers above, to check the closed forms. */
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -2.2123890, TU_PI / 2 + 2.5 - TU_TWO_PI);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -0.2895307, 0.5 * (cos(-2.5) - sin(-2.5)) / DS);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -11.3514756, -0.2895307 + 5.0 * -2.2123890);
}

static void test_avd_control_heading_error_and_omega_general(void)
{
    /* Off the circle, against the double reference: e = wrap(β − θ),
     * ω = β̇ + k2 e, with e1 = e3 = 0 so that the speed in β̇ is v_r. */
    const double c[][4] = { /* x, y, θ, v_r */
                            { 1.6, 1.0, 0.3, 0.5 },
                            { 2.3, 1.35, -2.5, 0.4 },
                            { 1.7, 1.3, 2.8, 0.5 }
    };
    avd_gains_t g = { tu_num(3.0), tu_num(6.0) };
    trk_err_t err = { NUM_ZERO, NUM_ZERO, NUM_ZERO };
    char msg[96];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        for (int side = -1; side <= 1; side += 2) {
            pose_t robot = tu_pose(c[i][0], c[i][1], c[i][2]);
            num_t v, w, e;
            avd_control(&g, &robot, &err, tu_num(c[i][3]), tu_num(2.0), tu_num(1.0), tu_num(DS),
                        (avd_side_t)side, &v, &w, &e);
            const double x = tu_q(c[i][0]), y = tu_q(c[i][1]), th = tu_q(c[i][2]);
            const double b = ref_beta(x, y, 2.0, 1.0, tu_q(DS), side, NULL);
            const double e_exp = tu_wrap(b - th);
            const double bd =
                ref_beta_dot(x, y, th, tu_q(c[i][3]), 2.0, 1.0, tu_q(DS), side, false);
            snprintf(msg, sizeof msg, "pose (%g, %g, %g) side %d", c[i][0], c[i][1], c[i][2], side);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_BETA, e_exp, e, msg);
            TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(e, msg);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_OMEGA, bd + 6.0 * e_exp, w, msg);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_V, c[i][3], v, msg);
        }
    }
}

static void test_avd_control_linear_speed_is_eq23(void)
{
    /* v = v_r cos e3 + k1 e1 (eq. (23), the same as eq. (2)): e1 = 0.1,
     * e3 = 0.2, v_r = 0.5, k1 = 3: v = 0.5·0.9800666 + 0.3 = 0.7900333. */
    avd_gains_t g = { tu_num(3.0), tu_num(6.0) };
    trk_err_t err = { tu_num(0.1), tu_num(-0.4), tu_num(0.2) };
    pose_t robot = tu_pose(1.6, 1.0, 0.3);
    num_t v, w, e;
    avd_control(&g, &robot, &err, tu_num(0.5), tu_num(2.0), tu_num(1.0), tu_num(DS), AVD_SIDE_LEFT,
                &v, &w, &e);
    TEST_ASSERT_NUM_WITHIN(TOL_V, 0.5 * cos(tu_q(0.2)) + 3.0 * tu_q(0.1), v);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.7900333, 0.5 * cos(0.2) + 0.3);
    /* e does not depend on the tracking errors: wrap(atan 8 − 0.3). */
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, atan(8.0) - tu_q(0.3), e);
}

/* ------------------------------------------------------- avd_turn ("mstc") */

static void test_avd_turn_of_a_static_circle_is_eq24(void)
{
    /* For a still circle and the v of eq. (23), avd_turn() gives the ω and e
     * of avd_control() (β̇ + k2 e, the independent double formula). */
    const avd_gains_t g = { .k1 = tu_num(3.0), .k2 = tu_num(5.0) };
    const double c[][4] = { { 1.6, 1.0, 0.3, 0.5 },
                            { 2.3, 1.35, -2.5, 0.4 },
                            { 1.5, 0.9, -3.0, 0.45 } };
    char msg[96];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        for (int side = -1; side <= 1; side += 2) {
            const pose_t robot = tu_pose(c[i][0], c[i][1], c[i][2]);
            const avd_obstacle_t o = { .x = tu_num(2.0),
                                       .y = tu_num(1.0),
                                       .vx = NUM_ZERO,
                                       .vy = NUM_ZERO,
                                       .d_s = tu_num(DS) };
            num_t w, e;
            avd_turn(&g, &robot, num_cos(robot.theta), num_sin(robot.theta), &o, (avd_side_t)side,
                     tu_num(c[i][3]), &w, &e);
            double un;
            const double beta =
                ref_beta(tu_q(c[i][0]), tu_q(c[i][1]), 2.0, 1.0, tu_q(DS), side, &un);
            const double ee = tu_wrap(beta - tu_q(c[i][2]));
            const double ww = ref_beta_dot(tu_q(c[i][0]), tu_q(c[i][1]), tu_q(c[i][2]),
                                           tu_q(c[i][3]), 2.0, 1.0, tu_q(DS), side, false) +
                              5.0 * ee;
            snprintf(msg, sizeof msg, "pose %zu side %d", i, side);
            TEST_ASSERT_ANGLE_WITHIN_MESSAGE(TOL_BETA, ee, e, msg);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_OMEGA, ww, w, msg);
        }
    }
}

static void test_avd_turn_takes_the_velocity_relative_to_a_moving_circle(void)
{
    /* Hand case: robot at the origin heading +y at 0.5 m/s, circle of 0.35
     * centred at (0.35, 0) (the robot on it), LEFT, moving +y at 0.5 m/s
     * too: relative velocity 0, so β̇ = 0 (for a still circle it would be
     * −v/D_s = −1.4286, test_avd_beta_dot_hand_values_on_the_safe_circle's
     * β = π/2 case). β = π/2 = θ: e = 0, ω = 0. */
    const avd_gains_t g = { .k1 = tu_num(3.0), .k2 = tu_num(6.0) };
    const pose_t robot = tu_pose(0.0, 0.0, TU_PI / 2);
    avd_obstacle_t o = {
        .x = tu_num(DS), .y = NUM_ZERO, .vx = NUM_ZERO, .vy = tu_num(V), .d_s = tu_num(DS)
    };
    num_t w, e;
    avd_turn(&g, &robot, num_cos(robot.theta), num_sin(robot.theta), &o, AVD_SIDE_LEFT, tu_num(V),
             &w, &e);
    TEST_ASSERT_NUM_WITHIN(TOL_BETA, 0.0, e);
    TEST_ASSERT_NUM_WITHIN(TOL_OMEGA, 0.0, w);
    o.vy = NUM_ZERO;
    avd_turn(&g, &robot, num_cos(robot.theta), num_sin(robot.theta), &o, AVD_SIDE_LEFT, tu_num(V),
             &w, &e);
    TEST_ASSERT_NUM_WITHIN(TOL_OMEGA, -V / DS, w);
    /* General points: the double formula with q̇ − w. */
    const double c[][6] = {
        /* x, y, θ, v, w_x, w_y */
        { 1.6, 1.0, 0.3, 0.5, 0.2, -0.1 },
        { 2.3, 1.35, -2.5, 0.4, -0.3, 0.25 },
        { 1.75, 0.8, 0.9, 0.4, 0.0, 0.4 },
    };
    char msg[96];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        for (int side = -1; side <= 1; side += 2) {
            const pose_t r = tu_pose(c[i][0], c[i][1], c[i][2]);
            const avd_obstacle_t m = { .x = tu_num(2.0),
                                       .y = tu_num(1.0),
                                       .vx = tu_num(c[i][4]),
                                       .vy = tu_num(c[i][5]),
                                       .d_s = tu_num(DS) };
            avd_turn(&g, &r, num_cos(r.theta), num_sin(r.theta), &m, (avd_side_t)side,
                     tu_num(c[i][3]), &w, &e);
            const double th = tu_q(c[i][2]), v = tu_q(c[i][3]);
            double un;
            const double beta =
                ref_beta(tu_q(c[i][0]), tu_q(c[i][1]), 2.0, 1.0, tu_q(DS), side, &un);
            const double bd =
                ref_beta_dot_q(tu_q(c[i][0]), tu_q(c[i][1]), v * cos(th) - tu_q(c[i][4]),
                               v * sin(th) - tu_q(c[i][5]), 2.0, 1.0, tu_q(DS), side, false);
            snprintf(msg, sizeof msg, "pose %zu side %d", i, side);
            TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_OMEGA, bd + 6.0 * tu_wrap(beta - th), w, msg);
        }
    }
}

static void test_avd_turn_matches_a_finite_difference_with_the_circle_moving(void)
{
    /* β along a straight line while the circle moves at (0.3, −0.2): the
     * central difference of avd_direction()'s β, with the centre where it
     * is at each time, against avd_turn()'s β̇ = ω − k2 e. */
    const avd_gains_t g = { .k1 = tu_num(3.0), .k2 = tu_num(6.0) };
    const double x0 = 1.2, y0 = 0.75, th = 0.25, wx = 0.3, wy = -0.2;
    const double ts[] = { 0.4, 0.8, 1.2 };
    char msg[64];
    for (size_t i = 0; i < 3; i++) {
        double b[2];
        for (int k = 0; k < 2; k++) {
            const double t = ts[i] + (k == 0 ? -FD_H : FD_H);
            const pose_t r = tu_pose(x0 + V * t * cos(th), y0 + V * t * sin(th), th);
            avd_dir_t dir;
            avd_direction(&r, tu_num(2.0 + wx * t), tu_num(1.0 + wy * t), tu_num(DS), AVD_SIDE_LEFT,
                          tu_num(V), &dir);
            b[k] = tu_dbl(dir.beta);
        }
        const double t = ts[i];
        const pose_t r = tu_pose(x0 + V * t * cos(th), y0 + V * t * sin(th), th);
        const avd_obstacle_t o = { .x = tu_num(2.0 + wx * t),
                                   .y = tu_num(1.0 + wy * t),
                                   .vx = tu_num(wx),
                                   .vy = tu_num(wy),
                                   .d_s = tu_num(DS) };
        num_t w, e;
        avd_turn(&g, &r, num_cos(r.theta), num_sin(r.theta), &o, AVD_SIDE_LEFT, tu_num(V), &w, &e);
        snprintf(msg, sizeof msg, "t = %g", t);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(TOL_FD, tu_wrap(b[1] - b[0]) / (2.0 * FD_H),
                                          tu_dbl(w) - 6.0 * tu_dbl(e), msg);
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_avd_side_in_all_four_quadrants);
    RUN_TEST(test_avd_side_across_the_pi_seam);
    RUN_TEST(test_avd_side_uses_the_robot_to_obstacle_vector);
    RUN_TEST(test_avd_side_straight_ahead_is_left);
    RUN_TEST(test_avd_beta_on_the_safe_circle_is_phi_plus_or_minus_half_pi);
    RUN_TEST(test_avd_beta_off_the_safe_circle);
    RUN_TEST(test_avd_beta_dot_hand_values_on_the_safe_circle);
    RUN_TEST(test_avd_beta_dot_matches_corrected_eq15_at_many_points);
    RUN_TEST(test_avd_beta_dot_matches_finite_difference_along_a_line);
    RUN_TEST(test_avd_misprinted_eq15_fails_the_finite_difference);
    RUN_TEST(test_avd_robot_at_obstacle_centre_commands_no_turn);
    RUN_TEST(test_avd_control_wraps_e_and_adds_beta_dot);
    RUN_TEST(test_avd_control_heading_error_and_omega_general);
    RUN_TEST(test_avd_control_linear_speed_is_eq23);
    RUN_TEST(test_avd_turn_of_a_static_circle_is_eq24);
    RUN_TEST(test_avd_turn_takes_the_velocity_relative_to_a_moving_circle);
    RUN_TEST(test_avd_turn_matches_a_finite_difference_with_the_circle_moving);
    return UNITY_END();
}
