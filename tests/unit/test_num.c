/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/num: the scalar type and its operations.
 *
 * Expected values: hand values (written beside each), or libm in double on
 * the value the input really holds (tu_q), which is an independent
 * computation of the same closed form.
 */
#include <fenv.h>
#include <float.h>
#include <stdio.h>
#include <string.h>

#include "num/num.h"
#include "test_util.h"
#include "unity.h"

/* ------------------------------------------------------------ tolerances */

/* Values that must come back unchanged (in-range wrap, min/max/clamp): exact
 * in both modes, the functions only select or return their input. */
#define TOL_EXACT    TU_TOL(0.0, 0.0)
/* An angle of magnitude ≤ 2π after one reduction step. float: float(π) is
 * 8.7e-8 above π and the result rounds to ulp(π)/2 = 1.2e-7; fixed: Q16.16
 * π and 2π are within 2^-17 = 7.6e-6 and the result within one lsb 1.5e-5. */
#define TOL_WRAP_ABS TU_TOL(4e-7, 3e-5)
/* Growth of the wrap error with |a|, per radian of input. float: a − 2π·n
 * loses half an ulp of |a| (6e-8·|a|) and float(2π)'s error 2.8e-8 times n
 * turns; 4·FLT_EPSILON = 4.8e-7 covers both. fixed: Q16.16 2π is off by up to
 * 7.6e-6, times n = |a|/2π turns: 1.2e-6·|a|; 2e-6 leaves margin. */
#define TOL_WRAP_REL TU_TOL(4.8e-7, 2e-6)
/* atan2, sin, cos results ≤ π. float: libm float versions are within 1-2 ulp
 * of values ≤ π (2.4e-7 each); fixed: the trig error target of issue 3 is
 * about 1e-4 rad (libfixmath), doubled for margin. */
#define TOL_TRIG     TU_TOL(5e-7, 2e-4)
/* hypot and sqrt, absolute part. float: unused (relative part dominates);
 * fixed: inputs rounded to 7.6e-6 each plus the root rounded to 1.5e-5. */
#define TOL_ROOT_ABS TU_TOL(0.0, 6e-5)
/* hypot and sqrt, relative part. float: hypotf/sqrtf are within 1 ulp
 * (1.2e-7 relative), 3e-7 for margin; fixed: 1e-5 relative allows for a
 * range reduction of large arguments before the root. */
#define TOL_ROOT_REL TU_TOL(3e-7, 1e-5)
/* One multiply or divide of values ≤ 4. float: one rounding, ulp(4)/2 =
 * 2.4e-7; fixed: one Q16.16 rounding, 1.5e-5. */
#define TOL_ARITH    TU_TOL(2.4e-7, 1.6e-5)
/* Conversion of a value ≤ 20000 from float and back. float: exact; fixed:
 * rounding to the Q16.16 grid, half an lsb = 7.6e-6. */
#define TOL_CONVERT  TU_TOL(0.0, 7.7e-6)

static double tol_wrap(double a) { return TOL_WRAP_ABS + TOL_WRAP_REL * fabs(a); }

void setUp(void) {}
void tearDown(void) {}

/* ------------------------------------------------------------- num_wrap */

static void test_num_wrap_leaves_interior_angles_unchanged(void)
{
    /* Already in (-π, π]: returned as they are. */
    const double in[] = { 0.0, 1.0, -1.0, 3.0, -3.0, 3.14, -3.14, 1e-3 };
    for (size_t i = 0; i < sizeof in / sizeof in[0]; i++) {
        num_t a = tu_num(in[i]);
        TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_dbl(a), num_wrap(a));
    }
}

static void test_num_wrap_maps_pi_to_pi(void)
{
    /* π is inside (-π, π]: it stays π (not -π). */
    num_t r = num_wrap(NUM_PI);
    TEST_ASSERT_NUM_WITHIN(TOL_WRAP_ABS, TU_PI, r);
    TEST_ASSERT_NUM_ANGLE_IN_RANGE(r);
}

static void test_num_wrap_maps_minus_pi_to_plus_pi(void)
{
    /* -π is outside (-π, π]; -π ≡ π, so the answer is +π. A plain
     * closeness check to π fails on -π (off by 2π). */
    num_t r = num_wrap(num_neg(NUM_PI));
    TEST_ASSERT_NUM_WITHIN(TOL_WRAP_ABS, TU_PI, r);
    TEST_ASSERT_NUM_ANGLE_IN_RANGE(r);
    /* The same from the literal, which rounds to the same or a neighbouring
     * value just beyond -π. */
    r = num_wrap(tu_num(-TU_PI));
    TEST_ASSERT_NUM_WITHIN(TOL_WRAP_ABS, TU_PI, r);
    TEST_ASSERT_NUM_ANGLE_IN_RANGE(r);
}

static void test_num_wrap_odd_multiples_of_pi_land_on_the_seam(void)
{
    /* ±3π ≡ π. The inputs hold 3π only to within rounding, so the exact
     * answer is π or -π + ε (both the seam); check the angle modulo 2π and
     * the range. */
    const double in[] = { 3.0 * TU_PI, -3.0 * TU_PI, 5.0 * TU_PI, -7.0 * TU_PI };
    for (size_t i = 0; i < sizeof in / sizeof in[0]; i++) {
        num_t r = num_wrap(tu_num(in[i]));
        TEST_ASSERT_ANGLE_WITHIN(tol_wrap(in[i]), TU_PI, r);
        TEST_ASSERT_NUM_ANGLE_IN_RANGE(r);
    }
}

static void test_num_wrap_reduces_by_whole_turns(void)
{
    /* Hand values: subtract the whole number of turns k·2π. */
    const struct {
        double in, expected;
    } c[] = {
        { TU_TWO_PI, 0.0 },               /* 2π − 2π */
        { -TU_TWO_PI, 0.0 },              /* −2π + 2π */
        { TU_TWO_PI + 0.5, 0.5 },         /* one turn */
        { -2.0 * TU_TWO_PI - 0.5, -0.5 }, /* two turns */
        { 7.0, 7.0 - TU_TWO_PI },         /* 0.7168147 */
        { -7.0, -7.0 + TU_TWO_PI },       /* −0.7168147 */
        { 3.2, 3.2 - TU_TWO_PI },         /* just past π: −3.0831853 */
        { -3.2, -3.2 + TU_TWO_PI },       /* just past −π: 3.0831853 */
        { 4.0 * TU_PI + 1.0, 1.0 },       /* two turns */
    };
    char msg[64];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        snprintf(msg, sizeof msg, "input %.9g", c[i].in);
        num_t r = num_wrap(tu_num(c[i].in));
        TEST_ASSERT_NUM_WITHIN_MESSAGE(tol_wrap(c[i].in), c[i].expected, r, msg);
        TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(r, msg);
    }
}

static void test_num_wrap_large_angles(void)
{
    /* Expected: libm remainder() in double of the value the input holds.
     * Hand check: 100 − 16·2π = −0.5309649; −1000 + 159·2π = −0.9735362;
     * 20000 − 3183·2π = 0.6211928 (Q16.16 holds up to 32767). */
    const double in[] = { 100.0, -1000.0, 20000.0, -20000.0 };
    char msg[64];
    for (size_t i = 0; i < sizeof in / sizeof in[0]; i++) {
        snprintf(msg, sizeof msg, "input %.9g", in[i]);
        num_t r = num_wrap(tu_num(in[i]));
        TEST_ASSERT_NUM_WITHIN_MESSAGE(tol_wrap(in[i]), tu_wrap(tu_q(in[i])), r, msg);
        TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(r, msg);
    }
    /* The hand value of the first, to check the reference itself. */
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -0.5309649, tu_wrap(100.0));
}

