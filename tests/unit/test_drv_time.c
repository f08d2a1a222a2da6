/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the time and tick drivers (hal/stm32/time.c: SysTick;
 * hal/stm32/tick.c: the control period's timer, TIM2) against their
 * registers: the core's SysTick, SCB and NVIC modelled
 * (tests/unit/stm32_host/stm32_host.c), the STM32F405 board's TIM2 (32 bits,
 * 84 MHz kernel clock) a timer model (model_tim.h).
 *
 * Expected values by hand: SysTick at 168 MHz reloads every 168,000 cycles
 * (RVR 167,999: ARMv7-M ARM B3.3, the counter counts RVR..0); the 20 ms
 * control period at 84 MHz is PSC 27, ARR 59,999 (28 · 60,000 = 1,680,000
 * timer clocks: stm32_timer_period(), docs/porting.md's table).
 */
#include <errno.h>
#include <stdint.h>

#include "board_host.h"
#include "cortex_m.h"
#include "hal/hal_time.h"
#include "model_tim.h"
#include "stm32_hal.h"
#include "stm32_host.h"
#include "unity.h"

static tim_model_t tick_tim;

void setUp(void)
{
    stm32_host_reset();
    board_host_reset();
    stm32_host_set_clock(168000000u);
    stm32_host_vector(-1, SysTick_Handler);
    stm32_host_vector(TIM2_IRQn, TIM2_IRQHandler);
    tim_model_init(&tick_tim, TIM2_BASE, 32u, TIM2_IRQn, 84000000u);
}

void tearDown(void) {}

/* ---------------------------------------------------------------- time */

static void test_drv_time_init_runs_systick_at_1_khz_lowest_priority(void)
{
    stm32_time_init(168000000u);
    TEST_ASSERT_EQUAL_UINT32(167999u, CM_SYST_RVR);
    TEST_ASSERT_EQUAL_HEX32(0x7u, CM_SYST_CSR & 0x7u); /* CLKSOURCE, TICKINT, ENABLE */
    TEST_ASSERT_EQUAL_HEX32(0xF0u, CM_SCB_SHPR3 >> 24);
}

static void test_drv_time_counts_microseconds_and_milliseconds(void)
{
    stm32_time_init(168000000u);
    const uint64_t t0 = hal_time_now_us();
    stm32_host_run_us(2500u);
    const uint64_t t1 = hal_time_now_us();
    TEST_ASSERT_UINT64_WITHIN(2u, 2500u, t1 - t0);
    TEST_ASSERT_EQUAL_UINT(2u, stm32_host_taken(-1)); /* two ticks */
    /* Cycles: one a cycle, modulo 2^32. */
    const uint32_t c0 = stm32_time_cycles();
    stm32_host_run_us(10u);
    TEST_ASSERT_UINT32_WITHIN(200u, 1680u, stm32_time_cycles() - c0);
}

static void test_drv_time_counts_a_tick_that_is_pending_while_masked(void)
{
    stm32_time_init(168000000u);
    stm32_host_run_us(900u);
    /* Interrupts masked across a millisecond boundary (an ISR of equal
     * priority, a critical section): SysTick_Handler has not run, the
     * counter has wrapped; the time still moves on, not back. */
    const uint32_t primask = cm_irq_save();
    const uint64_t before = hal_time_now_us();
    stm32_host_spend(168000u / 2u); /* 0.5 ms, past the 1 ms boundary */
    const uint64_t masked = hal_time_now_us();
    TEST_ASSERT_EQUAL_UINT(0u, stm32_host_taken(-1));
    TEST_ASSERT_UINT64_WITHIN(3u, before + 500u, masked);
    cm_irq_restore(primask); /* now the tick is taken */
    TEST_ASSERT_EQUAL_UINT(1u, stm32_host_taken(-1));
    TEST_ASSERT_UINT64_WITHIN(3u, masked, hal_time_now_us());
}

static void test_drv_time_sleeps_until_a_time(void)
{
    stm32_time_init(168000000u);
    const uint64_t until = hal_time_now_us() + 4321u;
    hal_time_sleep_until_us(until);
    const uint64_t now = hal_time_now_us();
    TEST_ASSERT_TRUE(now >= until);
    TEST_ASSERT_TRUE(now < until + 1000u); /* woken by a tick at most 1 ms later */
}

/* ---------------------------------------------------------------- tick */

static void test_drv_tick_start_sets_the_period_and_its_interrupt(void)
{
    TEST_ASSERT_EQUAL_INT(0, stm32_tick_start(20000u));
    TEST_ASSERT_EQUAL_UINT32(27u, tick_tim.p.reg[0x28 / 4]);    /* PSC */
    TEST_ASSERT_EQUAL_UINT32(59999u, tick_tim.p.reg[0x2C / 4]); /* ARR */
    TEST_ASSERT_EQUAL_HEX32(0x1u, tick_tim.p.reg[0x0C / 4]);    /* DIER.UIE */
    TEST_ASSERT_TRUE(stm32_host_irq_enabled(TIM2_IRQn));
    TEST_ASSERT_EQUAL_HEX8(3u << 4, stm32_host_irq_priority(TIM2_IRQn));
    TEST_ASSERT_EQUAL_UINT(0u, stm32_host_taken(TIM2_IRQn)); /* UG's UIF not counted */
    TEST_ASSERT_FALSE(stm32_tick_pending());
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_tick_start(0u));
}

static void test_drv_tick_counts_periods_and_the_ones_the_loop_missed(void)
{
    TEST_ASSERT_EQUAL_INT(0, stm32_tick_start(20000u));
    stm32_host_run_us(19990u);
    TEST_ASSERT_EQUAL_UINT32(0u, stm32_tick_take());
    stm32_host_run_us(20u);
    TEST_ASSERT_TRUE(stm32_tick_pending());
    TEST_ASSERT_EQUAL_UINT32(1u, stm32_tick_take());
    TEST_ASSERT_FALSE(stm32_tick_pending());
    TEST_ASSERT_EQUAL_UINT32(0u, stm32_tick_overruns());
    /* Three periods without a look: two of them missed. */
    stm32_host_run_us(60000u);
    TEST_ASSERT_EQUAL_UINT32(3u, stm32_tick_take());
    TEST_ASSERT_EQUAL_UINT32(2u, stm32_tick_overruns());
    /* The interrupt cleared its flag each time (rc_w0): one per period. */
    TEST_ASSERT_EQUAL_UINT(4u, stm32_host_taken(TIM2_IRQn));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_drv_time_init_runs_systick_at_1_khz_lowest_priority);
    RUN_TEST(test_drv_time_counts_microseconds_and_milliseconds);
    RUN_TEST(test_drv_time_counts_a_tick_that_is_pending_while_masked);
    RUN_TEST(test_drv_time_sleeps_until_a_time);
    RUN_TEST(test_drv_tick_start_sets_the_period_and_its_interrupt);
    RUN_TEST(test_drv_tick_counts_periods_and_the_ones_the_loop_missed);
    return UNITY_END();
}
