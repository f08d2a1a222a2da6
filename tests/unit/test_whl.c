/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the wheel-speed loop (firmware/wheel/whl.h), in closed loop
 * against the DC gearmotor model (sim/dcmotor/dcm.h, itself tested against its
 * datasheet and its first-order solution in test_dcm.c), at 1 kHz, with the
 * defaults of the limits table: the acceptance of the wheel loop.
 *
 * Expected values: the acceptance's bounds (settling within 2 % in 150 ms,
 * overshoot ≤ 10 %, ramp within 1 rad/s, load rejected within 100 ms, noise
 * below 0.4 rad/s, faults within their times), and where the model has an
 * analytic answer, that answer computed here from its constants: the drive
 * that holds a speed against a load (the loop's integral must find it), the
 * fastest the motor can reach a speed at full drive (no loop can beat it),
 * a speed from counts by hand (2π/1920 rad a count).
 */
#include <math.h>

#include "ctrl/ctl.h"
#include "dcm.h"
#include "test_util.h"
#include "unity.h"
#include "wheel/whl.h"

#define DT 1e-3 /* the default rate, 1 kHz */

static dcm_params_t mp;
static dcm_t m[WHL_N];
static whl_params_t wp;
static num_t accel; /* the setpoint ramp, wheel_accel [rad/s²] */
static whl_t w;
static whl_output_t out;
static unsigned k; /* periods run */

static void start(void)
{
    whl_init(&w, &wp, accel);
    k = 0;
}

void setUp(void)
{
    dcm_params_default(&mp);
    dcm_init(&m[0]);
    dcm_init(&m[1]);
    ctl_params_t c;
    ctl_params_default(&c);
    wp = c.wheel;
    /* No ramp of the loop's own: 10000 rad/s², wheel_accel's largest
     * (wheels that follow at once), 10 rad/s a period. */
    accel = tu_num(10000.0);
    start();
}
void tearDown(void) {}

static double now(void) { return k * DT; }

/* One period: read the encoders, step the loop, drive the motors. */
static void period(double left, double right)
{
    const whl_input_t in = { { tu_num(left), tu_num(right) },
                             { dcm_count(&m[0], &mp), dcm_count(&m[1], &mp) } };
    whl_step(&w, &in, &out);
    for (unsigned i = 0; i < WHL_N; i++) {
        TEST_ASSERT_TRUE(out.drive[i] >= num_neg(NUM_ONE) && out.drive[i] <= NUM_ONE);
        dcm_step(&m[i], &mp, tu_dbl(out.drive[i]), DT);
    }
    k++;
}

/* The stall torque at the output: Kt·V/R − τc (1.373 N·m, the datasheet's). */
static double stall_torque(void) { return mp.kt * mp.v_supply / mp.r_ohm - mp.tau_c; }

/* ------------------------------------------------------------ acceptance */

static void test_whl_step_settles_within_2_percent_in_150_ms(void)
{
    TEST_ASSERT_NUM_WITHIN(1e-3, 10.0, w.ramp_step); /* 10000 / 1000: a step */
    double peak[2] = { 0.0, 0.0 };
    double settled[2] = { 0.0, 0.0 }; /* last time outside ±2 % */
    double drive_sum[2] = { 0.0, 0.0 };
    while (now() < 0.6) {
        period(20.0, -20.0);
        for (unsigned i = 0; i < WHL_N; i++) {
            const double wi = i == 0 ? m[i].omega : -m[i].omega;
            peak[i] = fmax(peak[i], wi);
            if (fabs(wi - 20.0) > 0.02 * 20.0) {
                settled[i] = now();
            }
            if (now() > 0.4) {
                drive_sum[i] += fabs(tu_dbl(out.drive[i]));
            }
        }
    }
    /* Full drive from rest enters the band, 19.6 rad/s, at
     * −τm·ln(1 − 19.6/ω∞(1)) at the earliest (72 ms, dcm.h's solution): no
     * loop can beat that. */
    const double damp = mp.b + mp.kt * mp.ke / mp.r_ohm;
    const double w_full = (mp.kt * mp.v_supply / mp.r_ohm - mp.tau_c) / damp;
    const double t_min = -(mp.j / damp) * log(1.0 - 0.98 * 20.0 / w_full);
    /* The drive that holds 20 rad/s without load, by hand. */
    const double u_hold =
        mp.r_ohm / (mp.kt * mp.v_supply) * (mp.b * 20.0 + mp.tau_c) + mp.ke * 20.0 / mp.v_supply;
    for (unsigned i = 0; i < WHL_N; i++) {
        TEST_ASSERT_TRUE_MESSAGE(settled[i] < 0.150, "settles within 2 % in under 150 ms");
        TEST_ASSERT_TRUE(settled[i] >= t_min - DT);
        TEST_ASSERT_TRUE_MESSAGE(peak[i] <= 1.10 * 20.0, "overshoot at most 10 %");
        TEST_ASSERT_DOUBLE_WITHIN(0.01, u_hold, drive_sum[i] / 200.0);
    }
    TEST_ASSERT_EQUAL_UINT8(0u, out.faults);
}

static void test_whl_ramp_is_tracked_within_1_rad_s(void)
{
    /* 0 → 20 → −20 → 0 rad/s at 125 rad/s², the ramp docs/wheel.md sets
     * for this motor (four fifths of what full drive gives at 20 rad/s,
     * (34.56/0.0856)·(1 − 20/34.56) = 170 rad/s²), tracked thanks to the
     * acceleration feed-forward. */
    accel = tu_num(125.0);
    start();
    double worst = 0.0;
    while (now() < 1.5) {
        const double t = now();
        const double sp = t < 0.1 ? 0.0 : (t < 0.5 ? 20.0 : (t < 1.0 ? -20.0 : 0.0));
        period(sp, -sp);
        for (unsigned i = 0; i < WHL_N; i++) {
            const double wi = i == 0 ? m[i].omega : -m[i].omega;
            const double ref = i == 0 ? tu_dbl(w.w[i].setpoint) : -tu_dbl(w.w[i].setpoint);
            worst = fmax(worst, fabs(wi - ref));
        }
        /* The ramped setpoint: 125 rad/s² from t = 0.1 s, so 10 rad/s 80 ms
         * later (k counts the period just run). */
        if (k == 180u) {
            TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-3, 2e-3), 10.0, w.w[0].setpoint);
        }
    }
    TEST_ASSERT_TRUE_MESSAGE(worst <= 1.0, "ramp tracked within 1 rad/s");
    TEST_ASSERT_TRUE(worst > 0.0);
}

