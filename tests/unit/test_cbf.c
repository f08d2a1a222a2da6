/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/cbf: the closed-form safety filter.
 *
 * Expected values: hand derivations for a robot heading straight at an
 * obstacle, and an independent computation in double in this file of the
 * barrier of cbf.h, h = |p_l − c|² − (D_s + l)² with p_l = p + l[cos θ,
 * sin θ], and of its rate ḣ = 2 (p_l − c)·(u − w) for the point velocity
 * u = v[cos θ, sin θ] + l ω[−sin θ, cos θ]. On random states the filtered
 * command must keep ḣ >= −α h (to CBF_TOLERANCE and rounding), and leave a
 * command that already does untouched; in closed loop (forward Euler,
 * dt = 0.02 s) the barrier must stay non-negative.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ctrl/cbf.h"
#include "test_util.h"
#include "unity.h"

/* ḣ + α h [m²/s] against the bound: the filter's own tolerance
 * (CBF_TOLERANCE = 5e-4) plus rounding. float: products of values <= 20
 * (1e-6 each); fixed: Q16.16 roundings of a (3e-5 m) times |u| <= 5, and of
 * α h (20 × 3e-5), and cos/sin errors (1e-4) times |a||u| <= 10. */
#define TOL_RATE TU_TOL(1e-3, 4e-3)
/* Velocities [m/s], [rad/s] of a hand case. float: a division and a few
 * products (1e-6); fixed: Q16.16 division of values ≈ 15 / 1.9 (1e-4). */
#define TOL_VW   TU_TOL(1e-5, 1e-3)

#define L_AHEAD CBF_LOOKAHEAD_M
#define ALPHA   CBF_ALPHA_PER_S

static cbf_t f;

void setUp(void) { cbf_init(&f); }
void tearDown(void) {}

static sup_entry_t entry(uint8_t id, double x, double y, double d_s, double vx, double vy)
{
    sup_entry_t e;
    memset(&e, 0, sizeof e);
    e.o.id = id;
    e.o.x = tu_num(x);
    e.o.y = tu_num(y);
    e.o.radius = tu_num(d_s - 0.25);
    e.o.vx = tu_num(vx);
    e.o.vy = tu_num(vy);
    e.d_s = tu_num(d_s);
    e.d_act = tu_num(d_s + 0.15);
    return e;
}

/* The barrier and ḣ + α h in double, from the values the firmware holds. */
static double ref_h(double x, double y, double th, const sup_entry_t *o)
{
    const double px = x + L_AHEAD * cos(th) - tu_dbl(o->o.x);
    const double py = y + L_AHEAD * sin(th) - tu_dbl(o->o.y);
    const double rho = tu_dbl(o->d_s) + L_AHEAD;
    return px * px + py * py - rho * rho;
}

static double ref_slack(double x, double y, double th, double v, double w, const sup_entry_t *o)
{
    const double px = x + L_AHEAD * cos(th) - tu_dbl(o->o.x);
    const double py = y + L_AHEAD * sin(th) - tu_dbl(o->o.y);
    const double ux = v * cos(th) - L_AHEAD * w * sin(th) - tu_dbl(o->o.vx);
    const double uy = v * sin(th) + L_AHEAD * w * cos(th) - tu_dbl(o->o.vy);
    return 2.0 * (px * ux + py * uy) + ALPHA * ref_h(x, y, th, o);
}

static void filter(double x, double y, double th, const sup_entry_t *e, uint8_t n, num_t *v,
                   num_t *w, cbf_result_t *r)
{
    const pose_t p = tu_pose(x, y, th);
    num_t dist[SUP_MAX_OBSTACLES];
    for (uint8_t i = 0; i < n; i++) {
        dist[i] = num_hypot(num_sub(e[i].o.x, p.x), num_sub(e[i].o.y, p.y));
    }
    cbf_step(&f, &p, num_cos(p.theta), num_sin(p.theta), NULL, e, dist, n, v, w, r);
}

/* --------------------------------------------------------------- hand */

static void test_cbf_barrier_hand_values(void)
{
    /* Robot at the origin heading +x, obstacle at (1, 0), D_s 0.35:
     * p_l = (0.05, 0), p_l − c = (−0.95, 0): h = 0.9025 − 0.4² = 0.7425,
     * a = (−1.9, 0). */
    const sup_entry_t o = entry(1, 1.0, 0.0, 0.35, 0, 0);
    const pose_t p = tu_pose(0, 0, 0);
    num_t h, ax, ay;
    cbf_barrier(&p, num_cos(p.theta), num_sin(p.theta), NULL, &o, &h, &ax, &ay);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.7425, 0.95 * 0.95 - 0.4 * 0.4);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.7425, h);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -1.9, ax);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, ay);
}

