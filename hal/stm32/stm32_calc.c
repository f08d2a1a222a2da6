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
