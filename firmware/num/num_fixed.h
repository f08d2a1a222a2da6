/* SPDX-License-Identifier: MIT */
/**
 * @file num_fixed.h
 * @brief Fixed mode of num.h (`-DNUM_FIXED`): `num_t` is signed Q16.16.
 *        Include num.h, not this file.
 *
 * Representation: a num_t `a` holds the real value a / 2^16.
 * - Range: [-32768, 32768 - 2^-16] = [NUM_MIN, NUM_MAX].
 * - Resolution (1 LSB): 2^-16 = 1.52587890625e-5 (15.3 µm, 15.3 µrad).
 * - Overflow: every operation saturates to NUM_MIN or NUM_MAX; none wraps.
 *   There is no NaN and no infinity: num_is_finite() is true for every value.
 *
 * Who computes what (see docs/numerics.md for the measured errors, and
 * tools/numerics/ for the tool that measures them):
 * - add, sub, neg, abs, conversions, wrap: here and in num_fixed.c;
 * - div: num_fixed.c, the same bits as libfixmath's fix16_sdiv (rounding,
 *   saturation) in closed form; libfixmath is built from its source with the
 *   configuration below for the host and for every cross build alike, and is
 *   the reference of num_mul and num_div in the tests;
 * - mul: here, inline, the same bits as libfixmath's fix16_smul (64-bit
 *   product, rounding, saturation) in that configuration;
 * - sqrt, hypot, sin, cos, atan2: num_fixed.c. libfixmath's versions were
 *   measured and fall short: its sin/cos are off by up to 7.8e-3 (509 LSB)
 *   near ±π (the x^11 term of its series overflows Q16.16), its atan2 by
 *   1.0e-2 rad (a cubic), it has no hypot, and its sqrt, correctly rounded,
 *   takes almost four times the instructions of num_sqrt on a Cortex-M3 (178
 *   against 46).
 *   Figures: docs/numerics.md and docs/performance.md.
 *
 * libfixmath configuration (mk/numeric.mk, the same for every build):
 * FIXMATH_NO_CACHE (its sin and atan2 caches take 80 KiB of RAM, and make
 * the time of a call depend on the calls before it); rounding on (FIXMATH_NO_ROUNDING unset: mul
 * and div round to nearest); overflow detection on (FIXMATH_NO_OVERFLOW unset: needed by the
 * saturating fix16_smul/fix16_sdiv); 64-bit multiply (FIXMATH_NO_64BIT unset: a Cortex-M3 has
 * SMULL); FIXMATH_FAST_SIN and FIXMATH_SIN_LUT unset (their sin is not used).
 */
#ifndef MSTC_NUM_FIXED_H
#define MSTC_NUM_FIXED_H

#include <stdbool.h>
#include <stdint.h>

/** @brief Q16.16: value = raw / 65536. */
typedef int32_t num_t;

/** @brief Name of the numeric mode, for logs and reports. */
#define NUM_MODE_NAME "fixed"

/** @brief Fractional bits of num_t. */
#define NUM_FRAC_BITS 16

/**
 * @brief A compile-time constant from a literal or constant expression:
 *        rounded to the nearest Q16.16 value (ties away from zero) and
 *        saturated to [NUM_MIN, NUM_MAX]. The double arithmetic is folded by
 *        the compiler; no double reaches the code.
 */
#define NUM_C(x)                                                                                   \
    ((num_t)((x) >= 32767.9999847412109375                                                         \
                 ? 2147483647.0                                                                    \
                 : ((x) <= -32768.0 ? -2147483648.0                                                \
                                    : ((x) >= 0 ? (x)*65536.0 + 0.5 : (x)*65536.0 - 0.5))))

#define NUM_ZERO   ((num_t)0)
#define NUM_ONE    ((num_t)65536)
/** @brief round(π·2^16) = 205887 = 3.14158630, 6.35e-6 (0.42 LSB) below π:
 *         the largest Q16.16 value <= π. −NUM_PI is likewise above −π. */
#define NUM_PI     ((num_t)205887)
/** @brief round(2π·2^16) = 411775 = 6.28318787, 2.56e-6 (0.17 LSB) above 2π. */
#define NUM_TWO_PI ((num_t)411775)
/** @brief Largest value, 32768 − 2^-16. */
#define NUM_MAX    ((num_t)INT32_MAX)
/** @brief Smallest value, −32768. */
#define NUM_MIN    ((num_t)INT32_MIN)

/**
 * @brief a + b, saturated to [NUM_MIN, NUM_MAX]. Exact when in range.
 */