static void test_whl_setpoint_ramps_at_wheel_accel(void)
{
    /* One parameter for one fact: the loop's ramp is the control step's
     * wheel_accel, handed beside the loop's parameters. The table's default,
     * 20 rad/s² at 1 kHz: 0.02 rad/s a period, so 2 rad/s after 100 periods
     * and the 10 rad/s asked after 500 (by hand). */
    ctl_params_t c;
    ctl_params_default(&c);
    TEST_ASSERT_NUM_WITHIN(1e-3, 20.0, c.wheel_accel);
    accel = c.wheel_accel;
    start();
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-6, 2e-5), 0.02, w.ramp_step);
    while (k < 100u) {
        period(10.0, -10.0);
    }
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-4, 2e-3), 2.0, w.w[0].setpoint);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-4, 2e-3), -2.0, w.w[1].setpoint);
    while (k < 520u) {
        period(10.0, -10.0);
    }
    TEST_ASSERT_NUM_WITHIN(1e-6, 10.0, w.w[0].setpoint);
    /* A new ramp takes effect at once, the state kept: 125 rad/s² down to
     * 0 from 10 rad/s is 80 periods (0.125 rad/s each). */
    whl_set_params(&w, &wp, tu_num(125.0));
    for (unsigned i = 0; i < 40u; i++) {
        period(0.0, 0.0);
    }
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-4, 2e-3), 5.0, w.w[0].setpoint);
}

