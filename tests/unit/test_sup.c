/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/sup: the switch strategy of section 4 of the
 * paper (p1, p2, p3), detection (Definition 1), the held side, several
 * obstacles (docs/equations.md), events, rejected reports, and the radius offset of
 * the thresholds (sup.h).
 *
 * Expected values are hand derivations, written beside each case: distances,
 * dot products and sides of the small geometries used. Inputs at thresholds
 * are chosen exact in binary (0.5, 0.375, 0.625, 3.5, ...) so that "at the
 * threshold" means exactly that in float and in Q16.16.
 */
#include <stdio.h>
#include <string.h>

#include "ctrl/sup.h"
#include "test_util.h"
#include "unity.h"

/* ------------------------------------------------------------ tolerances */

/* Positions and per-obstacle thresholds [m] stored in the table, ≤ 5 m.
 * float: one addition (ulp(5)/2 = 2.4e-7); fixed: two Q16.16 roundings. */
#define TOL_M TU_TOL(1e-6, 4e-5)

static sup_t s;
static sup_event_t ev[SUP_MAX_EVENTS];
static sup_decision_t d;

void setUp(void)
{
    /* Table 1: R_ob 0.1, D_det 3.5, D_act 0.5, D_s 0.35. */
    sup_params_t p;
    p.r_ob = tu_num(0.1);
    p.d_det = tu_num(3.5);
    p.d_act = tu_num(0.5);
    p.d_s = tu_num(0.35);
    memset(&s, 0xA5, sizeof s); /* sup_init must set every field it relies on */
    sup_init(&s, &p);
    memset(ev, 0, sizeof ev);
    memset(&d, 0, sizeof d);
}

void tearDown(void) {}

static sup_obstacle_t obstacle(uint8_t id, double x, double y, double radius)
{
    sup_obstacle_t o;
    o.id = id;
    o.x = tu_num(x);
    o.y = tu_num(y);
    o.radius = tu_num(radius);
    o.vx = NUM_ZERO; /* static: the paper's switch ignores it */
    o.vy = NUM_ZERO;
    return o;
}

/* One supervisor step with the reference moving at 0.5 m/s (p3 false). */
static void step(pose_t robot, pose_t ref, const sup_obstacle_t *reports, size_t n, uint64_t t_us)
{
    memset(ev, 0, sizeof ev);
    sup_step(&s, &robot, &ref, tu_num(0.5), NUM_ZERO, reports, n, t_us, ev, &d);
}

static void expect_event(size_t i, sup_event_kind_t kind, uint8_t id, avd_side_t side,
                         uint64_t t_us)
{
    char msg[64];
    snprintf(msg, sizeof msg, "event %zu", i);
    TEST_ASSERT_TRUE_MESSAGE(i < d.n_events, msg);
    TEST_ASSERT_EQUAL_INT_MESSAGE((int)kind, (int)ev[i].kind, msg);
    TEST_ASSERT_EQUAL_INT_MESSAGE((int)id, (int)ev[i].obstacle, msg);
    TEST_ASSERT_EQUAL_INT_MESSAGE((int)side, (int)ev[i].side, msg);
    TEST_ASSERT_EQUAL_UINT64_MESSAGE(t_us, ev[i].t_us, msg);
}

static void expect_avoiding(uint8_t id, avd_side_t side)
{
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_NOT_NULL(d.active);
    TEST_ASSERT_EQUAL_INT((int)id, (int)d.active->o.id);
    TEST_ASSERT_EQUAL_INT((int)side, (int)d.side);
}

static void expect_tracking(void)
{
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
    TEST_ASSERT_NULL(d.active);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_NONE, d.side);
}

/* ------------------------------------------------------------------ p1 */

static void test_sup_p1_reference_distance_threshold(void)
{
    /* Obstacle (2, 1); robot at (2.3, 1): u1 = (0.3, 0). D_act = 0.5.
     * ref (2.5, 1): u2 = (0.5, 0), |u2| = D_act, not > → false.
     * ref (2.501, 1): |u2| = 0.501 > 0.5, u1·u2 = 0.15 > 0 → true.
     * ref (2.499, 1): |u2| = 0.499 → false. */
    const num_t ox = tu_num(2.0), oy = tu_num(1.0), da = tu_num(0.5);
    pose_t robot = tu_pose(2.3, 1.0, 0.0);
    pose_t ref = tu_pose(2.5, 1.0, 0.0);
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, da));
    ref = tu_pose(2.501, 1.0, 0.0);
    TEST_ASSERT_TRUE(sup_p1(&robot, &ref, ox, oy, da));
    ref = tu_pose(2.499, 1.0, 0.0);
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, da));

    /* Off the axes: ref (2.375, 0.5): u2 = (0.375, −0.5), |u2| = 0.625
     * exactly (3-4-5). Robot (2.3, 0.8): u1 = (0.3, −0.2), u1·u2 = 0.2125 > 0.
     * D_act = 0.625 → false (not >); 0.624 → true; 0.626 → false. */
    robot = tu_pose(2.3, 0.8, 0.0);
    ref = tu_pose(2.375, 0.5, 0.0);
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, tu_num(0.625)));
    TEST_ASSERT_TRUE(sup_p1(&robot, &ref, ox, oy, tu_num(0.624)));
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, tu_num(0.626)));
}

static void test_sup_p1_sign_of_the_dot_product(void)
{
    /* Obstacle (−1, 2); ref at (0, 2): u2 = (1, 0), |u2| = 1 > 0.5.
     * u1 = robot − obstacle; u1·u2 = u1_x. */
    const num_t ox = tu_num(-1.0), oy = tu_num(2.0), da = tu_num(0.5);
    const pose_t ref = tu_pose(0.0, 2.0, 0.0);
    pose_t robot;
    robot = tu_pose(-0.7, 2.0, 0.0); /* u1 = (0.3, 0): dot 0.3 > 0 → true */
    TEST_ASSERT_TRUE(sup_p1(&robot, &ref, ox, oy, da));
    robot = tu_pose(-1.0, 2.3, 0.0); /* u1 = (0, 0.3): dot 0, not > 0 → false */
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, da));
    robot = tu_pose(-1.3, 2.0, 0.0); /* u1 = (−0.3, 0): dot −0.3 → false */
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, da));
    robot = tu_pose(-0.999, 2.3, 0.0); /* u1 = (0.001, 0.3): dot 0.001 → true */
    TEST_ASSERT_TRUE(sup_p1(&robot, &ref, ox, oy, da));
    robot = tu_pose(-1.001, 2.3, 0.0); /* u1 = (−0.001, 0.3): dot −0.001 → false */
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, da));
    /* The dot product, not the x components: ref (−1, 3) → u2 = (0, 1);
     * robot (−0.7, 2.2): u1 = (0.3, 0.2), dot 0.2 → true; robot (−0.7, 1.8):
     * dot −0.2 → false. */
    const pose_t ref_n = tu_pose(-1.0, 3.0, 0.0);
    robot = tu_pose(-0.7, 2.2, 0.0);
    TEST_ASSERT_TRUE(sup_p1(&robot, &ref_n, ox, oy, da));
    robot = tu_pose(-0.7, 1.8, 0.0);
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref_n, ox, oy, da));
}

/* ------------------------------------------------------------------ p2 */