static inline num_t num_add(num_t a, num_t b)
{
#if defined(__GNUC__)
    /* The processor's overflow flag (ADDS, BVS on a Cortex-M: 2 instructions
     * where the test below takes 5); the same test. */
    num_t s;
    const bool overflow = __builtin_add_overflow(a, b, &s);
    if (overflow) {
        return a < 0 ? NUM_MIN : NUM_MAX;
    }
    return s;
#else
    /* Unsigned sum wraps by definition; overflow happened when a and b have
     * the same sign and the sum has the other. */
    const uint32_t s = (uint32_t)a + (uint32_t)b;
    if ((int32_t)((s ^ (uint32_t)a) & (s ^ (uint32_t)b)) < 0) {
        return a < 0 ? NUM_MIN : NUM_MAX;
    }
    return (num_t)s;
#endif
}

/**
 * @brief a − b, saturated to [NUM_MIN, NUM_MAX]. Exact when in range.
 */
static inline num_t num_sub(num_t a, num_t b)
{
#if defined(__GNUC__)
    num_t d; /* as num_add */
    const bool overflow = __builtin_sub_overflow(a, b, &d);
    if (overflow) {
        return a < 0 ? NUM_MIN : NUM_MAX;
    }
    return d;
#else
    const uint32_t d = (uint32_t)a - (uint32_t)b;
    if ((int32_t)((d ^ (uint32_t)a) & ((uint32_t)a ^ (uint32_t)b)) < 0) {
        return a < 0 ? NUM_MIN : NUM_MAX;
    }
    return (num_t)d;
#endif
}

/** @brief −a; −NUM_MIN saturates to NUM_MAX. Exact otherwise. */
static inline num_t num_neg(num_t a) { return a == NUM_MIN ? NUM_MAX : -a; }

/** @brief |a|; |NUM_MIN| saturates to NUM_MAX. Exact otherwise. */
static inline num_t num_abs(num_t a) { return a < 0 ? num_neg(a) : a; }

/* libfixmath (deps/libfixmath/fix16.c), declared here so that users of num.h
 * do not see its header, which is not clean under -Wconversion. num_fixed.c
 * includes fix16.h, so the compiler checks that these declarations match.
 * They are the references of num_mul and num_div in the tests. */
int32_t fix16_smul(int32_t inArg0, int32_t inArg1);
int32_t fix16_sdiv(int32_t inArg0, int32_t inArg1);

/**
 * @brief a · b, rounded to nearest (ties away from zero), saturated to
 *        [NUM_MIN, NUM_MAX]. Error ≤ 0.5 LSB when in range.
 *
 * The same bits as libfixmath's fix16_smul (64-bit build with rounding and
 * overflow detection, the configuration of mk/numeric.mk) for every pair of
 * inputs, inline: on a Cortex-M3 the call and fix16_mul's separate overflow
 * and rounding branches cost more than the product. fix16_mul rounds the
 * exact product p by floor((p − [p < 0])/2^16) + bit 15 of (p − [p < 0]),
 * which is floor((p + 2^15 − [p < 0])/2^16); fix16_smul saturates every
 * result outside [NUM_MIN, NUM_MAX] and, for p < 0, also the products below
 * −2^47 whose rounded value is NUM_MIN anyway. So a clamp of the rounded
 * 64-bit value gives its result (checked against fix16_smul on the edges and
 * 1.7·10^6 pairs in tests/unit/test_num.c, and on 1.3·10^8 when it was
 * written).
 */
static inline num_t num_mul(num_t a, num_t b)
{
    const int64_t p = (int64_t)a * b;
    const int64_t r = (p + (p < 0 ? INT64_C(0x7FFF) : INT64_C(0x8000))) >> 16;
    if (r > INT32_MAX) {
        return NUM_MAX;
    }
    if (r < INT32_MIN) {
        return NUM_MIN;
    }
    return (num_t)r;
}

/* a², rounded, unsaturated: (a² + 2^15) >> 16, at most 2^46. The product is
 * never negative, so num_mul's rounding adds 2^15. */
static inline uint64_t num_sq_wide(num_t a)
{
    return ((uint64_t)((int64_t)a * a) + UINT64_C(0x8000)) >> 16;
}

/** @brief a², the same bits as num_mul(a, a): only the upper saturation can
 *         apply. */
static inline num_t num_sq(num_t a)
{
    const uint64_t r = num_sq_wide(a);
    return r > (uint64_t)INT32_MAX ? NUM_MAX : (num_t)r;
}

