/* SPDX-License-Identifier: MIT */
/**
 * @file num.h
 * @brief The scalar type of every controller and kinematics module, and its
 *        operations. One source builds in two modes:
 *        - float mode (default): `num_t` is single-precision `float`;
 *        - fixed mode (`-DNUM_FIXED`): `num_t` is Q16.16 (see num_fixed.h).
 *
 * Controllers never use `+ - * /` on num_t directly: they call num_add,
 * num_sub, num_mul, num_div, so that fixed point can saturate instead of
 * wrapping. Comparisons (`<`, `>=`, ...) and `NUM_C()` constants are valid in
 * both modes.
 */
#ifndef MSTC_NUM_H
#define MSTC_NUM_H

#if defined(NUM_FIXED)
#include "num_fixed.h"
#else
#include "num_float.h"
#endif

#if defined(NUM_FIXED)
/** @brief sqrt(x² + y²) for |x|, |y| < 128: num_sqrt(num_sum_sq_small(x, y))
 *         (float mode: the same bits, without num_sqrt's test of the sign). */
static inline num_t num_norm_small(num_t x, num_t y) { return num_sqrt(num_sum_sq_small(x, y)); }
#endif

/** @brief π/2, the avoidance rotation angle of eq. (10)-(12). */
#define NUM_HALF_PI NUM_C(1.5707963267948966)

/** @brief Smaller of two scalars. */
static inline num_t num_min(num_t a, num_t b) { return a < b ? a : b; }

/** @brief Larger of two scalars. */
static inline num_t num_max(num_t a, num_t b) { return a > b ? a : b; }

/** @brief @p x clamped into [@p lo, @p hi] (requires lo <= hi). */
static inline num_t num_clamp(num_t x, num_t lo, num_t hi) { return num_min(num_max(x, lo), hi); }

#endif /* MSTC_NUM_H */
