/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the board-independent computations of the STM32 ports
 * (hal/stm32/stm32_calc.c: watchdog, timer, PWM, encoder, reset cause,
 * SysTick, USART baud rate) and of the wheel-speed-to-motor glue
 * (hal/stm32/wheel_cmd.c, against the encoder and motor fakes of hal/fake),
 * in both numeric modes.
 *
 * Neither source touches a register, so the host test build compiles and
 * links them (TEST_SRCS_test_stm32_calc in the Makefile).
 * Expected values are derived by hand beside each case from the reference
 * manuals' formulas (RM0090 §21.3.3 IWDG, §18.3.1 timer time base, §18.3.12
 * encoder interface, §30.3.4 USART baud rate).
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>

#include "ctrl/ctl.h"
#include "div64.h"
#include "hal_fake.h"
#include "stm32_calc.h"
#include "unity.h"
#include "wheel_cmd.h"

void setUp(void) { hal_fake_reset(); }
void tearDown(void) {}

/* ---------------------------------------------------------------- IWDG */

static void expect_iwdg(uint32_t ms, uint32_t lsi, unsigned pr, unsigned rlr)
{
    stm32_iwdg_t c;
    TEST_ASSERT_EQUAL_INT(0, stm32_iwdg_config(ms, lsi, &c));
    TEST_ASSERT_EQUAL_UINT(pr, c.pr);
    TEST_ASSERT_EQUAL_UINT(rlr, c.rlr);
}

/* timeout = 4 · 2^pr · (rlr + 1) / f_LSI. */
static void test_stm32_iwdg_hand_values(void)
{
    /* F4 board: 100 ms at 32 kHz = 3200 LSI clocks = 800 × 4: pr 0, rlr 799. */
    expect_iwdg(100, 32000, 0, 799);
    /* F1 board: 100 ms at 40 kHz = 4000 clocks = 1000 × 4: pr 0, rlr 999. */
    expect_iwdg(100, 40000, 0, 999);
    /* 1 s at 32 kHz = 32000 clocks: / 4 = 8000 > 4096; / 8 = 4000: pr 1, rlr 3999. */
    expect_iwdg(1000, 32000, 1, 3999);
    /* 3 ms at 30 kHz = 90 clocks / 4 = 22.5, rounded up to 23: never shorter. */
    expect_iwdg(3, 30000, 0, 22);
    /* The longest: 4096 × 256 / 32 kHz = 32.768 s: pr 6, rlr 4095. */
    expect_iwdg(32768, 32000, 6, 4095);
}

static void test_stm32_iwdg_rejects_out_of_range(void)
{
    stm32_iwdg_t c;
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_iwdg_config(32769, 32000, &c));
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_iwdg_config(0, 32000, &c));
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_iwdg_config(100, 0, &c));
}

/* Property: the timeout is never shorter than asked, and within one reload
 * step (4 · 2^pr clocks) of it. */
static void test_stm32_iwdg_timeout_never_shorter(void)
{
    for (uint32_t ms = 1; ms <= 30000; ms += 37) {
        stm32_iwdg_t c;
        TEST_ASSERT_EQUAL_INT(0, stm32_iwdg_config(ms, 32000, &c));
        const double step_ms = 4.0 * (double)(1u << c.pr) / 32.0;
        const double got_ms = step_ms * (c.rlr + 1.0);
        TEST_ASSERT_TRUE(got_ms >= (double)ms);
        TEST_ASSERT_TRUE(got_ms < (double)ms + step_ms);
    }
}

/* -------------------------------------------------------------- timers */

static void expect_timer(uint32_t clk, uint32_t us, unsigned psc, unsigned arr, int32_t ppm)
{
    stm32_timer_t t;
    int32_t err = 99;
    TEST_ASSERT_EQUAL_INT(0, stm32_timer_period(clk, us, &t, &err));
    TEST_ASSERT_EQUAL_UINT(psc, t.psc);
    TEST_ASSERT_EQUAL_UINT(arr, t.arr);
    TEST_ASSERT_EQUAL_INT32(ppm, err);
}