/**
 * @brief x² + y², the same bits as num_add(num_mul(x, x), num_mul(y, y)):
 *        both squares are >= 0, so saturating each and then their sum is
 *        saturating the exact sum of the rounded squares once.
 */
static inline num_t num_sum_sq(num_t x, num_t y)
{
    const uint64_t r = num_sq_wide(x) + num_sq_wide(y);
    return r > (uint64_t)INT32_MAX ? NUM_MAX : (num_t)r;
}

/**
 * @brief num_sq(a) for |a| < 128 (not checked): the same bits, without the
 *        saturation test, which cannot fire there: |a| <= 2^23 − 1 codes, so
 *        a² <= 2^46 − 2^24 + 1 and the rounded square is below 2^30 − 255.
 */
static inline num_t num_sq_small(num_t a) { return (num_t)(uint32_t)num_sq_wide(a); }

/**
 * @brief num_sum_sq(x, y) for |x|, |y| < 128 (not checked): the same bits in
 *        32-bit arithmetic after the products (each rounded square below
 *        2^30 − 255, as num_sq_small's, so their sum is below 2^31 and is
 *        never saturated).
 */
static inline num_t num_sum_sq_small(num_t x, num_t y)
{
    return (num_t)((uint32_t)num_sq_wide(x) + (uint32_t)num_sq_wide(y));
}

/**
 * @brief a / b, rounded to nearest as libfixmath's fix16_sdiv rounds,
 *        saturated to [NUM_MIN, NUM_MAX]: the same bits as fix16_sdiv (in
 *        the configuration of mk/numeric.mk) for every pair of inputs.
 *        Error ≤ 0.56 LSB when in range (measured, docs/numerics.md:
 *        libfixmath's first estimate for |b| >= 16 costs a little over the
 *        0.5 of rounding). b == 0 gives NUM_MAX for a >= 0 and NUM_MIN for
 *        a < 0. num_fixed.c derives the closed form it computes from
 *        fix16_div's steps; on a Cortex-M3 it takes fewer instructions than
 *        fix16_div's loop of 32-bit divisions.
 */
num_t num_div(num_t a, num_t b);

/**
 * @brief a · dt for a period dt of @p us microseconds (@p us < 10^6), rounded
 *        to nearest: error <= 0.5 LSB + |a| 2^-32 (0.52 LSB for |a| <= 1000).
 *        @p dt is the period as num_t and is not used here: a period of whole
 *        microseconds is rarely a whole number of codes (0.02 s is 1310.72,
 *        held as 1311: 2.1e-4 too long), and a · dt carries that error times
 *        a (20 rad/s² × 0.02 s gives 0.40009, 5.6 LSB above 0.4); from the
 *        microseconds the product is as exact as the result can be. Float
 *        mode multiplies a by dt.
 */
num_t num_mul_period(num_t a, num_t dt, uint32_t us);

/**
 * @brief Square root, rounded to nearest: error ≤ 0.5 LSB over the whole
 *        range (exact integer square root of a·2^16). Negative input gives 0.
 *        Range of the result: [0, 181.02].
 */
num_t num_sqrt(num_t a);

/**
 * @brief sqrt(x² + y²), rounded to nearest (error ≤ 0.5 LSB), from the exact
 *        64-bit sum of squares: no intermediate overflow for any inputs. The
 *        result saturates to NUM_MAX only when the true value exceeds it
 *        (e.g. |x| = |y| > 23170), far outside a 100 m × 100 m field, whose
 *        largest distance is 141.5.
 */
num_t num_hypot(num_t x, num_t y);

/**
 * @brief Sine, any input. The argument is reduced by the nearest multiple
 *        of π/2 (held to 2^-32), then a polynomial is evaluated in Q2.30.
 *        Error ≤ 0.52 LSB for |a| ≤ 4π, ≤ 0.6 LSB at |a| = 32768
 *        (docs/numerics.md). Result in [−1, 1].
 */
num_t num_sin(num_t a);

/** @brief Cosine; as num_sin(). */
num_t num_cos(num_t a);

/**
 * @brief Sine and cosine of one angle: *s = num_sin(a), *c = num_cos(a), the
 *        same bits, with the argument reduced once.
 */
void num_sincos(num_t a, num_t *s, num_t *c);