static void test_sup_p2_robot_distance_threshold(void)
{
    /* Obstacle (−1, 2); ref (−0.8, 2.1): u2 = (0.2, 0.1), |u2| = 0.224 <
     * D_act, so p1 is false and p2 is |u1| < D_act alone. */
    const num_t ox = tu_num(-1.0), oy = tu_num(2.0), da = tu_num(0.5);
    const pose_t ref = tu_pose(-0.8, 2.1, 0.0);
    pose_t robot;
    robot = tu_pose(-0.501, 2.0, 0.0); /* |u1| = 0.499 < 0.5 → true */
    TEST_ASSERT_TRUE(sup_p2(&robot, &ref, ox, oy, da));
    robot = tu_pose(-0.5, 2.0, 0.0); /* |u1| = 0.5, not < → false */
    TEST_ASSERT_FALSE(sup_p2(&robot, &ref, ox, oy, da));
    robot = tu_pose(-0.499, 2.0, 0.0); /* |u1| = 0.501 → false */
    TEST_ASSERT_FALSE(sup_p2(&robot, &ref, ox, oy, da));
    /* Off the axes, exact: u1 = (−0.375, 0.5), |u1| = 0.625.
     * D_act 0.625 → false; 0.626 → true; 0.624 → false. */
    robot = tu_pose(-1.375, 2.5, 0.0);
    TEST_ASSERT_FALSE(sup_p2(&robot, &ref, ox, oy, tu_num(0.625)));
    TEST_ASSERT_TRUE(sup_p2(&robot, &ref, ox, oy, tu_num(0.626)));
    TEST_ASSERT_FALSE(sup_p2(&robot, &ref, ox, oy, tu_num(0.624)));
}

static void test_sup_p2_is_false_while_p1_holds(void)
{
    const num_t ox = tu_num(-1.0), oy = tu_num(2.0), da = tu_num(0.5);
    /* Robot close (u1 = (0.3, 0), |u1| = 0.3 < 0.5) but the reference is
     * clear: u2 = (1, 0), |u2| = 1 > 0.5, dot 0.3 > 0 → p1 → p2 false. */
    pose_t robot = tu_pose(-0.7, 2.0, 0.0);
    pose_t ref = tu_pose(0.0, 2.0, 0.0);
    TEST_ASSERT_TRUE(sup_p1(&robot, &ref, ox, oy, da));
    TEST_ASSERT_FALSE(sup_p2(&robot, &ref, ox, oy, da));
    /* Same reference, robot on the far side: u1 = (−0.3, 0), dot −0.3 →
     * p1 false → p2 true. */
    robot = tu_pose(-1.3, 2.0, 0.0);
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, da));
    TEST_ASSERT_TRUE(sup_p2(&robot, &ref, ox, oy, da));
}

/* ------------------------------------------------------------------ p3 */

static void test_sup_p3_only_when_both_reference_velocities_are_zero(void)
{
    TEST_ASSERT_TRUE(sup_p3(NUM_ZERO, NUM_ZERO));
    TEST_ASSERT_FALSE(sup_p3(tu_num(0.1), NUM_ZERO));
    TEST_ASSERT_FALSE(sup_p3(NUM_ZERO, tu_num(-0.1)));
    TEST_ASSERT_FALSE(sup_p3(tu_num(-0.5), tu_num(0.3)));
    TEST_ASSERT_FALSE(sup_p3(tu_num(1e-3), NUM_ZERO));
}

/* ----------------------------------------------------------- detection */

static void test_sup_detects_on_first_step_within_range_and_only_once(void)
{
    const pose_t robot = tu_pose(1.0, 1.0, 0.0), ref = tu_pose(1.2, 1.1, 0.0);
    const uint64_t t0 = 5000000000ull; /* beyond 2^32 µs: t_us is 64-bit */
    sup_obstacle_t o;

    /* D_r = 3.501 > D_det = 3.5: not detected, not remembered, not dropped. */
    o = obstacle(5, 4.501, 1.0, 0.1);
    step(robot, ref, &o, 1, t0);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    TEST_ASSERT_EQUAL_UINT8(0, s.n_obs);
    TEST_ASSERT_EQUAL_UINT16(0, s.dropped);
    expect_tracking();

    /* D_r = 3.5 = D_det: detected (≤), stamped with this step's time. */
    o = obstacle(5, 4.5, 1.0, 0.1);
    step(robot, ref, &o, 1, t0 + 20000u);
    TEST_ASSERT_EQUAL_size_t(1, d.n_events);
    expect_event(0, SUP_EVENT_DETECT, 5, AVD_SIDE_NONE, t0 + 20000u);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    TEST_ASSERT_EQUAL_UINT8(5, s.obs[0].o.id);
    expect_tracking();

    /* Closer, reported again within SUP_AVG_GATE of its entry (0.05 m in x
     * and y): the same obstacle, no second DETECT; the position is updated. */
    o = obstacle(5, 4.45, 1.05, 0.1);
    step(robot, ref, &o, 1, t0 + 40000u);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 4.45, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.05, s.obs[0].o.y);

    /* Not reported this step: still remembered, no event. */
    step(robot, ref, NULL, 0, t0 + 60000u);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);

    /* Reported beyond D_det, 1.55 m from its entry: another obstacle under
     * the same id (sup.h), not yet detected: no event, the entry kept. */
    o = obstacle(5, 6.0, 1.0, 0.1);
    step(robot, ref, &o, 1, t0 + 80000u);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 4.45, s.obs[0].o.x);
    /* Within the gate and beyond D_det (3.501 m from the robot, 0.05 m
     * from its entry): a known obstacle, updated, no event. */
    o = obstacle(5, 4.501, 1.0, 0.1);
    step(robot, ref, &o, 1, t0 + 100000u);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 4.501, s.obs[0].o.x);
}

static void test_sup_the_range_counts_from_the_obstacle_s_boundary(void)
{
    /* Issue 21, case 6. D_det 3.5 is the centre distance at which an obstacle
     * of radius R_ob = 0.1 is seen: its boundary is 3.4 m away. One of radius
     * 1.0 is then seen at a centre distance of 3.4 + 1.0 = 4.4 m (= D_det +
     * r − R_ob, as D_s and D_act are moved: 1.25 and 1.4 m), one of the
     * largest radius a report carries, 2.55 m, at 5.95 m; one of 0.05 m at
     * 3.45 m. Distances by hand, along the x axis. */
    const pose_t robot = tu_pose(0.0, 0.0, 0.0), ref = tu_pose(0.2, 0.0, 0.0);
    static const struct {
        double r, seen, unseen;
    } c[] = { { 1.0, 4.4, 4.41 }, { 2.55, 5.95, 5.96 }, { 0.05, 3.45, 3.46 } };
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        setUp();
        sup_obstacle_t o = obstacle(3, c[i].unseen, 0.0, c[i].r);
        step(robot, ref, &o, 1, 0u);
        TEST_ASSERT_EQUAL_UINT8(0, s.n_obs);
        o = obstacle(3, c[i].seen, 0.0, c[i].r);
        step(robot, ref, &o, 1, 20000u);
        TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
        expect_event(0, SUP_EVENT_DETECT, 3, AVD_SIDE_NONE, 20000u);
        /* Avoidance starts within the range, as for R_ob: D_act + r − R_ob
         * = 0.4 + r <= 3.4 + r. */
        TEST_ASSERT_NUM_WITHIN(TOL_M, 0.4 + c[i].r, s.obs[0].d_act);
    }
}

static void test_sup_remembers_a_detected_obstacle_without_new_reports(void)
{
    /* Detected at 3 m; then the robot is 0.4 m from it with no report:
     * ref (2.8, 0.1) → u2 = (−0.2, 0.1), p1 false; |u1| = 0.4 → p2 →
     * ACTIVATE. φ = 0, θ = 0.1 → wrap(0.1) ≥ 0 → LEFT. */
    sup_obstacle_t o = obstacle(4, 3.0, 0.0, 0.1);
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.2, 0.0, 0.0), &o, 1, 0);
    expect_event(0, SUP_EVENT_DETECT, 4, AVD_SIDE_NONE, 0);
    step(tu_pose(2.6, 0.0, 0.1), tu_pose(2.8, 0.1, 0.0), NULL, 0, 20000);
    TEST_ASSERT_EQUAL_size_t(1, d.n_events);
    expect_event(0, SUP_EVENT_ACTIVATE, 4, AVD_SIDE_LEFT, 20000);
    expect_avoiding(4, AVD_SIDE_LEFT);
}

/* ------------------------------------------------ activation, completion */