static void test_stm32_timer_control_period(void)
{
    /* F4: TIM2 at 84 MHz, 20 ms = 1 680 000 clocks; the prescaler must be
     * >= 1680000 / 65536 = 25.6; 26 and 27 do not divide it, 28 does:
     * 60 000 counts. psc 27, arr 59999. */
    expect_timer(84000000, 20000, 27, 59999, 0);
    /* F1: 72 MHz, 1 440 000 clocks, >= 21.97: 22, 23 no, 24 gives 60 000. */
    expect_timer(72000000, 20000, 23, 59999, 0);
    /* HSI fallbacks: 16 MHz: 320 000 clocks, >= 4.88: 5 gives 64 000. */
    expect_timer(16000000, 20000, 4, 63999, 0);
    /* 8 MHz: 160 000, >= 2.44: 3 no, 4 gives 40 000. */
    expect_timer(8000000, 20000, 3, 39999, 0);
    /* 1 ms at 72 MHz: 72 000 clocks, >= 1.1: 2 gives 36 000. */
    expect_timer(72000000, 1000, 1, 35999, 0);
}

/* Not exact: 1 000 003 Hz × 0.1 s = 100 000.3 clocks; prescaler 2, reload
 * round(50 000.15) = 50 000: 100 000 clocks, (100000 - 100000.3) / 100000.3
 * = -3.0 ppm. */
static void test_stm32_timer_inexact_reports_error(void)
{
    expect_timer(1000003, 100000, 1, 49999, -3);
}

static void test_stm32_timer_rejects_out_of_range(void)
{
    stm32_timer_t t;
    int32_t err;
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_timer_period(0, 20000, &t, &err));
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_timer_period(84000000, 0, &t, &err));
    /* 2^32 · 84 MHz^-1 = 51.1 s is the longest period. */
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_timer_period(84000000, 60000000, &t, &err));
}

/* ----------------------------------------------------------------- PWM */

static void test_stm32_pwm_compare(void)
{
    /* 84 MHz / 20 kHz: arr 4199, 4200 counts per period. */
    TEST_ASSERT_EQUAL_UINT32(0, stm32_pwm_compare(0, 10000, 4199));
    TEST_ASSERT_EQUAL_UINT32(2100, stm32_pwm_compare(5000, 10000, 4199));
    TEST_ASSERT_EQUAL_UINT32(1050, stm32_pwm_compare(-2500, 10000, 4199));
    TEST_ASSERT_EQUAL_UINT32(4200, stm32_pwm_compare(10000, 10000, 4199)); /* always high */
    TEST_ASSERT_EQUAL_UINT32(4200, stm32_pwm_compare(-32768, 10000, 4199));
    /* 1 → 0.42 counts → 0; 2 → 0.84 → 1; 3 → 1.26 → 1 (nearest). */
    TEST_ASSERT_EQUAL_UINT32(0, stm32_pwm_compare(1, 10000, 4199));
    TEST_ASSERT_EQUAL_UINT32(1, stm32_pwm_compare(2, 10000, 4199));
    TEST_ASSERT_EQUAL_UINT32(1, stm32_pwm_compare(3, 10000, 4199));
    /* 72 MHz / 20 kHz: arr 3599; 3333 → 1199.88 → 1200. */
    TEST_ASSERT_EQUAL_UINT32(1200, stm32_pwm_compare(3333, 10000, 3599));
    TEST_ASSERT_EQUAL_UINT32(0, stm32_pwm_compare(5000, 0, 3599));
}

/* --------------------------------------------------------- reset cause */

