/* SPDX-License-Identifier: MIT */
/* STM32 ports: board-independent computations (see stm32_calc.h). */
#include "stm32_calc.h"

#include <errno.h>
#include <stddef.h>

#include "div64.h"

int stm32_iwdg_config(uint32_t timeout_ms, uint32_t lsi_hz, stm32_iwdg_t *out)
{
    if (out == NULL || timeout_ms == 0u || lsi_hz == 0u) {
        return -EINVAL;
    }
    /* LSI clocks in the timeout, then per divider the reload rounded up. */
    const uint64_t clocks = (uint64_t)timeout_ms * lsi_hz;
    for (uint8_t pr = 0u; pr <= 6u; pr++) {
        const uint64_t div = 4000u * ((uint64_t)1u << pr); /* ms → s folded in */
        const uint64_t counts = div64_u(clocks + div - 1u, div, NULL);
        if (counts >= 1u && counts <= 4096u) {
            out->pr = pr;
            out->rlr = (uint16_t)(counts - 1u);
            return 0;
        }
    }
    return -EINVAL;
}

int stm32_timer_period(uint32_t clk_hz, uint32_t period_us, stm32_timer_t *out, int32_t *err_ppm)
{
    if (out == NULL || err_ppm == NULL || clk_hz == 0u || period_us == 0u) {
        return -EINVAL;
    }
    /* Timer clocks per period, ×10^6 to stay exact. */
    const uint64_t ticks_e6 = (uint64_t)clk_hz * period_us;
    const uint64_t max_counts_e6 = (uint64_t)65536u * 1000000u; /* one prescaler step */
    if (ticks_e6 > (uint64_t)65536u * max_counts_e6 || ticks_e6 < 1000000u) {
        return -EINVAL;
    }
    const uint64_t min_div = div64_u(ticks_e6 + max_counts_e6 - 1u, max_counts_e6, NULL);
    uint64_t frac = 0u;
    const uint64_t ticks = div64_u(ticks_e6, 1000000u, &frac);
    if (frac == 0u) {
        for (uint64_t div = min_div < 1u ? 1u : min_div; div <= 65536u; div++) {
            uint64_t left = 0u;
            const uint64_t counts = div64_u(ticks, div, &left);
            if (left == 0u && counts <= 65536u) {
                out->psc = (uint16_t)(div - 1u);
                out->arr = (uint16_t)(counts - 1u);
                *err_ppm = 0;
                return 0;
            }
        }
    }
    /* No exact setting: the smallest prescaler, nearest reload. */
    const uint64_t div = min_div < 1u ? 1u : min_div;
    uint64_t counts = div64_u(div64_u(ticks_e6, div, NULL) + 500000u, 1000000u, NULL);
    if (counts < 1u) {
        counts = 1u;
    }
    if (counts > 65536u) {
        counts = 65536u;
    }
    out->psc = (uint16_t)(div - 1u);
    out->arr = (uint16_t)(counts - 1u);
    const int64_t actual_e6 = (int64_t)(div * counts * 1000000u);
    const int64_t diff = (actual_e6 - (int64_t)ticks_e6) * 1000000;
    *err_ppm = (int32_t)div64_nearest(diff, ticks_e6);
    return 0;
}

uint32_t stm32_pwm_compare(int32_t cmd, int32_t full_scale, uint32_t arr)
{
    if (full_scale <= 0) {
        return 0u;
    }
    const uint32_t mag = cmd < 0 ? (uint32_t)0 - (uint32_t)cmd : (uint32_t)cmd;
    if (mag >= (uint32_t)full_scale) {
        return arr + 1u;
    }
    const uint64_t period = (uint64_t)arr + 1u;
    return (uint32_t)div64_u(mag * period + (uint32_t)full_scale / 2u, (uint32_t)full_scale, NULL);
}

bool stm32_encoder_trusted(int32_t step, unsigned bits)
{
    const int64_t quarter = (int64_t)1 << (bits - 2u);
    return (int64_t)step < quarter && (int64_t)step > -quarter;
}

int32_t stm32_encoder_step(uint32_t now, uint32_t last, unsigned bits)
{
    const uint32_t d = now - last;
    /* Sign-extend the low @p bits (ODrive's encoder.cpp: the 16-bit
     * difference cast to int16_t). */
    return bits >= 32u ? (int32_t)d : (int32_t)(int16_t)(uint16_t)d;
}

/* TIMx_SMCR, TIMx_CCMR1 (input view), TIMx_CCER bit positions: RM0090
 * §18.4.3, §18.4.7, §18.4.9 [RM0008 §15.4.3, §15.4.7, §15.4.9]. */
#define SMCR_SMS_ENCODER3 3u
#define CCMR1_CC1S_POS    0u
#define CCMR1_IC1F_POS    4u
#define CCMR1_CC2S_POS    8u
#define CCMR1_IC2F_POS    12u
#define CCxS_TI           1u
#define CCER_CC1P         (1u << 1)

stm32_encoder_regs_t stm32_encoder_regs(uint32_t filter, bool invert)
{
    const uint32_t f = filter & 0xFu;
    return (stm32_encoder_regs_t){
        .smcr = SMCR_SMS_ENCODER3,
        .ccmr1 = (CCxS_TI << CCMR1_CC1S_POS) | (f << CCMR1_IC1F_POS) | (CCxS_TI << CCMR1_CC2S_POS) |
                 (f << CCMR1_IC2F_POS),
        .ccer = invert ? CCER_CC1P : 0u,
    };
}

hal_reset_cause_t stm32_reset_cause(uint32_t csr)
{
    if ((csr & (STM32_RCC_CSR_IWDGRSTF | STM32_RCC_CSR_WWDGRSTF)) != 0u) {
        return HAL_RESET_WATCHDOG;
    }
    if ((csr & STM32_RCC_CSR_SFTRSTF) != 0u) {
        return HAL_RESET_SOFTWARE;
    }
    if ((csr & (STM32_RCC_CSR_PORRSTF | STM32_RCC_CSR_BORRSTF)) != 0u) {
        return HAL_RESET_POWER_ON;
    }
    if ((csr & STM32_RCC_CSR_LPWRRSTF) != 0u) {
        return HAL_RESET_OTHER;
    }
    if ((csr & STM32_RCC_CSR_PINRSTF) != 0u) {
        return HAL_RESET_PIN;
    }
    return HAL_RESET_OTHER;
}

uint32_t stm32_systick_reload(uint32_t sysclk_hz) { return sysclk_hz / 1000u - 1u; }

int stm32_usart_brr(uint32_t pclk_hz, uint32_t baud, uint16_t *brr, int32_t *err_ppm)
{
    if (brr == NULL || err_ppm == NULL || baud == 0u) {
        return -EINVAL;
    }
    const uint64_t div = div64_u((uint64_t)pclk_hz + baud / 2u, baud, NULL);
    if (div < 16u || div > 0xFFFFu) {
        return -EINVAL;
    }
    /* actual / baud - 1 = pclk / (div · baud) - 1, in ppm, rounded */
    const uint64_t den = div * baud;
    const int64_t num = ((int64_t)pclk_hz - (int64_t)den) * 1000000;
    const int64_t err = div64_nearest(num, den);
    if (err > STM32_USART_MAX_ERR_PPM || err < -STM32_USART_MAX_ERR_PPM) {
        return -EINVAL;
    }
    *brr = (uint16_t)div;
    *err_ppm = (int32_t)err;
    return 0;
}
