/* SPDX-License-Identifier: MIT */
/**
 * @file test_util.h
 * @brief Helpers shared by the Unity tests of the firmware modules.
 *
 * The same tests build in float mode and in fixed mode (`-DNUM_FIXED`,
 * Q16.16). So a test never compares num_t values with a float assertion
 * directly: it converts with num_to_float() and compares in double against an
 * expected value that comes from a hand derivation or from an independent
 * closed form evaluated in double with libm.
 *
 * Tolerances are named constants in each test file, written with TU_TOL(float
 * value, fixed value) and a one-line justification beside each.
 */
#ifndef MSTC_TEST_UTIL_H
#define MSTC_TEST_UTIL_H

#include <fenv.h>
#include <math.h>
#include <stdint.h>

#include "ctrl/pose.h"
#include "num/num.h"
#include "unity.h"

/* glibc's feenableexcept() is a GNU extension, hidden by the -std=c11 the
 * tests build with; declared here rather than defining _GNU_SOURCE for every
 * file that includes this header. */
extern int feenableexcept(int excepts);
extern int fedisableexcept(int excepts);

/**
 * @brief Trap the floating-point exceptions that mean a computation went
 *        wrong (invalid operation, division by zero, overflow), before main()
 *        runs, in every test binary that includes this header: the firmware
 *        must never raise them (docs/safety.md). A trapped one ends the test
 *        binary with SIGFPE, which tools/run-unit-tests reports as a failure.
 *        Underflow and inexact are normal and stay untrapped.
 */
__attribute__((constructor, used)) static void tu_trap_fp_exceptions(void)
{
    (void)feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
}

/** @brief π and 2π in double, for the tests' own reference computations. */
#define TU_PI     3.14159265358979323846
#define TU_TWO_PI 6.28318530717958647692

/** @brief A tolerance with one value per numeric mode. */
#ifdef NUM_FIXED
#define TU_TOL(float_value, fixed_value) (fixed_value)
#else
#define TU_TOL(float_value, fixed_value) (float_value)
#endif

/** @brief A num_t input built from a double (through float, as firmware inputs are). */
static inline num_t tu_num(double x) { return num_from_float((float)x); }

/** @brief The value of a num_t, in double. */
static inline double tu_dbl(num_t a) { return (double)num_to_float(a); }

/**
 * @brief The value an input @p x really holds once converted to num_t.
 *        Reference computations use it, so that tolerances cover the code's
 *        arithmetic and not the rounding of the test's own inputs.
 */
static inline double tu_q(double x) { return tu_dbl(tu_num(x)); }

/** @brief A pose from doubles. */
static inline pose_t tu_pose(double x, double y, double theta)
{
    pose_t p;
    p.x = tu_num(x);
    p.y = tu_num(y);
    p.theta = tu_num(theta);
    return p;
}

/** @brief Reference angle wrap into (-π, π], in double (libm remainder). */
static inline double tu_wrap(double a)
{
    double r = remainder(a, TU_TWO_PI); /* in [-π, π] */
    if (r <= -TU_PI) {
        r += TU_TWO_PI;
    }
    return r;
}

/**
 * @brief Assert that num_t @p actual equals double @p expected within @p tol.
 *        A NaN or infinite @p actual always fails.
 */
#define TEST_ASSERT_NUM_WITHIN(tol, expected, actual)                                              \
    TEST_ASSERT_DOUBLE_WITHIN((double)(tol), (double)(expected), tu_dbl(actual))
#define TEST_ASSERT_NUM_WITHIN_MESSAGE(tol, expected, actual, msg)                                 \
    TEST_ASSERT_DOUBLE_WITHIN_MESSAGE((double)(tol), (double)(expected), tu_dbl(actual), (msg))

/**
 * @brief Assert that angle @p actual (num_t, rad) equals @p expected (double)
 *        modulo 2π within @p tol: for results that may legitimately come out
 *        as π or -π (the seam), or that any multiple of 2π would satisfy.
 */
#define TEST_ASSERT_ANGLE_WITHIN(tol, expected, actual)                                            \
    TEST_ASSERT_DOUBLE_WITHIN((double)(tol), 0.0, tu_wrap(tu_dbl(actual) - (double)(expected)))
#define TEST_ASSERT_ANGLE_WITHIN_MESSAGE(tol, expected, actual, msg)                               \
    TEST_ASSERT_DOUBLE_WITHIN_MESSAGE((double)(tol), 0.0,                                          \
                                      tu_wrap(tu_dbl(actual) - (double)(expected)), (msg))

/** @brief Assert that angle @p a (num_t) lies in (-π, π] as num.h defines it. */
#define TEST_ASSERT_NUM_ANGLE_IN_RANGE(a)                                                          \
    TEST_ASSERT_TRUE_MESSAGE((a) > num_neg(NUM_PI) && (a) <= NUM_PI, "angle outside (-pi, pi]")
#define TEST_ASSERT_NUM_ANGLE_IN_RANGE_MESSAGE(a, msg)                                             \
    TEST_ASSERT_TRUE_MESSAGE((a) > num_neg(NUM_PI) && (a) <= NUM_PI, (msg))

#endif /* MSTC_TEST_UTIL_H */