static void test_sup_activation_emits_the_side_and_holds_it(void)
{
    /* Step 1: robot (0, 0, 0.2), obstacle 9 at (0.45, 0), ref (0.2, 0.1).
     * |u1| = 0.45 < 0.5; u2 = (−0.25, 0.1), |u2| = 0.27 < 0.5 → p1 false →
     * p2. φ = atan2(0, 0.45) = 0, wrap(0.2 − 0) = 0.2 ≥ 0 → LEFT.
     * Detection and activation in the same step: DETECT first. */
    sup_obstacle_t o = obstacle(9, 0.45, 0.0, 0.1);
    step(tu_pose(0.0, 0.0, 0.2), tu_pose(0.2, 0.1, 0.0), &o, 1, 1000);
    TEST_ASSERT_EQUAL_size_t(2, d.n_events);
    expect_event(0, SUP_EVENT_DETECT, 9, AVD_SIDE_NONE, 1000);
    expect_event(1, SUP_EVENT_ACTIVATE, 9, AVD_SIDE_LEFT, 1000);
    expect_avoiding(9, AVD_SIDE_LEFT);

    /* Step 2: the robot has turned to θ = −0.3 at (0.05, 0): now
     * wrap(θ − φ) = −0.3 < 0, so a fresh choice would be RIGHT; but p1 is
     * still false (ref (0.25, 0.1): u2 = (−0.2, 0.1)), so the side held since
     * activation stays LEFT and nothing is emitted. */
    step(tu_pose(0.05, 0.0, -0.3), tu_pose(0.25, 0.1, 0.0), &o, 1, 21000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_avoiding(9, AVD_SIDE_LEFT);

    /* Step 3: robot on the other side, heading far off: still LEFT. */
    step(tu_pose(0.45, -0.4, 2.5), tu_pose(0.5, 0.2, 0.0), &o, 1, 41000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_avoiding(9, AVD_SIDE_LEFT);
}

static void test_sup_completion_returns_to_tracking(void)
{
    sup_obstacle_t o = obstacle(9, 0.45, 0.0, 0.1);
    step(tu_pose(0.0, 0.0, 0.2), tu_pose(0.2, 0.1, 0.0), &o, 1, 0);
    expect_avoiding(9, AVD_SIDE_LEFT); /* as in the test above */

    /* ref (1.2, 0): u2 = (0.75, 0), |u2| > 0.5; robot (0.45, 0.4):
     * u1 = (0, 0.4), u1·u2 = 0 → p1 false: still avoiding. */
    step(tu_pose(0.45, 0.4, 0.0), tu_pose(1.2, 0.0, 0.0), &o, 1, 20000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_avoiding(9, AVD_SIDE_LEFT);

    /* robot (0.6, 0.35): u1 = (0.15, 0.35), u1·u2 = 0.1125 > 0 → p1 →
     * COMPLETE, tracking. |u1| = 0.38 < 0.5 but p1 holds, so p2 does not and
     * the same obstacle is not activated again in this step. */
    step(tu_pose(0.6, 0.35, 0.0), tu_pose(1.2, 0.0, 0.0), &o, 1, 40000);
    TEST_ASSERT_EQUAL_size_t(1, d.n_events);
    expect_event(0, SUP_EVENT_COMPLETE, 9, AVD_SIDE_NONE, 40000);
    expect_tracking();

    /* Next step, same geometry: nothing happens. */
    step(tu_pose(0.6, 0.35, 0.0), tu_pose(1.2, 0.0, 0.0), &o, 1, 60000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_tracking();

    /* Later p2 holds again for the same obstacle (robot (0.2, 0, 0),
     * ref (0.3, 0.1): u2 = (−0.15, 0.1), p1 false, |u1| = 0.25): activated
     * again, with a fresh side: φ = 0, θ = −0.1 → RIGHT. */
    step(tu_pose(0.2, 0.0, -0.1), tu_pose(0.3, 0.1, 0.0), &o, 1, 80000);
    TEST_ASSERT_EQUAL_size_t(1, d.n_events);
    expect_event(0, SUP_EVENT_ACTIVATE, 9, AVD_SIDE_RIGHT, 80000);
    expect_avoiding(9, AVD_SIDE_RIGHT);
}

/* ---------------------------------------------------- several obstacles */

static void test_sup_activates_the_nearest_obstacle_satisfying_p2(void)
{
    /* Robot (0, 0, 0), ref (0.1, −0.1). Obstacle 7 at (0.45, 0): |u1| = 0.45,
     * u2 = (−0.35, −0.1), |u2| = 0.36 → p1 false → p2. Obstacle 3 at
     * (0, −0.4): |u1| = 0.4, u2 = (0.1, 0.3), |u2| = 0.32 → p2. Nearest: 3.
     * Side for 3: φ = −π/2, wrap(0 + π/2) > 0 → LEFT. Both report orders
     * (the table keeps detection order; nearness decides). */
    sup_obstacle_t r[2];
    for (int order = 0; order < 2; order++) {
        setUp();
        r[order] = obstacle(7, 0.45, 0.0, 0.1);
        r[1 - order] = obstacle(3, 0.0, -0.4, 0.1);
        step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, -0.1, 0.0), r, 2, 777);
        TEST_ASSERT_EQUAL_size_t(3, d.n_events);
        expect_event(0, SUP_EVENT_DETECT, r[0].id, AVD_SIDE_NONE, 777);
        expect_event(1, SUP_EVENT_DETECT, r[1].id, AVD_SIDE_NONE, 777);
        expect_event(2, SUP_EVENT_ACTIVATE, 3, AVD_SIDE_LEFT, 777);
        expect_avoiding(3, AVD_SIDE_LEFT);
    }
}

static void test_sup_skips_a_nearer_obstacle_for_which_p1_holds(void)
{
    /* Robot (0, 0, 0), ref (1, 0).
     * Obstacle 1 at (−0.3, 0), nearer (0.3): u1 = (0.3, 0), u2 = (1.3, 0),
     * |u2| > 0.5, dot > 0 → p1 → not p2.
     * Obstacle 2 at (0.4, 0.1), 0.41 away: u1 = (−0.4, −0.1),
     * u2 = (0.6, −0.1), |u2| = 0.61 > 0.5 but dot = −0.24 + 0.01 < 0 →
     * p1 false → p2. Activated: 2; φ = atan2(0.1, 0.4) = 0.245,
     * wrap(0 − 0.245) < 0 → RIGHT. */
    sup_obstacle_t r[2] = { obstacle(1, -0.3, 0.0, 0.1), obstacle(2, 0.4, 0.1, 0.1) };
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(1.0, 0.0, 0.0), r, 2, 100);
    TEST_ASSERT_EQUAL_size_t(3, d.n_events);
    expect_event(2, SUP_EVENT_ACTIVATE, 2, AVD_SIDE_RIGHT, 100);
    expect_avoiding(2, AVD_SIDE_RIGHT);
}

static void test_sup_completes_one_and_activates_another_in_the_same_step(void)
{
    /* Step 1 (t = 1 s): robot (0, 0, 0.1), ref (0.2, 0.1); A = 1 at (0.45, 0),
     * B = 2 at (1.2, 0.6) (1.34 away). A activated: φ = 0, θ = 0.1 → LEFT. */
    sup_obstacle_t r[2] = { obstacle(1, 0.45, 0.0, 0.1), obstacle(2, 1.2, 0.6, 0.1) };
    step(tu_pose(0.0, 0.0, 0.1), tu_pose(0.2, 0.1, 0.0), r, 2, 1000000);
    TEST_ASSERT_EQUAL_size_t(3, d.n_events);
    expect_event(2, SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT, 1000000);
    expect_avoiding(1, AVD_SIDE_LEFT);

    /* Step 2 (t = 1.02 s): robot (0.9, 0.35, 0), ref (1.5, 0.25).
     * A: u1 = (0.45, 0.35), u2 = (1.05, 0.25), |u2| = 1.08 > 0.5,
     *    dot = 0.4725 + 0.0875 = 0.56 > 0 → p1 → COMPLETE 1.
     * B: u1 = (−0.3, −0.25), |u1| = 0.39 < 0.5; u2 = (0.3, −0.35),
     *    |u2| = 0.46 < 0.5 → p1 false → p2 → ACTIVATE 2.
     *    φ = atan2(0.25, 0.3) = 0.69, wrap(0 − 0.69) < 0 → RIGHT.
     * (A after completion: |u1| = 0.57 > 0.5, not p2.)
     * Order: COMPLETE, then ACTIVATE, both stamped 1020000. */
    step(tu_pose(0.9, 0.35, 0.0), tu_pose(1.5, 0.25, 0.0), r, 2, 1020000);
    TEST_ASSERT_EQUAL_size_t(2, d.n_events);
    expect_event(0, SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE, 1020000);
    expect_event(1, SUP_EVENT_ACTIVATE, 2, AVD_SIDE_RIGHT, 1020000);
    expect_avoiding(2, AVD_SIDE_RIGHT);
}

static void test_sup_does_not_switch_obstacles_while_avoiding(void)
{
    /* Avoiding A (as above); then B comes within D_act while p1 of A is
     * still false: only one controller runs, A stays active. Step 2: robot
     * (0.3, 0.3, 0.5), ref (0.5, 0.3): A: u1 = (−0.15, 0.3), u2 = (0.05, 0.3),
     * |u2| = 0.30 < 0.5 → no completion. B at (0.5, 0.65): |u1| = 0.40 <
     * 0.5, u2 = (0, −0.35) → p2 would hold, but A is active. */
    sup_obstacle_t r[2] = { obstacle(1, 0.45, 0.0, 0.1), obstacle(2, 0.5, 0.65, 0.1) };
    step(tu_pose(0.0, 0.0, 0.1), tu_pose(0.2, 0.1, 0.0), r, 2, 0);
    expect_avoiding(1, AVD_SIDE_LEFT);
    step(tu_pose(0.3, 0.3, 0.5), tu_pose(0.5, 0.3, 0.0), r, 2, 20000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_avoiding(1, AVD_SIDE_LEFT);
}

static void test_sup_works_across_a_100_m_field(void)
{
    /* Issue 3: no squared distance may overflow in a 100 m × 100 m field.
     * Obstacle (100, 100), ref at (0, 0): u2 = (−100, −100), |u2| = 141.4;
     * robot (99.7, 99.6): u1 = (−0.3, −0.4), u1·u2 = 30 + 40 = 70 > 0 → p1;
     * robot (100.3, 100.4): u1·u2 = −70 → not p1;
     * robot (100.3, 100.3): |u1| = 0.42 → p2. */
    const num_t ox = tu_num(100.0), oy = tu_num(100.0), da = tu_num(0.5);
    const pose_t ref = tu_pose(0.0, 0.0, 0.0);
    pose_t robot = tu_pose(99.7, 99.6, 0.0);
    TEST_ASSERT_TRUE(sup_p1(&robot, &ref, ox, oy, da));
    robot = tu_pose(100.3, 100.4, 0.0);
    TEST_ASSERT_FALSE(sup_p1(&robot, &ref, ox, oy, da));
    robot = tu_pose(100.3, 100.3, 0.0);
    TEST_ASSERT_TRUE(sup_p2(&robot, &ref, ox, oy, da));
    /* Across the field diagonal: robot (0, 0), obstacle (100, 100), 141 m:
     * not detected (D_det 3.5), not dropped. */
    sup_obstacle_t o = obstacle(1, 100.0, 100.0, 0.1);
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), &o, 1, 0);
    TEST_ASSERT_EQUAL_UINT8(0, s.n_obs);
    TEST_ASSERT_EQUAL_UINT16(0, s.dropped);
    /* Robot at (97, 98.5): 3.354 m (√(9 + 2.25)) from it → DETECT. */
    step(tu_pose(97.0, 98.5, 0.0), tu_pose(97.1, 98.5, 0.0), &o, 1, 20000);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    expect_event(0, SUP_EVENT_DETECT, 1, AVD_SIDE_NONE, 20000);
}