static void test_cbf_braking_margin_widens_the_barrier_while_closing(void)
{
    /* The hand case above with the wheels' motion (cbf_motion_t): the
     * command in force drives the look-ahead point at q = (0.5, 0) m/s
     * straight at the obstacle, σ = 0.5 m/s; with T_b = 0.36 s the margin of
     * a static obstacle is σ T_b = 0.18 m, ρ = 0.35 + 0.05 + 0.18 = 0.58,
     * h = 0.9025 − 0.3364 = 0.5661. With T_b = 0.6 s: 0.3 m, ρ = 0.7,
     * h = 0.4125. Driving away (q = (−0.5, 0)) there is none: 0.7425. The
     * prediction's shift (0.1, 0) moves p_l to (0.15, 0): h = 0.85² − 0.4² =
     * 0.5625. */
    const sup_entry_t o = entry(1, 1.0, 0.0, 0.35, 0, 0);
    const pose_t p = tu_pose(0, 0, 0);
    cbf_motion_t m = { .qx = tu_num(0.5), .brake_t = tu_num(0.36), .inv_accel = tu_num(1.0) };
    num_t h, ax, ay;
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &o, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 2e-3), 0.5661, h);
    m.brake_t = tu_num(0.6);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &o, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 2e-3), 0.4125, h);
    m.qx = tu_num(-0.5);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &o, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 2e-3), 0.7425, h);
    /* The obstacle coming at 0.5 m/s, the robot at 0.5 m/s: σ = 1 m/s,
     * faster than braking nulls (a_v = 1 m/s²: σ/a_v = 1 s > T_b = 0.36 s).
     * Dead ahead (Δ = (−0.95, 0): cos β_b = 1) the gain is 1.5 + 1.25 × 2
     * = 4: the margin is 4 × σ × 1 s = 4 m, ρ = 4.4, h = 0.9025 − 19.36 =
     * −18.4575. */
    const sup_entry_t moving = entry(1, 1.0, 0.0, 0.35, -0.5, 0);
    m = (cbf_motion_t){ .qx = tu_num(0.5),
                        .brake_t = tu_num(0.36),
                        .inv_accel = tu_num(1.0),
                        .side = tu_num(1.0 / 3.0),
                        .inv_side = tu_num(3.0) };
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &moving, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-4, 2e-2), -18.4575, h);
    /* A robot at rest, an obstacle coming at 0.5 m/s: head on (centre
     * (1.05, 0), Δ = (−1, 0) along the heading) the look-ahead point gets
     * away at a_v = 1 m/s²: σ/a_v = 0.5 s > T_b, gain 4 (dead ahead),
     * margin 4 × 0.25 = 1 m, ρ = 1.4, h = 1 − 1.96 = −0.96. From behind
     * (centre (−0.95, 0) coming along +x: Δ = (1, 0), cos β_b = −1) the
     * same but for the gain, 1.5: margin 0.375 m, ρ = 0.775,
     * h = 1 − 0.600625 = 0.399375. From the side (centre (0.05, 1), coming
     * down: Δ = (0, −1) across the heading, cos β_b = 0, gain 1.5 + 1.25 =
     * 2.75) only at a_v side = 1/3 m/s² (act_configure()): 1.5 s, margin
     * 2.75 × 0.75 = 2.0625 m, ρ = 2.4625, h = 1 − 6.06390625 =
     * −5.06390625. At 60° off the heading (centre (0.55, √3/2), coming at
     * p_l at 0.5 m/s: Δ = (−1/2, −√3/2), cos β_b = 1/2, gain 1.5 + 1.25 ×
     * 1.5 = 3.375) at a_v max(1/2, (√3/2)/3) = 1/2 m/s²: 1 s, margin
     * 3.375 × 0.5 = 1.6875 m, ρ = 2.0875, h = 1 − 4.35765625 =
     * −3.35765625. */
    m.qx = NUM_ZERO;
    const sup_entry_t ahead = entry(1, 1.05, 0.0, 0.35, -0.5, 0);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &ahead, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 4e-3), -0.96, h);
    const sup_entry_t chasing = entry(1, -0.95, 0.0, 0.35, 0.5, 0);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &chasing, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 4e-3), 0.399375, h);
    const sup_entry_t beside = entry(1, 0.05, 1.0, 0.35, 0, -0.5);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &beside, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-2), -5.06390625, h);
    const double r3 = sqrt(3.0) / 2.0;
    const sup_entry_t oblique = entry(1, 0.55, r3, 0.35, -0.25, -0.5 * r3);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &oblique, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 1e-2), -3.35765625, h);
    /* Fast wheels (a_v = 10 m/s²), head on: σ/a_v = 0.05 s, 4 × 0.05 =
     * 0.2 s < 1.5 T_b = 0.54 s: the braking time decides, margin 0.5 ×
     * 0.54 = 0.27 m, ρ = 0.67, h = 1 − 0.4489 = 0.5511 (the gain by bearing
     * on T_b too would give 0.72 m, h = −0.2544). */
    m.inv_accel = tu_num(0.1);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &ahead, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 4e-3), 0.5511, h);
    m.inv_accel = tu_num(1.0);
    /* The prediction's horizon T_p = 0.2 s: a moving obstacle is taken
     * where it will be then. Centre (1, 0) coming at 0.5 m/s, the robot at
     * rest: at (0.9, 0), Δ = (−0.85, 0), σ = 0.5, σ/a_v = 0.5 s > T_b,
     * dead ahead: margin 4 × 0.25 = 1 m, ρ = 1.4, h = 0.7225 − 1.96 =
     * −1.2375, a_x = 2 Δ_x = −1.7; taken where it is now (T_p = 0):
     * h = 0.9025 − 1.96 = −1.0575. A static obstacle stays where it
     * is: (1, 0), no margin at rest, h = 0.9025 − 0.16 = 0.7425. */
    const sup_entry_t coming = entry(1, 1.0, 0.0, 0.35, -0.5, 0);
    m.horizon = tu_num(0.2);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &coming, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 4e-3), -1.2375, h);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -1.7, ax);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, ay);
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &o, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 2e-3), 0.7425, h);
    m.horizon = NUM_ZERO;
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &coming, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 4e-3), -1.0575, h);
    m = (cbf_motion_t){ .shift_x = tu_num(0.1) };
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &o, &h, &ax, &ay);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-5, 2e-3), 0.5625, h);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, -1.7, ax);
}

