/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the motor driver (hal/stm32/motor_pwm.c) against its
 * registers: the STM32F405 board's TIM3 (16 bits, 84 MHz kernel clock) as
 * the SVD lays it out, a model of a timer in PWM mode 1
 * (tests/unit/stm32_host/model_tim.h), and the direction and enable pins
 * through the board (board_host.h).
 *
 * Expected values by hand: 84 MHz / 20 kHz = 4,200 counts a period, ARR
 * 4,199; a command c of full scale 10,000 gives the duty |c| / 10,000, the
 * compare value |c| · 4,200 / 10,000 (RM0090 §18.3.9: PWM mode 1 is high
 * while CNT < CCR; CCR = ARR + 1 is always high); the preload (OCxPE) takes
 * a new duty at the next update, 50 µs at most.
 */
#include <errno.h>
#include <stdint.h>

#include "board_host.h"
#include "hal/hal_motor.h"
#include "model_tim.h"
#include "stm32_hal.h"
#include "stm32_host.h"
#include "unity.h"

static tim_model_t pwm;

void setUp(void)
{
    stm32_host_reset();
    board_host_reset();
    tim_model_init(&pwm, TIM3_BASE, 16u, TIM3_IRQn, 84000000u);
}

void tearDown(void) {}

/* A PWM period and a bit: any new duty is in force. */
static void one_period(void) { stm32_host_run_us(60u); }

static void test_drv_pwm_without_init_refuses_a_command(void)
{
    /* First of the suite: the driver has not been started. */
    TEST_ASSERT_EQUAL_INT(-ENODEV, hal_motor_set(1000, 1000));
    TEST_ASSERT_FALSE(board_host.motor_enabled);
}

static void test_drv_pwm_a_clock_without_a_period_is_refused(void)
{
    /* 2 GHz / 20 kHz = 100,000 counts: beyond 16 bits. */
    board_host.clocks.apb1_tim_hz = 2000000000u;
    TEST_ASSERT_EQUAL_INT(-EINVAL, hal_motor_init());
    board_host.clocks.apb1_tim_hz = 20000u; /* one count: no duty to set */
    TEST_ASSERT_EQUAL_INT(-EINVAL, hal_motor_init());
}

static void test_drv_pwm_init_sets_pwm_mode_1_on_both_channels_driver_off(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_motor_init());
    TEST_ASSERT_EQUAL_UINT32(4199u, pwm.p.reg[0x2C / 4]);        /* ARR */
    TEST_ASSERT_EQUAL_UINT32(0u, pwm.p.reg[0x28 / 4]);           /* PSC */
    TEST_ASSERT_EQUAL_HEX32(0x6868u, pwm.p.reg[0x18 / 4]);       /* OCxM 110, OCxPE */
    TEST_ASSERT_EQUAL_HEX32(0x11u, pwm.p.reg[0x20 / 4] & 0x11u); /* CC1E, CC2E */
    TEST_ASSERT_EQUAL_HEX32(0x81u, pwm.p.reg[0x00 / 4] & 0x81u); /* ARPE, CEN */
    TEST_ASSERT_TRUE(pwm.update_events >= 1u);                   /* UG: loaded */
    TEST_ASSERT_TRUE(tim_model_pwm_on(&pwm, 1u) && tim_model_pwm_on(&pwm, 2u));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tim_model_duty(&pwm, 1u));
    TEST_ASSERT_FALSE(board_host.motor_enabled);
    TEST_ASSERT_TRUE(board_host.timers_enabled >= 1u);
}

static void test_drv_pwm_duty_is_the_command_with_its_direction(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_motor_init());
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(5000, -2500));
    TEST_ASSERT_TRUE(board_host.motor_enabled);
    TEST_ASSERT_TRUE(board_host.forward[0]);
    TEST_ASSERT_FALSE(board_host.forward[1]);
    one_period();
    TEST_ASSERT_EQUAL_DOUBLE(0.5, tim_model_duty(&pwm, 1u));  /* CCR 2,100 */
    TEST_ASSERT_EQUAL_DOUBLE(0.25, tim_model_duty(&pwm, 2u)); /* CCR 1,050 */
    /* And the other way round: each wheel's direction is its own. */
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(-2500, 5000));
    TEST_ASSERT_FALSE(board_host.forward[0]);
    TEST_ASSERT_TRUE(board_host.forward[1]);
    one_period();
    TEST_ASSERT_EQUAL_DOUBLE(0.25, tim_model_duty(&pwm, 1u));
    TEST_ASSERT_EQUAL_DOUBLE(0.5, tim_model_duty(&pwm, 2u));
    /* 1 of 10,000: 0.42 counts, rounded to 0; 3: 1.26, to 1. */
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(1, 3));
    one_period();
    TEST_ASSERT_EQUAL_UINT32(0u, pwm.ccr[0]);
    TEST_ASSERT_EQUAL_UINT32(1u, pwm.ccr[1]);
}