/* The steady speed at full drive against @p load, moving forward: ω∞ of
 * dcm.h with u = 1. */
static double full_drive_speed(double load)
{
    const double damp = mp.b + mp.kt * mp.ke / mp.r_ohm;
    return (mp.kt * mp.v_supply / mp.r_ohm - mp.tau_c - load) / damp;
}

/* The load under which full drive turns the wheel at @p omega (by hand from
 * the same ω∞). */
static double load_for(double omega)
{
    const double damp = mp.b + mp.kt * mp.ke / mp.r_ohm;
    return stall_torque() - omega * damp;
}

static void test_whl_release_after_a_1_s_stall_overshoots_at_most_10_percent(void)
{
    /* Held for 1 s by a load it can barely turn against (2 rad/s at full
     * drive: the drive saturated all the while, the windup's situation; a
     * wheel held so rigidly that it gives no count at all is stopped within
     * 0.1 s, test_whl_a_wheel_held_rigid_is_stopped_within_0_1_s). */
    wp.stall_time = tu_num(2.0); /* the windup, not the stall fault, is tested */
    start();
    const double load = load_for(2.0);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 2.0, full_drive_speed(load));
    double peak = 0.0;
    double integ_max = 0.0;
    while (now() < 2.0) {
        m[0].load = now() >= 0.3 && now() < 1.3 ? load : 0.0;
        period(20.0, 20.0);
        if (now() >= 1.3) {
            peak = fmax(peak, m[0].omega);
        }
        integ_max = fmax(integ_max, fabs(tu_dbl(w.w[0].integ)));
    }
    TEST_ASSERT_TRUE_MESSAGE(peak <= 1.10 * 20.0, "release overshoots at most 10 %");
    TEST_ASSERT_TRUE(peak >= 0.98 * 20.0); /* it did come back to speed */
    TEST_ASSERT_TRUE(integ_max <= 1.0);
    TEST_ASSERT_EQUAL_UINT8(0u, out.faults);
}

static void test_whl_load_step_of_30_percent_stall_is_rejected_within_100_ms(void)
{
    const double load = 0.3 * stall_torque();
    double dip = 0.0;
    double late_error = 0.0;
    double drive_sum = 0.0;
    while (now() < 1.2) {
        m[0].load = now() >= 0.5 ? load : 0.0;
        period(20.0, 20.0);
        if (now() >= 0.5) {
            dip = fmax(dip, 20.0 - m[0].omega);
        }
        if (now() >= 0.5 + 0.1) {
            late_error = fmax(late_error, fabs(m[0].omega - 20.0));
        }
        if (now() > 1.0) {
            drive_sum += tu_dbl(out.drive[0]);
        }
    }
    TEST_ASSERT_TRUE(dip > 0.02 * 20.0); /* the load did knock it off */
    TEST_ASSERT_TRUE_MESSAGE(late_error <= 0.02 * 20.0, "back within 2 % in 100 ms, and stays");
    /* The integral found the drive that holds 20 rad/s against the load:
     * (R/(Kt·V))·(b·ω + τc + τL) + Ke·ω/V, by hand. */
    const double u = mp.r_ohm / (mp.kt * mp.v_supply) * (mp.b * 20.0 + mp.tau_c + load) +
                     mp.ke * 20.0 / mp.v_supply;
    TEST_ASSERT_DOUBLE_WITHIN(0.01, u, drive_sum / 200.0);
}