/* ---------------------------------------------------------- bad reports */

static void test_sup_counts_bad_reports_as_dropped(void)
{
    /* id 0, radius 0 and radius < 0 are rejected and counted; the good one
     * (id 4, 2 m away) is detected. */
    sup_obstacle_t r[4] = { obstacle(0, 1.0, 0.0, 0.1), obstacle(2, 1.0, 0.5, 0.0),
                            obstacle(3, 1.0, -0.5, -0.1), obstacle(4, 2.0, 0.0, 0.1) };
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), r, 4, 50);
    TEST_ASSERT_EQUAL_UINT16(3, s.dropped);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    TEST_ASSERT_EQUAL_UINT8(4, s.obs[0].o.id);
    TEST_ASSERT_EQUAL_size_t(1, d.n_events);
    expect_event(0, SUP_EVENT_DETECT, 4, AVD_SIDE_NONE, 50);
    /* Every step counts again. */
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), r, 4, 70);
    TEST_ASSERT_EQUAL_UINT16(6, s.dropped);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
}

#ifndef NUM_FIXED
/* Float mode only: Q16.16 has no NaN or infinity, so such a report cannot
 * be built in fixed mode. */
static void test_sup_drops_non_finite_reports(void)
{
    sup_obstacle_t r[5] = { obstacle(4, 2.0, 0.0, 0.1), obstacle(5, 1.0, 0.0, 0.1),
                            obstacle(6, 1.0, 0.5, 0.1), obstacle(7, 1.0, -0.5, 0.1),
                            obstacle(8, 1.5, 0.0, 0.1) };
    r[1].x = num_from_float(NAN);
    r[2].y = num_from_float(INFINITY);
    r[3].radius = num_from_float(NAN);
    r[4].radius = num_from_float(INFINITY);
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), r, 5, 0);
    TEST_ASSERT_EQUAL_UINT16(4, s.dropped);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    TEST_ASSERT_EQUAL_UINT8(4, s.obs[0].o.id);
    /* A known id reported with a NaN position: dropped, position kept. */
    r[0].x = num_from_float(NAN);
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), r, 1, 20000);
    TEST_ASSERT_EQUAL_UINT16(5, s.dropped);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 2.0, s.obs[0].o.x);
}
#endif

static void test_sup_table_full_drops_new_obstacles(void)
{
    /* SUP_MAX_OBSTACLES (48) obstacles on a circle of 2 m around the robot:
     * all detected (48 DETECT events, fewer than SUP_MAX_EVENTS). Another
     * id: dropped once per step; the 48 known ids are updates, not drops. */
    sup_obstacle_t r[SUP_MAX_OBSTACLES + 1];
    for (unsigned k = 0; k < SUP_MAX_OBSTACLES; k++) {
        const double a = TU_TWO_PI * (double)k / (double)SUP_MAX_OBSTACLES;
        r[k] = obstacle((uint8_t)(k + 1), 2.0 * cos(a), 2.0 * sin(a), 0.1);
    }
    const uint8_t extra = (uint8_t)(SUP_MAX_OBSTACLES + 1u);
    r[SUP_MAX_OBSTACLES] = obstacle(extra, 0.0, 3.0, 0.1);
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), r, SUP_MAX_OBSTACLES, 0);
    TEST_ASSERT_EQUAL_size_t(SUP_MAX_OBSTACLES, d.n_events);
    TEST_ASSERT_EQUAL_UINT8(SUP_MAX_OBSTACLES, s.n_obs);
    TEST_ASSERT_EQUAL_UINT16(0, s.dropped);
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), r, SUP_MAX_OBSTACLES + 1, 20000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    TEST_ASSERT_EQUAL_UINT8(SUP_MAX_OBSTACLES, s.n_obs);
    TEST_ASSERT_EQUAL_UINT16(1, s.dropped);
    for (unsigned k = 0; k < SUP_MAX_OBSTACLES; k++) {
        TEST_ASSERT_TRUE(s.obs[k].o.id != extra);
    }
}

/* -------------------------------------------------------- radius offset */

