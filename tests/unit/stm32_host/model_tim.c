/* SPDX-License-Identifier: MIT */
/* A general-purpose timer's behaviour (model_tim.h; RM0090 §18.3, §18.4). */
#include "model_tim.h"

#include <stddef.h>

enum {
    CR1 = 0x00,
    SMCR = 0x08,
    DIER = 0x0C,
    SR = 0x10,
    EGR = 0x14,
    CCMR1 = 0x18,
    CCER = 0x20,
    CNT = 0x24,
    PSC = 0x28,
    ARR = 0x2C,
    CCR1 = 0x34,
    CCR2 = 0x38,
};
#define R(t, off) ((t)->p.reg[(off) / 4])
#define CEN       0x1u
#define URS       0x4u
#define UIF       0x1u
#define UIE       0x1u
#define UG        0x1u

static uint32_t mask(const tim_model_t *t) { return t->bits >= 32u ? 0xFFFFFFFFu : 0xFFFFu; }

static bool encoder_mode(const tim_model_t *t) { return (R(t, SMCR) & 0x7u) == 3u; }

static bool counting(const tim_model_t *t) { return (R(t, CR1) & CEN) != 0u; }

/* The update event (RM0090 §18.3.1): the buffered prescaler and compare
 * values take effect, the counter restarts; UIF set unless URS forbids it
 * for a software update. */
static void update_event(tim_model_t *t, bool by_software)
{
    t->psc = R(t, PSC) & 0xFFFFu;
    t->ccr[0] = R(t, CCR1);
    t->ccr[1] = R(t, CCR2);
    t->update_events++;
    if (!(by_software && (R(t, CR1) & URS) != 0u)) {
        R(t, SR) |= UIF;
        if ((R(t, DIER) & UIE) != 0u) {
            stm32_host_pend(t->irqn);
        }
    }
}

/* Timer clocks per core cycle, as a ratio: the count from core cycles. */
static uint64_t timer_clocks(const tim_model_t *t, uint64_t core)
{
    return core * t->clk_hz / stm32_host_clock();
}

static void tick(void *ctx, uint64_t now)
{
    tim_model_t *t = ctx;
    if (!counting(t) || encoder_mode(t)) {
        return;
    }
    const uint64_t period = ((uint64_t)t->psc + 1u) * ((uint64_t)(R(t, ARR) & mask(t)) + 1u);
    const uint64_t due = timer_clocks(t, now - t->from) / period;
    while (t->updates < due) {
        t->updates++;
        update_event(t, false);
    }
}

/* UIF is a level: pending again while it stays set with UIE. */
static void level(void *ctx)
{
    tim_model_t *t = ctx;
    if ((R(t, SR) & UIF) != 0u && (R(t, DIER) & UIE) != 0u) {
        stm32_host_pend(t->irqn);
    }
}

uint32_t tim_model_count(tim_model_t *t)
{
    if (counting(t) && encoder_mode(t)) {
        /* Mode 3 counts every edge of TI1 and TI2, up or down with the
         * direction; CC1P inverts TI1, which reverses it (RM0090 §18.3.12). */
        const int64_t dir = (R(t, CCER) & 0x2u) != 0u ? -1 : 1;
        const int64_t moved = dir * (t->shaft - t->shaft_at);
        const uint64_t m = (uint64_t)(R(t, ARR) & mask(t)) + 1u;
        const int64_t c = ((int64_t)t->cnt_at + moved) % (int64_t)m;
        return (uint32_t)(c < 0 ? c + (int64_t)m : c);
    }
    if (counting(t)) {
        const uint64_t period = ((uint64_t)t->psc + 1u);
        const uint64_t clocks = timer_clocks(t, stm32_host_cycles() - t->from);
        return (uint32_t)((clocks / period) % ((uint64_t)(R(t, ARR) & mask(t)) + 1u));
    }
    return t->cnt_at;
}

static uint32_t tim_read(stm32_host_periph_t *p, uint32_t off)
{
    tim_model_t *t = (tim_model_t *)p;
    return off == CNT ? tim_model_count(t) : p->reg[off / 4u];
}

static void tim_write(stm32_host_periph_t *p, uint32_t off, uint32_t v)
{
    tim_model_t *t = (tim_model_t *)p;
    switch (off) {
    case SR: p->reg[off / 4u] &= v; break; /* rc_w0 */
    case EGR:
        if ((v & UG) != 0u) {
            t->from = stm32_host_cycles();
            t->updates = 0u;
            t->cnt_at = 0u;
            t->shaft_at = t->shaft;
            update_event(t, true);
        }
        break;
    case CNT:
        t->cnt_at = v & mask(t);
        t->shaft_at = t->shaft;
        break;
    case CR1: {
        const bool start = (v & CEN) != 0u && !counting(t);
        const uint32_t was = tim_model_count(t);
        p->reg[off / 4u] = v;
        if (start) {
            t->from = stm32_host_cycles();
            t->updates = 0u;
            t->cnt_at = was;
            t->shaft_at = t->shaft;
        } else if ((v & CEN) == 0u) {
            t->cnt_at = was; /* the counter stops where it is */
        }
        break;
    }
    case ARR:
    case CCR1:
    case CCR2: p->reg[off / 4u] = v & mask(t); break;
    default: p->reg[off / 4u] = v; break;
    }
}

void tim_model_init(tim_model_t *t, uint32_t base, unsigned bits, int irqn, uint32_t clk_hz)
{
    *t = (tim_model_t){
        .p = { .base = base, .size = 0x54u, .name = "TIM", .read = tim_read, .write = tim_write },
        .bits = bits,
        .irqn = irqn,
        .clk_hz = clk_hz,
    };
    R(t, ARR) = mask(t); /* the reset value: the counter's full range */
    stm32_host_map(&t->p);
    stm32_host_on_time(tick, t);
    stm32_host_on_level(level, t);
}

void tim_model_turn(tim_model_t *t, int64_t edges) { t->shaft += edges; }

bool tim_model_pwm_on(tim_model_t *t, unsigned ch)
{
    const uint32_t ccmr = R(t, CCMR1) >> (ch == 1u ? 0u : 8u);
    const bool pwm1 = ((ccmr >> 4) & 0x7u) == 6u;
    const bool enabled = (R(t, CCER) & (ch == 1u ? 0x1u : 0x10u)) != 0u;
    return counting(t) && pwm1 && enabled;
}

double tim_model_duty(tim_model_t *t, unsigned ch)
{
    const double top = (double)(R(t, ARR) & mask(t)) + 1.0;
    const double d = (double)t->ccr[ch - 1u] / top;
    return d > 1.0 ? 1.0 : d;
}
