/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the watchdog driver (hal/stm32/sys.c) against its
 * registers: the STM32F405's IWDG as the SVD lays it out, a model of the
 * independent watchdog (tests/unit/stm32_host/model_iwdg.h): its keys, the
 * write protection of PR and RLR, their updates reaching the LSI domain, the
 * count down and the reset.
 *
 * Expected values by hand: 100 ms at the board's nominal 32 kHz LSI is
 * divider 4 (PR 0) and RLR 799: 4 · 800 / 32,000 = 0.1 s (RM0090 §21.3.3);
 * at the fastest LSI (47 kHz, DS8626) 68.1 ms.
 */
#include <errno.h>
#include <stdint.h>

#include "board_host.h"
#include "hal/hal_sys.h"
#include "model_iwdg.h"
#include "stm32_calc.h"
#include "stm32_host.h"
#include "unity.h"

static iwdg_model_t wdg;

void setUp(void)
{
    stm32_host_reset();
    board_host_reset();
    stm32_host_set_clock(168000000u);
    iwdg_model_init(&wdg, IWDG_BASE, BOARD_LSI_HZ);
}

void tearDown(void) {}

static void test_drv_iwdg_start_sets_100_ms_through_the_protection(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_sys_watchdog_start(100u));
    TEST_ASSERT_TRUE(wdg.started);
    TEST_ASSERT_EQUAL_UINT32(0u, wdg.pr);
    TEST_ASSERT_EQUAL_UINT32(799u, wdg.rlr);
    TEST_ASSERT_EQUAL_UINT(0u, wdg.ignored); /* unlocked before writing */
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 100000.0, iwdg_model_timeout_us(&wdg));
    /* It waited for both values to reach the LSI domain, five LSI periods
     * (156 µs at 32 kHz), before its first reload. */
    TEST_ASSERT_TRUE(stm32_host_cycles() >= (uint64_t)(5.0 * 168e6 / 32000.0));
    TEST_ASSERT_EQUAL_UINT(1u, wdg.reloads);
    TEST_ASSERT_FALSE(wdg.unlocked); /* the reload key protected them again */
}

static void test_drv_iwdg_kicks_keep_it_from_resetting(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_sys_watchdog_start(100u));
    for (unsigned i = 0; i < 5u; i++) {
        stm32_host_spend((uint64_t)(0.09 * 168e6)); /* 90 ms */
        TEST_ASSERT_FALSE(iwdg_model_expired(&wdg));
        hal_sys_watchdog_kick();
    }
    TEST_ASSERT_EQUAL_UINT(6u, wdg.reloads);
    /* Not kicked: it resets after its time-out. */
    stm32_host_spend((uint64_t)(0.099 * 168e6));
    TEST_ASSERT_FALSE(iwdg_model_expired(&wdg));
    stm32_host_spend((uint64_t)(0.002 * 168e6));
    TEST_ASSERT_TRUE(iwdg_model_expired(&wdg));
}

static void test_drv_iwdg_time_out_at_the_fastest_lsi(void)
{
    /* The LSI is not trimmed: the same settings on a 47 kHz LSI. */
    wdg.lsi_hz = 47000u;
    TEST_ASSERT_EQUAL_INT(0, hal_sys_watchdog_start(100u));
    TEST_ASSERT_DOUBLE_WITHIN(1.0, 4.0 * 800.0 / 47000.0 * 1e6, iwdg_model_timeout_us(&wdg));
}

static void test_drv_iwdg_refuses_a_time_out_it_cannot_set(void)
{
    TEST_ASSERT_EQUAL_INT(-EINVAL, hal_sys_watchdog_start(0u));
    TEST_ASSERT_EQUAL_INT(-EINVAL, hal_sys_watchdog_start(40000u)); /* > 32.7 s */
    TEST_ASSERT_FALSE(wdg.started);
}

static void test_drv_iwdg_reset_cause_from_the_board_flags(void)
{
    board_host.reset_flags = STM32_RCC_CSR_IWDGRSTF | STM32_RCC_CSR_PINRSTF;
    TEST_ASSERT_EQUAL_INT(HAL_RESET_WATCHDOG, hal_sys_reset_cause());
    board_host.reset_flags = STM32_RCC_CSR_PORRSTF | STM32_RCC_CSR_PINRSTF;
    TEST_ASSERT_EQUAL_INT(HAL_RESET_POWER_ON, hal_sys_reset_cause());
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_drv_iwdg_start_sets_100_ms_through_the_protection);
    RUN_TEST(test_drv_iwdg_kicks_keep_it_from_resetting);
    RUN_TEST(test_drv_iwdg_time_out_at_the_fastest_lsi);
    RUN_TEST(test_drv_iwdg_refuses_a_time_out_it_cannot_set);
    RUN_TEST(test_drv_iwdg_reset_cause_from_the_board_flags);
    return UNITY_END();
}
