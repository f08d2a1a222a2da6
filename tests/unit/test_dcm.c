/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the DC gearmotor model (sim/dcmotor/dcm.h), which the wheel loop's
 * tests and the simulation run against: its defaults against the datasheet
 * they come from, and its motion against the first-order solution.
 *
 * Expected values: the Pololu 37D 12 V 30:1 datasheet (330 rpm and 0.2 A at
 * no load, 140 kg·mm and 5.5 A at stall, 12 V, 64 CPR × 30), and the
 * closed forms of dcm.h written out here in double from the constants, not
 * through the model's own helpers.
 */
#include <math.h>

#include "dcm.h"
#include "test_util.h"
#include "unity.h"

static dcm_params_t p;
static dcm_t m;

void setUp(void)
{
    dcm_params_default(&p);
    dcm_init(&m);
}
void tearDown(void) {}

#define RPM_TO_RAD_S (TU_TWO_PI / 60.0)

/* ω of a free motor under constant drive u from rest, by hand:
 * J·ω' = Kt·u·V/R − τc − (b + Kt·Ke/R)·ω. */
static double step_response(double u, double t)
{
    const double damp = p.b + p.kt * p.ke / p.r_ohm;
    const double w_inf = (p.kt * u * p.v_supply / p.r_ohm - p.tau_c) / damp;
    return w_inf * (1.0 - exp(-t * damp / p.j));
}

static void test_dcm_defaults_give_the_datasheet_no_load_point(void)
{
    /* Full drive, no load: the steady state is 330 rpm, drawing 0.2 A. */
    const double w = (p.kt * p.v_supply / p.r_ohm - p.tau_c) / (p.b + p.kt * p.ke / p.r_ohm);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 330.0 * RPM_TO_RAD_S, w);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.2, (p.v_supply - p.ke * w) / p.r_ohm);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 330.0 * RPM_TO_RAD_S, dcm_speed_steady(&p, 1.0, 0.0));
}

static void test_dcm_defaults_give_the_datasheet_stall_point(void)
{
    /* At rest under full drive: 5.5 A and 140 kg·mm of torque out. */
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 5.5, p.v_supply / p.r_ohm);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 140.0 * 9.80665e-3, p.kt * 5.5 - p.tau_c);
    /* 64 counts per motor revolution, ×30. */
    TEST_ASSERT_EQUAL_DOUBLE(1920.0, p.counts_per_rev);
    /* The robot's share of the inertia: 1 kg on a 0.05 m wheel. */
    TEST_ASSERT_TRUE(p.j > 1.0 * 0.05 * 0.05);
}

static void test_dcm_step_response_is_first_order(void)
{
    /* Half drive from rest, 1 ms steps, against ω∞(1 − exp(−t/τm)). */
    for (int k = 1; k <= 400; k++) {
        dcm_step(&m, &p, 0.5, 1e-3);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, step_response(0.5, k * 1e-3), m.omega);
    }
    /* τm by hand (docs/wheel.md: 85.6 ms) and the model's. */
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, p.j / (p.b + p.kt * p.ke / p.r_ohm), dcm_tau(&p));
    TEST_ASSERT_DOUBLE_WITHIN(0.5e-3, 0.0856, dcm_tau(&p));
}

static void test_dcm_angle_is_the_integral_of_the_speed(void)
{
    /* θ(t) = ω∞·(t − τ(1 − exp(−t/τ))) for the step from rest. */
    const double tau = dcm_tau(&p);
    const double w_inf = step_response(1.0, 1e9);
    for (int k = 0; k < 250; k++) {
        dcm_step(&m, &p, 1.0, 1e-3);
    }
    const double t = 0.25;
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, w_inf * (t - tau * (1.0 - exp(-t / tau))), m.theta);
}

static void test_dcm_static_friction_holds_a_weak_drive(void)
{
    /* Below τc·R/(Kt·V) the drive does not break the motor loose. */
    const double breakaway = p.tau_c * p.r_ohm / (p.kt * p.v_supply);
    dcm_step(&m, &p, 0.99 * breakaway, 0.1);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, m.omega);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, m.theta);
    dcm_step(&m, &p, 1.01 * breakaway, 0.1);
    TEST_ASSERT_TRUE(m.omega > 0.0);
}

static void test_dcm_coasting_stops_and_does_not_reverse(void)
{
    for (int k = 0; k < 300; k++) {
        dcm_step(&m, &p, 1.0, 1e-3);
    }
    /* Drive 0: the motor brakes on its back-EMF (short-circuited windings)
     * and friction; friction stops it at exactly 0, at t0, by hand from
     * J·ω' = −B·ω − τc: ω(t) = −τc/B + (ω0 + τc/B)·e^{−t/τ} = 0. */
    const double bb = p.b + p.kt * p.ke / p.r_ohm;
    const double tau = dcm_tau(&p);
    const double w0 = m.omega;
    const double t0 = tau * log((w0 + p.tau_c / bb) / (p.tau_c / bb));
    const double theta0 = m.theta;
    dcm_step(&m, &p, 0.0, t0 - 1e-6);
    TEST_ASSERT_TRUE(m.omega > 0.0);
    dcm_step(&m, &p, 0.0, 0.5);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, m.omega);
    /* The way it went meanwhile: the integral of ω(t) over [0, t0]. */
    const double way = -(p.tau_c / bb) * t0 + tau * (w0 + p.tau_c / bb) * (1.0 - exp(-t0 / tau));
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, theta0 + way, m.theta);
}

