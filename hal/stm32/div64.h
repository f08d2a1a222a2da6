/* SPDX-License-Identifier: MIT */
/**
 * @file div64.h
 * @brief 64-bit integer division for the STM32 ports' set-up computations
 *        (stm32_calc.c, bxcan_calc.c), by shifts and subtractions.
 *
 * The Cortex-M3 and M4 divide 32-bit integers only; a 64-bit `/` or `%`
 * links libgcc's __aeabi_uldivmod and __aeabi_ldivmod, about 800 B of flash
 * on images that must fit 32 KB. These computations run a few times at start
 * (and the PWM compare once per control period), where 64 shift-and-subtract
 * steps cost nothing that matters. Results are exactly C's.
 */
#ifndef STM32_DIV64_H
#define STM32_DIV64_H

#include <stdint.h>

/**
 * @brief n / d and n % d, truncated as C's `/` and `%` on uint64_t.
 * @param d divisor, 1 .. 2^63 (a larger one, or 0, is a programming error:
 *          0 is returned and the remainder is n).
 * @param[out] rem n % d, or NULL.
 */
uint64_t div64_u(uint64_t n, uint64_t d, uint64_t *rem);

/**
 * @brief num / den rounded to nearest, halves away from zero:
 *        (num ± den / 2) / den with C's truncation toward zero.
 * @param den 1 .. 2^62.
 */
int64_t div64_nearest(int64_t num, uint64_t den);

#endif /* STM32_DIV64_H */