static void test_num_wrap_sweep_stays_in_range_and_keeps_the_angle(void)
{
    /* Every input from −50 to 50 rad in steps of 0.37: result in (−π, π]
     * and equal to the input modulo 2π (libm reference). */
    char msg[64];
    for (int i = -135; i <= 135; i++) {
        double a = 0.37 * (double)i;
        num_t r = num_wrap(tu_num(a));
        snprintf(msg, sizeof msg, "input %.9g", a);
        TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(r, msg);
        TEST_ASSERT_ANGLE_WITHIN_MESSAGE(tol_wrap(a), tu_q(a), r, msg);
    }
}

/* The num_t value one step (ulp in float, LSB in fixed) after @p a, @p d
 * steps away. */
static num_t step_from(num_t a, int d)
{
#ifdef NUM_FIXED
    return (num_t)(a + d);
#else
    for (; d > 0; d--) {
        a = nextafterf(a, INFINITY);
    }
    for (; d < 0; d++) {
        a = nextafterf(a, -INFINITY);
    }
    return a;
#endif
}

static void test_num_wrap_near_odd_multiples_of_pi_stays_in_range(void)
{
    /* The seam is where rounding can push a reduced angle to −π or just
     * beyond π. Every representable input within 6 steps of kπ, k odd,
     * |k| ≤ 41 (|a| ≤ 129) and 1801 ≤ |k| ≤ 2001 (|a| up to 6286, where a
     * float ulp, 4.9e-4, is coarse enough for a reduction to land beyond ±π):
     * the result lies in (−π, π] and equals the input modulo 2π (libm
     * remainder in double on the value the input holds). */
    char msg[80];
    for (int k = -2001; k <= 2001; k += 2) {
        if (k < -41 && k > -1801) {
            k = -43;
            continue;
        }
        if (k > 41 && k < 1801) {
            k = 1799;
            continue;
        }
        const num_t centre = tu_num((double)k * TU_PI);
        for (int d = -6; d <= 6; d++) {
            const num_t a = step_from(centre, d);
            const num_t r = num_wrap(a);
            snprintf(msg, sizeof msg, "input %.9g (%d pi %+d steps)", tu_dbl(a), k, d);
            TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(r, msg);
            TEST_ASSERT_ANGLE_WITHIN_MESSAGE(tol_wrap(tu_dbl(a)), tu_dbl(a), r, msg);
        }
    }
}

/* ------------------------------------------------------------ num_atan2 */