static void test_dcm_coasting_with_the_windings_open_brakes_on_friction_alone(void)
{
    for (int k = 0; k < 300; k++) {
        dcm_step(&m, &p, 1.0, 1e-3);
    }
    /* No current: J·ω' = −b·ω − τc, ω(t) = −τc/b + (ω0 + τc/b)·e^{−b·t/J}. */
    const double w0 = m.omega;
    dcm_coast(&m, &p, 0.1);
    const double want = -p.tau_c / p.b + (w0 + p.tau_c / p.b) * exp(-p.b * 0.1 / p.j);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, want, m.omega);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, m.current);
    /* Slower than braking on the back-EMF: shorted windings would be near
     * rest by now (τm = 86 ms). */
    TEST_ASSERT_TRUE(m.omega > 0.5 * w0);
}

static void test_dcm_load_lowers_the_steady_speed_by_hand(void)
{
    /* 30 % of stall torque at full drive: ω∞ = (Kt·V/R − τc − τL)/B. */
    const double load = 0.3 * (p.kt * p.v_supply / p.r_ohm - p.tau_c);
    m.load = load;
    for (int k = 0; k < 2000; k++) {
        dcm_step(&m, &p, 1.0, 1e-3);
    }
    const double bb = p.b + p.kt * p.ke / p.r_ohm;
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, (p.kt * p.v_supply / p.r_ohm - p.tau_c - load) / bb, m.omega);
    /* 0.7 of the no-load speed (a linear torque-speed line). */
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.7 * 330.0 * RPM_TO_RAD_S, m.omega);
    /* The drive that holds a speed, solved by hand for u. */
    const double u =
        (p.r_ohm / (p.kt * p.v_supply)) * (p.b * 20.0 + p.tau_c + load) + p.ke * 20.0 / p.v_supply;
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, u, dcm_drive_steady(&p, 20.0, load));
}

static void test_dcm_encoder_counts_1920_a_revolution(void)
{
    m.theta = TU_TWO_PI + 1e-9;
    TEST_ASSERT_EQUAL_INT32(1920, dcm_count(&m, &p));
    m.theta = -1e-9;
    TEST_ASSERT_EQUAL_INT32(-1, dcm_count(&m, &p));
    m.theta = 10.0 * TU_TWO_PI / 1920.0 + 1e-9; /* ten counts */
    TEST_ASSERT_EQUAL_INT32(10, dcm_count(&m, &p));
}

static void test_dcm_a_dead_encoder_keeps_its_count(void)
{
    m.theta = 0.1;
    dcm_kill_encoder(&m, &p);
    const int32_t c = dcm_count(&m, &p);
    TEST_ASSERT_EQUAL_INT32((int32_t)floor(0.1 * 1920.0 / TU_TWO_PI), c);
    for (int k = 0; k < 100; k++) {
        dcm_step(&m, &p, 1.0, 1e-3);
    }
    TEST_ASSERT_TRUE(m.theta > 1.0);
    TEST_ASSERT_EQUAL_INT32(c, dcm_count(&m, &p));
}

static void test_dcm_a_held_wheel_winds_up_its_compliance(void)
{
    dcm_hold(&m, true);
    for (int k = 0; k < 1000; k++) {
        dcm_step(&m, &p, 1.0, 1e-3);
    }
    /* Stopped, deflected by the drive's torque at rest over the stiffness,
     * give or take what static friction takes: (Kt·V/R ± τc)/k, about 1°
     * (the stall torque, Kt·V/R − τc, deflects it by exactly 1°): 5 counts. */
    const double torque = p.kt * p.v_supply / p.r_ohm;
    TEST_ASSERT_DOUBLE_WITHIN(1e-3, 0.0, m.omega);
    TEST_ASSERT_TRUE(m.theta >= (torque - p.tau_c) / p.hold_k - 1e-6);
    TEST_ASSERT_TRUE(m.theta <= (torque + p.tau_c) / p.hold_k + 1e-6);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, TU_PI / 180.0, (torque - p.tau_c) / p.hold_k);
    TEST_ASSERT_EQUAL_INT32(5, dcm_count(&m, &p)); /* ⌊(1° to 1.04°)·1920/360°⌋ */
    /* Let go: it turns freely. */
    dcm_hold(&m, false);
    dcm_step(&m, &p, 1.0, 0.05);
    TEST_ASSERT_TRUE(m.omega > 10.0);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_dcm_defaults_give_the_datasheet_no_load_point);
    RUN_TEST(test_dcm_defaults_give_the_datasheet_stall_point);
    RUN_TEST(test_dcm_step_response_is_first_order);
    RUN_TEST(test_dcm_angle_is_the_integral_of_the_speed);
    RUN_TEST(test_dcm_static_friction_holds_a_weak_drive);
    RUN_TEST(test_dcm_coasting_stops_and_does_not_reverse);
    RUN_TEST(test_dcm_coasting_with_the_windings_open_brakes_on_friction_alone);
    RUN_TEST(test_dcm_load_lowers_the_steady_speed_by_hand);
    RUN_TEST(test_dcm_encoder_counts_1920_a_revolution);
    RUN_TEST(test_dcm_a_dead_encoder_keeps_its_count);
    RUN_TEST(test_dcm_a_held_wheel_winds_up_its_compliance);
    return UNITY_END();
}
