/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the encoder driver (hal/stm32/encoder.c) against its
 * registers: the STM32F405 board's TIM4 (16 bits, left) and TIM5 (32 bits,
 * right) as the SVD lays them out, each a model of a timer in encoder mode
 * (tests/unit/stm32_host/model_tim.h) counting a shaft the test turns.
 *
 * Expected values by hand: counts are edges turned; a 16-bit counter wraps
 * modulo 65,536, a 32-bit one modulo 2^32; the encoder mode registers from
 * RM0090 §18.4 (SMCR.SMS = 011; CCMR1: CC1S = CC2S = 01, IC1F = IC2F = 8;
 * CCER.CC1P clear: no board inverts a wheel).
 */
#include <errno.h>
#include <stdint.h>

#include "board_host.h"
#include "hal/hal_encoder.h"
#include "model_tim.h"
#include "stm32_host.h"
#include "unity.h"

static tim_model_t left, right;

void setUp(void)
{
    stm32_host_reset();
    board_host_reset();
    tim_model_init(&left, TIM4_BASE, 16u, TIM4_IRQn, 84000000u);
    tim_model_init(&right, TIM5_BASE, 32u, TIM5_IRQn, 84000000u);
}

void tearDown(void) {}

static int32_t l_count, r_count;

static int read_both(void) { return hal_encoder_read(&l_count, &r_count); }

/* Turn both shafts by many edges, reading every @p step of them, as the
 * wheel loop reads every millisecond. */
static void turn_reading(tim_model_t *t, int64_t edges, int64_t step)
{
    const int64_t dir = edges >= 0 ? 1 : -1;
    for (int64_t done = 0; done != edges;) {
        const int64_t n = (edges - done) * dir > step ? step * dir : edges - done;
        tim_model_turn(t, n);
        done += n;
        TEST_ASSERT_EQUAL_INT(0, read_both());
    }
}

static void test_drv_encoder_without_init_reads_nothing(void)
{
    /* First of the suite: the driver has not been started. */
    TEST_ASSERT_EQUAL_INT(-ENODEV, read_both());
    TEST_ASSERT_EQUAL_INT32(0, l_count);
    TEST_ASSERT_EQUAL_INT32(0, r_count);
}

static void test_drv_encoder_init_sets_encoder_mode_3_on_both_timers(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_encoder_init());
    TEST_ASSERT_EQUAL_UINT(1u, board_host.encoders_enabled);
    const tim_model_t *t[2] = { &left, &right };
    for (unsigned i = 0; i < 2u; i++) {
        TEST_ASSERT_EQUAL_HEX32(0x3u, t[i]->p.reg[0x08 / 4] & 0x7u); /* SMS */
        TEST_ASSERT_EQUAL_HEX32(0x8181u, t[i]->p.reg[0x18 / 4]);     /* CCMR1 */
        TEST_ASSERT_EQUAL_HEX32(0x0u, t[i]->p.reg[0x20 / 4] & 0x2u); /* CC1P */
        TEST_ASSERT_EQUAL_HEX32(0x1u, t[i]->p.reg[0x00 / 4] & 0x1u); /* CEN */
        TEST_ASSERT_EQUAL_HEX32(0x0u, t[i]->p.reg[0x28 / 4]);        /* PSC */
    }
    TEST_ASSERT_EQUAL_HEX32(0xFFFFu, left.p.reg[0x2C / 4]);      /* ARR: 16 bits */
    TEST_ASSERT_EQUAL_HEX32(0xFFFFFFFFu, right.p.reg[0x2C / 4]); /* ARR: 32 bits */
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_INT32(0, l_count);
    TEST_ASSERT_EQUAL_INT32(0, r_count);
}

static void test_drv_encoder_counts_what_the_shafts_turn_both_ways(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_encoder_init());
    tim_model_turn(&left, 100);
    tim_model_turn(&right, -50);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_INT32(100, l_count);
    TEST_ASSERT_EQUAL_INT32(-50, r_count);
    tim_model_turn(&left, -130);
    tim_model_turn(&right, 7);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_INT32(-30, l_count);
    TEST_ASSERT_EQUAL_INT32(-43, r_count);
}