static void test_drv_pwm_a_new_duty_waits_for_the_period_to_end(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_motor_init());
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(2000, 2000));
    one_period();
    TEST_ASSERT_EQUAL_DOUBLE(0.2, tim_model_duty(&pwm, 1u));
    /* Just after a period began: the preload holds the new value back for
     * the rest of it, so no period is cut short (OCxPE). */
    const unsigned before = pwm.update_events;
    while (pwm.update_events == before) {
        stm32_host_run_us(1u);
    }
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(8000, 8000));
    TEST_ASSERT_EQUAL_UINT(before + 1u, pwm.update_events);
    TEST_ASSERT_EQUAL_DOUBLE(0.2, tim_model_duty(&pwm, 1u));
    one_period();
    TEST_ASSERT_EQUAL_DOUBLE(0.8, tim_model_duty(&pwm, 1u));
}

static void test_drv_pwm_saturates_at_full_scale_either_way(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_motor_init());
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(10000, -10000));
    one_period();
    /* Full scale: CCR = ARR + 1, high the whole period. */
    TEST_ASSERT_EQUAL_UINT32(4200u, pwm.ccr[0]);
    TEST_ASSERT_EQUAL_DOUBLE(1.0, tim_model_duty(&pwm, 2u));
    TEST_ASSERT_FALSE(board_host.forward[1]);
    /* Beyond it: still full, never more, and the direction kept. */
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(INT16_MAX, INT16_MIN));
    one_period();
    TEST_ASSERT_EQUAL_UINT32(4200u, pwm.ccr[0]);
    TEST_ASSERT_EQUAL_UINT32(4200u, pwm.ccr[1]);
    TEST_ASSERT_TRUE(board_host.forward[0]);
    TEST_ASSERT_FALSE(board_host.forward[1]);
}

static void test_drv_pwm_a_halt_brakes_a_fault_coasts(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_motor_init());
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(6000, 6000));
    one_period();
    /* A halt's end (the application's ramp reaching 0): duty 0 with the
     * driver enabled: the bridge holds the motor (brake, on PWM/DIR
     * drivers with the low side on between pulses; docs/porting.md). */
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(0, 0));
    one_period();
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tim_model_duty(&pwm, 1u));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tim_model_duty(&pwm, 2u));
    TEST_ASSERT_TRUE(board_host.motor_enabled);
    /* A fault (hal_motor_stop()): the driver disabled at once, the windings
     * open: the wheels coast; the duty 0 from the next period. */
    TEST_ASSERT_EQUAL_INT(0, hal_motor_set(6000, -6000));
    one_period();
    hal_motor_stop();
    TEST_ASSERT_FALSE(board_host.motor_enabled);
    one_period();
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tim_model_duty(&pwm, 1u));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tim_model_duty(&pwm, 2u));
}

static void test_drv_pwm_a_flashing_image_has_no_simulated_motors(void)
{
    /* The wheel loop's hooks for the PIL images' simulated motors
     * (pil_wheels.c) do nothing beside a real driver: no period is run for
     * the loop, no model time is spent. */
    TEST_ASSERT_FALSE(stm32_wheels_period(1000u));
    stm32_wheels_lockstep();
    TEST_ASSERT_EQUAL_UINT32(0u, stm32_wheels_model_cycles());
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_drv_pwm_without_init_refuses_a_command);
    RUN_TEST(test_drv_pwm_a_clock_without_a_period_is_refused);
    RUN_TEST(test_drv_pwm_init_sets_pwm_mode_1_on_both_channels_driver_off);
    RUN_TEST(test_drv_pwm_duty_is_the_command_with_its_direction);
    RUN_TEST(test_drv_pwm_a_new_duty_waits_for_the_period_to_end);
    RUN_TEST(test_drv_pwm_saturates_at_full_scale_either_way);
    RUN_TEST(test_drv_pwm_a_halt_brakes_a_fault_coasts);
    RUN_TEST(test_drv_pwm_a_flashing_image_has_no_simulated_motors);
    return UNITY_END();
}