static void test_stm32_reset_cause_most_specific_flag_wins(void)
{
    const uint32_t pin = STM32_RCC_CSR_PINRSTF;
    TEST_ASSERT_EQUAL_INT(HAL_RESET_POWER_ON,
                          stm32_reset_cause(STM32_RCC_CSR_PORRSTF | STM32_RCC_CSR_BORRSTF | pin));
    TEST_ASSERT_EQUAL_INT(HAL_RESET_POWER_ON, stm32_reset_cause(STM32_RCC_CSR_BORRSTF | pin));
    TEST_ASSERT_EQUAL_INT(HAL_RESET_WATCHDOG, stm32_reset_cause(STM32_RCC_CSR_IWDGRSTF | pin));
    TEST_ASSERT_EQUAL_INT(HAL_RESET_WATCHDOG, stm32_reset_cause(STM32_RCC_CSR_WWDGRSTF | pin));
    TEST_ASSERT_EQUAL_INT(HAL_RESET_SOFTWARE, stm32_reset_cause(STM32_RCC_CSR_SFTRSTF | pin));
    TEST_ASSERT_EQUAL_INT(HAL_RESET_OTHER, stm32_reset_cause(STM32_RCC_CSR_LPWRRSTF | pin));
    TEST_ASSERT_EQUAL_INT(HAL_RESET_PIN, stm32_reset_cause(pin));
    TEST_ASSERT_EQUAL_INT(HAL_RESET_OTHER, stm32_reset_cause(0));
    /* The other CSR bits (LSION, LSIRDY, RMVF) do not matter. */
    TEST_ASSERT_EQUAL_INT(HAL_RESET_PIN, stm32_reset_cause(pin | 0x01000003u));
}

static void test_stm32_systick_reload(void)
{
    TEST_ASSERT_EQUAL_UINT32(167999, stm32_systick_reload(168000000));
    TEST_ASSERT_EQUAL_UINT32(71999, stm32_systick_reload(72000000));
    TEST_ASSERT_EQUAL_UINT32(15999, stm32_systick_reload(16000000));
}

/* ------------------------------------------------------------- USART */

static void expect_brr(uint32_t pclk, uint32_t baud, unsigned brr, int32_t err_ppm)
{
    uint16_t b;
    int32_t err;
    TEST_ASSERT_EQUAL_INT(0, stm32_usart_brr(pclk, baud, &b, &err));
    TEST_ASSERT_EQUAL_UINT(brr, b);
    TEST_ASSERT_EQUAL_INT32(err_ppm, err);
}

/* BRR = pclk / baud rounded (16 × the divider, 12.4 fixed point); the error
 * is pclk / (BRR · baud) - 1. */
static void test_stm32_usart_brr_hand_values(void)
{
    /* F4, APB1 42 MHz: 42e6 / 460800 = 91.146 → 91 (mantissa 5, fraction 11);
     * 42e6 / 91 = 461538.5 baud: 67200 / 41932800 = +1602.6 ppm. */
    expect_brr(42000000, 460800, 91, 1603);
    /* F1, APB1 36 MHz: 78.125 → 78; 36e6 / 78 = 461538.5 baud, the same +1603 ppm. */
    expect_brr(36000000, 460800, 78, 1603);
    /* F4 on its HSI fallback (16 MHz): 34.72 → 35, 457142.9 baud: -128000 /
     * 16128000 = -7936.5 ppm, rounded away from zero. */
    expect_brr(16000000, 460800, 35, -7937);
    /* F1 on HSI (8 MHz): 17.36 → 17, 470588.2 baud: 166400 / 7833600 =
     * +21241.8 ppm, still within the 3 % limit. */
    expect_brr(8000000, 460800, 17, 21242);
    /* 72 MHz / 115200 = 625 exactly. */
    expect_brr(72000000, 115200, 625, 0);
}

static void test_stm32_usart_brr_rejects_out_of_range(void)
{
    uint16_t b;
    int32_t err;
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_usart_brr(42000000, 0, &b, &err));
    /* 8 MHz / 1 Mbaud = 8 < 16: a divider below 1. */
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_usart_brr(8000000, 1000000, &b, &err));
    /* 42 MHz / 300 baud = 140000 > 0xFFFF. */
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_usart_brr(42000000, 300, &b, &err));
    /* 1 MHz / 60643 = 16.49 → 16: 62500 baud, +3.06 % > 3 %. */
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_usart_brr(1000000, 60643, &b, &err));
    TEST_ASSERT_EQUAL_INT(-EINVAL, stm32_usart_brr(42000000, 460800, NULL, &err));
}

