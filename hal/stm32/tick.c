/* SPDX-License-Identifier: MIT */
/* The control-period timer of the STM32 ports: a general-purpose timer
 * (board_config.h: BOARD_TICK_TIM, TIM2 on both boards; RM0090 §18, RM0008
 * §15) whose update interrupt only counts. The main loop takes the count:
 * events up, no control code in the interrupt. */
#include <errno.h>

#include "board.h"
#include "cortex_m.h"
#include "stm32_calc.h"
#include "stm32_hal.h"

#define PRIO_TICK 3u

static volatile uint32_t ticks; /* written by the ISR only */
static uint32_t ticks_taken;    /* main loop only */
static uint32_t overruns;       /* main loop only */

int stm32_tick_start(uint32_t period_us)
{
    stm32_timer_t cfg;
    int32_t err_ppm = 0;
    if (stm32_timer_period(board_clocks()->apb1_tim_hz, period_us, &cfg, &err_ppm) != 0) {
        return -EINVAL;
    }
    board_timers_enable();
    TIM_TypeDef *const tim = BOARD_TICK_TIM;
    tim->CR1 = 0u;
    tim->PSC = cfg.psc;
    tim->ARR = cfg.arr;
    tim->CNT = 0u;
    tim->EGR = TIM_EGR_UG_Msk; /* load PSC now (it is buffered) */
    tim->SR = 0u;              /* ... without counting that as a period */
    tim->DIER = TIM_DIER_UIE_Msk;
    ticks = 0u;
    ticks_taken = 0u;
    overruns = 0u;
    cm_nvic_set_priority(BOARD_TICK_IRQn, PRIO_TICK);
    cm_nvic_enable(BOARD_TICK_IRQn);
    tim->CR1 = TIM_CR1_URS_Msk | TIM_CR1_CEN_Msk;
    return 0;
}

uint32_t stm32_tick_take(void)
{
    const uint32_t now = ticks;
    const uint32_t n = now - ticks_taken;
    ticks_taken = now;
    if (n > 1u) {
        overruns += n - 1u;
    }
    return n;
}

bool stm32_tick_pending(void) { return ticks != ticks_taken; }

uint32_t stm32_tick_overruns(void) { return overruns; }

void BOARD_TICK_IRQHandler(void)
{
    BOARD_TICK_TIM->SR = ~TIM_SR_UIF_Msk; /* rc_w0: clear UIF only */
    ticks = ticks + 1u;
}