static void test_cbf_braking_margin_at_the_centre_of_a_closing_obstacle_is_finite(void)
{
    /* The prediction's shift (−l, 0) puts p_l at the origin, the obstacle's
     * centre a hair beyond it (closer than any distance whose square the
     * number type holds: 1e-30 m in float, one lsb in Q16.16), and the
     * command in force drives p_l at it (q = (2, 0)): its closing direction
     * is undefined, |Δ| rounds to 0. The barrier must come out finite and
     * at least as unsafe as without a margin: h <= 0 − (D_s + l)² = −0.16. */
#ifdef NUM_FIXED
    const double hair = 1.0 / 65536.0;
#else
    const double hair = 1e-30;
#endif
    const sup_entry_t o = entry(1, hair, 0.0, 0.35, 0, 0);
    const pose_t p = tu_pose(0, 0, 0);
    const cbf_motion_t m = { .shift_x = tu_num(-L_AHEAD),
                             .qx = tu_num(2.0),
                             .brake_t = tu_num(0.36),
                             .inv_accel = tu_num(1.0) };
    num_t h, ax, ay;
    cbf_barrier(&p, NUM_ONE, NUM_ZERO, &m, &o, &h, &ax, &ay);
    TEST_ASSERT_TRUE(num_is_finite(h));
    TEST_ASSERT_TRUE(tu_dbl(h) <= -0.16 + 1e-3);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, ax);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, ay);
}

/* cbf_brake_clear() for a robot at the origin heading +x. */
static bool brake_clear(const sup_entry_t *e, uint8_t n, double v, double w, double travel_t)
{
    num_t dist[SUP_MAX_OBSTACLES];
    for (uint8_t i = 0; i < n; i++) {
        dist[i] = num_hypot(e[i].o.x, e[i].o.y);
    }
    const cbf_brake_t b = { .start = tu_pose(0, 0, 0),
                            .c = NUM_ONE,
                            .s = NUM_ZERO,
                            .v = tu_num(v),
                            .w = tu_num(w),
                            .travel_t = tu_num(travel_t) };
    return cbf_brake_clear(&b, e, dist, n);
}

static void test_cbf_brake_guard_hand_cases(void)
{
    /* Obstacle at (1, 0), D_s 0.35: the guard keeps 0.39 (CBF_GUARD_MARGIN).
     * At 0.5 m/s the braking path is 0.5 × travel long: 1.0 s ends at
     * 0.5 m, 0.5 from the centre: clear; 1.4 s ends at 0.7 m, 0.3 away: not. */
    sup_entry_t o = entry(1, 1.0, 0.0, 0.35, 0, 0);
    TEST_ASSERT_TRUE(brake_clear(&o, 1, 0.5, 0.0, 1.0));
    TEST_ASSERT_FALSE(brake_clear(&o, 1, 0.5, 0.0, 1.4));
    /* Beside the path, 0.5 m off it: clear at any length. */
    o = entry(1, 1.0, 0.5, 0.35, 0, 0);
    TEST_ASSERT_TRUE(brake_clear(&o, 1, 0.5, 0.0, 4.0));
    /* A turn at 0.5 m/s, 1 rad/s: the arc of radius 0.5 m about (0, 0.5)
     * passes through (0.5, 0.5) after a quarter turn (1.57 s): an obstacle
     * there is hit by a path of 1.6 s; a path of 0.2 s ends at
     * (0.5 sin 0.2, 0.5 − 0.5 cos 0.2) = (0.099, 0.010), 0.63 m from it:
     * clear. */
    o = entry(1, 0.5, 0.5, 0.35, 0, 0);
    TEST_ASSERT_FALSE(brake_clear(&o, 1, 0.5, 1.0, 1.6));
    TEST_ASSERT_TRUE(brake_clear(&o, 1, 0.5, 1.0, 0.2));
    /* A moving obstacle is the filter's: not the guard's. */
    o = entry(1, 0.6, 0.0, 0.35, -0.3, 0);
    TEST_ASSERT_TRUE(brake_clear(&o, 1, 0.5, 0.0, 1.4));
    /* Already inside the margin (0.37 < 0.39): no closer than now. Turning
     * in place stays at 0.37: clear; driving at it: not; away: clear. */
    o = entry(1, 0.37, 0.0, 0.35, 0, 0);
    TEST_ASSERT_TRUE(brake_clear(&o, 1, 0.0, 1.0, 1.0));
    TEST_ASSERT_FALSE(brake_clear(&o, 1, 0.1, 0.0, 1.0));
    TEST_ASSERT_TRUE(brake_clear(&o, 1, -0.1, 0.0, 1.0));
}

/* ------------------------------------------- the guard under real wheels */

/* A deterministic generator for the closed loop (the tests' own, so that
 * both numeric modes see the same scenes). */
static uint32_t lcg_state;
static double rnd_g(double lo, double hi)
{
    lcg_state = lcg_state * 1664525u + 1013904223u;
    return lo + (hi - lo) * (double)(lcg_state >> 8) / 16777216.0;
}

/* One wheel of the actuator model of docs/strategy.md, in double: its speed
 * follows the command through a first-order lag tau and never changes
 * faster than accel, integrated exactly per 1 ms substep as the plant does
 * (sim/mstc/sim/actuator.py). */
static double wheel_substep(double w, double u, double tau, double accel, double h)
{
    const double target = tau > 0.0 ? u + (w - u) * exp(-h / tau) : u;
    double step = target - w;
    step = step > accel * h ? accel * h : (step < -accel * h ? -accel * h : step);
    return w + step;
}

/* Runs of the closed loop: the firmware's rate limiter and braking guard
 * (cbf_guard(), with act_estimate() and act_predict() as ctl.c uses them)
 * against wheels anywhere within the documented limits: lag at most
 * wheel_tau, acceleration at least wheel_accel. The nominal command drives
 * at 1 m/s towards the nearest obstacle with a random turn: the guard alone
 * keeps the robot out. Returns the smallest centre distance less D_s. */