static void test_sup_thresholds_move_out_with_the_obstacle_radius(void)
{
    /* sup.h: D_s and D_act move out by (R − R_ob). R = 0.3: +0.2 →
     * D_s 0.55, D_act 0.7. R = 0.05: −0.05 → D_s 0.30, D_act 0.45. R = 0.1:
     * unchanged. */
    sup_obstacle_t r[3] = { obstacle(1, 3.0, 0.0, 0.3), obstacle(2, 0.0, 3.0, 0.05),
                            obstacle(3, -3.0, 0.0, 0.1) };
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.1, 0.0, 0.0), r, 3, 0);
    TEST_ASSERT_EQUAL_UINT8(3, s.n_obs);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.55, s.obs[0].d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.70, s.obs[0].d_act);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.30, s.obs[1].d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.45, s.obs[1].d_act);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.35, s.obs[2].d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.50, s.obs[2].d_act);
}

static void test_sup_large_obstacle_activates_and_completes_at_its_own_d_act(void)
{
    /* Robot (0, 0, 0), ref (0.3, 0.3), obstacle at (0.65, 0): |u1| = 0.65.
     * u2 = (−0.35, 0.3), |u2| = 0.46 → p1 false.
     * Radius 0.1 (D_act 0.5): 0.65 ≥ 0.5, nothing. */
    sup_obstacle_t o = obstacle(1, 0.65, 0.0, 0.1);
    step(tu_pose(0.0, 0.0, 0.0), tu_pose(0.3, 0.3, 0.0), &o, 1, 0);
    TEST_ASSERT_EQUAL_size_t(1, d.n_events); /* DETECT only */
    expect_tracking();

    /* Radius 0.3 (D_act 0.7): 0.65 < 0.7 → ACTIVATE; φ = 0, θ = 0.1 → LEFT. */
    setUp();
    o = obstacle(1, 0.65, 0.0, 0.3);
    step(tu_pose(0.0, 0.0, 0.1), tu_pose(0.3, 0.3, 0.0), &o, 1, 0);
    TEST_ASSERT_EQUAL_size_t(2, d.n_events);
    expect_event(1, SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT, 0);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.55, d.active->d_s);

    /* ref (1.25, 0): u2 = (0.6, 0), |u2| = 0.6: > 0.5 but not > 0.7; robot
     * (0.9, 0.5): u1 = (0.25, 0.5), dot 0.15 > 0. Not complete. */
    step(tu_pose(0.9, 0.5, 0.0), tu_pose(1.25, 0.0, 0.0), &o, 1, 20000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_avoiding(1, AVD_SIDE_LEFT);
    /* ref (1.4, 0): |u2| = 0.75 > 0.7 → COMPLETE. */
    step(tu_pose(0.9, 0.5, 0.0), tu_pose(1.4, 0.0, 0.0), &o, 1, 40000);
    TEST_ASSERT_EQUAL_size_t(1, d.n_events);
    expect_event(0, SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE, 40000);
    expect_tracking();
}

/* ------------------------------------------------------------ p3, reset */

static void test_sup_p3_stops_and_keeps_the_avoidance(void)
{
    sup_obstacle_t o = obstacle(9, 0.45, 0.0, 0.1);
    const pose_t robot = tu_pose(0.0, 0.0, 0.2), ref = tu_pose(0.2, 0.1, 0.0);
    step(robot, ref, &o, 1, 0);
    expect_avoiding(9, AVD_SIDE_LEFT);

    /* v_r = ω_r = 0: STOP, the avoidance state (obstacle, side) is kept. */
    sup_step(&s, &robot, &ref, NUM_ZERO, NUM_ZERO, &o, 1, 20000, ev, &d);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_STOP, d.mode);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    TEST_ASSERT_EQUAL_UINT8(1, s.avoiding);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, s.side);

    /* Moving again: back to AVOID with the held side, no new ACTIVATE. */
    step(robot, ref, &o, 1, 40000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_avoiding(9, AVD_SIDE_LEFT);
}

static void test_sup_p3_stops_while_tracking(void)
{
    const pose_t robot = tu_pose(0.0, 0.0, 0.0), ref = tu_pose(0.2, 0.0, 0.0);
    sup_step(&s, &robot, &ref, NUM_ZERO, NUM_ZERO, NULL, 0, 0, ev, &d);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_STOP, d.mode);
    /* ω_r alone non-zero: not p3. */
    sup_step(&s, &robot, &ref, NUM_ZERO, tu_num(0.3), NULL, 0, 20000, ev, &d);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
}

static void test_sup_reset_forgets_obstacles_and_keeps_thresholds(void)
{
    sup_obstacle_t o = obstacle(9, 0.45, 0.0, 0.1);
    step(tu_pose(0.0, 0.0, 0.2), tu_pose(0.2, 0.1, 0.0), &o, 1, 0);
    expect_avoiding(9, AVD_SIDE_LEFT);
    sup_reset(&s);
    TEST_ASSERT_EQUAL_UINT8(0, s.n_obs);
    TEST_ASSERT_EQUAL_UINT8(0, s.avoiding);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.5, s.p.d_act);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.35, s.p.d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 3.5, s.p.d_det);
    /* Nothing remembered: tracking, and the same report is new again. */
    step(tu_pose(0.0, 0.0, 0.2), tu_pose(0.2, 0.1, 0.0), NULL, 0, 20000);
    expect_tracking();
    step(tu_pose(0.0, 0.0, 0.2), tu_pose(0.2, 0.1, 0.0), &o, 1, 40000);
    expect_event(0, SUP_EVENT_DETECT, 9, AVD_SIDE_NONE, 40000);
}

static void test_sup_set_params_recomputes_thresholds_and_keeps_state(void)
{
    /* Avoiding obstacle 9 (radius 0.3: D_s 0.55, D_act 0.7 under Table 1),
     * obstacle 4 (radius 0.1) remembered. New thresholds D_act 0.6, D_s 0.4:
     * 9 → D_s 0.4 + 0.2 = 0.6, D_act 0.6 + 0.2 = 0.8; 4 → 0.4, 0.6. The
     * table, the avoidance and its side are kept (sup.h). */
    sup_obstacle_t r[2] = { obstacle(9, 0.65, 0.0, 0.3), obstacle(4, 2.0, 2.0, 0.1) };
    step(tu_pose(0.0, 0.0, 0.1), tu_pose(0.3, 0.3, 0.0), r, 2, 0);
    expect_avoiding(9, AVD_SIDE_LEFT); /* 0.65 < 0.7, φ = 0, θ = 0.1 → LEFT */
    sup_params_t p = s.p;
    p.d_act = tu_num(0.6);
    p.d_s = tu_num(0.4);
    sup_set_params(&s, &p);
    TEST_ASSERT_EQUAL_UINT8(2, s.n_obs);
    TEST_ASSERT_EQUAL_UINT8(1, s.avoiding);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, s.side);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.6, s.obs[0].d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.8, s.obs[0].d_act);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.4, s.obs[1].d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.6, s.obs[1].d_act);
    /* The new D_act is the one completion uses: ref at (1.4, 0), |u2| = 0.75,
     * robot (0.9, 0.5), dot 0.1875 > 0. Complete under 0.7, not under 0.8. */
    step(tu_pose(0.9, 0.5, 0.0), tu_pose(1.4, 0.0, 0.0), r, 2, 20000);
    TEST_ASSERT_EQUAL_size_t(0, d.n_events);
    expect_avoiding(9, AVD_SIDE_LEFT);
}

/* ------------------------------------------------ table alone ("mstc") */