static void test_whl_speed_noise_at_10_rad_s_is_below_0_4_rad_s(void)
{
    /* A wheel turning at exactly 10 rad/s (the encoder of a shaft at
     * θ0 + 10·t), 32 phases of the count: the estimate's error against 10.
     * By hand, a window of 10 periods is off by less than one count over
     * it: 2π/1920/0.01 = 0.327 rad/s. */
    const double bound = TU_TWO_PI / 1920.0 / 0.01;
    double sq = 0.0;
    double worst = 0.0;
    unsigned n = 0;
    for (unsigned ph = 0; ph < 32u; ph++) {
        start();
        const double theta0 = TU_TWO_PI / 1920.0 * ph / 32.0;
        for (unsigned i = 0; i < 1000u; i++) {
            const int32_t c = (int32_t)floor((theta0 + 10.0 * i * DT) * 1920.0 / TU_TWO_PI);
            const whl_input_t in = { { tu_num(10.0), tu_num(10.0) }, { c, c } };
            whl_step(&w, &in, &out);
            w.faults = 0u; /* the motion is imposed: only the estimate counts */
            if (i >= 50u) {
                const double e = tu_dbl(out.speed[0]) - 10.0;
                sq += e * e;
                worst = fmax(worst, fabs(e));
                n++;
            }
        }
    }
    const double rms = sqrt(sq / n);
    TEST_ASSERT_TRUE_MESSAGE(rms < 0.4, "noise at 10 rad/s under 0.4 rad/s");
    TEST_ASSERT_TRUE(worst < bound + TU_TOL(1e-4, 1e-3));
    TEST_ASSERT_TRUE(rms > 0.0); /* the quantisation is there */
}

static void test_whl_stall_fault_stops_both_wheels_after_its_time(void)
{
    /* The left wheel loaded from the start so that full drive only creeps
     * it, at 0.5 rad/s (a count every 6.5 ms: the encoder lives): no motion
     * worth the name the way it drives; after stall_time (0.5 s) the loop
     * stops. */
    m[0].load = load_for(0.5);
    double fault_at = -1.0;
    while (now() < 1.5) {
        period(20.0, 20.0);
        if (fault_at < 0.0 && out.faults != 0u) {
            fault_at = now();
        }
        if (fault_at >= 0.0) {
            TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
            TEST_ASSERT_EQUAL_INT16(0, out.cmd[1]);
        }
    }
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_STALL_LEFT, out.faults);
    /* The stall needs stall_time at full drive below 1 rad/s; the drive is
     * full within a few periods of the start. */
    TEST_ASSERT_TRUE(fault_at >= 0.5);
    TEST_ASSERT_TRUE(fault_at <= 0.5 + 0.05);
    TEST_ASSERT_TRUE(m[1].omega < 1.0); /* the free wheel coasted down */
}

static void test_whl_a_wheel_held_rigid_is_stopped_within_0_1_s(void)
{
    /* Held from the start, as against a wall: the gearbox and tyre wind up
     * by a few counts (the model's hold: 1° at stall torque, 5 counts), then
     * none come: WHL_DEAD_TIME after the last, an encoder fault (the loop
     * cannot tell a rigid hold from a dead encoder; either way the drive
     * stops). */
    dcm_hold(&m[0], true);
    int32_t last = dcm_count(&m[0], &mp);
    double last_at = 0.0;
    double fault_at = -1.0;
    while (now() < 1.0 && fault_at < 0.0) {
        period(20.0, 20.0);
        const int32_t c = dcm_count(&m[0], &mp);
        if (c != last) {
            last = c;
            last_at = now();
        }
        if (out.faults != 0u) {
            fault_at = now();
        }
    }
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_LEFT, out.faults);
    TEST_ASSERT_TRUE(last != 0); /* it did wind up */
    TEST_ASSERT_TRUE(fault_at >= last_at + 0.1);
    TEST_ASSERT_TRUE(fault_at <= last_at + 0.1 + 2.0 * DT);
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
}