static double guarded_runs(double wheel_accel, double wheel_tau, unsigned runs)
{
    const double r = 0.05, track = 0.3, dt = 0.02, d_s = 0.35;
    const kin_params_t kin = { tu_num(r), tu_num(track), tu_num(100.0) };
    double worst = 1e9;
    for (unsigned run = 0; run < runs; run++) {
        sup_entry_t e[3];
        for (uint8_t i = 0; i < 3u; i++) {
            e[i] = entry((uint8_t)(i + 1u), rnd_g(1.0, 3.0), rnd_g(-1.0, 1.0), d_s, 0, 0);
        }
        const double tau = rnd_g(0.0, wheel_tau);
        const double accel = rnd_g(1.0, 2.0) * wheel_accel;
        double x = 0.0, y = 0.0, th = rnd_g(-0.5, 0.5), wl = 0.0, wr = 0.0;
        act_t a;
        act_init(&a);
        const double turn = rnd_g(-2.0, 2.0);
        for (unsigned k = 0; k < 200u; k++) {
            const pose_t p = tu_pose(x, y, th);
            num_t dist[3];
            double best = 1e9;
            uint8_t near = 0;
            for (uint8_t i = 0; i < 3u; i++) {
                dist[i] = num_hypot(num_sub(e[i].o.x, p.x), num_sub(e[i].o.y, p.y));
                if (tu_dbl(dist[i]) < best) {
                    best = tu_dbl(dist[i]);
                    near = i;
                }
            }
            /* Nominal: 1 m/s, heading for the nearest obstacle, plus a turn. */
            const double bearing = atan2(tu_dbl(e[near].o.y) - y, tu_dbl(e[near].o.x) - x) - th;
            const double w_nom = 2.0 * atan2(sin(bearing), cos(bearing)) + turn;
            kin_wheels_t u;
            kin_wheels_from_vw(&kin, tu_num(1.0), tu_num(w_nom), &u);
            (void)kin_saturate(&kin, &u);
            act_estimate(&a, tu_num(wheel_tau), tu_num(dt), NULL);
            num_t ve, we;
            kin_vw_from_wheels(&kin, &a.est, &ve, &we);
            const cbf_guard_t g = { .kin = &kin,
                                    .step = tu_num(wheel_accel * dt),
                                    .inv_accel = tu_num(1.0 / wheel_accel),
                                    .dt = tu_num(dt) };
            cbf_guard_t gp = g;
            act_pose_t at;
            act_predict(&p, num_cos(p.theta), num_sin(p.theta), ve, we, tu_num(wheel_tau), &at);
            gp.start = at.p;
            gp.c = at.c;
            gp.s = at.s;
            gp.lead = num_mul(num_abs(ve), tu_num(wheel_tau));
            cbf_body_t body = { .known = false };
            (void)cbf_guard(&a, &gp, e, dist, 3u, &u, &body);
            const double ul = tu_dbl(u.left), ur = tu_dbl(u.right);
            for (unsigned s = 0; s < 20u; s++) {
                const double nl = wheel_substep(wl, ul, tau, accel, 0.001);
                const double nr = wheel_substep(wr, ur, tau, accel, 0.001);
                const double v = r * (nl + nr + wl + wr) / 4.0;
                const double w = r * (nr - nl + wr - wl) / (2.0 * track);
                x += v * cos(th) * 0.001;
                y += v * sin(th) * 0.001;
                th += w * 0.001;
                wl = nl;
                wr = nr;
                for (uint8_t i = 0; i < 3u; i++) {
                    const double d = hypot(tu_dbl(e[i].o.x) - x, tu_dbl(e[i].o.y) - y) - d_s;
                    worst = d < worst ? d : worst;
                }
            }
        }
    }
    return worst;
}

static void test_cbf_guard_keeps_d_s_under_wheels_within_their_limits(void)
{
    lcg_state = 19u;
    /* The suite's "gearmotor" and "sluggish" profiles (the second's delay
     * of 2 periods within its wheel_tau, docs/scenarios.md). The guard keeps
     * CBF_GUARD_MARGIN = 0.04 m; its model's approximations (the predicted
     * pose, the arc for a path that starts with the lag's turn) may eat into
     * that margin, never through D_s. */
    const double gear = guarded_runs(20.0, 0.06, 100u);
    const double slug = guarded_runs(10.0, 0.14, 100u);
    printf("smallest clearance to D_s: gearmotor %+.4f m, sluggish %+.4f m\n", gear, slug);
    TEST_ASSERT_TRUE(gear >= 0.0);
    TEST_ASSERT_TRUE(slug >= 0.0);
}

static void test_cbf_brakes_a_robot_driving_straight_at_an_obstacle(void)
{
    /* As above: ḣ = a·u = −1.9 v (a ⟂ the turn direction, so ω does not
     * enter); ḣ >= −α h = −20 × 0.7425 = −14.85 holds for v <= 7.8158.
     * v = 10 is projected to exactly 14.85 / 1.9 = 7.8157895, ω kept. */
    const sup_entry_t o = entry(4, 1.0, 0.0, 0.35, 0, 0);
    num_t v = tu_num(10.0), w = tu_num(0.3);
    cbf_result_t r;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed);
    TEST_ASSERT_TRUE(r.new_episode);
    TEST_ASSERT_FALSE(r.infeasible);
    TEST_ASSERT_EQUAL_UINT8(4, r.obstacle);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 7.8157895, 14.85 / 1.9);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 14.85 / 1.9, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.3, w);
    /* v = 7 already meets it: untouched, bit for bit. */
    num_t v2 = tu_num(7.0), w2 = tu_num(0.3);
    const num_t v2_in = v2, w2_in = w2;
    filter(0, 0, 0, &o, 1, &v2, &w2, &r);
    TEST_ASSERT_FALSE(r.changed);
    TEST_ASSERT_EQUAL_INT32(0, r.obstacle);
    TEST_ASSERT_TRUE(v2 == v2_in && w2 == w2_in);
}