/* ------------------------------------------------------- wheel command */

static num_t n(double x) { return num_from_float((float)x); }

static void test_wheel_cmd_scales_to_full_scale(void)
{
    /* 3 / 8 = 0.375 exactly in both modes: 3750. */
    TEST_ASSERT_EQUAL_INT16(3750, wheel_cmd_from_speed(n(3.0), n(8.0)));
    TEST_ASSERT_EQUAL_INT16(-3750, wheel_cmd_from_speed(n(-3.0), n(8.0)));
    /* 12.345 / 40 = 0.308625 → 3086.25 → 3086 (fixed: 12.345 is
     * 809042 / 65536 = 12.3450012, still 3086). */
    TEST_ASSERT_EQUAL_INT16(3086, wheel_cmd_from_speed(n(12.345), n(40.0)));
    /* Below half a step: 1/1024 / 20.48 · 10000 = 0.477 → 0, either sign. */
    TEST_ASSERT_EQUAL_INT16(0, wheel_cmd_from_speed(n(1.0 / 1024.0), n(20.48)));
    TEST_ASSERT_EQUAL_INT16(0, wheel_cmd_from_speed(n(-1.0 / 1024.0), n(20.48)));
    /* 1/512 / 20.48 · 10000 = 0.954 → 1. */
    TEST_ASSERT_EQUAL_INT16(1, wheel_cmd_from_speed(n(1.0 / 512.0), n(20.48)));
    TEST_ASSERT_EQUAL_INT16(0, wheel_cmd_from_speed(NUM_ZERO, n(8.0)));
}

static void test_wheel_cmd_clamps_and_guards(void)
{
    TEST_ASSERT_EQUAL_INT16(10000, wheel_cmd_from_speed(n(100.0), n(100.0)));
    TEST_ASSERT_EQUAL_INT16(10000, wheel_cmd_from_speed(n(150.0), n(100.0)));
    TEST_ASSERT_EQUAL_INT16(-10000, wheel_cmd_from_speed(n(-1000.0), n(100.0)));
    /* A limit of 0 or below commands nothing. */
    TEST_ASSERT_EQUAL_INT16(0, wheel_cmd_from_speed(n(5.0), NUM_ZERO));
    TEST_ASSERT_EQUAL_INT16(0, wheel_cmd_from_speed(n(5.0), n(-10.0)));
#ifndef NUM_FIXED
    TEST_ASSERT_EQUAL_INT16(0, wheel_cmd_from_speed(NAN, n(10.0)));
    TEST_ASSERT_EQUAL_INT16(0, wheel_cmd_from_speed(n(1.0), NAN));
    TEST_ASSERT_EQUAL_INT16(10000, wheel_cmd_from_speed(INFINITY, n(10.0)));
#endif
}

/* ------------------------------------------------------------ encoder */

static void test_stm32_encoder_trusts_less_than_a_quarter_of_the_range(void)
{
    /* 16 bits: a quarter is 16,384; 16,383 either way is taken. */
    TEST_ASSERT_TRUE(stm32_encoder_trusted(16383, 16u));
    TEST_ASSERT_TRUE(stm32_encoder_trusted(-16383, 16u));
    TEST_ASSERT_FALSE(stm32_encoder_trusted(16384, 16u));
    TEST_ASSERT_FALSE(stm32_encoder_trusted(-16384, 16u));
    /* +40,000 counts between two reads sign-extend to −25,536: not taken. */
    TEST_ASSERT_FALSE(stm32_encoder_trusted(stm32_encoder_step(40000u, 0u, 16u), 16u));
    /* 32 bits: a quarter is 2^30. */
    TEST_ASSERT_TRUE(stm32_encoder_trusted(0x3FFFFFFF, 32u));
    TEST_ASSERT_FALSE(stm32_encoder_trusted(0x40000000, 32u));
    TEST_ASSERT_FALSE(stm32_encoder_trusted(INT32_MIN, 32u));
}