static void test_whl_dead_encoder_fault_stops_both_wheels_after_its_time(void)
{
    dcm_kill_encoder(&m[0], &mp);
    double fault_at = -1.0;
    double drive_at_fault = 0.0;
    while (now() < 0.5) {
        period(10.0, 10.0);
        if (fault_at < 0.0 && out.faults != 0u) {
            fault_at = now();
            drive_at_fault = m[0].omega;
        }
    }
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_LEFT, out.faults);
    /* A quarter of full drive is reached in the first periods (the
     * feed-forward of 10 rad/s alone is 0.29); then WHL_DEAD_TIME. */
    TEST_ASSERT_TRUE(fault_at >= 0.1);
    TEST_ASSERT_TRUE(fault_at <= 0.1 + 0.01);
    TEST_ASSERT_TRUE(drive_at_fault > 1.0); /* the motor did turn: only its encoder was dead */
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[1]);
}

/* ------------------------------------------------------------- behaviour */

static void test_whl_an_encoder_dying_while_turning_is_a_fault_within_0_1_s(void)
{
    /* Counts from the start of the drive show the encoder alive; when it
     * dies later the loop sees a stopped wheel and drives it harder, the
     * wheel speeding up unseen: no count for WHL_DEAD_TIME at well over a
     * quarter of full drive, an encoder fault (docs/wheel.md, "Faults"),
     * before the wheel has gained much. */
    while (now() < 0.3) {
        period(20.0, 20.0);
    }
    dcm_kill_encoder(&m[0], &mp);
    double fault_at = -1.0;
    double top = 0.0;
    while (now() < 1.5) {
        period(20.0, 20.0);
        top = fmax(top, m[0].omega);
        if (fault_at < 0.0 && out.faults != 0u) {
            fault_at = now();
        }
    }
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_LEFT, out.faults);
    TEST_ASSERT_TRUE(fault_at >= 0.3 + 0.1);
    TEST_ASSERT_TRUE(fault_at <= 0.3 + 0.1 + 2.0 * DT);
    /* Full drive for 0.1 s from 20 rad/s: at most ω∞ − (ω∞ − 20)·e^(−0.1/τm)
     * (dcm.h's solution), 27.8 rad/s, by hand. */
    const double w_full = full_drive_speed(0.0);
    const double tau_m = mp.j / (mp.b + mp.kt * mp.ke / mp.r_ohm);
    TEST_ASSERT_TRUE(top <= w_full - (w_full - 20.0) * exp(-(0.1 + 2.0 * DT) / tau_m));
}

static void test_whl_an_encoder_counting_backwards_ends_in_a_stall_fault(void)
{
    /* The left encoder wired the wrong way round: the loop drives forward,
     * sees the wheel go backwards, drives harder: no motion the way it
     * drives, so after stall_time the stall check stops it rather than let
     * it run away. */
    double fault_at = -1.0;
    while (now() < 1.0) {
        const whl_input_t in = { { tu_num(10.0), tu_num(10.0) },
                                 { -dcm_count(&m[0], &mp), dcm_count(&m[1], &mp) } };
        whl_step(&w, &in, &out);
        dcm_step(&m[0], &mp, tu_dbl(out.drive[0]), DT);
        dcm_step(&m[1], &mp, tu_dbl(out.drive[1]), DT);
        k++;
        if (fault_at < 0.0 && out.faults != 0u) {
            fault_at = now();
        }
    }
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_STALL_LEFT, out.faults);
    TEST_ASSERT_TRUE(fault_at >= 0.5);
    TEST_ASSERT_TRUE(fault_at <= 0.5 + 0.05);
}

static void test_whl_more_counts_than_the_wheel_can_turn_are_an_encoder_fault(void)
{
    /* At most 2 × 34.56 rad/s: 2·34.56·1920/(2π·1000) = 21.1 counts a
     * period, rounded, plus one: 22 pass, 23 do not. */
    TEST_ASSERT_EQUAL_INT32(22, w.max_step);
    int32_t c = 0;
    for (unsigned i = 0; i < 5u; i++) {
        c += 22;
        const whl_input_t in = { { NUM_ZERO, NUM_ZERO }, { c, -c } };
        whl_step(&w, &in, &out);
        TEST_ASSERT_EQUAL_UINT8(0u, out.faults);
    }
    const whl_input_t jump = { { NUM_ZERO, NUM_ZERO }, { c + 23, -c } };
    whl_step(&w, &jump, &out);
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_LEFT, out.faults);
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[1]);
}