static void test_sup_take_reports_alone_detects_and_keeps_velocities(void)
{
    /* The table without the paper's switch: a report within D_det enters
     * it (DETECT), one beyond does not; the velocity is kept. */
    sup_obstacle_t r[2] = { obstacle(3, 1.0, 0.0, 0.1), obstacle(4, 5.0, 0.0, 0.1) };
    r[0].vx = tu_num(0.25);
    r[0].vy = tu_num(-0.5);
    const pose_t robot = tu_pose(0.0, 0.0, 0.0);
    size_t n = 0;
    sup_take_reports(&s, &robot, r, 2, 60000, ev, &n);
    TEST_ASSERT_EQUAL_size_t(1, n);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_DETECT, ev[0].kind);
    TEST_ASSERT_EQUAL_UINT8(3, ev[0].obstacle);
    TEST_ASSERT_EQUAL_UINT64(60000, ev[0].t_us);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.25, s.obs[0].o.vx);
    TEST_ASSERT_NUM_WITHIN(TOL_M, -0.5, s.obs[0].o.vy);
    /* No decision is taken: still tracking. */
    TEST_ASSERT_EQUAL_UINT8(0, s.avoiding);
    /* Events are appended after those already there. */
    r[0].vx = NUM_ZERO;
    const pose_t near = tu_pose(3.0, 0.0, 0.0);
    sup_take_reports(&s, &near, r, 2, 80000, ev, &n);
    TEST_ASSERT_EQUAL_size_t(2, n);
    TEST_ASSERT_EQUAL_UINT8(4, ev[1].obstacle);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.0, s.obs[0].o.vx);
}

static void test_sup_take_finite_reports_drops_id_0_and_no_radius(void)
{
    /* Reports the caller found finite (ctl.c's screening): id 0 and a
     * radius <= 0 are still dropped and counted, the others taken as
     * sup_take_reports() takes them. By hand: obstacle 5 at 1 m is within
     * D_det (DETECT); the report of id 0 and obstacle 6 of radius 0 make
     * two drops. */
    sup_obstacle_t r[3] = { obstacle(5, 1.0, 0.0, 0.1), obstacle(0, 1.5, 0.0, 0.1),
                            obstacle(6, 2.0, 0.0, 0.1) };
    r[2].radius = NUM_ZERO;
    r[0].vy = tu_num(0.75);
    const pose_t robot = tu_pose(0.0, 0.0, 0.0);
    const uint16_t dropped = s.dropped;
    size_t n = 0;
    sup_take_finite_reports(&s, &robot, r, 3, 40000, ev, &n);
    TEST_ASSERT_EQUAL_size_t(1, n);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_DETECT, ev[0].kind);
    TEST_ASSERT_EQUAL_UINT8(5, ev[0].obstacle);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
    TEST_ASSERT_EQUAL_UINT16(dropped + 2u, s.dropped);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.75, s.obs[0].o.vy);
}

static void test_sup_revision_changes_only_when_the_table_does(void)
{
    const sup_obstacle_t o = obstacle(3, 1.0, 0.0, 0.1);
    const pose_t robot = tu_pose(0.0, 0.0, 0.0);
    size_t n = 0;
    uint16_t rev = s.revision;
    sup_take_reports(&s, &robot, &o, 1, 0, ev, &n); /* new entry */
    TEST_ASSERT_TRUE(s.revision != rev);
    rev = s.revision;
    sup_take_reports(&s, &robot, &o, 1, 0, ev, &n); /* the same report */
    TEST_ASSERT_EQUAL_UINT16(rev, s.revision);
    sup_take_reports(&s, &robot, NULL, 0, 0, ev, &n); /* no report */
    TEST_ASSERT_EQUAL_UINT16(rev, s.revision);
    const sup_obstacle_t moved[3] = { obstacle(3, 1.001, 0.0, 0.1), obstacle(3, 1.001, 0.5, 0.1),
                                      obstacle(3, 1.001, 0.5, 0.2) };
    for (int i = 0; i < 3; i++) {
        sup_take_reports(&s, &robot, &moved[i], 1, 0, ev, &n); /* x, then y, then radius */
        TEST_ASSERT_TRUE(s.revision != rev);
        rev = s.revision;
    }
    /* A velocity alone is kept, but moves nothing a cluster is made of. */
    sup_obstacle_t m = moved[2];
    m.vx = tu_num(0.1);
    m.vy = tu_num(0.1);
    sup_take_reports(&s, &robot, &m, 1, 0, ev, &n);
    TEST_ASSERT_EQUAL_UINT16(rev, s.revision);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.1, s.obs[0].o.vy);
    /* New thresholds and a reset change it too. */
    sup_set_params(&s, &s.p);
    TEST_ASSERT_TRUE(s.revision != rev);
    rev = s.revision;
    sup_reset(&s);
    TEST_ASSERT_TRUE(s.revision != rev);
}

/* -------------------------------------- averaged reports ("mstc", sup.h) */

/* One report of @p o into the table through sup_take_averaged_reports(),
 * the robot at the origin (every report here is within D_det). */
static void average(const sup_obstacle_t *o)
{
    const pose_t robot = tu_pose(0.0, 0.0, 0.0);
    size_t n = 0;
    sup_take_averaged_reports(&s, &robot, o, 1, 0, ev, &n);
}

/* Report @p o through average(): taken as it comes, the entry's centre and
 * velocity the report's, (x, y) and (vx, vy), and its mean started anew. */
static void expect_as_it_comes(const sup_obstacle_t *o, double x, double y, double vx, double vy)
{
    average(o);
    TEST_ASSERT_NUM_WITHIN(TOL_M, x, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, y, s.obs[0].o.y);
    TEST_ASSERT_NUM_WITHIN(TOL_M, vx, s.obs[0].o.vx);
    TEST_ASSERT_NUM_WITHIN(TOL_M, vy, s.obs[0].o.vy);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_avg[0]);
}

static void test_sup_averaged_reports_of_a_static_obstacle_take_their_mean(void)
{
    /* Four reports of a static obstacle, each within SUP_AVG_GATE (0.1 m)
     * of the centre so far: the centre is their running mean. By hand:
     * x: 1.0, 1.0625, 0.9375, 1.0625 -> means 1.0, 1.03125, 1.0, 1.015625;
     * y: 0.5, 0.4375, 0.5625, 0.4375 -> means 0.5, 0.46875, 0.5, 0.484375. */
    const double xs[4] = { 1.0, 1.0625, 0.9375, 1.0625 };
    const double ys[4] = { 0.5, 0.4375, 0.5625, 0.4375 };
    const double mx[4] = { 1.0, 1.03125, 1.0, 1.015625 };
    const double my[4] = { 0.5, 0.46875, 0.5, 0.484375 };
    for (int i = 0; i < 4; i++) {
        const sup_obstacle_t o = obstacle(7, xs[i], ys[i], 0.1);
        average(&o);
        TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
        TEST_ASSERT_NUM_WITHIN(TOL_M, mx[i], s.obs[0].o.x);
        TEST_ASSERT_NUM_WITHIN(TOL_M, my[i], s.obs[0].o.y);
        TEST_ASSERT_EQUAL_UINT8((uint8_t)(i + 1), s.n_avg[0]);
    }
    /* The thresholds are the obstacle's own, as for a report taken as it
     * comes: D_s 0.35, D_act 0.5 (radius R_ob). */
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.35, s.obs[0].d_s);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.5, s.obs[0].d_act);
}

static void test_sup_averaged_reports_weigh_at_least_one_in_sup_avg_max(void)
{
    /* SUP_AVG_MAX (8) reports alternating 1 and 1.0625 (x): the running
     * means are 1, 1.03125, 1.0208333, 1.03125, 1.025, 1.03125, 1.0267857,
     * 1.03125 (four of each after 8), and n stops at 8. Then 1.12, twice:
     * each moves the centre by (report − centre) / 8: 1.03125 + 0.08875/8 =
     * 1.04234375, then 1.04234375 + 0.07765625/8 = 1.0520507813. */
    TEST_ASSERT_EQUAL_UINT(8u, SUP_AVG_MAX);
    const double means[8] = { 1.0,   1.03125, 1.0208333333, 1.03125,
                              1.025, 1.03125, 1.0267857143, 1.03125 };
    for (unsigned i = 0; i < 8u; i++) {
        const sup_obstacle_t o = obstacle(7, (i % 2u) == 0u ? 1.0 : 1.0625, 0.0, 0.1);
        average(&o);
        TEST_ASSERT_NUM_WITHIN(TOL_M, means[i], s.obs[0].o.x);
        TEST_ASSERT_EQUAL_UINT8((uint8_t)(i + 1u), s.n_avg[0]);
    }
    const sup_obstacle_t far = obstacle(7, 1.12, 0.0, 0.1);
    average(&far);
    TEST_ASSERT_EQUAL_UINT8(SUP_AVG_MAX, s.n_avg[0]);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.04234375, s.obs[0].o.x);
    average(&far);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.0520507813, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.0, s.obs[0].o.y);
}