static void test_cbf_brakes_for_the_last_entry_of_a_full_table(void)
{
    /* The case above with the obstacle the last of a full table (index
     * SUP_MAX_OBSTACLES − 1: in the upper half of the filter's masks,
     * sup.h), the others static 20 m behind the robot, whose constraints
     * do not bind (ḣ = a·u with a pointing away from u): the same
     * projection, v = 14.85 / 1.9, named by its id. */
    static sup_entry_t e[SUP_MAX_OBSTACLES];
    for (uint8_t i = 0; i + 1u < SUP_MAX_OBSTACLES; i++) {
        e[i] = entry((uint8_t)(i + 1u), -20.0, 0.5 * i, 0.35, 0, 0);
    }
    e[SUP_MAX_OBSTACLES - 1u] = entry(SUP_MAX_OBSTACLES, 1.0, 0.0, 0.35, 0, 0);
    num_t v = tu_num(10.0), w = tu_num(0.3);
    cbf_result_t r;
    filter(0, 0, 0, e, SUP_MAX_OBSTACLES, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed);
    TEST_ASSERT_EQUAL_UINT8(SUP_MAX_OBSTACLES, r.obstacle);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 14.85 / 1.9, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.3, w);
}

static void test_cbf_episodes_start_once(void)
{
    const sup_entry_t o = entry(2, 1.0, 0.0, 0.35, 0, 0);
    cbf_result_t r;
    num_t v, w;
    /* Two intervening steps: a new episode, then its continuation. */
    v = tu_num(10.0), w = NUM_ZERO;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed && r.new_episode);
    v = tu_num(10.0), w = NUM_ZERO;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed && !r.new_episode);
    /* A quiet step ends it; the next intervention starts a new one. */
    v = tu_num(1.0), w = NUM_ZERO;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_FALSE(r.changed || r.new_episode);
    v = tu_num(10.0), w = NUM_ZERO;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed && r.new_episode);
    /* cbf_reset ends it too. */
    cbf_reset(&f);
    v = tu_num(10.0), w = NUM_ZERO;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_TRUE(r.new_episode);
}

static void test_cbf_look_ahead_point_at_a_centre_stops_the_robot(void)
{
    /* p_l exactly at the obstacle's centre: a = 0, no direction to leave by. */
    const sup_entry_t o = entry(3, L_AHEAD, 0.0, 0.35, 0, 0);
    num_t v = tu_num(0.5), w = tu_num(1.0);
    cbf_result_t r;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, v);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.0, w);
}

/* ------------------------------------------------------------- moving */

static void test_cbf_moves_a_still_robot_out_of_the_way_of_a_moving_obstacle(void)
{
    /* Robot still at the origin heading +x; obstacle 0.5 behind it coming
     * along +x: p_l − c = (0.55, 0), a = (1.1, 0), h = 0.55² − 0.4² = 0.1425,
     * b = a·w − α h = 1.1 w_x − 2.85; g1 = a·[1, 0] = 1.1, g2 = l a·[0, 1] = 0.
     * At 3 m/s b = 0.45 > 0: the robot must move forward, v >= 0.45 / 1.1
     * (the least change from v = 0); at 2 m/s b = −0.65 <= 0 = a·u: fine. */
    sup_entry_t o = entry(5, -0.5, 0.0, 0.35, 3.0, 0.0);
    num_t v = NUM_ZERO, w = NUM_ZERO;
    cbf_result_t r;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed);
    TEST_ASSERT_FALSE(r.infeasible);
    TEST_ASSERT_NUM_WITHIN(TOL_VW, 0.45 / 1.1, v);
    TEST_ASSERT_TRUE(ref_slack(0, 0, 0, tu_dbl(v), tu_dbl(w), &o) >= -TOL_RATE);
    /* At 2 m/s the still robot is left alone. */
    o = entry(5, -0.5, 0.0, 0.35, 2.0, 0.0);
    v = NUM_ZERO, w = NUM_ZERO;
    filter(0, 0, 0, &o, 1, &v, &w, &r);
    TEST_ASSERT_FALSE(r.changed);
}

static void test_cbf_meets_two_constraints_at_their_vertex(void)
{
    /* Chased from behind (the case above: 1.1 v >= 0.45) and an obstacle
     * just ahead at (0.45, 0.05): p_l − c = (−0.4, −0.05), h = 0.1625 − 0.16
     * = 0.0025, a = (−0.8, −0.1), g1 = −0.8, g2 = −0.005, b = −0.05: with
     * ω = 0 it asks v <= 0.0625, the chase v >= 0.409. Only a turn meets
     * both: the vertex v = 0.409, ω = (0.05 − 0.8·0.409)/0.005 = −55.5. */
    sup_entry_t e[2];
    e[0] = entry(1, -0.5, 0.0, 0.35, 3.0, 0.0);
    e[1] = entry(2, 0.45, 0.05, 0.35, 0.0, 0.0);
    num_t v = tu_num(2.0), w = NUM_ZERO;
    cbf_result_t r;
    filter(0, 0, 0, e, 2, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed);
    TEST_ASSERT_FALSE(r.infeasible);
    for (int i = 0; i < 2; i++) {
        TEST_ASSERT_TRUE(ref_slack(0, 0, 0, tu_dbl(v), tu_dbl(w), &e[i]) >= -TOL_RATE);
    }
    TEST_ASSERT_DOUBLE_WITHIN(0.1, -55.45, (0.05 - 0.8 * (0.45 / 1.1)) / 0.005);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-3, 2e-2), 0.45 / 1.1, v);
    TEST_ASSERT_NUM_WITHIN(TU_TOL(0.05, 1.0), (0.05 - 0.8 * (0.45 / 1.1)) / 0.005, w);
}