static void test_stm32_encoder_step_sign_extends_16_bits(void)
{
    TEST_ASSERT_EQUAL_INT32(5, stm32_encoder_step(105u, 100u, 16u));
    TEST_ASSERT_EQUAL_INT32(-5, stm32_encoder_step(95u, 100u, 16u));
    /* Across the wrap: 0xFFFE → 0x0003 is +5, 0x0003 → 0xFFFE is −5. */
    TEST_ASSERT_EQUAL_INT32(5, stm32_encoder_step(0x0003u, 0xFFFEu, 16u));
    TEST_ASSERT_EQUAL_INT32(-5, stm32_encoder_step(0xFFFEu, 0x0003u, 16u));
    /* The bound: 32,767 either way is right; 32,768 reads as −32,768. */
    TEST_ASSERT_EQUAL_INT32(32767, stm32_encoder_step(32767u, 0u, 16u));
    TEST_ASSERT_EQUAL_INT32(-32767, stm32_encoder_step(0u, 32767u, 16u));
    TEST_ASSERT_EQUAL_INT32(-32768, stm32_encoder_step(32768u, 0u, 16u));
    /* A 16-bit timer's register never has the upper half set; QEMU's does:
     * it is ignored. */
    TEST_ASSERT_EQUAL_INT32(3, stm32_encoder_step(0x12340003u, 0x56780000u, 16u));
}

static void test_stm32_encoder_step_takes_32_bits_whole(void)
{
    TEST_ASSERT_EQUAL_INT32(100000, stm32_encoder_step(100000u, 0u, 32u));
    TEST_ASSERT_EQUAL_INT32(-2, stm32_encoder_step(0xFFFFFFFFu, 1u, 32u));
}

static void test_stm32_encoder_regs_hand_values(void)
{
    /* SMCR.SMS = 011; CCMR1: CC1S = 01 (bits 1:0), IC1F (7:4), CC2S = 01
     * (9:8), IC2F (15:12): filter 8 gives 0x8181; CCER.CC1P (bit 1). */
    const stm32_encoder_regs_t r = stm32_encoder_regs(8u, false);
    TEST_ASSERT_EQUAL_HEX32(0x3u, r.smcr);
    TEST_ASSERT_EQUAL_HEX32(0x8181u, r.ccmr1);
    TEST_ASSERT_EQUAL_HEX32(0x0u, r.ccer);
    const stm32_encoder_regs_t inv = stm32_encoder_regs(0xFu, true);
    TEST_ASSERT_EQUAL_HEX32(0xF1F1u, inv.ccmr1);
    TEST_ASSERT_EQUAL_HEX32(0x2u, inv.ccer);
    /* Only the filter's four bits are taken. */
    TEST_ASSERT_EQUAL_HEX32(0x1111u, stm32_encoder_regs(0x11u, false).ccmr1);
}

/* ----------------------------------------------------- wheel loop glue */

static whl_t loop;

static void loop_start(void)
{
    ctl_params_t c;
    ctl_params_default(&c);
    whl_init(&loop, &c.wheel, c.wheel_accel);
}

static void test_wheel_period_reads_encoders_and_drives_the_motors(void)
{
    loop_start();
    whl_output_t out;
    /* At rest, setpoint 0: no drive, the driver enabled at duty 0. */
    TEST_ASSERT_EQUAL_INT(0, wheel_cmd_period(&loop, NUM_ZERO, NUM_ZERO, &out));
    TEST_ASSERT_EQUAL_UINT(1u, hal_fake.encoder_reads);
    TEST_ASSERT_EQUAL_UINT(1u, hal_fake.motor_sets);
    TEST_ASSERT_EQUAL_INT16(0, hal_fake.motor[0]);
    /* 10 rad/s asked, the wheels not moving yet: the loop's commands go to
     * the motors, forward on the left, backward on the right. */
    TEST_ASSERT_EQUAL_INT(0, wheel_cmd_period(&loop, num_from_int(10), num_from_int(-10), &out));
    TEST_ASSERT_TRUE(out.cmd[0] > 0 && out.cmd[1] < 0);
    TEST_ASSERT_EQUAL_INT16(out.cmd[0], hal_fake.motor[0]);
    TEST_ASSERT_EQUAL_INT16(out.cmd[1], hal_fake.motor[1]);
    TEST_ASSERT_TRUE(hal_fake.motor_enabled);
    TEST_ASSERT_EQUAL_UINT(0u, hal_fake.motor_stops);
}

