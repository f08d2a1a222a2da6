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

/* The two views of a binary32, for num_bits() and num_of_bits(): C11
 * reinterprets the bytes of the member written (6.5.2.3, note 95). */
typedef union {
    num_t f;
    uint32_t u;
} num_pun_t;

/* The bit pattern of @p a (IEEE-754 binary32). For the integer tests of
 * num_within() and num_any_nonzero(). */
static inline uint32_t num_bits(num_t a)
{
    const num_pun_t v = { .f = a };
    return v.u;
}

/* The value of bit pattern @p u (num_bits() reversed). */
static inline num_t num_of_bits(uint32_t u)
{
    const num_pun_t v = { .u = u };
    return v.f;
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
/**
 * @brief Square root; negative input (or NaN) gives 0.
 *
 * On an FPU with a square root instruction (the Cortex-M4F) that
 * instruction, as sqrtf() itself gives: IEEE-754's correctly rounded root,
 * so the same bits. Called as sqrtf() the instruction is followed by a test
 * of its result for a NaN and a call to sqrtf() to set errno (GCC's
 * -fmath-errno), dead after a > 0: 4 instructions a root.
 */
static inline num_t num_sqrt(num_t a)
{
#if defined(__GNUC__) && defined(__ARM_FP) && (__ARM_FP & 4) != 0 && !defined(__SOFTFP__)
    if (a > 0.0f) {
        num_t r;
        __asm__("vsqrt.f32 %0, %1" : "=t"(r) : "t"(a));
        return r;
    }
    return 0.0f;
#else
    return a > 0.0f ? sqrtf(a) : 0.0f;
#endif
}
/**
 * @brief num_sqrt(a) for an @p a that is >= +0 and not NaN (a sum of squares
 *        of finite values: never −0), bit for bit: num_sqrt()'s test of the
 *        sign left out (3 instructions a root on a Cortex-M4F).
 */
static inline num_t num_sqrt_nonneg(num_t a)
{
#if defined(__GNUC__) && defined(__ARM_FP) && (__ARM_FP & 4) != 0 && !defined(__SOFTFP__)
    num_t r;
    __asm__("vsqrt.f32 %0, %1" : "=t"(r) : "t"(a));
    return r;
#else
    return num_sqrt(a);
#endif
}

/**
 * @brief sqrt(x² + y²) for finite |x|, |y| < 128: num_sqrt(num_sum_sq_small(x,
 *        y)), bit for bit (num_sqrt_nonneg()).
 */
static inline num_t num_norm_small(num_t x, num_t y)
{
    return num_sqrt_nonneg(num_sum_sq_small(x, y));
}
static inline num_t num_sin(num_t a) { return sinf(a); }
static inline num_t num_cos(num_t a) { return cosf(a); }
/* newlib's steps inline (num_hypot(), the reduction of num_sincos()): with
 * newlib on a single-precision FPU with fused multiply-add (the Cortex-M4F),
 * where they are written as that library is compiled; not when optimising
 * for size (the board images, -Os: each caller's copy of them would cost
 * 3.7 KB of the STM32F405's flash, make firmware-budget). */
#if defined(__NEWLIB__) && defined(__ARM_FEATURE_FMA) && defined(__ARM_FP) &&                      \
    (__ARM_FP & 4) != 0 && !defined(__SOFTFP__) && !defined(__OPTIMIZE_SIZE__)
#define NUM_NEWLIB_INLINE 1
#else
#define NUM_NEWLIB_INLINE 0
#endif

/* num_rem_pio2_quick() and num_hypot()'s inline steps below follow newlib's
 * fdlibm routines (ef_rem_pio2.c, e_hypotf.c) step for step, with their
 * constants; their notice, as those files give it:
 *
 * ====================================================
 * Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
 *
 * Developed at SunPro, a Sun Microsystems, Inc. business.
 * Permission to use, copy, modify, and distribute this
 * software is freely granted, provided that this notice
 * is preserved.
 * ====================================================
 *
 * (Conversion to float by Ian Lance Taylor, Cygnus Support.) */
#if defined(__NEWLIB__)
/* newlib's sinf() and cosf() (fdlibm's sf_sin.c, sf_cos.c) are the same three
 * steps: the angle reduced to y = a − nπ/2, |y| <= π/4 (as the pair y[0] +
 * y[1], by __ieee754_rem_pio2f(); none when |a| <= π/4 already), then
 * __kernel_sinf or __kernel_cosf of y by n's quadrant, negated in two
 * quadrants. num_sincos() below takes those steps itself, reducing once for
 * both. */
int32_t __ieee754_rem_pio2f(float x, float *y);
float __kernel_sinf(float x, float y, int iy);
float __kernel_cosf(float x, float y);

#if NUM_NEWLIB_INLINE
/* The first steps of __ieee754_rem_pio2f() (fdlibm's ef_rem_pio2.c) as its
 * library is compiled for the Cortex-M4F (fused multiply-adds included), for
 * |a| < 3π/4 (n = ±1) and for n up to NUM_RP_MEDIUM_N where its first
 * approximation stands: *n and y[0], y[1] as it gives them, and true; false
 * for every other angle (the library's call then). Its constants: π/2 in
 * parts of 24 bits (pio2_1 + pio2_1t, and pio2_1 + pio2_2 + pio2_2t), 2/π,
 * and the top 24 bits of nπ/2 (npio2_hw), whose match with the angle's asks
 * for its second approximation. */
#define NUM_RP_MEDIUM_N 4
static inline bool num_rem_pio2_quick(num_t a, uint32_t ix, int32_t *n, num_t *y0, num_t *y1)
{
    static const uint32_t npio2_hw[NUM_RP_MEDIUM_N] = { 0x3FC90F00u, 0x40490F00u, 0x4096CB00u,
                                                        0x40C90F00u };
    const num_t pio2_1 = num_of_bits(0x3FC90F80u);
    const num_t pio2_1t = num_of_bits(0x37354443u);
    const bool negative = (int32_t)num_bits(a) <= 0;
    if (ix <= UINT32_C(0x4016CBE3)) { /* |a| < 3π/4: n = ±1 */
        num_t z = negative ? a + pio2_1 : a - pio2_1;
        num_t t = pio2_1t;
        if ((ix & UINT32_C(0xFFFFFFF0)) == UINT32_C(0x3FC90FD0)) { /* near π/2: 72 bits */
            const num_t pio2_2 = num_of_bits(0x37354400u);
            z = negative ? z + pio2_2 : z - pio2_2;
            t = num_of_bits(0x2E85A308u); /* pio2_2t */
        }
        if (negative) {
            *y0 = z + t;
            *y1 = (z - *y0) + t;
            *n = -1;
        } else {
            *y0 = z - t;
            *y1 = (z - *y0) - t;
            *n = 1;
        }
        return true;
    }
    const num_t t = fabsf(a);
    const int32_t k = (int32_t)fmaf(t, num_of_bits(0x3F22F984u), 0.5f); /* |a| 2/π, rounded */
    if (k > NUM_RP_MEDIUM_N || (ix & UINT32_C(0xFFFFFF00)) == npio2_hw[k - 1]) {
        return false;
    }
    const num_t fn = (num_t)k;
    const num_t r = fmaf(-fn, pio2_1, t);
    const num_t w = fn * pio2_1t;
    const num_t r0 = r - w;
    const num_t r1 = (r - r0) - w;
    *y0 = negative ? -r0 : r0;
    *y1 = negative ? -r1 : r1;
    *n = negative ? -k : k;
    return true;
}
#endif
#endif

/**
 * @brief Sine and cosine of one angle: *s = num_sin(a), *c = num_cos(a), bit
 *        for bit.
 *
 * With newlib (the Cortex-M images) one argument reduction serves both: the
 * two calls reduce the angle twice (some 40 instructions each on a
 * Cortex-M4F, make bench); on the Cortex-M4F (NUM_NEWLIB_INLINE) the
 * reduction of the angles the controllers meet (|a| below 4.5 π/2, but near
 * a multiple of π/2) is inline too (num_rem_pio2_quick()). The same library steps on the same
 * values, so the same bits (make bench's `sincos_differs` checks it on the target); elsewhere (the
 * host's C library) the two calls.
 */
static inline void num_sincos(num_t a, num_t *s, num_t *c)
{
#if defined(__NEWLIB__)
    const uint32_t ix = num_bits(a) & UINT32_C(0x7FFFFFFF);
    if (ix <= UINT32_C(0x3F490FD8)) { /* |a| <= π/4: no reduction (nor quadrant) */
        *s = __kernel_sinf(a, 0.0f, 0);
        *c = __kernel_cosf(a, 0.0f);
        return;
    }
    if (ix >= UINT32_C(0x7F800000)) { /* ±inf or NaN: NaN */
        *s = a - a;
        *c = a - a;
        return;
    }
    float y[2];
    int32_t n;
#if NUM_NEWLIB_INLINE
    if (!num_rem_pio2_quick(a, ix, &n, &y[0], &y[1])) {
        n = __ieee754_rem_pio2f(a, y);
    }
#else
    n = __ieee754_rem_pio2f(a, y);
#endif
    const float ks = __kernel_sinf(y[0], y[1], 1);
    const float kc = __kernel_cosf(y[0], y[1]);
    switch (n & 3) {
    case 0:
        *s = ks;
        *c = kc;
        break;
    case 1:
        *s = kc;
        *c = -ks;
        break;
    case 2:
        *s = -ks;
        *c = -kc;
        break;
    default:
        *s = -kc;
        *c = ks;
        break;
    }
#else
    *s = sinf(a);
    *c = cosf(a);
#endif
}
/** @brief atan2(y, x) in [-π, π]; atan2(0, 0) = 0. */
static inline num_t num_atan2(num_t y, num_t x) { return atan2f(y, x); }

/**
 * @brief sqrt(x² + y²) without intermediate overflow: hypotf(x, y), bit for
 *        bit.
 *
 * With newlib on a Cortex-M4F (NUM_NEWLIB_INLINE) the arguments hypotf()
 * takes without scaling (its "medium" range: the larger below 2^50, the smaller at least 2^-50,
 * their ratio below 2^30; every distance the controllers take) are taken
 * here, inline: the same steps as newlib's __ieee754_hypotf() (fdlibm's
 * e_hypotf.c) as its library is compiled, fused multiply-adds included, then
 * the root, which cannot fail there (hypotf()'s errno test after it is
 * dead). The rest, and every other build, call hypotf(). make bench's
 * `hypot_differs` checks the bits on the target (some 10^6 pairs); the
 * call and its tests cost 49 instructions on average, this about 25.
 */
static inline num_t num_hypot(num_t x, num_t y)
{
#if NUM_NEWLIB_INLINE
    uint32_t ha = num_bits(x) & UINT32_C(0x7FFFFFFF);
    uint32_t hb = num_bits(y) & UINT32_C(0x7FFFFFFF);
    if (ha < hb) {
        const uint32_t t = ha;
        ha = hb;
        hb = t;
    }
    if (ha - hb <= UINT32_C(0x0F000000) && ha <= UINT32_C(0x58800000) &&
        hb >= UINT32_C(0x26800000)) {
        const num_t a = num_of_bits(ha);
        const num_t b = num_of_bits(hb);
        const num_t w = a - b;
        num_t q;
        if (w > b) {
            const num_t t1 = num_of_bits(ha & UINT32_C(0xFFFFF000));
            q = (a + t1) * (a - t1);
            q = fmaf(b, b, q);
            q = fmaf(t1, t1, q);
        } else {
            const num_t t1 = num_of_bits(ha + UINT32_C(0x00800000));
            const num_t y1 = num_of_bits(hb & UINT32_C(0xFFFFF000));
            q = b * ((a + a) - t1);
            q = fmaf(b - y1, t1, q);
            q = fmaf(w, w, q);
            q = fmaf(y1, t1, q);
        }
        num_t r;
        __asm__("vsqrt.f32 %0, %1" : "=t"(r) : "t"(q)); /* q > 0 */
        return r;
    }
#endif
    return hypotf(x, y);
}
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