static void test_num_atan2_four_quadrants(void)
{
    /* Hand values: the diagonals. */
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, TU_PI / 4.0, num_atan2(tu_num(1.0), tu_num(1.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, 3.0 * TU_PI / 4.0, num_atan2(tu_num(1.0), tu_num(-1.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, -3.0 * TU_PI / 4.0, num_atan2(tu_num(-1.0), tu_num(-1.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, -TU_PI / 4.0, num_atan2(tu_num(-1.0), tu_num(1.0)));
    /* Off the diagonals, libm atan2 in double: (3, 4) → 0.6435011. */
    const double yx[][2] = {
        { 3.0, 4.0 }, { 4.0, -3.0 }, { -0.05, -0.02 }, { -100.0, 250.0 }, { 0.2, 7.0 }
    };
    char msg[64];
    for (size_t i = 0; i < sizeof yx / sizeof yx[0]; i++) {
        snprintf(msg, sizeof msg, "atan2(%g, %g)", yx[i][0], yx[i][1]);
        TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_TRIG, atan2(tu_q(yx[i][0]), tu_q(yx[i][1])),
                                       num_atan2(tu_num(yx[i][0]), tu_num(yx[i][1])), msg);
    }
}

static void test_num_atan2_axes(void)
{
    /* Hand values on the axes; (0, −1) is π or −π (same angle). */
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, 0.0, num_atan2(tu_num(0.0), tu_num(2.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, TU_PI / 2.0, num_atan2(tu_num(2.0), tu_num(0.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, -TU_PI / 2.0, num_atan2(tu_num(-2.0), tu_num(0.0)));
    TEST_ASSERT_ANGLE_WITHIN(TOL_TRIG, TU_PI, num_atan2(tu_num(0.0), tu_num(-2.0)));
    /* Documented: atan2(0, 0) = 0. */
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.0, num_atan2(NUM_ZERO, NUM_ZERO));
}

/* ------------------------------------------------------------ num_hypot */

static void test_num_hypot_known_triangles(void)
{
    /* Hand values: 3-4-5 triangles at several scales, signs, the axes. */
    const double c[][3] = {
        { 3.0, 4.0, 5.0 },       { -3.0, 4.0, 5.0 }, { -3.0, -4.0, 5.0 },    { 0.0, -2.5, 2.5 },
        { 0.003, 0.004, 0.005 }, { 0.0, 0.0, 0.0 },  { -60.0, 80.0, 100.0 },
    };
    char msg[64];
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        snprintf(msg, sizeof msg, "hypot(%g, %g)", c[i][0], c[i][1]);
        TEST_ASSERT_NUM_WITHIN_MESSAGE(TOL_ROOT_ABS + TOL_ROOT_REL * c[i][2], c[i][2],
                                       num_hypot(tu_num(c[i][0]), tu_num(c[i][1])), msg);
    }
}

static void test_num_hypot_across_a_100_m_field_and_beyond(void)
{
    /* Diagonal of a 100 m × 100 m field: 100·√2 = 141.4213562 (issue 3: no
     * squared distance may overflow there). */
    TEST_ASSERT_NUM_WITHIN(TOL_ROOT_ABS + TOL_ROOT_REL * 141.5, 100.0 * sqrt(2.0),
                           num_hypot(tu_num(100.0), tu_num(-100.0)));
    /* num.h: "without intermediate overflow": 300² + 400² = 250000 is far
     * beyond Q16.16's 32767, the result 500 is not. */
    TEST_ASSERT_NUM_WITHIN(TOL_ROOT_ABS + TOL_ROOT_REL * 500.0, 500.0,
                           num_hypot(tu_num(300.0), tu_num(400.0)));
}

static void test_num_sqrt_values_and_negative_input(void)
{
    TEST_ASSERT_NUM_WITHIN(TOL_ROOT_ABS + TOL_ROOT_REL * 1.5, sqrt(2.0), num_sqrt(tu_num(2.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_ROOT_ABS + TOL_ROOT_REL * 0.35, 0.35, num_sqrt(tu_num(0.1225)));
    TEST_ASSERT_NUM_WITHIN(TOL_ROOT_ABS + TOL_ROOT_REL * 150.0, 150.0, num_sqrt(tu_num(22500.0)));
    /* Documented: negative input gives 0. */
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.0, num_sqrt(tu_num(-4.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.0, num_sqrt(NUM_ZERO));
}

/* ---------------------------------------------------- min, max, clamp */

static void test_num_min_max_pick_the_right_operand(void)
{
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(1.25), num_min(tu_num(1.25), tu_num(2.5)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(1.25), num_min(tu_num(2.5), tu_num(1.25)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(-2.0), num_min(tu_num(-1.0), tu_num(-2.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(2.5), num_max(tu_num(1.25), tu_num(2.5)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(2.5), num_max(tu_num(2.5), tu_num(1.25)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(-1.0), num_max(tu_num(-1.0), tu_num(-2.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(0.5), num_max(tu_num(0.5), tu_num(0.5)));
}

static void test_num_clamp_limits_and_passes_through(void)
{
    const num_t lo = tu_num(-1.0), hi = tu_num(2.0);
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 2.0, num_clamp(tu_num(5.0), lo, hi));       /* above */
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, -1.0, num_clamp(tu_num(-5.0), lo, hi));     /* below */
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, tu_q(0.3), num_clamp(tu_num(0.3), lo, hi)); /* inside */
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 2.0, num_clamp(tu_num(2.0), lo, hi));       /* on hi */
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, -1.0, num_clamp(tu_num(-1.0), lo, hi));     /* on lo */
    /* lo == hi: everything becomes that value. */
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.5, num_clamp(tu_num(-3.0), tu_num(0.5), tu_num(0.5)));
}

/* ------------------------------------------------- arithmetic, trig */

/* num_mul_period(a, dt, us): a times a period of us microseconds. Hand
 * values: 20 rad/s² over 20 ms is 0.4; −3 over 33,333 µs is −0.099999;
 * nothing over no time. */
static void test_num_mul_period_hand_values(void)
{
    TEST_ASSERT_NUM_WITHIN(TOL_ARITH, 0.4, num_mul_period(tu_num(20.0), tu_num(0.02), 20000u));
    TEST_ASSERT_NUM_WITHIN(TOL_ARITH, -0.099999,
                           num_mul_period(tu_num(-3.0), tu_num(0.033333), 33333u));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.0, num_mul_period(tu_num(20.0), NUM_ZERO, 0u));
}

static void test_num_arithmetic_hand_values(void)
{
    /* Hand values: 1.5·(−2.25) = −3.375; 1/3; 0.75 + 1.5 = 2.25; 0.75 − 1.5
     * = −0.75; −(−0.5) = 0.5; |−1.75| = 1.75. */
    TEST_ASSERT_NUM_WITHIN(TOL_ARITH, -3.375, num_mul(tu_num(1.5), tu_num(-2.25)));
    TEST_ASSERT_NUM_WITHIN(TOL_ARITH, 1.0 / 3.0, num_div(tu_num(1.0), tu_num(3.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_ARITH, -4.0 / 3.0, num_div(tu_num(4.0), tu_num(-3.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 2.25, num_add(tu_num(0.75), tu_num(1.5)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, -0.75, num_sub(tu_num(0.75), tu_num(1.5)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.5, num_neg(tu_num(-0.5)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 1.75, num_abs(tu_num(-1.75)));
}

static void test_num_sin_cos_hand_values(void)
{
    /* sin(π/6) = 0.5, cos(π/3) = 0.5, sin(−π/2) = −1, cos(π) = −1, cos(0) = 1,
     * sin(3π/4) = √2/2. */
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, 0.5, num_sin(tu_num(TU_PI / 6.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, 0.5, num_cos(tu_num(TU_PI / 3.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, -1.0, num_sin(tu_num(-TU_PI / 2.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, -1.0, num_cos(NUM_PI));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, 1.0, num_cos(NUM_ZERO));
    TEST_ASSERT_NUM_WITHIN(TOL_TRIG, sqrt(2.0) / 2.0, num_sin(tu_num(3.0 * TU_PI / 4.0)));
}

/* The bits of a num_t (4 bytes in both modes), so that NaN equals NaN. */
static uint32_t bits_of(num_t a)
{
    uint32_t u;
    memcpy(&u, &a, sizeof u);
    return u;
}

/* num_sincos gives the bits of num_sin and num_cos (the reference: the two
 * calls), on 400,001 angles over [−40, 40] (all quadrants, ten turns each
 * way), the multiples of π/4 and, in fixed mode, the extremes. */
static void test_num_sincos_is_sin_and_cos(void)
{
    char msg[64];
    unsigned long differ = 0;
    for (int32_t i = -200000; i <= 200000; i++) {
        const num_t a = tu_num((double)i * 2e-4);
        num_t s;
        num_t c;
        num_sincos(a, &s, &c);
        if ((bits_of(s) != bits_of(num_sin(a)) || bits_of(c) != bits_of(num_cos(a))) &&
            differ++ == 0u) {
            snprintf(msg, sizeof msg, "angle %.6f", (double)num_to_float(a));
            TEST_FAIL_MESSAGE(msg);
        }
    }
    const num_t edge[] = { NUM_ZERO,
                           NUM_PI,
                           num_neg(NUM_PI),
                           NUM_HALF_PI,
                           NUM_TWO_PI,
                           tu_num(TU_PI / 4.0),
                           tu_num(-3.0 * TU_PI / 4.0),
                           NUM_MAX,
                           num_neg(NUM_MAX) };
    for (size_t i = 0; i < sizeof edge / sizeof edge[0]; i++) {
        num_t s;
        num_t c;
        num_sincos(edge[i], &s, &c);
        TEST_ASSERT_EQUAL_HEX32(bits_of(num_sin(edge[i])), bits_of(s));
        TEST_ASSERT_EQUAL_HEX32(bits_of(num_cos(edge[i])), bits_of(c));
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* num_norm_small(x, y): 5 for (3, −4), 0 for (0, 0) (hand values), and
 * num_sqrt(num_sum_sq_small(x, y)) bit for bit over a grid of both signs
 * below 128; in float mode num_sqrt_nonneg(a) is num_sqrt(a) for a >= +0. */
static void test_num_norm_small_is_the_root_of_the_squares(void)
{
    TEST_ASSERT_NUM_WITHIN(TOL_ROOT_ABS + TOL_ROOT_REL * 5.0, 5.0,
                           num_norm_small(tu_num(3.0), tu_num(-4.0)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.0, num_norm_small(NUM_ZERO, NUM_ZERO));
    unsigned long differ = 0;
    for (int i = -1270; i <= 1270; i += 3) {
        for (int j = -1270; j <= 1270; j += 13) {
            const num_t x = tu_num((double)i * 0.1);
            const num_t y = tu_num((double)j * 0.1);
            differ += bits_of(num_norm_small(x, y)) != bits_of(num_sqrt(num_sum_sq_small(x, y)));
        }
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
#if !defined(NUM_FIXED)
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 1.5, num_sqrt_nonneg(tu_num(2.25)));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.0, num_sqrt_nonneg(NUM_ZERO));
    for (int32_t i = 0; i <= 100000; i++) {
        const num_t a = tu_num((double)i * 0.37);
        differ += bits_of(num_sqrt_nonneg(a)) != bits_of(num_sqrt(a));
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
#endif
}

static void test_num_conversions_round_trip(void)
{
    const double in[] = { 0.0, 1.5, -0.1, 0.35, -12345.5, 20000.25 };
    char msg[64];
    for (size_t i = 0; i < sizeof in / sizeof in[0]; i++) {
        snprintf(msg, sizeof msg, "value %g", in[i]);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(TOL_CONVERT + fabs(in[i]) * (double)FLT_EPSILON, in[i],
                                          tu_q(in[i]), msg);
    }
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, -7.0, num_from_int(-7));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 1000.0, num_from_int(1000));
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 0.0, NUM_ZERO);
    TEST_ASSERT_NUM_WITHIN(TOL_EXACT, 1.0, NUM_ONE);
    TEST_ASSERT_NUM_WITHIN(TOL_WRAP_ABS, TU_PI / 2.0, NUM_HALF_PI);
    TEST_ASSERT_NUM_WITHIN(TOL_WRAP_ABS, TU_TWO_PI, NUM_TWO_PI);
}

/* A xorshift64 generator: the same pseudo-random pairs on every run. */
static uint64_t xorshift64(uint64_t *s)
{
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

/* num_any_nonzero(a, b) is a != 0 || b != 0: hand values, then 10^6 random
 * bit patterns (each half of the time a zero) against the definition. No
 * traps meanwhile: in float mode the patterns include signalling NaNs, whose
 * comparison raises FE_INVALID. */
static void test_num_any_nonzero_is_a_or_b_not_zero(void)
{
    TEST_ASSERT_FALSE(num_any_nonzero(NUM_ZERO, NUM_ZERO));
    TEST_ASSERT_FALSE(num_any_nonzero(num_neg(NUM_ZERO), NUM_ZERO));
    TEST_ASSERT_TRUE(num_any_nonzero(tu_num(-1.5), NUM_ZERO));
    TEST_ASSERT_TRUE(num_any_nonzero(NUM_ZERO, NUM_MAX));
    TEST_ASSERT_TRUE(num_any_nonzero(NUM_ZERO, num_neg(NUM_MAX)));
    TEST_ASSERT_TRUE(num_any_nonzero(tu_num(1e-4), tu_num(2.0)));
    fenv_t env;
    (void)feholdexcept(&env);
    uint64_t s = 3141592653589793238u;
    unsigned long differ = 0;
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t r = xorshift64(&s);
        uint32_t bits[2] = { (k & 1u) != 0u ? 0u : (uint32_t)r,
                             (k & 2u) != 0u ? (uint32_t)(k & 4u) << 29 : (uint32_t)(r >> 32) };
        num_t v[2];
        memcpy(v, bits, sizeof v);
        differ += num_any_nonzero(v[0], v[1]) != (v[0] != NUM_ZERO || v[1] != NUM_ZERO);
    }
    (void)feclearexcept(FE_ALL_EXCEPT);
    (void)fesetenv(&env);
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* num_below(a, lim) is |a| < lim (hand values, exact in both modes: the
 * bound itself is not below, nothing is below a bound <= 0), and the squares
 * of values below 128 are the squares: 1.5² = 2.25, 3² + 4² = 25. */
static void test_num_below_and_small_squares_hand_values(void)
{
    TEST_ASSERT_TRUE(num_below(tu_num(1.0), tu_num(2.0)));
    TEST_ASSERT_TRUE(num_below(tu_num(-1.5), tu_num(2.0)));
    TEST_ASSERT_FALSE(num_below(tu_num(2.0), tu_num(2.0)));
    TEST_ASSERT_FALSE(num_below(tu_num(-2.0), tu_num(2.0)));
    TEST_ASSERT_FALSE(num_below(tu_num(-2.5), tu_num(2.0)));
    TEST_ASSERT_FALSE(num_below(NUM_ZERO, NUM_ZERO));
    TEST_ASSERT_FALSE(num_below(NUM_ZERO, tu_num(-1.0)));
    TEST_ASSERT_TRUE(num_below(tu_num(-127.5), tu_num(128.0)));
    TEST_ASSERT_EQUAL_FLOAT(2.25f, num_to_float(num_sq_small(tu_num(-1.5))));
    TEST_ASSERT_EQUAL_FLOAT(25.0f, num_to_float(num_sum_sq_small(tu_num(3.0), tu_num(-4.0))));
    TEST_ASSERT_EQUAL_FLOAT(0.0f, num_to_float(num_sum_sq_small(NUM_ZERO, NUM_ZERO)));
}

#ifndef NUM_FIXED
/* Float mode only: Q16.16 has no NaN or infinity, so these values cannot be
 * built in fixed mode; test_num_every_fixed_value_is_finite covers it. */
static void test_num_is_finite_rejects_nan_and_inf(void)
{
    TEST_ASSERT_TRUE(num_is_finite(tu_num(1.0)));
    TEST_ASSERT_TRUE(num_is_finite(NUM_MAX));
    TEST_ASSERT_FALSE(num_is_finite(num_from_float(NAN)));
    TEST_ASSERT_FALSE(num_is_finite(num_from_float(INFINITY)));
    TEST_ASSERT_FALSE(num_is_finite(num_from_float(-INFINITY)));
}

/* num_within(a, lim) is num_is_finite(a) && |a| <= lim for the inputs where
 * one of the two tests decides alone (hand values: NaN compares false, an
 * infinite a is not finite, |−0| = 0 <= −0), and raises no FE_INVALID for a
 * NaN (the quiet comparison of C99's islessequal). */
static void test_num_within_is_finite_and_in_range(void)
{
    TEST_ASSERT_TRUE(num_within(1.0f, 2.0f));
    TEST_ASSERT_TRUE(num_within(2.0f, 2.0f));
    TEST_ASSERT_TRUE(num_within(-2.0f, 2.0f));
    TEST_ASSERT_FALSE(num_within(-2.5f, 2.0f));
    TEST_ASSERT_TRUE(num_within(0.0f, -0.0f));
    TEST_ASSERT_FALSE(num_within(0.0f, -1.0f));
    TEST_ASSERT_TRUE(num_within(1e30f, INFINITY));
    TEST_ASSERT_TRUE(num_within(-FLT_MAX, INFINITY));
    TEST_ASSERT_FALSE(num_within(INFINITY, INFINITY));
    TEST_ASSERT_FALSE(num_within(-INFINITY, INFINITY));
    TEST_ASSERT_FALSE(num_within(INFINITY, 2.0f));
    TEST_ASSERT_FALSE(num_within(NAN, 2.0f));
    TEST_ASSERT_FALSE(num_within(NAN, INFINITY));
    TEST_ASSERT_FALSE(num_within(1.0f, NAN));
    /* volatile: compared at run time, not folded by the compiler. */
    volatile float nan = NAN;
    volatile float inf = INFINITY;
    volatile float two = 2.0f;
    feclearexcept(FE_ALL_EXCEPT);
    TEST_ASSERT_FALSE(num_within(nan, two));
    TEST_ASSERT_FALSE(num_within(-nan, inf));
    TEST_ASSERT_FALSE(num_within(two, nan));
    TEST_ASSERT_FALSE(fetestexcept(FE_INVALID));
}

/* num_within against its definition, num_is_finite(a) && |a| <= lim, in
 * double (exact for every float): every lim of the integer comparison's
 * range (+0 up to FLT_MAX) and outside it (−0, negative, +inf, NaN), each
 * against a at and one ulp either side of ±lim, ±0, ±inf, NaN, and 10^6
 * random bit patterns for both; then the same random a against literal
 * limits, the form in which the comparison of bits runs (num_float.h: only
 * for a limit known at compile time, not under -Os). */
static bool within_by_definition(float a, float lim)
{
    return isfinite(a) && islessequal(fabs((double)a), (double)lim);
}

static float float_of_bits(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static void test_num_within_is_its_definition(void)
{
    static const float lims[] = { 0.0f, -0.0f, 1e-45f,  1.0f,     2.0f,      100.0f, 10000.0f,
                                  3.5f, -2.0f, FLT_MAX, INFINITY, -INFINITY, NAN };
    /* Random bit patterns include signalling NaNs, whose conversion to
     * double (and the fallback's comparison) raise FE_INVALID: no traps
     * here (feholdexcept), the test_util.h ones again after. */
    fenv_t env;
    (void)feholdexcept(&env);
    unsigned long differ = 0;
    for (size_t i = 0; i < sizeof lims / sizeof lims[0]; i++) {
        const float lim = lims[i];
        uint32_t b;
        memcpy(&b, &lim, sizeof b);
        /* lim, and its neighbours by one code of its bit pattern either way
         * (one ulp in magnitude), each with either sign. */
        const float near[] = { lim, float_of_bits(b - 1u), float_of_bits(b + 1u) };
        for (size_t j = 0; j < 3u; j++) {
            differ += num_within(near[j], lim) != within_by_definition(near[j], lim);
            differ += num_within(-near[j], lim) != within_by_definition(-near[j], lim);
        }
        const float special[] = { 0.0f, -0.0f, INFINITY, -INFINITY, NAN, 1.0f };
        for (size_t j = 0; j < sizeof special / sizeof special[0]; j++) {
            differ += num_within(special[j], lim) != within_by_definition(special[j], lim);
        }
    }
    uint64_t s = 5573589319906701683u;
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t r = xorshift64(&s);
        const float a = float_of_bits((uint32_t)r);
        /* Half the limits positive and finite, where the integer test runs. */
        const uint32_t lb = (uint32_t)(r >> 32);
        const float lim = float_of_bits((k & 1u) != 0u ? lb % 0x7F800000u : lb);
        differ += num_within(a, lim) != within_by_definition(a, lim);
    }
    /* Literal limits with a at them and one code either side. */
    for (uint32_t d = 0; d < 3u; d++) {
        const float at2 = float_of_bits(0x40000000u + d - 1u);           /* 2.0f's neighbours */
        const float atmax = float_of_bits(0x7F7FFFFFu + d - 1u);         /* FLT_MAX's */
        const float at0 = float_of_bits(d == 0u ? 0x80000000u : d - 1u); /* −0, +0, 1e-45 */
        differ += num_within(at2, 2.0f) != within_by_definition(at2, 2.0f);
        differ += num_within(-at2, 2.0f) != within_by_definition(-at2, 2.0f);
        differ += num_within(atmax, FLT_MAX) != within_by_definition(atmax, FLT_MAX);
        differ += num_within(-atmax, FLT_MAX) != within_by_definition(-atmax, FLT_MAX);
        differ += num_within(at0, 0.0f) != within_by_definition(at0, 0.0f);
        differ += num_within(at0, 1e-45f) != within_by_definition(at0, 1e-45f);
    }
    for (unsigned k = 0; k < 1000000u; k++) {
        const float a = float_of_bits((uint32_t)xorshift64(&s));
        differ += num_within(a, 0.0f) != within_by_definition(a, 0.0f);
        differ += num_within(a, 1e-45f) != within_by_definition(a, 1e-45f);
        differ += num_within(a, 2.0f) != within_by_definition(a, 2.0f);
        differ += num_within(a, 10000.0f) != within_by_definition(a, 10000.0f);
        differ += num_within(a, FLT_MAX) != within_by_definition(a, FLT_MAX);
        differ += num_within(a, -0.0f) != within_by_definition(a, -0.0f);
        differ += num_within(a, INFINITY) != within_by_definition(a, INFINITY);
    }
    (void)feclearexcept(FE_ALL_EXCEPT);
    (void)fesetenv(&env);
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}
#else
/* Fixed mode: every Q16.16 value is a finite number. */
static void test_num_every_fixed_value_is_finite(void)
{
    TEST_ASSERT_TRUE(num_is_finite(NUM_MAX));
    TEST_ASSERT_TRUE(num_is_finite(num_neg(NUM_MAX)));
    TEST_ASSERT_TRUE(num_is_finite(NUM_ZERO));
}

/* Issue 3: fixed-point helpers saturate, never wrap. 200·200 = 40000 and
 * 30000 + 30000 = 60000 exceed Q16.16's 32767.99998. */
static void test_num_fixed_overflow_saturates(void)
{
    TEST_ASSERT_TRUE(num_to_float(num_mul(tu_num(200.0), tu_num(200.0))) > 32767.0f);
    TEST_ASSERT_TRUE(num_to_float(num_mul(tu_num(200.0), tu_num(-200.0))) < -32767.0f);
    TEST_ASSERT_TRUE(num_to_float(num_add(tu_num(30000.0), tu_num(30000.0))) > 32767.0f);
    TEST_ASSERT_TRUE(num_to_float(num_sub(tu_num(-30000.0), tu_num(30000.0))) < -32767.0f);
}

/* Saturation at the exact edges (hand values): one code past NUM_MAX or
 * NUM_MIN saturates, landing exactly on it does not (−1 − NUM_MIN is
 * 2^31 − 1 codes = NUM_MAX, exact). num_within: |NUM_MIN| saturates to
 * NUM_MAX. */
static void test_num_fixed_add_sub_edges(void)
{
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_add(NUM_MAX, 1));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_add(NUM_MAX - 1, 1));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX - 1, num_add(NUM_MAX, -1));
    TEST_ASSERT_EQUAL_INT32(NUM_MIN, num_add(NUM_MIN, -1));
    TEST_ASSERT_EQUAL_INT32(NUM_MIN, num_add(NUM_MIN + 1, -1));
    TEST_ASSERT_EQUAL_INT32(-1, num_add(NUM_MIN, NUM_MAX));
    TEST_ASSERT_EQUAL_INT32(NUM_MIN, num_add(NUM_MIN, NUM_MIN));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_add(NUM_MAX, NUM_MAX));
    TEST_ASSERT_EQUAL_INT32(NUM_MIN, num_sub(NUM_MIN, 1));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_sub(NUM_MAX, -1));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_sub(0, NUM_MIN));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_sub(-1, NUM_MIN));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX - 1, num_sub(-2, NUM_MIN));
    TEST_ASSERT_EQUAL_INT32(NUM_MIN, num_sub(-2, NUM_MAX));
    TEST_ASSERT_EQUAL_INT32(NUM_MIN + 1, num_sub(0, NUM_MAX));
    TEST_ASSERT_EQUAL_INT32(NUM_MIN, num_sub(NUM_MIN, NUM_MAX));
    TEST_ASSERT_TRUE(num_within(NUM_MIN, NUM_MAX));
    TEST_ASSERT_FALSE(num_within(NUM_MIN, NUM_MAX - 1));
    TEST_ASSERT_TRUE(num_within(-NUM_ONE, NUM_ONE));
    TEST_ASSERT_FALSE(num_within(NUM_ONE + 1, NUM_ONE));
    /* num_within's one comparison (0 <= lim < NUM_MAX), at its edges: |a| =
     * lim passes, lim + 1 does not, on either side; NUM_MIN never does;
     * lim = 0 takes 0 alone; a negative lim takes nothing. */
    TEST_ASSERT_FALSE(num_within(-NUM_ONE - 1, NUM_ONE));
    TEST_ASSERT_TRUE(num_within(NUM_MAX - 1, NUM_MAX - 1));
    TEST_ASSERT_TRUE(num_within(NUM_MIN + 2, NUM_MAX - 1));
    TEST_ASSERT_FALSE(num_within(NUM_MIN + 1, NUM_MAX - 1));
    TEST_ASSERT_FALSE(num_within(NUM_MAX, NUM_MAX - 1));
    TEST_ASSERT_FALSE(num_within(NUM_MIN, NUM_MAX - 1));
    TEST_ASSERT_TRUE(num_within(NUM_MIN + 1, NUM_MAX));
    TEST_ASSERT_TRUE(num_within(0, 0));
    TEST_ASSERT_FALSE(num_within(1, 0));
    TEST_ASSERT_FALSE(num_within(-1, 0));
    TEST_ASSERT_FALSE(num_within(0, -1));
    TEST_ASSERT_FALSE(num_within(NUM_MIN, NUM_MIN));
}

/* num_mul is libfixmath's fix16_smul written inline: the same bits for every
 * pair (the reference is libfixmath itself, linked in fixed mode). The edges
 * ±2 around 0, ±1, ±0.5 LSB-scale values, the saturation thresholds and the
 * extremes, each with each; then products within ±3 codes of ±2^47 (where
 * fix16_mul's overflow test and its rounding meet), then random pairs, half
 * of them shifted down to small magnitudes. */
static void test_num_fixed_mul_is_libfixmath_smul(void)
{
    static const int32_t edge[] = { 0,        1,           2,           0x7FFF,       0x8000,
                                    0x10000,  0x10001,     0x00B504F3,  0x00B504F4,   181 << 16,
                                    1 << 23,  1 << 24,     INT32_MAX,   -1,           -0x8000,
                                    -0x10000, -0x00B504F3, -0x00B504F4, -(181 << 16), INT32_MIN };
    const size_t n_edge = sizeof edge / sizeof edge[0];
    char msg[64];
    unsigned long differ = 0;
    for (size_t i = 0; i < n_edge; i++) {
        for (size_t j = 0; j < n_edge; j++) {
            for (uint32_t d = 0; d < 5u; d++) {
                const int32_t a = (int32_t)((uint32_t)edge[i] + d - 2u);
                const int32_t b = (int32_t)((uint32_t)edge[j] - d + 2u);
                if (num_mul(a, b) != fix16_smul(a, b) && differ++ == 0u) {
                    snprintf(msg, sizeof msg, "a %ld b %ld", (long)a, (long)b);
                    TEST_FAIL_MESSAGE(msg);
                }
            }
        }
    }
    uint64_t s = 88172645463325252u;
    for (int k = 0; k < 100000; k++) {
        const int32_t a = (int32_t)(uint32_t)xorshift64(&s) | 1;
        const int32_t b0 = (int32_t)((INT64_C(1) << 47) / a);
        for (int32_t d = -3; d <= 3; d++) {
            const int32_t b1 = (int32_t)((uint32_t)b0 + (uint32_t)d);
            const int32_t b2 = (int32_t)(0u - (uint32_t)b1);
            differ += num_mul(a, b1) != fix16_smul(a, b1);
            differ += num_mul(a, b2) != fix16_smul(a, b2);
        }
    }
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t x = xorshift64(&s);
        int32_t a = (int32_t)(uint32_t)x;
        int32_t b = (int32_t)(uint32_t)(x >> 32);
        if ((k & 16u) != 0u) {
            a >>= k & 15u;
            b >>= 15u - (k & 15u);
        }
        differ += num_mul(a, b) != fix16_smul(a, b);
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* num_sq and num_sum_sq: the same bits as num_mul(a, a) and
 * num_add(num_mul(x, x), num_mul(y, y)) (num_mul: libfixmath's fix16_smul,
 * test above), and hand values: 2² = 4, (1 + 2^-16)² = 1 + 2^-15 (+ 2^-32,
 * rounded away), 181² = 32761 in range, 182² saturates, as does
 * 128² + 128². */
static void test_num_fixed_squares_are_mul_and_add(void)
{
    TEST_ASSERT_EQUAL_INT32(4 * NUM_ONE, num_sq(2 * NUM_ONE));
    TEST_ASSERT_EQUAL_INT32(4 * NUM_ONE, num_sq(-2 * NUM_ONE));
    TEST_ASSERT_EQUAL_INT32(NUM_ONE + 2, num_sq(NUM_ONE + 1));
    TEST_ASSERT_EQUAL_INT32(32761 * NUM_ONE, num_sq(181 * NUM_ONE));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_sq(182 * NUM_ONE));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_sq(NUM_MIN));
    TEST_ASSERT_EQUAL_INT32(25 * NUM_ONE, num_sum_sq(3 * NUM_ONE, -4 * NUM_ONE));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_sum_sq(128 * NUM_ONE, 128 * NUM_ONE));
    TEST_ASSERT_EQUAL_INT32(0, num_sum_sq(0, 0));
    uint64_t s = 7046029254386353131u;
    unsigned long differ = 0;
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t r = xorshift64(&s);
        const int32_t x = (int32_t)(uint32_t)r >> (k % 31u);
        const int32_t y = (int32_t)(uint32_t)(r >> 32) >> ((k / 31u) % 31u);
        differ += num_sq(x) != num_mul(x, x);
        differ += num_sum_sq(x, y) != num_add(num_mul(x, x), num_mul(y, y));
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* num_sq_small and num_sum_sq_small drop num_sq's saturation test for
 * |a| < 128, where it cannot fire: hand values at the largest such a,
 * 2^23 − 1 codes: a² = 2^46 − 2^24 + 1, rounded (+2^15, >> 16) to
 * 2^30 − 256, and twice that, 2^31 − 512, still below NUM_MAX (where 128²
 * + 128² saturates: test above); (1 + 2^-16)² = 1 + 2^-15. Then every a
 * with |a| < 128 against num_sq, and 10^6 random pairs against
 * num_sum_sq. */
static void test_num_fixed_small_squares_are_sq_and_sum_sq(void)
{
    const int32_t top = (1 << 23) - 1;
    TEST_ASSERT_EQUAL_INT32(1073741568, num_sq_small(top));
    TEST_ASSERT_EQUAL_INT32(1073741568, num_sq_small(-top));
    TEST_ASSERT_EQUAL_INT32(2147483136, num_sum_sq_small(top, -top));
    TEST_ASSERT_EQUAL_INT32(NUM_ONE + 2, num_sq_small(NUM_ONE + 1));
    unsigned long differ = 0;
    for (int32_t a = -top; a <= top; a++) {
        differ += num_sq_small(a) != num_sq(a);
    }
    uint64_t s = 1181783497276652981u;
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t r = xorshift64(&s);
        const int32_t x = (int32_t)(uint32_t)r >> (8u + k % 24u);
        const int32_t y = (int32_t)(uint32_t)(r >> 32) >> (8u + (k / 24u) % 24u);
        differ += num_sum_sq_small(x, y) != num_sum_sq(x, y);
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* num_below(a, lim) is num_abs(a) < lim for every a and lim: hand values at
 * the edges (|NUM_MIN| saturates to NUM_MAX, below no lim; NUM_MAX − 1 is
 * below NUM_MAX; 0 is below 1 code, 1 code is not), then each edge ±2 codes
 * with each, and 10^6 random pairs at every magnitude, against num_abs. */
static void test_num_fixed_below_is_abs_less_than(void)
{
    TEST_ASSERT_FALSE(num_below(NUM_MIN, NUM_MAX));
    TEST_ASSERT_FALSE(num_below(NUM_MAX, NUM_MAX));
    TEST_ASSERT_TRUE(num_below(NUM_MAX - 1, NUM_MAX));
    TEST_ASSERT_TRUE(num_below(-(NUM_MAX - 1), NUM_MAX));
    TEST_ASSERT_TRUE(num_below(0, 1));
    TEST_ASSERT_FALSE(num_below(1, 1));
    TEST_ASSERT_FALSE(num_below(-1, 1));
    TEST_ASSERT_FALSE(num_below(0, NUM_MIN));
    static const int32_t edge[] = { 0, 1, 2, 0x10000, 1 << 23, INT32_MAX, -1, -0x10000, INT32_MIN };
    const size_t n_edge = sizeof edge / sizeof edge[0];
    unsigned long differ = 0;
    for (size_t i = 0; i < n_edge; i++) {
        for (size_t j = 0; j < n_edge; j++) {
            for (uint32_t d = 0; d < 5u; d++) {
                for (uint32_t f = 0; f < 5u; f++) {
                    const int32_t a = (int32_t)((uint32_t)edge[i] + d - 2u);
                    const int32_t lim = (int32_t)((uint32_t)edge[j] + f - 2u);
                    differ += num_below(a, lim) != (num_abs(a) < lim);
                }
            }
        }
    }
    uint64_t s = 2685821657736338717u;
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t r = xorshift64(&s);
        const int32_t a = (int32_t)(uint32_t)r >> (k % 32u);
        const int32_t lim = (int32_t)(uint32_t)(r >> 32) >> ((k / 32u) % 32u);
        differ += num_below(a, lim) != (num_abs(a) < lim);
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* num_div is libfixmath's fix16_sdiv in closed form (num_fixed.c): the same
 * bits for every pair (the reference is libfixmath itself, linked in fixed
 * mode). The edges (0, ±1, the divisors where num_div changes method: 2^15,
 * 2^20 and libfixmath's estimate, the extremes) ±3 codes each with each;
 * quotients within a few codes of saturation; then random pairs with each
 * operand shifted down to every magnitude. */
static void test_num_fixed_div_is_libfixmath_sdiv(void)
{
    static const int32_t edge[] = { 0,         1,          16,        0x7FFF,      0x8000,
                                    0x10000,   0xFFFFF,    0x100000,  0x1FFFF,     0x20000,
                                    0x3FFFFFF, 0x40000000, INT32_MAX, -1,          -0x8000,
                                    -0x10000,  -0x100000,  -0x20000,  -0x40000000, INT32_MIN };
    const size_t n_edge = sizeof edge / sizeof edge[0];
    char msg[64];
    unsigned long differ = 0;
    for (size_t i = 0; i < n_edge; i++) {
        for (size_t j = 0; j < n_edge; j++) {
            for (uint32_t d = 0; d < 7u; d++) {
                for (uint32_t f = 0; f < 7u; f++) {
                    const int32_t a = (int32_t)((uint32_t)edge[i] + d - 3u);
                    const int32_t b = (int32_t)((uint32_t)edge[j] + f - 3u);
                    if (num_div(a, b) != fix16_sdiv(a, b) && differ++ == 0u) {
                        snprintf(msg, sizeof msg, "a %ld b %ld", (long)a, (long)b);
                        TEST_FAIL_MESSAGE(msg);
                    }
                }
            }
        }
    }
    uint64_t s = 1181783497276652981u;
    for (int k = 0; k < 200000; k++) {
        const uint64_t x = xorshift64(&s);
        const int32_t b = ((int32_t)(uint32_t)x >> (x >> 59)) | 1;
        /* a = q b / 2^16 for a quotient q within 2^8 codes of ±NUM_MAX. */
        const int64_t q = (INT32_MAX - (int64_t)((x >> 32) & 0xFFu)) * ((x & 2u) != 0u ? 1 : -1);
        const int64_t a = (q * b) / 65536;
        for (int64_t d = -2; d <= 2; d++) {
            if (a + d >= INT32_MIN && a + d <= INT32_MAX) {
                differ += num_div((int32_t)(a + d), b) != fix16_sdiv((int32_t)(a + d), b);
            }
        }
    }
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t x = xorshift64(&s);
        const int32_t a = (int32_t)(uint32_t)x >> (k % 31u);
        const int32_t b = (int32_t)(uint32_t)(x >> 32) >> ((k / 31u) % 31u);
        differ += num_div(a, b) != fix16_sdiv(a, b);
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* round(sqrt(s)) for s < 2^64 the slow, plain way, independent of
 * num_fixed.c: the floor root bit by bit (restoring, one result bit per
 * step), then up by one when s − f² > f: s and f² are integers, so that is
 * s − f² >= f + 1 > f + 1/4, i.e. s > (f + 1/2)² (never a tie). */
static uint32_t ref_sqrt_round(uint64_t s)
{
    uint64_t rem = s;
    uint64_t root = 0;
    for (uint64_t bit = UINT64_C(1) << 62; bit != 0u; bit >>= 2) {
        if (rem >= root + bit) {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
    }
    return (uint32_t)(rem > root ? root + 1u : root);
}

/* num_sqrt(a) = round(sqrt(a·2^16)), correctly rounded (num_fixed.h), against
 * the bit-by-bit reference: the edges (1, the codes around every power of
 * two, perfect squares, the codes at which the rounding turns,
 * s = r² ± r, and INT32_MAX), then random codes at every magnitude. */
static void test_num_fixed_sqrt_is_correctly_rounded(void)
{
    char msg[64];
    unsigned long differ = 0;
    for (uint32_t e = 0; e < 31u; e++) {
        for (int32_t d = -2; d <= 2; d++) {
            const int64_t a = ((int64_t)1 << e) + d;
            if (a > 0 && a <= INT32_MAX) {
                differ += (uint32_t)num_sqrt((num_t)a) != ref_sqrt_round((uint64_t)a << 16);
            }
        }
    }
    /* a·2^16 = r² ± r and ± 1 around it: a = (r² ± r)/2^16 for r a multiple of
     * 256 (then r² ± r is not a multiple of 2^16; take the codes either side). */
    for (uint32_t r = 256u; r < 11863283u; r += 256u * 97u) {
        const uint64_t r2 = (uint64_t)r * r;
        const uint64_t turns[] = { r2 - r, r2 + r, r2 };
        for (size_t i = 0; i < 3u; i++) {
            for (int32_t d = -1; d <= 1; d++) {
                const int64_t a = (int64_t)(turns[i] >> 16) + d;
                if (a > 0 && a <= INT32_MAX) {
                    const uint32_t got = (uint32_t)num_sqrt((num_t)a);
                    const uint32_t want = ref_sqrt_round((uint64_t)a << 16);
                    if (got != want && differ++ == 0u) {
                        snprintf(msg, sizeof msg, "a %lld: %lu, not %lu", (long long)a,
                                 (unsigned long)got, (unsigned long)want);
                        TEST_FAIL_MESSAGE(msg);
                    }
                }
            }
        }
    }
    differ += (uint32_t)num_sqrt(NUM_MAX) != ref_sqrt_round((uint64_t)NUM_MAX << 16);
    TEST_ASSERT_EQUAL_UINT32(11863283u, (uint32_t)num_sqrt(NUM_MAX)); /* 181.02·2^16 */
    TEST_ASSERT_EQUAL_INT32(256, num_sqrt(1));                        /* sqrt(2^16) */
    TEST_ASSERT_EQUAL_INT32(NUM_ONE, num_sqrt(NUM_ONE));              /* 1 */
    TEST_ASSERT_EQUAL_INT32(2 * NUM_ONE, num_sqrt(4 * NUM_ONE));
    uint64_t s = 2463534242u;
    for (unsigned k = 0; k < 1000000u; k++) {
        const int32_t a = (int32_t)((uint32_t)xorshift64(&s) >> 1 >> (k % 31u));
        if (a > 0) {
            differ += (uint32_t)num_sqrt(a) != ref_sqrt_round((uint64_t)a << 16);
        }
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* num_hypot(x, y) = round(sqrt(x² + y²)) from the exact 64-bit sum,
 * saturated (num_fixed.h), against the bit-by-bit reference: the extremes,
 * then random pairs at every magnitude. */
/* num_mul_period in Q16.16, by hand: 0.4 is 26214.4 codes, so 26214, where
 * num_mul(20, 0.02) multiplies 0.02's code 1311 (1310.72 rounded) and
 * gives 26220; −0.099999 is −6553.53 codes: −6554. Then 10^6 random
 * pairs against the product formed in double (a below 2^31 codes, us
 * below 10^6, both exact in double; the product a·us/10^6 in codes to
 * within 2^-20): within 0.5 code of the exact product, plus |a| 2^-32 codes
 * (num_fixed.h), plus the double's own 2^-20. */
static void test_num_fixed_mul_period_is_rounded_from_microseconds(void)
{
    TEST_ASSERT_EQUAL_INT32(26214, num_mul_period(NUM_C(20.0), NUM_C(0.02), 20000u));
    TEST_ASSERT_EQUAL_INT32(26220, num_mul(NUM_C(20.0), NUM_C(0.02)));
    TEST_ASSERT_EQUAL_INT32(-6554, num_mul_period(NUM_C(-3.0), NUM_C(0.033333), 33333u));
    TEST_ASSERT_EQUAL_INT32(0, num_mul_period(NUM_MAX, NUM_ZERO, 0u));
    unsigned long worse = 0;
    uint64_t s = 0x9E3779B97F4A7C15u;
    for (unsigned k = 0; k < 1000000u; k++) {
        const uint64_t r = xorshift64(&s);
        const int32_t a = (int32_t)(uint32_t)r >> (k % 24u);
        const uint32_t us = (uint32_t)(r >> 32) % 1000000u;
        const double exact = (double)a * (double)us / 1.0e6;
        const double err = fabs((double)num_mul_period(a, NUM_ZERO, us) - exact);
        const double bound = 0.5 + fabs((double)a) / 4294967296.0 + 1.0 / 1048576.0;
        worse += err > bound;
    }
    TEST_ASSERT_EQUAL_UINT32(0u, worse);
}

static void test_num_fixed_hypot_is_correctly_rounded(void)
{
    static const int32_t edge[] = { 0, 1, -1, 0x8000, 0x10000, 23170 << 16, INT32_MAX, INT32_MIN };
    unsigned long differ = 0;
    uint64_t s = 1442695040888963407u;
    for (unsigned k = 0; k < 1000064u; k++) {
        int32_t x;
        int32_t y;
        if (k < 64u) {
            x = edge[k % 8u];
            y = edge[k / 8u];
        } else {
            const uint64_t r = xorshift64(&s);
            x = (int32_t)(uint32_t)r >> (k % 32u);
            y = (int32_t)(uint32_t)(r >> 32) >> ((k / 32u) % 32u);
        }
        const uint64_t ax = x < 0 ? 0u - (uint64_t)(int64_t)x : (uint64_t)x;
        const uint64_t ay = y < 0 ? 0u - (uint64_t)(int64_t)y : (uint64_t)y;
        const uint32_t want = ref_sqrt_round(ax * ax + ay * ay);
        const num_t expected = want > (uint32_t)INT32_MAX ? NUM_MAX : (num_t)want;
        differ += num_hypot(x, y) != expected;
    }
    TEST_ASSERT_EQUAL_INT32(5 * NUM_ONE, num_hypot(3 * NUM_ONE, -4 * NUM_ONE));
    TEST_ASSERT_EQUAL_INT32(NUM_MAX, num_hypot(INT32_MIN, INT32_MIN));
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}
#endif

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_num_wrap_leaves_interior_angles_unchanged);
    RUN_TEST(test_num_wrap_maps_pi_to_pi);
    RUN_TEST(test_num_wrap_maps_minus_pi_to_plus_pi);
    RUN_TEST(test_num_wrap_odd_multiples_of_pi_land_on_the_seam);
    RUN_TEST(test_num_wrap_reduces_by_whole_turns);
    RUN_TEST(test_num_wrap_large_angles);
    RUN_TEST(test_num_wrap_sweep_stays_in_range_and_keeps_the_angle);
    RUN_TEST(test_num_wrap_near_odd_multiples_of_pi_stays_in_range);
    RUN_TEST(test_num_atan2_four_quadrants);
    RUN_TEST(test_num_atan2_axes);
    RUN_TEST(test_num_hypot_known_triangles);
    RUN_TEST(test_num_hypot_across_a_100_m_field_and_beyond);
    RUN_TEST(test_num_sqrt_values_and_negative_input);
    RUN_TEST(test_num_norm_small_is_the_root_of_the_squares);
    RUN_TEST(test_num_min_max_pick_the_right_operand);
    RUN_TEST(test_num_clamp_limits_and_passes_through);
    RUN_TEST(test_num_arithmetic_hand_values);
    RUN_TEST(test_num_mul_period_hand_values);
    RUN_TEST(test_num_sin_cos_hand_values);
    RUN_TEST(test_num_sincos_is_sin_and_cos);
    RUN_TEST(test_num_conversions_round_trip);
    RUN_TEST(test_num_below_and_small_squares_hand_values);
    RUN_TEST(test_num_any_nonzero_is_a_or_b_not_zero);
#ifndef NUM_FIXED
    RUN_TEST(test_num_is_finite_rejects_nan_and_inf);
    RUN_TEST(test_num_within_is_finite_and_in_range);
    RUN_TEST(test_num_within_is_its_definition);
#else
    RUN_TEST(test_num_every_fixed_value_is_finite);
    RUN_TEST(test_num_fixed_overflow_saturates);
    RUN_TEST(test_num_fixed_add_sub_edges);
    RUN_TEST(test_num_fixed_mul_is_libfixmath_smul);
    RUN_TEST(test_num_fixed_squares_are_mul_and_add);
    RUN_TEST(test_num_fixed_small_squares_are_sq_and_sum_sq);
    RUN_TEST(test_num_fixed_below_is_abs_less_than);
    RUN_TEST(test_num_fixed_div_is_libfixmath_sdiv);
    RUN_TEST(test_num_fixed_sqrt_is_correctly_rounded);
    RUN_TEST(test_num_fixed_hypot_is_correctly_rounded);
    RUN_TEST(test_num_fixed_mul_period_is_rounded_from_microseconds);
#endif
    return UNITY_END();
}