static void test_wheel_period_stops_the_motors_on_a_fault(void)
{
    loop_start();
    whl_output_t out;
    (void)wheel_cmd_period(&loop, num_from_int(10), num_from_int(10), &out);
    /* 1,000 counts in a period: more than the wheel can turn. */
    hal_fake.encoder[0] = 1000;
    TEST_ASSERT_EQUAL_INT(0, wheel_cmd_period(&loop, num_from_int(10), num_from_int(10), &out));
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_LEFT, out.faults);
    TEST_ASSERT_EQUAL_UINT(1u, hal_fake.motor_stops);
    TEST_ASSERT_FALSE(hal_fake.motor_enabled);
    const unsigned sets = hal_fake.motor_sets;
    (void)wheel_cmd_period(&loop, num_from_int(10), num_from_int(10), &out);
    TEST_ASSERT_EQUAL_UINT(sets, hal_fake.motor_sets); /* stays stopped */
    TEST_ASSERT_FALSE(hal_fake.motor_enabled);
}

static void test_wheel_period_stops_the_motors_when_a_counter_overran(void)
{
    loop_start();
    whl_output_t out;
    (void)wheel_cmd_period(&loop, num_from_int(10), num_from_int(10), &out);
    TEST_ASSERT_EQUAL_UINT8(0u, out.faults);
    /* The right counter moved too far to be read (hal_encoder.h): that
     * wheel's encoder fault, both motors stopped at once. */
    hal_fake.encoder_rc = -ERANGE;
    hal_fake.encoder_overran = 2u;
    TEST_ASSERT_EQUAL_INT(0, wheel_cmd_period(&loop, num_from_int(10), num_from_int(10), &out));
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_RIGHT, out.faults);
    TEST_ASSERT_EQUAL_UINT(1u, hal_fake.motor_stops);
    TEST_ASSERT_FALSE(hal_fake.motor_enabled);
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[1]);
}

static void test_wheel_period_without_encoders_drives_open_loop(void)
{
    loop_start();
    hal_fake.encoder_rc = -ENODEV;
    whl_output_t out;
    /* 17.28 rad/s of a 34.56 rad/s free speed: half drive, 5000 (fixed:
     * both held to 2^-16, the ratio still 0.5 within 2e-6). */
    TEST_ASSERT_EQUAL_INT(-ENODEV, wheel_cmd_period(&loop, n(17.28), n(-34.56 / 4.0), &out));
    TEST_ASSERT_EQUAL_INT16(5000, hal_fake.motor[0]);
    TEST_ASSERT_EQUAL_INT16(-2500, hal_fake.motor[1]);
    TEST_ASSERT_EQUAL_INT16(5000, out.cmd[0]);
    TEST_ASSERT_EQUAL_UINT8(0u, out.faults);
}

/* ------------------------------------------------------------- div64 */