static void test_sup_averaged_reports_take_other_reports_as_they_come(void)
{
    /* Started at (1, 0), one report averaged in: n = 2. */
    sup_obstacle_t o = obstacle(7, 1.0, 0.0, 0.1);
    average(&o);
    o.x = tu_num(1.0625);
    average(&o);
    TEST_ASSERT_EQUAL_UINT8(2, s.n_avg[0]);
    /* Beyond the gate (0.15 m > 0.1 m in y): moved, taken as it comes, the
     * mean started anew (n = 1); the next report is averaged with weight
     * 1/2: (1.0625 + 1.125) / 2 = 1.09375. */
    o.y = tu_num(0.15);
    average(&o);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.0625, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.15, s.obs[0].o.y);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_avg[0]);
    o.x = tu_num(1.125);
    average(&o);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.09375, s.obs[0].o.x);
    /* Another radius: taken as it comes, thresholds with it (D_s
     * 0.35 + 0.1 for radius 0.2). */
    o.x = tu_num(1.0);
    o.radius = tu_num(0.2);
    average(&o);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.0, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.45, s.obs[0].d_s);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_avg[0]);
    /* A moving obstacle (a velocity in the report): as it comes, every
     * step; so is the first report after it that says it stopped. */
    o.vx = tu_num(0.25);
    o.x = tu_num(1.0625);
    average(&o);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.0625, s.obs[0].o.x);
    o.x = tu_num(1.0);
    average(&o);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.0, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.25, s.obs[0].o.vx);
    o.vx = NUM_ZERO;
    o.x = tu_num(1.0625);
    expect_as_it_comes(&o, 1.0625, 0.15, 0.0, 0.0);
}

static void test_sup_averaged_reports_across_the_gate_or_moving_along_y_come_as_they_are(void)
{
    /* Started at (1, 0), one report averaged in: n = 2, x = 1.03125. Then
     * 0.15 m beyond the gate in x alone (1.18125 − 1.03125 = 0.15 > 0.1):
     * taken as it comes, n = 1. A report moving along y only (vy 0.25,
     * 0.0625 m on): as it comes; the next one, static again, finds the entry
     * moving (its vy): as it comes too, n = 1 each time. */
    sup_obstacle_t o = obstacle(7, 1.0, 0.0, 0.1);
    average(&o);
    o.x = tu_num(1.0625);
    average(&o);
    TEST_ASSERT_EQUAL_UINT8(2, s.n_avg[0]);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.03125, s.obs[0].o.x);
    o.x = tu_num(1.18125);
    expect_as_it_comes(&o, 1.18125, 0.0, 0.0, 0.0);
    o.vy = tu_num(0.25);
    o.y = tu_num(0.0625);
    expect_as_it_comes(&o, 1.18125, 0.0625, 0.0, 0.25);
    o.vy = NUM_ZERO;
    o.y = tu_num(0.125);
    expect_as_it_comes(&o, 1.18125, 0.125, 0.0, 0.0);
}

static void test_sup_averaged_reports_that_do_not_move_change_nothing(void)
{
    /* Noiseless reports (every report the same, as in the suite's families
     * without [imperfections]): the table is bit for bit the one
     * sup_take_finite_reports() keeps, and the revision does not change. */
    static sup_t plain;
    plain = s;
    const sup_obstacle_t o = obstacle(7, 0.7, -0.3, 0.15);
    const pose_t robot = tu_pose(0.0, 0.0, 0.0);
    size_t n = 0;
    average(&o);
    sup_take_finite_reports(&plain, &robot, &o, 1, 0, ev, &n);
    const uint16_t rev = s.revision;
    for (int i = 0; i < 40; i++) {
        average(&o);
        sup_take_finite_reports(&plain, &robot, &o, 1, 0, ev, &n);
    }
    TEST_ASSERT_EQUAL_UINT16(rev, s.revision);
    TEST_ASSERT_EQUAL_UINT8(1, s.n_avg[0]); /* a repeated report is not counted */
    TEST_ASSERT_EQUAL_MEMORY(&plain.obs[0].o, &s.obs[0].o, sizeof s.obs[0].o);
    TEST_ASSERT_TRUE(plain.obs[0].d_s == s.obs[0].d_s && plain.obs[0].d_act == s.obs[0].d_act);
}

/* ------------------------- an id that comes back elsewhere (sup.h, slots) */

/* Reports @p o, the robot at (@p robot_x, 0), through the averaged path
 * ("mstc") or the plain one ("paper"): the events it gave. */
static size_t take(const sup_obstacle_t *o, double robot_x, bool averaged)
{
    const pose_t robot = tu_pose(robot_x, 0.0, 0.0);
    size_t n = 0;
    memset(ev, 0, sizeof ev);
    if (averaged) {
        sup_take_averaged_reports(&s, &robot, o, 1, 40000, ev, &n);
    } else {
        sup_take_reports(&s, &robot, o, 1, 40000, ev, &n);
    }
    return n;
}

static void expect_detect(size_t n, uint8_t id)
{
    TEST_ASSERT_EQUAL_size_t(1, n);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_DETECT, ev[0].kind);
    TEST_ASSERT_EQUAL_UINT8(id, ev[0].obstacle);
    TEST_ASSERT_EQUAL_UINT64(40000, ev[0].t_us);
}

static void test_sup_a_static_id_reported_beyond_the_gate_is_a_new_obstacle(void)
{
    for (int averaged = 1; averaged >= 0; averaged--) {
        setUp();
        /* Detected at (1, 0.5). */
        sup_obstacle_t o = obstacle(7, 1.0, 0.5, 0.1);
        expect_detect(take(&o, 0.0, averaged != 0), 7);
        /* 0.05 m on in x, within the gate (0.1): the same obstacle, no
         * event. Averaged: the mean of 1.0 and 1.05, 1.025, two reports;
         * plain: taken as it comes, 1.05. */
        o.x = tu_num(1.05);
        uint16_t rev = s.revision;
        TEST_ASSERT_EQUAL_size_t(0, take(&o, 0.0, averaged != 0));
        TEST_ASSERT_NUM_WITHIN(TOL_M, averaged ? 1.025 : 1.05, s.obs[0].o.x);
        TEST_ASSERT_EQUAL_UINT8(averaged ? 2 : 1, s.n_avg[0]);
        TEST_ASSERT_TRUE(s.revision != rev);
        /* 0.15 m beyond that centre in x (1.175 or 1.2): another obstacle
         * under the same id: DETECT, the entry the report's, in the same
         * place of the table, its mean started anew, the revision new. */
        const double x = averaged ? 1.175 : 1.2;
        o.x = tu_num(x);
        rev = s.revision;
        expect_detect(take(&o, 0.0, averaged != 0), 7);
        TEST_ASSERT_EQUAL_UINT8(1, s.n_obs);
        TEST_ASSERT_NUM_WITHIN(TOL_M, x, s.obs[0].o.x);
        TEST_ASSERT_NUM_WITHIN(TOL_M, 0.5, s.obs[0].o.y);
        TEST_ASSERT_EQUAL_UINT8(1, s.n_avg[0]);
        TEST_ASSERT_TRUE(s.revision != rev);
        /* And in y alone: 0.15 m on. */
        o.y = tu_num(0.65);
        expect_detect(take(&o, 0.0, averaged != 0), 7);
        TEST_ASSERT_NUM_WITHIN(TOL_M, 0.65, s.obs[0].o.y);
        /* Another radius within the gate: not another obstacle (taken as it
         * comes, D_s 0.35 + 0.1 with it). */
        o.radius = tu_num(0.2);
        TEST_ASSERT_EQUAL_size_t(0, take(&o, 0.0, averaged != 0));
        TEST_ASSERT_NUM_WITHIN(TOL_M, 0.45, s.obs[0].d_s);
    }
}

