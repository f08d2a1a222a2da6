/* SPDX-License-Identifier: MIT */
/* HAL motor on the STM32 ports: two sign-magnitude outputs, PWM on channels 1
 * and 2 of a general-purpose timer (BOARD_PWM_TIM, TIM3 on both boards) plus
 * a direction pin per wheel and a common driver-enable pin (board_config.h
 * has the pins). PWM mode 1, edge-aligned, BOARD_PWM_HZ (RM0090 §18.3.9,
 * RM0008 §15.3.9). Suits H-bridge drivers with a PWM/DIR interface
 * (DRV8871-style, VNH5019, Cytron MDxx...). */
#include <errno.h>
#include <stdbool.h>

#include "board.h"
#include "hal/hal_motor.h"
#include "stm32_calc.h"
#include "stm32_hal.h"

static volatile bool ready;
static uint32_t arr;

int hal_motor_init(void)
{
    /* No prescaler: clock / f counts per period, the finest duty step
     * (4200 steps at 84 MHz / 20 kHz, 3600 at 72 MHz). */
    const uint32_t counts = board_clocks()->apb1_tim_hz / BOARD_PWM_HZ;
    if (counts < 2u || counts > 65536u) {
        return -EINVAL;
    }
    board_timers_enable();
    board_motor_enable(false);
    TIM_TypeDef *const tim = BOARD_PWM_TIM;
    tim->CR1 = 0u;
    tim->PSC = 0u;
    tim->ARR = counts - 1u;
    tim->CCR1 = 0u;
    tim->CCR2 = 0u;
    /* OCxM = 110 (PWM mode 1), OCxPE: compare values take effect at the next
     * update, so a period is never cut short. */
    tim->CCMR1 = (6u << TIM_CCMR1_OC1M_Pos) | TIM_CCMR1_OC1PE_Msk | (6u << TIM_CCMR1_OC2M_Pos) |
                 TIM_CCMR1_OC2PE_Msk;
    tim->CCER = TIM_CCER_CC1E_Msk | TIM_CCER_CC2E_Msk;
    tim->EGR = TIM_EGR_UG_Msk;
    tim->CR1 = TIM_CR1_ARPE_Msk | TIM_CR1_CEN_Msk;
    arr = counts - 1u;
    ready = true;
    return 0;
}

static uint32_t compare(int16_t cmd) { return stm32_pwm_compare(cmd, HAL_MOTOR_FULL_SCALE, arr); }

int hal_motor_set(int16_t left, int16_t right)
{
    if (!ready) {
        return -ENODEV;
    }
    board_motor_dir(0u, left >= 0);
    board_motor_dir(1u, right >= 0);
    BOARD_PWM_TIM->CCR1 = compare(left);
    BOARD_PWM_TIM->CCR2 = compare(right);
    board_motor_enable(true);
    return 0;
}

void hal_motor_stop(void)
{
    board_motor_enable(false);
    BOARD_PWM_TIM->CCR1 = 0u;
    BOARD_PWM_TIM->CCR2 = 0u;
}

/* A board's motors are real (pil_wheels.c has the PIL images' models). */
bool stm32_wheels_period(uint32_t period_us)
{
    (void)period_us;
    return false;
}

void stm32_wheels_lockstep(void) {}

uint32_t stm32_wheels_model_cycles(void) { return 0u; }