static void test_cbf_brakes_along_the_path_when_two_constraints_are_not_enough(void)
{
    /* Three static obstacles close around the heading (h >= 0 for each:
     * 0.0042, 0.0265, 0.0145), a fast turning command: the two most
     * violated constraints met at their vertex leave the third violated, so
     * the command is scaled down (v and ω together) until all three hold. */
    sup_entry_t e[3];
    e[0] = entry(1, 0.16, 0.39, 0.35, 0, 0);
    e[1] = entry(2, 0.48, 0.04, 0.35, 0, 0);
    e[2] = entry(3, 0.33, 0.31, 0.35, 0, 0);
    for (int i = 0; i < 3; i++) {
        TEST_ASSERT_TRUE(ref_h(0, 0, 0, &e[i]) >= 0.0);
    }
    num_t v = tu_num(2.6), w = tu_num(1.0);
    cbf_result_t r;
    filter(0, 0, 0, e, 3, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed);
    TEST_ASSERT_FALSE(r.infeasible);
    for (int i = 0; i < 3; i++) {
        TEST_ASSERT_TRUE(ref_slack(0, 0, 0, tu_dbl(v), tu_dbl(w), &e[i]) >= -TOL_RATE);
    }
}

static void test_cbf_reports_a_squeeze_it_cannot_escape(void)
{
    /* Obstacles closing from both sides along the heading's normal, fast:
     * no (v, ω) meets both (a look-ahead point cannot move sideways fast
     * enough and both push it). */
    sup_entry_t e[2];
    e[0] = entry(1, 0.05, 0.45, 0.35, 0.0, -3.0);
    e[1] = entry(2, 0.05, -0.45, 0.35, 0.0, 3.0);
    num_t v = tu_num(0.5), w = NUM_ZERO;
    cbf_result_t r;
    filter(0, 0, 0, e, 2, &v, &w, &r);
    TEST_ASSERT_TRUE(r.changed);
    TEST_ASSERT_TRUE(r.infeasible);
    TEST_ASSERT_TRUE(num_is_finite(v) && num_is_finite(w));
}

static void test_cbf_an_infeasible_squeeze_is_new_at_its_first_step_only(void)
{
    /* The squeeze above, twice: infeasible both times, reported as new
     * (SUP_EVENT_INFEASIBLE) at the first only; a feasible step ends it, so
     * the squeeze after it is new again. */
    sup_entry_t e[2];
    e[0] = entry(1, 0.05, 0.45, 0.35, 0.0, -3.0);
    e[1] = entry(2, 0.05, -0.45, 0.35, 0.0, 3.0);
    cbf_result_t r;
    num_t v = tu_num(0.5), w = NUM_ZERO;
    filter(0, 0, 0, e, 2, &v, &w, &r);
    TEST_ASSERT_TRUE(r.infeasible && r.new_infeasible);
    v = tu_num(0.5), w = NUM_ZERO;
    filter(0, 0, 0, e, 2, &v, &w, &r);
    TEST_ASSERT_TRUE(r.infeasible && !r.new_infeasible);
    /* Both 10 m away: nothing to meet. */
    sup_entry_t far[2] = { entry(1, 10.0, 0.0, 0.35, 0, 0), entry(2, -10.0, 0.0, 0.35, 0, 0) };
    v = tu_num(0.5), w = NUM_ZERO;
    filter(0, 0, 0, far, 2, &v, &w, &r);
    TEST_ASSERT_FALSE(r.infeasible || r.new_infeasible);
    v = tu_num(0.5), w = NUM_ZERO;
    filter(0, 0, 0, e, 2, &v, &w, &r);
    TEST_ASSERT_TRUE(r.infeasible && r.new_infeasible);
}

/* --------------------------------------------------------- random states */

static uint32_t lcg = 777u;
static double rnd(double lo, double hi)
{
    lcg = lcg * 1664525u + 1013904223u;
    return lo + (hi - lo) * ((double)(lcg >> 8) / 16777216.0);
}

static void test_cbf_on_random_states_the_barrier_never_falls_faster_than_its_bound(void)
{
    /* 1 to 4 static obstacles around a robot at the origin, each with h >= 0;
     * random commands. Afterwards every constraint holds, unless the filter
     * reports b > 0 ... which static obstacles with h >= 0 never give. And a
     * command that met every constraint with room is returned unchanged. */
    char msg[160];
    int changed = 0, kept = 0;
    for (int k = 0; k < 4000; k++) {
        const double th = tu_q(rnd(-3.1, 3.1));
        sup_entry_t e[4];
        const uint8_t n = (uint8_t)(1 + (int)rnd(0, 3.999));
        for (uint8_t i = 0; i < n; i++) {
            double ox, oy;
            do {
                const double a = rnd(-3.2, 3.2), d = rnd(0.41, 0.8);
                ox = tu_q(d * cos(a));
                oy = tu_q(d * sin(a));
                e[i] = entry((uint8_t)(i + 1u), ox, oy, tu_q(0.35), 0, 0);
            } while (ref_h(0, 0, th, &e[i]) < 0.0);
        }
        const double v0 = tu_q(rnd(-3.0, 5.0)), w0 = tu_q(rnd(-6.0, 6.0));
        bool safe = true;
        for (uint8_t i = 0; i < n; i++) {
            safe = safe && ref_slack(0, 0, th, v0, w0, &e[i]) > 0.01;
        }
        num_t v = tu_num(v0), w = tu_num(w0);
        cbf_result_t r;
        cbf_reset(&f);
        filter(0, 0, th, e, n, &v, &w, &r);
        snprintf(msg, sizeof msg, "case %d: θ %g, n %u, (v, ω) (%g, %g) → (%g, %g)", k, th, n, v0,
                 w0, tu_dbl(v), tu_dbl(w));
        TEST_ASSERT_FALSE_MESSAGE(r.infeasible, msg);
        for (uint8_t i = 0; i < n; i++) {
            TEST_ASSERT_TRUE_MESSAGE(ref_slack(0, 0, th, tu_dbl(v), tu_dbl(w), &e[i]) >= -TOL_RATE,
                                     msg);
        }
        if (safe) {
            TEST_ASSERT_FALSE_MESSAGE(r.changed, msg);
            TEST_ASSERT_TRUE_MESSAGE(v == tu_num(v0) && w == tu_num(w0), msg);
            kept++;
        }
        changed += r.changed ? 1 : 0;
    }
    /* Both kinds of case occurred often (749 and 3245 with this seed). */
    TEST_ASSERT_TRUE(changed > 500);
    TEST_ASSERT_TRUE(kept > 500);
}