/**
 * @brief atan2(y, x) in [−NUM_PI, NUM_PI] (within (−π, π]), any inputs: the
 *        ratio min/max is formed to 32 bits after normalisation, so nothing
 *        overflows and small vectors lose nothing. Error ≤ 0.52 LSB.
 *        atan2(0, 0) = 0; atan2(0, x < 0) = NUM_PI.
 */
num_t num_atan2(num_t y, num_t x);

/** @brief Always true: every Q16.16 value is finite. */
static inline bool num_is_finite(num_t a)
{
    (void)a;
    return true;
}

/**
 * @brief num_is_finite(a) && num_abs(a) <= lim: |a| <= lim here.
 *
 * For 0 <= lim < NUM_MAX (every range check of the controllers: a constant
 * lim folds the test away) it is −lim <= a <= lim (num_abs(NUM_MIN) =
 * NUM_MAX > lim, and NUM_MIN < −lim), which is one unsigned comparison:
 * a ↦ a + lim modulo 2^32 takes [−lim, lim] onto [0, 2 lim] and, as
 * 2 lim < 2^32, every other a above it. The same result for every a and lim
 * (checked over all 2^32 values of a for lim = 0, 1, NUM_MAX − 1, NUM_MAX,
 * −1 and others when it was written).
 */
static inline bool num_within(num_t a, num_t lim)
{
    if (lim >= 0 && lim < NUM_MAX) {
        return (uint32_t)a + (uint32_t)lim <= 2u * (uint32_t)lim;
    }
    return num_abs(a) <= lim;
}

/** @brief a != 0 || b != 0, in one test. */
static inline bool num_any_nonzero(num_t a, num_t b) { return (a | b) != 0; }

/**
 * @brief num_abs(a) < lim, the same result for every a and lim: false for
 *        lim <= 0; else |a| <= lim − 1, num_within's one comparison for a
 *        constant lim (num_abs(NUM_MIN) = NUM_MAX is not below any lim).
 */
static inline bool num_below(num_t a, num_t lim) { return lim > 0 && num_within(a, lim - 1); }

/**
 * @brief Angle wrapped into (−π, π] as float mode does it: the result lies in
 *        (−NUM_PI, NUM_PI], the codes −205886 … 205887.
 *
 * Identity on (−NUM_PI, NUM_PI]. Otherwise the real value a/2^16 is reduced
 * by the multiple of 2π (held to 2^-32) that brings it into (−π, π] and
 * rounded to the nearest code: error modulo 2π ≤ 0.5 LSB (+ 0.04 LSB at
 * |a| = 32768). The seam: −NUM_PI (−π + 0.42 LSB) is returned as NUM_PI
 * (π − 0.42 LSB), like float mode's wrap(−NUM_PI) = NUM_PI, so num.h's range
 * is the same in both modes; for the inputs that reduce to within 0.92 LSB
 * above −π, this costs up to 1.33 LSB modulo 2π (docs/numerics.md).
 * Constant time: no loop over periods.
 */
num_t num_wrap(num_t a);

/**
 * @brief Conversion from float: round to nearest (ties away from zero),
 *        saturated to [NUM_MIN, NUM_MAX]; ±inf saturates, NaN gives 0.
 *        The controllers never call it (float arithmetic: soft float on a
 *        Cortex-M3); the host side, the tests and parameter updates do.
 */
static inline num_t num_from_float(float f)
{
    if (!(f == f)) {
        return NUM_ZERO; /* NaN */
    }
    if (f >= 32768.0f) {
        return NUM_MAX;
    }
    if (f < -32768.0f) {
        return NUM_MIN;
    }
    /* f·2^16 is exact in float (a power-of-two scale) and lies in
     * [−2^31, 2^31); so do i and v − i. Adding 0.5f to v instead would round
     * twice for |v| >= 2^23. */
    const float v = f * 65536.0f;
    int32_t i = (int32_t)v; /* truncates toward zero */
    const float frac = v - (float)i;
    if (frac >= 0.5f) {
        i++;
    } else if (frac <= -0.5f) {
        i--;
    }
    return i;
}

/**
 * @brief Conversion to float: a / 2^16 rounded to float's 24-bit significand
 *        (exact for |a| < 256).
 */
static inline float num_to_float(num_t a) { return (float)a * (1.0f / 65536.0f); }

/** @brief Conversion from an integer, saturated to [−32768, 32767]. */
static inline num_t num_from_int(int32_t i)
{
    if (i > 32767) {
        return NUM_MAX;
    }
    if (i < -32768) {
        return NUM_MIN;
    }
    return (num_t)(i * 65536);
}

#endif /* MSTC_NUM_FIXED_H */
