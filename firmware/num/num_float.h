/* SPDX-License-Identifier: MIT */
/**
 * @file num_float.h
 * @brief Float mode of num.h: `num_t` is IEEE-754 single precision. Include
 *        num.h, not this file.
 *
 * Range and resolution are those of `float` (24-bit significand); overflow
 * gives ±inf, which the controllers never produce from finite inputs in range
 * (their entry points reject non-finite values, see ctl.h).
 */
#ifndef MSTC_NUM_FLOAT_H
#define MSTC_NUM_FLOAT_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

typedef float num_t;

/* The bit pattern of @p a (IEEE-754 binary32), read through a union: C11
 * reinterprets the bytes of the member written (6.5.2.3, note 95). For the
 * integer tests of num_within() and num_any_nonzero(). */
static inline uint32_t num_bits(num_t a)
{
    const union {
        num_t f;
        uint32_t u;
    } v = { .f = a };
    return v.u;
}

/** @brief Name of the numeric mode, for logs and reports. */
#define NUM_MODE_NAME "float"

/** @brief A compile-time constant from a literal or constant expression. */
#define NUM_C(x) ((num_t)(x))

#define NUM_ZERO   NUM_C(0.0)
#define NUM_ONE    NUM_C(1.0)
/** @brief float(π): 3.14159274, just above π. */
#define NUM_PI     NUM_C(3.14159265358979323846)
#define NUM_TWO_PI NUM_C(6.28318530717958647692)
/** @brief Largest finite value. */
#define NUM_MAX    NUM_C(3.40282347e+38)

static inline num_t num_add(num_t a, num_t b) { return a + b; }
static inline num_t num_sub(num_t a, num_t b) { return a - b; }
static inline num_t num_neg(num_t a) { return -a; }
static inline num_t num_mul(num_t a, num_t b) { return a * b; }
/** @brief a², as num_mul(a, a). */
static inline num_t num_sq(num_t a) { return a * a; }
/** @brief x² + y², as num_add(num_mul(x, x), num_mul(y, y)). */
static inline num_t num_sum_sq(num_t x, num_t y) { return x * x + y * y; }
/** @brief num_sq(a) for |a| < 128: the same expression (fixed mode drops a
 *         saturation test there). */
static inline num_t num_sq_small(num_t a) { return a * a; }
/** @brief num_sum_sq(x, y) for |x|, |y| < 128: the same expression. */
static inline num_t num_sum_sq_small(num_t x, num_t y) { return x * x + y * y; }
/** @brief a / b; b == 0 gives ±inf or NaN: callers guard against it. */
static inline num_t num_div(num_t a, num_t b) { return a / b; }
static inline num_t num_abs(num_t a) { return fabsf(a); }
/** @brief Square root; negative input gives 0. */
static inline num_t num_sqrt(num_t a) { return a > 0.0f ? sqrtf(a) : 0.0f; }
static inline num_t num_sin(num_t a) { return sinf(a); }
static inline num_t num_cos(num_t a) { return cosf(a); }
/** @brief Sine and cosine of one angle: *s = num_sin(a), *c = num_cos(a). */
static inline void num_sincos(num_t a, num_t *s, num_t *c)
{
    *s = sinf(a);
    *c = cosf(a);
}
/** @brief atan2(y, x) in [-π, π]; atan2(0, 0) = 0. */
static inline num_t num_atan2(num_t y, num_t x) { return atan2f(y, x); }
/** @brief sqrt(x² + y²) without intermediate overflow. */
static inline num_t num_hypot(num_t x, num_t y) { return hypotf(x, y); }
/** @brief true unless @p a is NaN or ±inf. */
static inline bool num_is_finite(num_t a) { return isfinite(a) != 0; }

/**
 * @brief num_is_finite(a) && num_abs(a) <= lim, for every a and lim (NaN,
 *        ±inf included), and quiet: no FE_INVALID for a NaN, as neither
 *        num_is_finite() nor the `<=` behind it raises one.
 *
 * One quiet comparison does both tests when lim < +inf: |a| <= lim is false
 * for a NaN a (unordered) and for an infinite a. Only lim = +inf needs the
 * finiteness test, and a constant lim removes it at compile time.
 *
 * For a lim of +0 up to the largest finite value (its sign bit clear, its
 * exponent not all ones: bits below 0x7F800000) that comparison is one of
 * integers: IEEE-754 orders the non-negative values as their bit patterns,
 * and a's with the sign bit cleared is |a|'s, above every such lim's when a
 * is infinite or NaN. The same result, with no floating-point comparison
 * (4 instructions a check on a Cortex-M4F where the FPU's compare, its flags'
 * transfer and the absolute value take 5, and no library call in soft
 * float); a constant lim folds the test of its bits away.
 */
static inline bool num_within(num_t a, num_t lim)
{
#if defined(__GNUC__) && !defined(__OPTIMIZE_SIZE__)
    const uint32_t ul = num_bits(lim);
    /* Only for a limit known at compile time: a variable one is tested as a
     * float (moving it to an integer register and testing its bits first
     * would cost more). Not under -Os (the board images): there GCC keeps
     * the callers' range checks out of line for the longer body, 145
     * instructions more a step on the STM32F405's image (make bench's board
     * rows), where the comparison below is as short. */
    if (__builtin_constant_p(ul) && ul < UINT32_C(0x7F800000)) {
        return (num_bits(a) & UINT32_C(0x7FFFFFFF)) <= ul;
    }
#endif
    return islessequal(fabsf(a), lim) && (isless(lim, INFINITY) || isfinite(a));
}

/**
 * @brief a != 0 || b != 0: a value is 0 exactly when its bits but the sign
 *        are (±0), so one integer test of both patterns shifted past their
 *        sign bits, with no floating-point comparison (a NaN is not 0 in
 *        either).
 */
static inline bool num_any_nonzero(num_t a, num_t b)
{
    return ((num_bits(a) | num_bits(b)) << 1) != 0u;
}

/** @brief a · dt, @p dt the period of @p us microseconds: a times dt here
 *         (fixed mode computes it from @p us, num_fixed.h). */
static inline num_t num_mul_period(num_t a, num_t dt, uint32_t us)
{
    (void)us;
    return a * dt;
}

/** @brief num_abs(a) < lim (false for a NaN). */
static inline bool num_below(num_t a, num_t lim) { return fabsf(a) < lim; }

/**
 * @brief Angle wrapped into (-π, π].
 * @param a angle [rad], finite.
 */
static inline num_t num_wrap(num_t a)
{
    if (a > NUM_PI || a <= -NUM_PI) {
        /* a - 2π·ceil((a - π)/2π) lies in (-π, π]; computed once, not by a
         * loop, so large inputs cost the same as small ones. */
        a = a - NUM_TWO_PI * ceilf((a - NUM_PI) / NUM_TWO_PI);
        if (a <= -NUM_PI) {
            a = NUM_PI;
        } else if (a > NUM_PI) {
            a = NUM_PI;
        }
    }
    return a;
}

/** @brief Conversion from float (exact in float mode). */
static inline num_t num_from_float(float f) { return f; }
/** @brief Conversion to float (exact in float mode). */
static inline float num_to_float(num_t a) { return a; }
/** @brief Conversion from a small integer. */
static inline num_t num_from_int(int32_t i) { return (num_t)i; }

#endif /* MSTC_NUM_FLOAT_H */
