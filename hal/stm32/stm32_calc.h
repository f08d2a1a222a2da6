/* SPDX-License-Identifier: MIT */
/**
 * @file stm32_calc.h
 * @brief Board-independent computations of the STM32 ports: watchdog and
 *        timer settings, PWM compare values, encoder counts, reset cause. Pure functions,
 *        unit-tested on the host (tests/unit/test_stm32_calc.c).
 *
 * The IWDG and the general-purpose timers TIM2..TIM5 are the same IP on the
 * F1 and F4. RM0090 sections first, RM0008 in brackets.
 */
#ifndef STM32_CALC_H
#define STM32_CALC_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_sys.h"

/** @brief IWDG prescaler code and reload value. */
typedef struct {
    uint8_t pr;   /**< IWDG_PR: divider 4 · 2^pr, 0..6 */
    uint16_t rlr; /**< IWDG_RLR, 0..4095 */
} stm32_iwdg_t;

/**
 * @brief IWDG setting for a timeout of @p timeout_ms at LSI frequency
 *        @p lsi_hz: timeout = 4 · 2^pr · (rlr + 1) / f_LSI (RM0090 §21.3.3
 *        [§19.3.3]). The smallest divider that reaches the timeout (finest
 *        step), the reload rounded up so the timeout is never shorter than
 *        asked at the nominal frequency. The LSI is not trimmed (F4: 17..47
 *        kHz, F1: 30..60 kHz): the real timeout is this one × nominal / actual.
 * @retval 0 done. @retval -EINVAL timeout 0, lsi_hz 0, or longer than
 *         4095 · 256 / f_LSI can hold (32.7 s at 32 kHz).
 */
int stm32_iwdg_config(uint32_t timeout_ms, uint32_t lsi_hz, stm32_iwdg_t *out);

/** @brief A timer's prescaler and auto-reload: update every
 *         (psc + 1)(arr + 1) timer clocks. */
typedef struct {
    uint16_t psc;
    uint16_t arr;
} stm32_timer_t;

/**
 * @brief Prescaler and auto-reload for an update event every @p period_us,
 *        on a 16-bit timer (TIM2 and TIM5 are 32-bit on the F4, 16-bit on
 *        the F1: 16 bits serve both) clocked at @p clk_hz (RM0090 §18.3.1
 *        [§15.3.1]). The smallest prescaler whose period is exact; when none
 *        is, the smallest prescaler that fits, rounded to the nearest count.
 * @param[out] err_ppm the period's error [ppm], rounded (0 when exact).
 * @retval 0 done. @retval -EINVAL period 0, or longer than 2^32 clocks.
 */
int stm32_timer_period(uint32_t clk_hz, uint32_t period_us, stm32_timer_t *out, int32_t *err_ppm);

/**
 * @brief Compare value (CCRx) for a duty of |@p cmd| / full_scale on a timer
 *        counting 0..@p arr in PWM mode 1 (output high while CNT < CCR):
 *        0 → 0 (always low), full scale or more → arr + 1 (always high),
 *        else rounded to nearest.
 */
uint32_t stm32_pwm_compare(int32_t cmd, int32_t full_scale, uint32_t arr);

/**
 * @brief Motion of an encoder counter between two reads: @p now − @p last
 *        modulo 2^@p bits, taken as signed (two's complement of that width).
 *        Right while the counter moved less than 2^(bits−1) counts between
 *        the reads (hal_encoder.h). @p bits is 16 or 32.
 */
int32_t stm32_encoder_step(uint32_t now, uint32_t last, unsigned bits);

/**
 * @brief Whether a counter's difference @p step (stm32_encoder_step()) of a
 *        @p bits wide counter is taken as a motion: less than a quarter of
 *        its range either way. A counter that moved past half its range reads
 *        as a motion the other way, of at least a quarter up to three
 *        quarters of a range (hal_encoder.h: the read then says so).
 */
bool stm32_encoder_trusted(int32_t step, unsigned bits);

/** @brief Register values of a timer in encoder mode. */
typedef struct {
    uint32_t smcr;  /**< SMS = 011: count on both edges of TI1 and TI2 (×4) */
    uint32_t ccmr1; /**< CC1S = CC2S = 01 (ICx on TIx), IC1F = IC2F = filter */
    uint32_t ccer;  /**< CC1P = invert: the counting direction reversed */
} stm32_encoder_regs_t;

/**
 * @brief Encoder mode 3 (RM0090 §18.3.12 [RM0008 §15.3.12]): SMCR.SMS = 011,
 *        CCMR1.CC1S = CC2S = 01, the input filter ICxF = @p filter (0..15:
 *        the number of samples and their rate, RM0090 §18.4.7), CCER.CC1P
 *        set when @p invert (TI1 inverted: the count runs the other way).
 */
stm32_encoder_regs_t stm32_encoder_regs(uint32_t filter, bool invert);

/** @brief Reset flags of RCC_CSR, at the same positions on the F1 and F4
 *         (RM0090 §7.3.21 [§7.3.10]). */
enum {
    STM32_RCC_CSR_BORRSTF = 1u << 25, /**< F4 only */
    STM32_RCC_CSR_PINRSTF = 1u << 26,
    STM32_RCC_CSR_PORRSTF = 1u << 27,
    STM32_RCC_CSR_SFTRSTF = 1u << 28,
    STM32_RCC_CSR_IWDGRSTF = 1u << 29,
    STM32_RCC_CSR_WWDGRSTF = 1u << 30,
    STM32_RCC_CSR_LPWRRSTF = 1u << 31,
};

/**
 * @brief Cause of the last reset from RCC_CSR. Several flags are set at
 *        once (every internal reset also drives NRST, so PINRSTF comes with
 *        all of them, and a power-on sets PINRSTF too): the most specific
 *        wins, in this order: watchdog (IWDG or WWDG), software, power-on or
 *        brown-out, low-power, pin.
 */
hal_reset_cause_t stm32_reset_cause(uint32_t csr);

/** @brief SysTick reload for a 1 kHz tick from the core clock (24 bits). */
uint32_t stm32_systick_reload(uint32_t sysclk_hz);

/** @brief Largest baud-rate error stm32_usart_brr() accepts [ppm]: the
 *         receiver of an 8N1 frame sampled 16 times a bit tolerates about
 *         3.75 % between the two ends (RM0090 §30.3.5 [§27.3.5]); the rest
 *         is left to the peer's clock. */
#define STM32_USART_MAX_ERR_PPM 30000

/**
 * @brief USART_BRR for @p baud from the peripheral clock @p pclk_hz, with 16
 *        times oversampling (OVER8 = 0; the F1 has no other): the divider
 *        pclk / (16 · baud) in 12.4 fixed point, which is pclk / baud rounded
 *        to the nearest integer (RM0090 §30.3.4 [RM0008 §27.3.4]).
 * @param[out] err_ppm the baud rate's error [ppm], rounded (0 when exact).
 * @retval 0 done. @retval -EINVAL baud 0, a divider below 1 (BRR < 16) or
 *         above 0xFFFF, or an error beyond STM32_USART_MAX_ERR_PPM.
 */
int stm32_usart_brr(uint32_t pclk_hz, uint32_t baud, uint16_t *brr, int32_t *err_ppm);

#endif /* STM32_CALC_H */