static void test_whl_faults_latch_until_cleared_then_resume_without_a_jump(void)
{
    accel = tu_num(125.0);
    start();
    dcm_hold(&m[0], true);
    while (now() < 0.6) {
        period(20.0, 20.0);
    }
    TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_LEFT, out.faults);
    dcm_hold(&m[0], false);
    while (now() < 1.6) {
        period(20.0, 20.0);
        TEST_ASSERT_EQUAL_UINT8(WHL_FAULT_ENCODER_LEFT, out.faults);
        TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
    }
    whl_clear_faults(&w);
    /* Both wheels at rest: the ramp starts from 0, 125 rad/s²: 0.125 rad/s
     * the first period, 20 rad/s in 160 ms. */
    period(20.0, 20.0);
    TEST_ASSERT_EQUAL_UINT8(0u, out.faults);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-4, 1e-3), 0.125, w.w[0].setpoint);
    while (now() < 2.0) {
        period(20.0, 20.0);
    }
    TEST_ASSERT_DOUBLE_WITHIN(0.4, 20.0, m[0].omega);
    TEST_ASSERT_DOUBLE_WITHIN(0.4, 20.0, m[1].omega);
}

static void test_whl_standstill_gives_no_drive(void)
{
    for (unsigned i = 0; i < 200u; i++) {
        period(0.0, 0.0);
        TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
        TEST_ASSERT_EQUAL_INT16(0, out.cmd[1]);
    }
    /* Back to 0 after a run: the wheel stops, then the drive is released. */
    while (now() < 0.6) {
        period(now() < 0.3 ? 15.0 : 0.0, 0.0);
    }
    TEST_ASSERT_EQUAL_DOUBLE(0.0, m[0].omega);
    TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
    TEST_ASSERT_EQUAL_INT32(0, w.w[0].integ);
}

static void test_whl_speed_from_counts_by_hand(void)
{
    /* 30 counts over the 10-period window: 30·(2π/1920)/0.01 s = 9.8175 rad/s;
     * −7 counts: −2.2907 rad/s. */
    for (unsigned i = 0; i <= 10u; i++) {
        const whl_input_t in = { { NUM_ZERO, NUM_ZERO },
                                 { (int32_t)(3 * i), -(int32_t)(7 * i / 10u) } };
        whl_step(&w, &in, &out);
    }
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-3), 30.0 * TU_TWO_PI / 1920.0 / 0.01, out.speed[0]);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-3), -7.0 * TU_TWO_PI / 1920.0 / 0.01, out.speed[1]);
}

static void test_whl_running_count_wraps_without_a_jump(void)
{
    /* A count that wraps past INT32_MAX still differences right. */
    int32_t c = INT32_MAX - 15;
    for (unsigned i = 0; i <= 10u; i++) {
        const whl_input_t in = { { NUM_ZERO, NUM_ZERO }, { c, 0 } };
        whl_step(&w, &in, &out);
        c = (int32_t)((uint32_t)c + 3u);
    }
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-3), 30.0 * TU_TWO_PI / 1920.0 / 0.01, out.speed[0]);
}

static void test_whl_window_is_whole_periods_within_the_ring(void)
{
    wp.window = tu_num(0.032);
    start();
    TEST_ASSERT_EQUAL_UINT8(32u, w.window);
    wp.rate = tu_num(100.0);
    wp.window = tu_num(0.001); /* a tenth of a period: one */
    whl_set_params(&w, &wp, accel);
    TEST_ASSERT_EQUAL_UINT8(1u, w.window);
    wp.window = tu_num(0.032); /* 3.2 periods at 100 Hz */
    whl_set_params(&w, &wp, accel);
    TEST_ASSERT_EQUAL_UINT8(3u, w.window);
    TEST_ASSERT_EQUAL_UINT32(10000u, whl_period_us(&wp));
    /* The estimate's age: half of 3 periods of 10 ms. */
    TEST_ASSERT_EQUAL_UINT32(15000u, whl_age_us(&w));
}