static void test_div64_hand_values(void)
{
    uint64_t r = 99u;
    TEST_ASSERT_EQUAL_UINT64(0u, div64_u(0u, 7u, &r));
    TEST_ASSERT_EQUAL_UINT64(0u, r);
    TEST_ASSERT_EQUAL_UINT64(2u, div64_u(17u, 7u, &r)); /* 17 = 2·7 + 3 */
    TEST_ASSERT_EQUAL_UINT64(3u, r);
    /* 2^64 − 1 = 3 · 5 · 17 · 257 · 641 · 65537 · 6700417. */
    TEST_ASSERT_EQUAL_UINT64(UINT64_C(0x5555555555555555), div64_u(UINT64_MAX, 3u, &r));
    TEST_ASSERT_EQUAL_UINT64(0u, r);
    TEST_ASSERT_EQUAL_UINT64(1u, div64_u(UINT64_MAX, UINT64_C(1) << 63, &r));
    TEST_ASSERT_EQUAL_UINT64((UINT64_C(1) << 63) - 1u, r);
    /* Outside the contract: 0 and the dividend back. */
    TEST_ASSERT_EQUAL_UINT64(0u, div64_u(5u, 0u, &r));
    TEST_ASSERT_EQUAL_UINT64(5u, r);
    /* Nearest, halves away from zero: 7/2 = 3.5 → 4, −7/2 → −4, 5/3 → 2. */
    TEST_ASSERT_EQUAL_INT64(4, div64_nearest(7, 2u));
    TEST_ASSERT_EQUAL_INT64(-4, div64_nearest(-7, 2u));
    TEST_ASSERT_EQUAL_INT64(2, div64_nearest(5, 3u));
    TEST_ASSERT_EQUAL_INT64(-2, div64_nearest(-5, 3u));
    TEST_ASSERT_EQUAL_INT64(0, div64_nearest(-1, 3u));
}

static void test_div64_agrees_with_c_division(void)
{
    /* The host's own 64-bit division is the independent reference. */
    uint64_t x = UINT64_C(0x9E3779B97F4A7C15);
    for (unsigned i = 0; i < 20000u; i++) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        const uint64_t n = x;
        const uint64_t d = (x >> (x % 60u)) | 1u; /* from 1 to large */
        uint64_t r = 0u;
        TEST_ASSERT_EQUAL_UINT64(n / d, div64_u(n, d, &r));
        TEST_ASSERT_EQUAL_UINT64(n % d, r);
        const int64_t s = (int64_t)(n >> 2) * ((x & 1u) != 0u ? -1 : 1);
        const uint64_t den = (d >> 2) | 1u;
        const int64_t half = (int64_t)(den / 2u);
        const int64_t want = (s + (s < 0 ? -half : half)) / (int64_t)den;
        TEST_ASSERT_EQUAL_INT64(want, div64_nearest(s, den));
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_div64_hand_values);
    RUN_TEST(test_div64_agrees_with_c_division);
    RUN_TEST(test_stm32_iwdg_hand_values);
    RUN_TEST(test_stm32_iwdg_rejects_out_of_range);
    RUN_TEST(test_stm32_iwdg_timeout_never_shorter);
    RUN_TEST(test_stm32_timer_control_period);
    RUN_TEST(test_stm32_timer_inexact_reports_error);
    RUN_TEST(test_stm32_timer_rejects_out_of_range);
    RUN_TEST(test_stm32_pwm_compare);
    RUN_TEST(test_stm32_reset_cause_most_specific_flag_wins);
    RUN_TEST(test_stm32_systick_reload);
    RUN_TEST(test_stm32_usart_brr_hand_values);
    RUN_TEST(test_stm32_usart_brr_rejects_out_of_range);
    RUN_TEST(test_wheel_cmd_scales_to_full_scale);
    RUN_TEST(test_wheel_cmd_clamps_and_guards);
    RUN_TEST(test_stm32_encoder_step_sign_extends_16_bits);
    RUN_TEST(test_stm32_encoder_trusts_less_than_a_quarter_of_the_range);
    RUN_TEST(test_stm32_encoder_step_takes_32_bits_whole);
    RUN_TEST(test_stm32_encoder_regs_hand_values);
    RUN_TEST(test_wheel_period_reads_encoders_and_drives_the_motors);
    RUN_TEST(test_wheel_period_stops_the_motors_on_a_fault);
    RUN_TEST(test_wheel_period_stops_the_motors_when_a_counter_overran);
    RUN_TEST(test_wheel_period_without_encoders_drives_open_loop);
    return UNITY_END();
}