static void test_drv_encoder_16_bit_counter_wraps_up_and_down_between_two_reads(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_encoder_init());
    /* To 65,530 (read every 10,000 edges), then 20 more: the counter passes
     * 0xFFFF and reads 14 (65,550 mod 65,536), the count 65,550. */
    turn_reading(&left, 65530, 10000);
    TEST_ASSERT_EQUAL_UINT32(65530u, tim_model_count(&left));
    tim_model_turn(&left, 20);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_UINT32(14u, tim_model_count(&left));
    TEST_ASSERT_EQUAL_INT32(65550, l_count);
    /* Down again through 0: 30 back reads 65,520 (−16 mod 65,536). */
    tim_model_turn(&left, -30);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_UINT32(65520u, tim_model_count(&left));
    TEST_ASSERT_EQUAL_INT32(65520, l_count);
    /* From 0 backwards: below zero the counter reads 65,536 − n. */
    turn_reading(&left, -65530, 10000);
    TEST_ASSERT_EQUAL_INT32(-10, l_count);
    TEST_ASSERT_EQUAL_UINT32(65526u, tim_model_count(&left));
}

static void test_drv_encoder_32_bit_counter_wraps_up_and_down_between_two_reads(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_encoder_init());
    tim_model_turn(&right, -5);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_UINT32(0xFFFFFFFBu, tim_model_count(&right));
    TEST_ASSERT_EQUAL_INT32(-5, r_count);
    /* Four turns of 2^30 − 1 and 9: 2^32 + 5 edges, back to 0 and past:
     * the counter reads 0 (−5 + 2^32 + 5), the count wraps with it. */
    turn_reading(&right, 4 * ((INT64_C(1) << 30) - 1) + 9, (INT64_C(1) << 30) - 1);
    TEST_ASSERT_EQUAL_UINT32(0u, tim_model_count(&right));
    TEST_ASSERT_EQUAL_INT32(0, r_count);
}

static void test_drv_encoder_past_half_the_range_between_two_reads_is_flagged_not_misread(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_encoder_init());
    tim_model_turn(&left, 100);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    /* 40,000 edges on the 16-bit counter between two reads: its difference
     * reads −25,536. The read says so, names the wheel, leaves its count;
     * the other wheel is read. */
    tim_model_turn(&left, 40000);
    tim_model_turn(&right, 7);
    TEST_ASSERT_EQUAL_INT(-ERANGE, read_both());
    TEST_ASSERT_EQUAL_UINT8(1u, hal_encoder_overran());
    TEST_ASSERT_EQUAL_INT32(100, l_count);
    TEST_ASSERT_EQUAL_INT32(7, r_count);
    /* From there on it reads again, from where the counter is. */
    tim_model_turn(&left, 5);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_UINT8(0u, hal_encoder_overran());
    TEST_ASSERT_EQUAL_INT32(105, l_count);
    /* The 32-bit counter: 2^31 + 10 edges read as −(2^31 − 10). */
    tim_model_turn(&right, (INT64_C(1) << 31) + 10);
    TEST_ASSERT_EQUAL_INT(-ERANGE, read_both());
    TEST_ASSERT_EQUAL_UINT8(2u, hal_encoder_overran());
    TEST_ASSERT_EQUAL_INT32(7, r_count);
    /* Both at once, backwards: a quarter of the 16-bit range exactly. */
    tim_model_turn(&left, -16384);
    tim_model_turn(&right, -(INT64_C(1) << 30));
    TEST_ASSERT_EQUAL_INT(-ERANGE, read_both());
    TEST_ASSERT_EQUAL_UINT8(3u, hal_encoder_overran());
    /* Just under a quarter is a motion. */
    tim_model_turn(&left, 16383);
    TEST_ASSERT_EQUAL_INT(0, read_both());
    TEST_ASSERT_EQUAL_INT32(105 + 16383, l_count);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_drv_encoder_without_init_reads_nothing);
    RUN_TEST(test_drv_encoder_init_sets_encoder_mode_3_on_both_timers);
    RUN_TEST(test_drv_encoder_counts_what_the_shafts_turn_both_ways);
    RUN_TEST(test_drv_encoder_16_bit_counter_wraps_up_and_down_between_two_reads);
    RUN_TEST(test_drv_encoder_32_bit_counter_wraps_up_and_down_between_two_reads);
    RUN_TEST(test_drv_encoder_past_half_the_range_between_two_reads_is_flagged_not_misread);
    return UNITY_END();
}