/* --------------------------------------------------------- closed loop */

static void test_cbf_keeps_the_barrier_non_negative_in_closed_loop(void)
{
    /* Discrete time (cbf.h): a robot driven at a constant command, forward
     * Euler with dt = 0.02 s, the filter on every step against three static
     * obstacles. However it is aimed, h stays >= 0 for each, so the centre
     * distance stays >= D_s. The command is at most 1.5 m/s and 3 rad/s,
     * what the "mstc" step gives (msw.h: |v_r| + MSW_CATCH_UP). */
    sup_entry_t e[3];
    e[0] = entry(1, 1.0, 0.0, 0.35, 0, 0);
    e[1] = entry(2, 1.3, 0.6, 0.35, 0, 0);
    e[2] = entry(3, 0.6, -0.7, 0.45, 0, 0);
    double worst_h = INFINITY, worst_d = INFINITY;
    char msg[96];
    for (int k = 0; k < 200; k++) {
        double x = -0.8, y = rnd(-1.0, 1.0), th = rnd(-0.8, 0.8);
        const double v0 = rnd(0.3, 1.5), w0 = rnd(-3.0, 3.0);
        cbf_reset(&f);
        for (int step = 0; step < 200; step++) {
            num_t v = tu_num(v0), w = tu_num(w0);
            cbf_result_t r;
            filter(x, y, th, e, 3, &v, &w, &r);
            const double vd = tu_dbl(v), wd = tu_dbl(w);
            x += vd * cos(th) * 0.02;
            y += vd * sin(th) * 0.02;
            th += wd * 0.02;
            for (int i = 0; i < 3; i++) {
                /* The barrier of the next step's state (θ as the plant has
                 * it: the filter sees tu_q of it). */
                worst_h = fmin(worst_h, ref_h(tu_q(x), tu_q(y), tu_q(th), &e[i]));
                worst_d = fmin(worst_d, hypot(x - tu_dbl(e[i].o.x), y - tu_dbl(e[i].o.y)) -
                                            tu_dbl(e[i].d_s));
            }
        }
        snprintf(msg, sizeof msg, "run %d: smallest h %g, clearance %g", k, worst_h, worst_d);
    }
    /* Rounding of the state into num_t and of the filter leave a few 1e-5
     * (float) or 1e-4 (fixed) m²; none of it reaches the centre distance. */
    TEST_ASSERT_TRUE_MESSAGE(worst_h >= -TU_TOL(1e-5, 2e-4), msg);
    TEST_ASSERT_TRUE_MESSAGE(worst_d >= -TU_TOL(1e-6, 1e-4), msg);
}

/* cbf_unreachable(): a robot at rest heading +x (r = 0.05 m, L = 0.3 m,
 * 20 rad/s² at 0.02 s: each wheel within 0.4 rad/s of zero this period),
 * an obstacle (d_s 0.35 m, contact at 0.30 m: gap 0.05) coming at it.
 * From the side, centre (0.05, 0.6) coming down at 0.5 m/s: Δ = (0, −0.6),
 * σ = 0.5 m/s, and across the heading p_l leaves at a_v/3 = 1/3 m/s²:
 * σ/a_β = 1.5 s, braking covers σ²/(2 a_β) = 0.375 m > d − l − 0.30 =
 * 0.25 m: doomed. Its constraint, beside the heading (gain 1.5 + 1.25 =
 * 2.75), ρ = 0.4 + 2.75 × 0.5 × 1.5 = 2.4625, h = 0.36 − 6.06390625 =
 * −5.70390625, g1 = 0, g2 = −1.2, b = 0.6 + 20 × 5.70390625 = 114.678125;
 * on the wheels c_L = 0.05 × 1.2 × 0.05/0.3 = 0.01, c_R = −0.01: at best
 * 0.4 × 0.02 = 0.008 < 114.678125: obstacle 1. At 0.2 m/s (σ²/(2a_β) = 0.06 m)
 * it is not doomed; head on at 0.5 m/s (a_β = 1 m/s²: 0.125 m) neither. */