static void test_sup_an_id_back_elsewhere_beyond_the_range_is_not_yet_detected(void)
{
    /* Detected at (1, 0.5) from the origin; the id then reported at (4, 0),
     * 4 m from the robot, beyond D_det (3.5): not yet detected, so the
     * entry stays the obstacle it was (and the revision with it). From
     * (1, 0) it is 3 m away: detected, the entry replaced. */
    sup_obstacle_t o = obstacle(7, 1.0, 0.5, 0.1);
    expect_detect(take(&o, 0.0, true), 7);
    o = obstacle(7, 4.0, 0.0, 0.1);
    const uint16_t rev = s.revision;
    TEST_ASSERT_EQUAL_size_t(0, take(&o, 0.0, true));
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.0, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.5, s.obs[0].o.y);
    TEST_ASSERT_EQUAL_UINT16(rev, s.revision);
    expect_detect(take(&o, 1.0, true), 7);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 4.0, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.0, s.obs[0].o.y);
}

static void test_sup_a_moving_id_has_a_gate_widened_by_its_speed(void)
{
    /* Moving at 1 m/s along x: the gate in x is 0.1 + 1 × 0.5 = 0.6 m, in y
     * 0.1 + 0 × 0.5 = 0.1 m (SUP_MOVING_GATE_TIME 0.5 s). */
    TEST_ASSERT_TRUE(SUP_MOVING_GATE_TIME == NUM_C(0.5));
    sup_obstacle_t o = obstacle(8, 1.0, 0.0, 0.1);
    o.vx = NUM_ONE;
    expect_detect(take(&o, 0.0, true), 8);
    /* 0.55 m on in x: itself, taken as it comes. */
    o.x = tu_num(1.55);
    TEST_ASSERT_EQUAL_size_t(0, take(&o, 0.0, true));
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.55, s.obs[0].o.x);
    /* 0.65 m on: another obstacle. */
    o.x = tu_num(2.2);
    expect_detect(take(&o, 0.0, true), 8);
    /* 0.15 m across (y), where it does not move: another. */
    o.y = tu_num(0.15);
    expect_detect(take(&o, 0.0, true), 8);
    /* A report that says it stopped, 0.4 m on: the entry's speed (1 m/s)
     * still widens the gate to 0.6 m: itself, its velocity now 0. */
    o.x = tu_num(2.6);
    o.vx = NUM_ZERO;
    TEST_ASSERT_EQUAL_size_t(0, take(&o, 0.0, true));
    TEST_ASSERT_NUM_WITHIN(TOL_M, 2.6, s.obs[0].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.0, s.obs[0].o.vx);
    /* Static again, both: 0.15 m on is another. */
    o.x = tu_num(2.75);
    expect_detect(take(&o, 0.0, true), 8);
}

/* ------------------------------------------- sets of table indices (sup.h) */

static void test_sup_mask_helpers_work_on_both_halves(void)
{
    /* Hand values: bit i of a 64-bit word is 2^i. */
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x1), sup_mask_of(0));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x80000000), sup_mask_of(31));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x100000000), sup_mask_of(32));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x800000000000), sup_mask_of(47));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x8000000000000000), sup_mask_of(63));
    const sup_mask_t m = UINT64_C(0x0000800100000001); /* indices 0, 32, 47 */
    const bool want[64] = { [0] = true, [32] = true, [47] = true };
    for (unsigned i = 0; i < 64u; i++) {
        TEST_ASSERT_EQUAL_INT_MESSAGE(want[i], sup_mask_has(m, i), "index");
    }
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0), sup_mask_first(0));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x1), sup_mask_first(1));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x7FFFFFFF), sup_mask_first(31));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0xFFFFFFFF), sup_mask_first(32));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x1FFFFFFFF), sup_mask_first(33));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0xFFFFFFFFFFFF), sup_mask_first(48));
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0x7FFFFFFFFFFFFFFF), sup_mask_first(63));
    /* Walking m: 0, 32, 47, in that order, then empty. */
    const unsigned order[3] = { 0, 32, 47 };
    sup_mask_t rest = m;
    for (unsigned k = 0; k < 3u; k++) {
        TEST_ASSERT_EQUAL_UINT(order[k], sup_mask_lowest(rest));
        rest = sup_mask_without_lowest(rest);
    }
    TEST_ASSERT_EQUAL_HEX64(UINT64_C(0), rest);
    TEST_ASSERT_EQUAL_UINT(63u, sup_mask_lowest(UINT64_C(0x8000000000000000)));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_sup_p1_reference_distance_threshold);
    RUN_TEST(test_sup_p1_sign_of_the_dot_product);
    RUN_TEST(test_sup_p2_robot_distance_threshold);
    RUN_TEST(test_sup_p2_is_false_while_p1_holds);
    RUN_TEST(test_sup_p3_only_when_both_reference_velocities_are_zero);
    RUN_TEST(test_sup_detects_on_first_step_within_range_and_only_once);
    RUN_TEST(test_sup_the_range_counts_from_the_obstacle_s_boundary);
    RUN_TEST(test_sup_remembers_a_detected_obstacle_without_new_reports);
    RUN_TEST(test_sup_activation_emits_the_side_and_holds_it);
    RUN_TEST(test_sup_completion_returns_to_tracking);
    RUN_TEST(test_sup_activates_the_nearest_obstacle_satisfying_p2);
    RUN_TEST(test_sup_skips_a_nearer_obstacle_for_which_p1_holds);
    RUN_TEST(test_sup_completes_one_and_activates_another_in_the_same_step);
    RUN_TEST(test_sup_does_not_switch_obstacles_while_avoiding);
    RUN_TEST(test_sup_works_across_a_100_m_field);
    RUN_TEST(test_sup_counts_bad_reports_as_dropped);
#ifndef NUM_FIXED
    RUN_TEST(test_sup_drops_non_finite_reports);
#endif
    RUN_TEST(test_sup_table_full_drops_new_obstacles);
    RUN_TEST(test_sup_thresholds_move_out_with_the_obstacle_radius);
    RUN_TEST(test_sup_large_obstacle_activates_and_completes_at_its_own_d_act);
    RUN_TEST(test_sup_p3_stops_and_keeps_the_avoidance);
    RUN_TEST(test_sup_p3_stops_while_tracking);
    RUN_TEST(test_sup_reset_forgets_obstacles_and_keeps_thresholds);
    RUN_TEST(test_sup_set_params_recomputes_thresholds_and_keeps_state);
    RUN_TEST(test_sup_take_reports_alone_detects_and_keeps_velocities);
    RUN_TEST(test_sup_take_finite_reports_drops_id_0_and_no_radius);
    RUN_TEST(test_sup_revision_changes_only_when_the_table_does);
    RUN_TEST(test_sup_averaged_reports_of_a_static_obstacle_take_their_mean);
    RUN_TEST(test_sup_averaged_reports_weigh_at_least_one_in_sup_avg_max);
    RUN_TEST(test_sup_averaged_reports_take_other_reports_as_they_come);
    RUN_TEST(test_sup_averaged_reports_across_the_gate_or_moving_along_y_come_as_they_are);
    RUN_TEST(test_sup_averaged_reports_that_do_not_move_change_nothing);
    RUN_TEST(test_sup_a_static_id_reported_beyond_the_gate_is_a_new_obstacle);
    RUN_TEST(test_sup_an_id_back_elsewhere_beyond_the_range_is_not_yet_detected);
    RUN_TEST(test_sup_a_moving_id_has_a_gate_widened_by_its_speed);
    RUN_TEST(test_sup_mask_helpers_work_on_both_halves);
    return UNITY_END();
}