static void test_whl_estimate_is_half_its_window_old(void)
{
    /* The defaults: 10 periods of 1 ms, 5 ms; one period of 1 ms, 0.5 ms
     * (rounded up to 1 µs: 500). */
    TEST_ASSERT_EQUAL_UINT32(5000u, whl_age_us(&w));
    wp.window = tu_num(0.001);
    whl_set_params(&w, &wp, accel);
    TEST_ASSERT_EQUAL_UINT32(500u, whl_age_us(&w));
}

static void test_whl_motor_command_rounds_and_clamps(void)
{
    TEST_ASSERT_EQUAL_INT16(5000, whl_motor_cmd(NUM_C(0.5)));
    TEST_ASSERT_EQUAL_INT16(-2500, whl_motor_cmd(NUM_C(-0.25)));
    TEST_ASSERT_EQUAL_INT16(10000, whl_motor_cmd(NUM_ONE));
    TEST_ASSERT_EQUAL_INT16(-10000, whl_motor_cmd(NUM_C(-3.0)));
    TEST_ASSERT_EQUAL_INT16(10000, whl_motor_cmd(NUM_C(2.0)));
    TEST_ASSERT_EQUAL_INT16(0, whl_motor_cmd(NUM_ZERO));
}

#if !defined(NUM_FIXED)
static void test_whl_a_non_finite_setpoint_counts_as_zero(void)
{
    for (unsigned i = 0; i < 50u; i++) {
        const whl_input_t in = { { NAN, INFINITY }, { 0, 0 } };
        whl_step(&w, &in, &out);
        TEST_ASSERT_EQUAL_INT16(0, out.cmd[0]);
        TEST_ASSERT_EQUAL_INT16(0, out.cmd[1]);
    }
}
#endif

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_whl_step_settles_within_2_percent_in_150_ms);
    RUN_TEST(test_whl_ramp_is_tracked_within_1_rad_s);
    RUN_TEST(test_whl_setpoint_ramps_at_wheel_accel);
    RUN_TEST(test_whl_release_after_a_1_s_stall_overshoots_at_most_10_percent);
    RUN_TEST(test_whl_load_step_of_30_percent_stall_is_rejected_within_100_ms);
    RUN_TEST(test_whl_speed_noise_at_10_rad_s_is_below_0_4_rad_s);
    RUN_TEST(test_whl_stall_fault_stops_both_wheels_after_its_time);
    RUN_TEST(test_whl_a_wheel_held_rigid_is_stopped_within_0_1_s);
    RUN_TEST(test_whl_dead_encoder_fault_stops_both_wheels_after_its_time);
    RUN_TEST(test_whl_an_encoder_dying_while_turning_is_a_fault_within_0_1_s);
    RUN_TEST(test_whl_an_encoder_counting_backwards_ends_in_a_stall_fault);
    RUN_TEST(test_whl_more_counts_than_the_wheel_can_turn_are_an_encoder_fault);
    RUN_TEST(test_whl_faults_latch_until_cleared_then_resume_without_a_jump);
    RUN_TEST(test_whl_standstill_gives_no_drive);
    RUN_TEST(test_whl_speed_from_counts_by_hand);
    RUN_TEST(test_whl_running_count_wraps_without_a_jump);
    RUN_TEST(test_whl_window_is_whole_periods_within_the_ring);
    RUN_TEST(test_whl_estimate_is_half_its_window_old);
    RUN_TEST(test_whl_motor_command_rounds_and_clamps);
#if !defined(NUM_FIXED)
    RUN_TEST(test_whl_a_non_finite_setpoint_counts_as_zero);
#endif
    return UNITY_END();
}