static void test_cbf_reports_a_moving_obstacle_no_command_within_the_limits_keeps_away(void)
{
    const kin_params_t kin = { tu_num(0.05), tu_num(0.3), tu_num(100.0) };
    const pose_t p = tu_pose(0, 0, 0);
    const cbf_motion_t m = { .brake_t = tu_num(0.36),
                             .inv_accel = tu_num(1.0),
                             .side = tu_num(1.0 / 3.0),
                             .inv_side = tu_num(3.0),
                             .gap = tu_num(0.05) };
    const kin_wheels_t rest = { NUM_ZERO, NUM_ZERO };
    const struct {
        double x, y, vx, vy;
        uint8_t want;
    } cases[] = {
        { 0.05, 0.6, 0.0, -0.5, 1u },
        { 0.05, 0.6, 0.0, -0.2, 0u },
        { 0.65, 0.0, -0.5, 0.0, 0u },
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const sup_entry_t o = entry(1, cases[i].x, cases[i].y, 0.35, cases[i].vx, cases[i].vy);
        const num_t dist = tu_num(sqrt(cases[i].x * cases[i].x + cases[i].y * cases[i].y));
        cbf_init(&f);
        num_t v = NUM_ZERO;
        num_t w = NUM_ZERO;
        cbf_result_t r;
        cbf_step(&f, &p, NUM_ONE, NUM_ZERO, &m, &o, &dist, 1, &v, &w, &r);
        TEST_ASSERT_EQUAL_UINT8(cases[i].want,
                                cbf_unreachable(&f, &o, 1, &kin, &rest, tu_num(0.4)));
    }
    /* The doomed case behind a static obstacle that is not (entry 0 of two):
     * reported by its own id, 2. Its constraint needs a·u >= 114.678125
     * and each rad/s of the box's corner (c_L, c_R) = (0.01, −0.01) gives
     * 0.02: a box of 5,730 rad/s reaches 114.6, short by 0.078125:
     * reported; one of 5,740 reaches 114.8: met, nobody is reported. */
    const sup_entry_t two[2] = { entry(1, 1.5, 0.0, 0.35, 0, 0),
                                 entry(2, 0.05, 0.6, 0.35, 0.0, -0.5) };
    const num_t dists[2] = { tu_num(1.5), tu_num(sqrt(0.05 * 0.05 + 0.6 * 0.6)) };
    cbf_init(&f);
    num_t v2 = NUM_ZERO;
    num_t w2 = NUM_ZERO;
    cbf_result_t r2;
    cbf_step(&f, &p, NUM_ONE, NUM_ZERO, &m, two, dists, 2, &v2, &w2, &r2);
    TEST_ASSERT_EQUAL_UINT8(2u, cbf_unreachable(&f, two, 2, &kin, &rest, tu_num(5730.0)));
    TEST_ASSERT_EQUAL_UINT8(0u, cbf_unreachable(&f, two, 2, &kin, &rest, tu_num(5740.0)));
    /* The doomed case (obstacle 1 of the first cases) as the last entry of
     * a full table (index SUP_MAX_OBSTACLES − 1: the upper half of the
     * masks, sup.h), the others static and 5 m away: reported by its id. */
    static sup_entry_t full[SUP_MAX_OBSTACLES];
    num_t far[SUP_MAX_OBSTACLES];
    for (uint8_t i = 0; i + 1u < SUP_MAX_OBSTACLES; i++) {
        full[i] = entry((uint8_t)(i + 1u), -5.0, 0.1 * i, 0.35, 0, 0);
        far[i] = tu_num(sqrt(25.0 + 0.01 * i * i));
    }
    full[SUP_MAX_OBSTACLES - 1u] = entry(SUP_MAX_OBSTACLES, 0.05, 0.6, 0.35, 0.0, -0.5);
    far[SUP_MAX_OBSTACLES - 1u] = tu_num(sqrt(0.05 * 0.05 + 0.6 * 0.6));
    cbf_init(&f);
    v2 = NUM_ZERO;
    w2 = NUM_ZERO;
    cbf_step(&f, &p, NUM_ONE, NUM_ZERO, &m, full, far, SUP_MAX_OBSTACLES, &v2, &w2, &r2);
    TEST_ASSERT_EQUAL_UINT8(SUP_MAX_OBSTACLES,
                            cbf_unreachable(&f, full, SUP_MAX_OBSTACLES, &kin, &rest, tu_num(0.4)));
    /* A static obstacle is never reported: braking is the guard's. */
    const sup_entry_t still = entry(1, 0.05, 0.4, 0.35, 0, 0);
    const num_t dist = tu_num(sqrt(0.05 * 0.05 + 0.4 * 0.4));
    cbf_init(&f);
    num_t v = tu_num(0.5);
    num_t w = NUM_ZERO;
    cbf_result_t r;
    cbf_step(&f, &p, NUM_ONE, NUM_ZERO, &m, &still, &dist, 1, &v, &w, &r);
    TEST_ASSERT_EQUAL_UINT8(0u, cbf_unreachable(&f, &still, 1, &kin, &rest, tu_num(0.4)));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_cbf_barrier_hand_values);
    RUN_TEST(test_cbf_braking_margin_widens_the_barrier_while_closing);
    RUN_TEST(test_cbf_braking_margin_at_the_centre_of_a_closing_obstacle_is_finite);
    RUN_TEST(test_cbf_brake_guard_hand_cases);
    RUN_TEST(test_cbf_guard_keeps_d_s_under_wheels_within_their_limits);
    RUN_TEST(test_cbf_brakes_a_robot_driving_straight_at_an_obstacle);
    RUN_TEST(test_cbf_brakes_for_the_last_entry_of_a_full_table);
    RUN_TEST(test_cbf_episodes_start_once);
    RUN_TEST(test_cbf_look_ahead_point_at_a_centre_stops_the_robot);
    RUN_TEST(test_cbf_moves_a_still_robot_out_of_the_way_of_a_moving_obstacle);
    RUN_TEST(test_cbf_meets_two_constraints_at_their_vertex);
    RUN_TEST(test_cbf_brakes_along_the_path_when_two_constraints_are_not_enough);
    RUN_TEST(test_cbf_reports_a_squeeze_it_cannot_escape);
    RUN_TEST(test_cbf_an_infeasible_squeeze_is_new_at_its_first_step_only);
    RUN_TEST(test_cbf_reports_a_moving_obstacle_no_command_within_the_limits_keeps_away);
    RUN_TEST(test_cbf_on_random_states_the_barrier_never_falls_faster_than_its_bound);
    RUN_TEST(test_cbf_keeps_the_barrier_non_negative_in_closed_loop);
    return UNITY_END();
}
