/* SPDX-License-Identifier: MIT */
/* HAL encoder on the STM32 ports: one timer per wheel in encoder mode 3
 * (both edges of both channels, ×4), with the input filter of
 * board_config.h (RM0090 §18.3.12, RM0008 §15.3.12). The counters run by
 * themselves; hal_encoder_read() extends them to 32-bit running counts by
 * the signed difference since the previous read (stm32_encoder_step(), as
 * ODrive's encoder.cpp does). A difference of a quarter of the counter's
 * range or more is not taken (stm32_encoder_trusted()): the counter may have
 * moved past half its range, which reads as a motion the other way; the read
 * says so (-ERANGE) and the wheel loop stops with an encoder fault. So a
 * 16-bit counter must be read before it moves 16,383 counts: 1.5 s at the
 * default motor's top speed (34.6 rad/s, 10,560 counts/s), against the wheel
 * loop's 1 ms. No interrupt: counting overflows with an update interrupt
 * would race with reading the counter.
 *
 * Under QEMU (make pil, make firmware-smoke) nothing counts edges: TIM4 and
 * TIM5 are modelled as free-running counters of the machine's clock, TIM1
 * not at all (it reads 0). docs/wheel.md says what the wheel loop makes of
 * either. */
#include <errno.h>
#include <stdbool.h>

#include "board.h"
#include "hal/hal_encoder.h"
#include "stm32_calc.h"

typedef struct {
    TIM_TypeDef *tim;
    unsigned bits;
    bool invert;
} encoder_hw_t;

static const encoder_hw_t hw[2] = {
    { BOARD_ENC_LEFT_TIM, BOARD_ENC_LEFT_BITS, BOARD_ENC_LEFT_INVERT },
    { BOARD_ENC_RIGHT_TIM, BOARD_ENC_RIGHT_BITS, BOARD_ENC_RIGHT_INVERT },
};

static bool ready;
static uint32_t last[2]; /* counter at the previous read */
static int32_t total[2]; /* running counts, modulo 2^32 */
static uint8_t overran;  /* the wheels the last read did not take */

int hal_encoder_init(void)
{
    board_encoder_enable();
    for (unsigned i = 0; i < 2u; i++) {
        TIM_TypeDef *const tim = hw[i].tim;
        const stm32_encoder_regs_t r = stm32_encoder_regs(BOARD_ENC_FILTER, hw[i].invert);
        tim->CR1 = 0u;
        tim->SMCR = r.smcr;
        tim->CCMR1 = r.ccmr1;
        tim->CCER = r.ccer;
        tim->PSC = 0u;
        tim->ARR = hw[i].bits >= 32u ? 0xFFFFFFFFu : 0xFFFFu;
        tim->CNT = 0u;
        tim->CR1 = TIM_CR1_CEN_Msk;
        last[i] = tim->CNT;
        total[i] = 0;
    }
    ready = true;
    return 0;
}

int hal_encoder_read(int32_t *left, int32_t *right)
{
    int32_t *const out[2] = { left, right };
    overran = 0u;
    for (unsigned i = 0; i < 2u; i++) {
        if (ready) {
            const uint32_t now = hw[i].tim->CNT;
            const int32_t step = stm32_encoder_step(now, last[i], hw[i].bits);
            if (stm32_encoder_trusted(step, hw[i].bits)) {
                total[i] = (int32_t)((uint32_t)total[i] + (uint32_t)step);
            } else {
                overran |= (uint8_t)(1u << i);
            }
            last[i] = now;
        }
        *out[i] = total[i];
    }
    if (!ready) {
        return -ENODEV;
    }
    return overran != 0u ? -ERANGE : 0;
}

uint8_t hal_encoder_overran(void) { return overran; }
