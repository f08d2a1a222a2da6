/* SPDX-License-Identifier: MIT */
/**
 * @file model_tim.h
 * @brief A general-purpose timer (TIM2..TIM5, RM0090 §18) as the drivers use
 *        one: the counter counting its kernel clock through the prescaler to
 *        the auto-reload, with its update event (EGR.UG, the buffered PSC and
 *        CCRx loaded then, SR.UIF cleared by writing 0, the update interrupt);
 *        in encoder mode 3 (SMCR.SMS = 011) counting a shaft's quadrature
 *        edges up or down, CCER.CC1P reversing them, wrapping at ARR both
 *        ways; and PWM mode 1 on channels 1 and 2 (the duty CCRx / (ARR + 1)
 *        once an update has loaded it). Registers as wide as the timer
 *        (16 or 32 bits).
 */
#ifndef MODEL_TIM_H
#define MODEL_TIM_H

#include <stdbool.h>
#include <stdint.h>

#include "stm32_host.h"

typedef struct {
    stm32_host_periph_t p;  /**< first: the hooks find the model from it */
    unsigned bits;          /**< 16 or 32 */
    int irqn;               /**< its update interrupt */
    uint32_t clk_hz;        /**< the kernel clock */
    int64_t shaft;          /**< edges the encoder gave, counted forward */
    int64_t shaft_at;       /**< ... when the counter was last set */
    uint32_t cnt_at;        /**< the counter then */
    uint32_t psc;           /**< the prescaler in force (loaded at an update) */
    uint64_t from;          /**< core cycle the count (re)started */
    uint64_t updates;       /**< updates since then */
    uint32_t ccr[2];        /**< compare values in force (loaded at an update) */
    unsigned update_events; /**< update events so far (UG and overflows) */
} tim_model_t;

/** @brief Map the timer at @p base, @p bits wide, update interrupt @p irqn,
 *         kernel clock @p clk_hz, at its reset state. */
void tim_model_init(tim_model_t *t, uint32_t base, unsigned bits, int irqn, uint32_t clk_hz);

/** @brief The encoder's shaft turns by @p edges (quadrature edges, ×4
 *         counts; negative: backwards). */
void tim_model_turn(tim_model_t *t, int64_t edges);

/** @brief The counter now, as CNT reads. */
uint32_t tim_model_count(tim_model_t *t);

/** @brief Channel @p ch (1 or 2) drives its pin: the counter runs, the
 *         channel is in PWM mode 1 and its output enabled. */
bool tim_model_pwm_on(tim_model_t *t, unsigned ch);

/** @brief Its duty in force, CCRx / (ARR + 1), 1 at most. */
double tim_model_duty(tim_model_t *t, unsigned ch);

#endif /* MODEL_TIM_H */
