/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/msw: the "mstc" switch strategy. The side of
 * a cluster, activation on the robot's own motion (closing within D_act, or
 * a moving obstacle's closest approach), the circle followed, the release
 * (dwell, p1, roll-out), the activation limit, the hand-over to a nearer
 * obstacle, blocked detection (a full turn, or standing still) and the
 * resume, and p3.
 *
 * Expected values are hand derivations written beside each case, for Table 1
 * thresholds (D_s 0.35, D_act 0.5, R_m 0.2: width 0.4) and obstacles of the
 * default radius.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ctrl/msw.h"
#include "test_util.h"
#include "unity.h"

static sup_t s;
static msw_t m;
static sup_event_t ev[SUP_MAX_EVENTS];
static size_t n_ev;
static msw_decision_t d;
static num_t dist[SUP_MAX_OBSTACLES];

/* The followed circle's radius [m]: D_s + offset, sums of two values. */
#define TOL_M TU_TOL(1e-6, 4e-5)

void setUp(void)
{
    const sup_params_t p = {
        .r_ob = tu_num(0.1), .d_det = tu_num(3.5), .d_act = tu_num(0.5), .d_s = tu_num(0.35)
    };
    memset(&s, 0xA5, sizeof s);
    sup_init(&s, &p);
    memset(&m, 0xA5, sizeof m);
    msw_init(&m, tu_num(0.4));
    n_ev = 0;
}

void tearDown(void) {}

static sup_obstacle_t obstacle(uint8_t id, double x, double y, double vx, double vy)
{
    sup_obstacle_t o;
    memset(&o, 0, sizeof o);
    o.id = id;
    o.x = tu_num(x);
    o.y = tu_num(y);
    o.radius = tu_num(0.1);
    o.vx = tu_num(vx);
    o.vy = tu_num(vy);
    return o;
}

/* One step: the table takes @p obs, then the strategy runs with the robot
 * at @p robot, the reference at @p ref moving at v_r = 0.5, and the tracking
 * command (v_trk, w_trk). */
typedef struct {
    pose_t robot, ref;
    double v_r, w_r, v_trk, w_trk;
    uint64_t t_us;
    uint8_t filtered; /* msw_input_t::filtered */
} step_t;

static void decide(const step_t *k);

static void step(const step_t *k, const sup_obstacle_t *obs, size_t n)
{
    memset(ev, 0, sizeof ev);
    n_ev = 0;
    sup_take_reports(&s, &k->robot, obs, n, k->t_us, ev, &n_ev);
    n_ev = 0; /* only the strategy's own events below */
    decide(k);
}

/* The strategy's step at @p k on the table as it is, its events after the
 * n_ev there already. */
static void decide(const step_t *k)
{
    for (uint8_t i = 0; i < s.n_obs; i++) {
        dist[i] = num_hypot(num_sub(s.obs[i].o.x, k->robot.x), num_sub(s.obs[i].o.y, k->robot.y));
    }
    const msw_input_t in = { .robot = &k->robot,
                             .ref = &k->ref,
                             .host = &k->ref,
                             .range = NUM_C(1.5),
                             .v_r = tu_num(k->v_r),
                             .w_r = tu_num(k->w_r),
                             .cos_th = num_cos(k->robot.theta),
                             .sin_th = num_sin(k->robot.theta),
                             .v_trk = tu_num(k->v_trk),
                             .w_trk = tu_num(k->w_trk),
                             .dist = dist,
                             .t_us = k->t_us,
                             .filtered = k->filtered };
    msw_step(&m, &s, &in, ev, &n_ev, &d);
}

static step_t at(double x, double y, double th, double rx, double ry, double rth, uint64_t t_us)
{
    step_t k = { .robot = tu_pose(x, y, th),
                 .ref = tu_pose(rx, ry, rth),
                 .v_r = 0.5,
                 .w_r = 0.0,
                 .v_trk = 0.5,
                 .w_trk = 0.0,
                 .t_us = t_us };
    return k;
}

static void expect_event(sup_event_kind_t kind, uint8_t id, avd_side_t side)
{
    TEST_ASSERT_EQUAL_size_t(1, n_ev);
    TEST_ASSERT_EQUAL_INT((int)kind, (int)ev[0].kind);
    TEST_ASSERT_EQUAL_UINT8(id, ev[0].obstacle);
    TEST_ASSERT_EQUAL_INT((int)side, (int)ev[0].side);
}

/* The side the strategy chooses on activation, with the robot heading +x
 * at (x, y), the reference at the origin heading along +x (v_r may be < 0). */
static avd_side_t side_for(double x, double y, double v_r, const sup_obstacle_t *o, size_t n)
{
    step_t k = at(x, y, 0.0, 0.0, 0.0, 0.0, 0);
    k.v_r = v_r;
    step(&k, o, n);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    return m.side;
}

/* ------------------------------------------------------------------ side */

static void test_msw_side_passes_where_the_cluster_leaves_the_path_nearer(void)
{
    /* Reference along the x axis. One obstacle 0.2 left of it, 0.45 ahead of
     * the robot (inside D_act, closing): edges 0.2 ± 0.41 → passing left
     * takes 0.61, passing right 0.21: RIGHT. Mirrored: LEFT. */
    sup_obstacle_t o = obstacle(1, 0.4, 0.2, 0, 0);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, side_for(0.0, 0.0, 0.5, &o, 1));
    setUp();
    o = obstacle(1, 0.4, -0.2, 0, 0);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, side_for(0.0, 0.0, 0.5, &o, 1));
    /* A reference driving backwards: its path runs along −x, so the same
     * obstacle (y = −0.2) is 0.2 to its left: RIGHT. */
    setUp();
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, side_for(0.0, 0.0, -0.5, &o, 1));
}

static void test_msw_side_of_a_cluster_uses_its_whole_extent(void)
{
    /* A cluster across the path: (0.45, 0.3) and (0.45, −0.1), 0.4 apart
     * (overlapping circles). Left edge 0.3 + 0.41 = 0.71, right edge
     * −0.1 − 0.41 = −0.51: RIGHT, though its nearer member (on the path's
     * right) alone would say LEFT. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.3, 0, 0), obstacle(2, 0.45, -0.1, 0, 0) };
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, side_for(0.0, 0.0, 0.5, o, 2));
    TEST_ASSERT_EQUAL_HEX64(0x0003u, m.cluster);
}

static void test_msw_side_on_the_path_falls_back_to_the_heading_then_left(void)
{
    /* Obstacle on the path at (0.35, 0) (offset 0: a tie). The robot 0.3
     * left of the path, heading +x, 0.461 from it, sees it at
     * ψ = atan2(−0.3, 0.35) = −0.709 with half-width asin(0.41/0.461) =
     * 1.095: L + R = 2ψ = −1.42 < −0.1, the extent leans right: turn LEFT.
     * From 0.3 right of the path: RIGHT. */
    sup_obstacle_t o = obstacle(1, 0.35, 0.0, 0, 0);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, side_for(0.0, 0.3, 0.5, &o, 1));
    setUp();
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, side_for(0.0, -0.3, 0.5, &o, 1));
    /* Exactly head-on, on the path: LEFT. */
    setUp();
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, side_for(0.0, 0.0, 0.5, &o, 1));
}

static void test_msw_side_passes_behind_a_crossing_obstacle(void)
{
    /* An obstacle ahead moving to the robot's left (+y): its back is on the
     * robot's right: RIGHT (whatever the path says: it is 0.2 right of it,
     * which alone would give LEFT). Moving to the right: LEFT. */
    sup_obstacle_t o = obstacle(1, 0.4, -0.2, 0.0, 0.5);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, side_for(0.0, 0.0, 0.5, &o, 1));
    setUp();
    o = obstacle(1, 0.4, 0.2, 0.0, -0.5);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, side_for(0.0, 0.0, 0.5, &o, 1));
}

/* ------------------------------------------------------------ activation */

static void test_msw_activates_within_d_act_when_closing_whatever_the_reference(void)
{
    /* Robot at the origin heading +x at 0.5 m/s. Obstacle 1 straight ahead
     * at 0.45 < D_act: closing → ACTIVATE, even though the reference is far
     * beyond it (p1 would hold: the paper would not activate). */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    step_t k = at(0, 0, 0, 5.0, 0.0, 0.0, 40000);
    step(&k, &o, 1);
    expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
    TEST_ASSERT_EQUAL_UINT64(40000, ev[0].t_us);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_EQUAL_PTR(&s.obs[0], d.followed);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, d.side);
    /* It follows the circle D_s + MSW_FOLLOW_OFFSET = 0.43 around it. */
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.43, d.circle.d_s);
    TEST_ASSERT_TRUE(d.circle.x == s.obs[0].o.x && d.circle.y == s.obs[0].o.y);
}

static void test_msw_does_not_activate_when_not_closing_or_beyond_d_act(void)
{
    /* Beside (tangent), behind, and ahead but at 0.55 > D_act: tracking. */
    const sup_obstacle_t o[3] = { obstacle(1, 0.0, 0.45, 0, 0), obstacle(2, -0.45, 0.0, 0, 0),
                                  obstacle(3, 0.55, 0.0, 0, 0) };
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 3);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
    TEST_ASSERT_NULL(d.followed);
    /* The same robot standing still (v_trk = 0) closes on nothing either,
     * even with an obstacle at 0.45 straight ahead. */
    setUp();
    const sup_obstacle_t ahead = obstacle(4, 0.45, 0.0, 0, 0);
    k.v_trk = 0.0;
    step(&k, &ahead, 1);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
}

static void test_msw_activates_the_nearest_boundary(void)
{
    /* Two obstacles within D_act and closing: 0.480 ahead-left and 0.420
     * ahead-right. The nearer boundary (0.420 − 0.35) triggers; being 0.669
     * apart (< 0.7: overlapping circles) they are one cluster. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.3, 0.375, 0, 0), obstacle(2, 0.3, -0.294, 0, 0) };
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_size_t(1, n_ev);
    TEST_ASSERT_EQUAL_UINT8(2, ev[0].obstacle);
    TEST_ASSERT_EQUAL_HEX64(0x0003u, m.cluster);
    /* Far apart instead (1.2): each its own cluster; the nearer triggers. */
    setUp();
    const sup_obstacle_t far[2] = { obstacle(1, 3.0, 0.0, 0, 0), obstacle(2, 0.3, -0.294, 0, 0) };
    step(&k, far, 2);
    TEST_ASSERT_EQUAL_UINT8(2, ev[0].obstacle);
    TEST_ASSERT_EQUAL_HEX64(0x0002u, m.cluster);
}

static void test_msw_activates_early_for_a_moving_obstacle_on_a_collision_course(void)
{
    /* Robot at the origin heading +x at 0.5 m/s; obstacle at (1.0, −0.5)
     * moving +y at 0.5 m/s: relative position (1, −0.5), relative velocity
     * (−0.5, 0.5): t* = 0.75 / 0.5 = 1.5 s, at (0.25, 0.25): 0.354 m
     * < D_s + MSW_CPA_MARGIN = 0.4. Centre distance 1.118 < D_act +
     * MSW_CPA_REACH = 1.5: ACTIVATE now, passing behind it (it moves to the
     * robot's left): RIGHT. */
    const sup_obstacle_t o = obstacle(1, 1.0, -0.5, 0.0, 0.5);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, &o, 1);
    expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_RIGHT);
    /* The same obstacle static: nothing (1.118 > D_act). */
    setUp();
    const sup_obstacle_t still = obstacle(1, 1.0, -0.5, 0.0, 0.0);
    step(&k, &still, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    /* Moving alongside at the robot's own velocity, 1.4 m away: no relative
     * motion, the closest approach is now: nothing. */
    setUp();
    const sup_obstacle_t wide = obstacle(1, 1.0, -1.0, 0.5, 0.0);
    step(&k, &wide, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
}

static void test_msw_moving_obstacle_judged_by_the_roll_out_chord(void)
{
    /* Robot at the origin heading +x, an obstacle at (0.45, −0.15), 0.474 m
     * away (< D_act = 0.5), moving at (0.3, −0.3) m/s. Tracking straight at
     * 0.5 m/s the robot's velocity relative to it is (0.2, 0.3), whose dot
     * with (0.45, −0.15) is 0.045 > 0: closing within D_act, ACTIVATE.
     * Tracking (0.5 m/s, π/2 rad/s) turns it a quarter round a circle of
     * radius 1/π m in the 1 s roll-out: the chord (1/π, 1/π) m, so the
     * velocity over the roll-out is (0.318, 0.318) m/s, relative (0.018,
     * 0.618), dot −0.085 < 0: not closing; the closest approach is now,
     * 0.474 m > D_s + MSW_CPA_MARGIN = 0.40: no activation, though the
     * heading alone says closing (computed by hand and checked in Python). */
    const sup_obstacle_t o = obstacle(1, 0.45, -0.15, 0.3, -0.3);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(1, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_ACTIVATE, ev[0].kind);
    TEST_ASSERT_EQUAL_UINT8(1, ev[0].obstacle);
    setUp();
    k.w_trk = 1.5707963267948966;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
}

static void test_msw_gapped_cluster_widens_the_circle_followed(void)
{
    /* Two obstacles 0.9 apart: circles of 0.35 leave a gap of 0.2 < 0.4:
     * one cluster with a gap. The circles followed grow to D_s + 0.4/2 +
     * MSW_FILL_MARGIN = 0.57, so that they overlap (0.57 + 0.57 > 0.9). */
    const sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.0, 0, 0), obstacle(2, 0.45, 0.9, 0, 0) };
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_EQUAL_HEX64(0x0003u, m.cluster);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.57, d.circle.d_s);
}

static void test_msw_follows_the_member_nearest_now_or_just_ahead(void)
{
    /* A cluster of two overlapping obstacles: A at (0.45, 0) ahead, B at
     * (0.75, 0.35): 0.46 apart. From the origin heading +x A is nearer (0.45
     * against 0.83; 0.25 ahead 0.20 against 0.60): A. From (0.2, 0.45)
     * heading +x, A is 0.515 away and B 0.559 (B is farther), but 0.25
     * ahead, at (0.45, 0.45), A is 0.45 and B 0.316: B. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.0, 0, 0), obstacle(2, 0.75, 0.35, 0, 0) };
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_PTR(&s.obs[0], d.followed);
    k = at(0.2, 0.45, 0, 0.1, 0.0, 0.0, 20000);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_EQUAL_PTR(&s.obs[1], d.followed);
}

/* --------------------------------------------------------------- release */

/* Activate obstacle 1 at (0.45, 0) from the origin at t = 0. */
static void activate_one(const sup_obstacle_t *o)
{
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 1);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_release_waits_for_the_dwell_then_completes(void)
{
    /* After going round: robot at (0.45, 0.41) heading +x, tracking straight
     * on (+x at 0.5 m/s for 1 s: the segment to (0.95, 0.41), 0.41 from the
     * obstacle at its start and further on, so more than 0.37 = D_s + margin
     * and never closer than 0.41 − 0.02). The reference at (1.2, 0.45) is
     * past: u2 = (0.75, 0.45), |u2| = 0.87 > 0.5, u1·u2 = 0.18 > 0: p1. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    activate_one(&o);
    step_t k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, 480000); /* 0.48 s: dwell not over */
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    k.t_us = 500000;
    k.ref.x = tu_num(1.21); /* on its schedule (a still one waits: test_msw_held_*) */
    step(&k, &o, 1);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
}

static void test_msw_release_needs_p1(void)
{
    /* As above, but the reference still near it, at (0.3, 0.4): u1·u2 > 0
     * but |u2| = 0.427 < 0.5: no p1, no release. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    activate_one(&o);
    step_t k = at(0.45, 0.41, 0.0, 0.3, 0.4, 0.0, 1000000);
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_release_needs_the_roll_out_clear(void)
{
    /* p1 holds, but the tracking command turns back right at 1.5 rad/s: the
     * arc of radius 1/3 about (0.45, 0.077), from its top clockwise through
     * 1.5 rad, ends at (0.782, 0.100), 0.347 from the obstacle: closer than
     * the 0.41 − 0.02 = 0.39 the robot is allowed to close in (it is within
     * D_act + margin): no release. Straight on it releases (the case above). */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    activate_one(&o);
    step_t k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, 1000000);
    k.w_trk = -1.5;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    k.w_trk = 0.0;
    k.t_us += 20000;
    k.ref.x = tu_num(1.21); /* on its schedule */
    step(&k, &o, 1);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
}

static void test_msw_no_obstacle_is_activated_more_than_twice(void)
{
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    uint64_t t = 0;
    for (int round = 0; round < 3; round++) {
        step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, t);
        step(&k, &o, 1);
        if (round < 2) {
            expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
            k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, t + 600000);
            step(&k, &o, 1);
            expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
        } else {
            /* The third time it calls for one, none comes: the safety
             * filter (cbf.h) is what is left. */
            TEST_ASSERT_EQUAL_size_t(0, n_ev);
            TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
        }
        t += 1000000;
    }
    TEST_ASSERT_EQUAL_UINT8(2, m.acts[0]);
    /* msw_reset clears the count. */
    msw_reset(&m);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, t);
    step(&k, &o, 1);
    expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
}

/* Obstacle @p o (id 1, at (0.45, 0)) activated and released twice, from 0
 * s: the robot at the origin closing on it, then past it (the case of
 * test_msw_no_obstacle_is_activated_more_than_twice). Returns the time
 * after the second release. */
static uint64_t activate_twice(const sup_obstacle_t *o)
{
    uint64_t t = 0;
    for (int round = 0; round < 2; round++) {
        step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, t);
        step(&k, o, 1);
        expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
        k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, t + 600000);
        step(&k, o, 1);
        expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
        t += 1000000;
    }
    return t;
}

/* An obstacle activated twice, whose id then comes back elsewhere (sup.h):
 * 0.15 m across, at (0.45, 0.15), it is another obstacle (DETECT), whose
 * count of activations starts at 0: the robot at the start, 0.474 m from
 * it and closing, activates it (the cluster's edges 0.15 ± 0.41 from the
 * reference's line: passing left takes 0.56, right 0.26: RIGHT). Moved by
 * 0.05 m instead, it is the same obstacle (averaged, no DETECT): no third
 * activation. The table takes the reports as "mstc" does (averaged), and
 * the strategy gets its detections, as ctl.c passes them. */
static void test_msw_an_id_that_comes_back_elsewhere_is_met_afresh(void)
{
    for (int far = 0; far < 2; far++) {
        setUp();
        const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
        const uint64_t t = activate_twice(&o);
        TEST_ASSERT_EQUAL_UINT8(2, m.acts[0]);
        const sup_obstacle_t back = obstacle(1, 0.45, far ? 0.15 : 0.05, 0, 0);
        const step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, t);
        memset(ev, 0, sizeof ev);
        n_ev = 0;
        sup_take_averaged_reports(&s, &k.robot, &back, 1, k.t_us, ev, &n_ev);
        decide(&k);
        if (far) {
            TEST_ASSERT_EQUAL_size_t(2, n_ev);
            TEST_ASSERT_EQUAL_INT(SUP_EVENT_DETECT, ev[0].kind);
            TEST_ASSERT_EQUAL_UINT8(1, ev[0].obstacle);
            TEST_ASSERT_EQUAL_INT(SUP_EVENT_ACTIVATE, ev[1].kind);
            TEST_ASSERT_EQUAL_UINT8(1, ev[1].obstacle);
            TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, ev[1].side);
            TEST_ASSERT_EQUAL_UINT8(1, m.acts[0]);
        } else {
            TEST_ASSERT_EQUAL_size_t(0, n_ev);
            TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
            TEST_ASSERT_EQUAL_UINT8(2, m.acts[0]);
        }
    }
}

/* Only a DETECT of an entry of the table resets a count (msw.h: the events
 * before the strategy's are the table's detections): after two activations
 * of obstacle 1, a filter event naming it and a DETECT of an id the table
 * does not know (9) leave its count at 2, so the robot closing on it gets no
 * third activation. */
static void test_msw_other_events_before_the_step_leave_the_counts(void)
{
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    const uint64_t t = activate_twice(&o);
    const step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, t);
    memset(ev, 0, sizeof ev);
    ev[0] = (sup_event_t){ .t_us = t, .kind = SUP_EVENT_FILTER, .obstacle = 1 };
    ev[1] = (sup_event_t){ .t_us = t, .kind = SUP_EVENT_DETECT, .obstacle = 9 };
    n_ev = 2;
    decide(&k);
    TEST_ASSERT_EQUAL_UINT8(2, m.acts[0]);
    TEST_ASSERT_EQUAL_size_t(2, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
}

/* An obstacle activated twice is met again once the robot has been out of
 * any activation's reach of it, D_act + MSW_CPA_REACH + reach = 0.5 + 1.0 +
 * 0 = 1.5 m here (reach 0: ideal wheels), as on a circular reference's next
 * lap; a robot that stayed within that distance gets no third activation. */
static void test_msw_an_obstacle_left_behind_is_met_afresh(void)
{
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    for (int leave = 0; leave < 2; leave++) {
        msw_reset(&m);
        const uint64_t t = activate_twice(&o);
        /* Tracking, 1.5 m (leave) or 1.49 m from the obstacle, heading away
         * from it (+x from (1.95, 0) or (1.94, 0)): no activation either way. */
        step_t k = at(leave ? 1.95 : 1.94, 0.0, 0.0, 2.0, 0.0, 0.0, t);
        step(&k, &o, 1);
        TEST_ASSERT_EQUAL_size_t(0, n_ev);
        TEST_ASSERT_EQUAL_UINT8(leave ? 0 : 2, m.acts[0]);
        /* Back at the start, closing on it within D_act. */
        k = at(0, 0, 0, 0.1, 0.0, 0.0, t + 1000000);
        step(&k, &o, 1);
        if (leave) {
            expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
        } else {
            TEST_ASSERT_EQUAL_size_t(0, n_ev);
            TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
        }
    }
}

static void test_msw_keeps_its_cluster_near_an_obstacle_outside_it(void)
{
    /* Avoiding 1 at (0.45, 0); obstacle 2 at (0.8, 1.3) is 1.38 from it:
     * not one cluster. The robot, moved to (0.8, 0.9) heading +y, is 0.4
     * from 2 (boundary 0.05) and closing; 1 is 0.97 away. No hand-over: the
     * avoidance of 1's cluster goes on (the filter keeps 2 beyond D_s), no
     * event, still following 1. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.0, 0, 0), obstacle(2, 0.8, 1.3, 0, 0) };
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
    k = at(0.8, 0.9, TU_PI / 2, 0.2, 0.0, 0.0, 20000);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_EQUAL_PTR(&s.obs[0], d.followed);
}

/* ------------------------------------------------ a reference that waits */

/* Obstacle 1 at (0.45, 0) activated from the origin with the reference at
 * (0.1, 0) heading +x at v_r = 0.5; then, 0.6 s on (past the dwell), the
 * robot at (0.45, 0.43) above it and the reference still at (0.1, 0): it
 * waits (held), p1 does not hold (the reference is behind), no release. */
static void hold_over_one(const sup_obstacle_t *o, size_t n)
{
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, n);
    expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
    k = at(0.45, 0.43, 0.0, 0.1, 0.0, 0.0, 600000);
    step(&k, o, n);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_TRUE(m.held);
    TEST_ASSERT_FALSE(m.ahead);
    /* The foot of the robot's perpendicular on the reference's line is
     * (0.45, 0): the obstacle's centre, no shortcut. */
    TEST_ASSERT_FALSE(m.aimed);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_held_leaves_where_the_reference_moves_on_and_the_way_is_clear(void)
{
    /* Bug2's leave: past the obstacle at (0.95, 0.1), the reference moved
     * on to (1.0, 0) (the robot met its path again, further along). Heading
     * back (−x), the roll-out, 0.5 m straight on, ends at (0.45, 0.1), 0.1
     * from the obstacle, within D_s + MSW_CLEAR_MARGIN = 0.395: no release.
     * Heading +x it stays hypot(0.5, 0.1) = 0.510 > 0.395 from it:
     * COMPLETE. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    hold_over_one(&o, 1);
    step_t k = at(0.95, 0.1, TU_PI, 1.0, 0.0, 0.0, 620000);
    step(&k, &o, 1);
    TEST_ASSERT_TRUE(m.ahead);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    k.robot = tu_pose(0.95, 0.1, 0.0);
    k.ref.x = tu_num(1.01);
    k.t_us += 20000;
    step(&k, &o, 1);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
}

static void test_msw_held_leave_judges_its_own_cluster(void)
{
    /* As the Bug2 leave above, with obstacle 2 at (1.6, 0.1), 1.15 from 1
     * (apart: not in its cluster, the harness's gap 0.4). The roll-out from
     * (0.95, 0.1) heading +x ends at (1.45, 0.1), 0.15 from 2, but the leave
     * judges the cluster it followed: COMPLETE; 2 is the next activation's
     * (and the filter's) to deal with. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.0, 0, 0), obstacle(2, 1.6, 0.1, 0, 0) };
    hold_over_one(o, 2);
    step_t k = at(0.95, 0.1, 0.0, 1.0, 0.0, 0.0, 620000);
    step(&k, o, 2);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
}

static void test_msw_held_aims_at_the_reference_line_when_a_straight_way_is_clear(void)
{
    /* VisBug's shortcut: the reference still at (0.1, 0); the robot at
     * (0.9, 0.3) heading +x is 0.8 >= MSW_SHORTCUT_MIN past it along its
     * line; the segment to the foot (0.9, 0) keeps 0.45 from the obstacle
     * (its nearest point, the foot), more than D_s + MSW_SHORTCUT_MARGIN =
     * 0.43, within the sensor's 1.5 m: the aim is the foot plus MSW_AIM_LEAD
     * along the line, (1.2, 0) heading 0. This step's tracking went to the
     * reference, so no release yet; the next step's goes to the aim, and
     * its roll-out (0.5 m straight on, beyond hypot(0.45, 0.3) = 0.54 >
     * 0.395) is clear: COMPLETE. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    hold_over_one(&o, 1);
    step_t k = at(0.9, 0.3, 0.0, 0.1, 0.0, 0.0, 620000);
    step(&k, &o, 1);
    TEST_ASSERT_TRUE(m.aimed);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.2, m.aim.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.0, m.aim.y);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.0, m.aim.theta);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    k.t_us += 20000;
    step(&k, &o, 1);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
}

static void test_msw_held_takes_no_shortcut_past_an_obstacle(void)
{
    /* As above, the robot further on at (1.6, 0.3), with obstacle 2 at
     * (2.0, 0.2) (1.56 from 1: not in its cluster): 0.40 < 0.43 from the
     * segment (1.6, 0.3)-(1.6, 0) (its point (1.6, 0.2)): no aim, no
     * release. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.0, 0, 0), obstacle(2, 2.0, 0.2, 0, 0) };
    hold_over_one(o, 2);
    step_t k = at(1.6, 0.3, 0.0, 0.1, 0.0, 0.0, 620000);
    step(&k, o, 2);
    TEST_ASSERT_FALSE(m.aimed);
    k.t_us += 20000;
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_held_circling_is_no_block(void)
{
    /* As test_msw_blocked_after_a_full_turn_around, the reference standing
     * still at (−1, 0) with v_r = 0.5 (it waits for the robot): turning
     * 7 rad round the obstacle is following its boundary, not a block. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    step_t k = at(0, 0, 0, -1.0, 0.0, 0.0, 0);
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    for (size_t i = 1; i <= 20; i++) {
        const double th = 0.5 * (double)i;
        k = at(0.45 - 0.43 * sin(th), 0.43 * cos(th), th, -1.0, 0.0, 0.0, 20000 * i);
        step(&k, &o, 1);
        TEST_ASSERT_EQUAL_size_t(0, n_ev);
    }
    TEST_ASSERT_TRUE(m.held);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_held_turns_back_once_when_led_behind_the_reference(void)
{
    /* Held over obstacle 1 (side LEFT), the reference waiting at (0.1, 0)
     * heading +x. At (−0.85, 0.3) the robot is 0.95 behind it along its
     * line, less than MSW_TURN_BACK = 1.0: the side is kept. At (−0.95,
     * 0.3), 1.05 behind: RIGHT from then on; further back still, it stays
     * RIGHT (once an activation). */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    hold_over_one(&o, 1);
    step_t k = at(-0.85, 0.3, TU_PI, 0.1, 0.0, 0.0, 620000);
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, m.side);
    k.robot = tu_pose(-0.95, 0.3, TU_PI);
    k.t_us += 20000;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, m.side);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, d.side);
    k.robot = tu_pose(-1.5, 0.3, TU_PI);
    k.t_us += 20000;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_TRUE(m.reversed);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, m.side);
    /* Mirrored: the obstacle at (0.45, 0.05), left of the path, is passed on
     * the right (the left edge 0.48 from the path, the right 0.38); led to
     * (−0.95, −0.3), 1.05 behind, the robot follows it on the left. */
    setUp();
    const sup_obstacle_t left = obstacle(1, 0.45, 0.05, 0, 0);
    k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, &left, 1);
    expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_RIGHT);
    k = at(0.45, -0.43, 0.0, 0.1, 0.0, 0.0, 600000);
    step(&k, &left, 1);
    TEST_ASSERT_TRUE(m.held);
    k = at(-0.95, -0.3, TU_PI, 0.1, 0.0, 0.0, 620000);
    step(&k, &left, 1);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_LEFT, m.side);
}

static void test_msw_held_aimed_waits_for_a_clear_roll_out(void)
{
    /* As test_msw_held_aims_at_the_reference_line_..., but the step after
     * the aim was taken the tracking command turns back towards the
     * obstacle (heading −x from (0.9, 0.3): the roll-out, 0.5 m straight on,
     * ends at (0.4, 0.3), 0.304 from its centre, within 0.395): no release
     * while aiming either. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    hold_over_one(&o, 1);
    step_t k = at(0.9, 0.3, 0.0, 0.1, 0.0, 0.0, 620000);
    step(&k, &o, 1);
    TEST_ASSERT_TRUE(m.aimed);
    k.robot = tu_pose(0.9, 0.3, TU_PI);
    k.t_us += 20000;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_held_takes_no_shortcut_beyond_the_sensors_range(void)
{
    /* The robot at (1.6, 1.5): the foot (1.6, 0) is 1.5 away, and the
     * segment's end must clear D_s + 0.08 = 0.43 beyond it: 1.93 > the
     * 1.5 m the harness's sensor covers (msw_input_t.range): no aim. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    hold_over_one(&o, 1);
    step_t k = at(1.6, 1.5, 0.0, 0.1, 0.0, 0.0, 620000);
    step(&k, &o, 1);
    TEST_ASSERT_FALSE(m.aimed);
}

static void test_msw_held_on_the_line_aims_ahead_of_itself(void)
{
    /* The robot on the reference's line itself, at (1.2, 0), 1.1 past the
     * waiting reference and 0.75 beyond the obstacle's centre (clear of
     * 0.43): the segment to the foot has no length; the aim is 0.3 ahead,
     * (1.5, 0). */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    hold_over_one(&o, 1);
    step_t k = at(1.2, 0.0, 0.0, 0.1, 0.0, 0.0, 620000);
    step(&k, &o, 1);
    TEST_ASSERT_TRUE(m.aimed);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 1.5, m.aim.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, 0.0, m.aim.y);
    /* At (0.84, 0), 0.39 from the centre, within 0.43: the point itself is
     * not clear, no aim. */
    setUp();
    hold_over_one(&o, 1);
    k = at(0.84, 0.0, 0.0, 0.1, 0.0, 0.0, 620000);
    step(&k, &o, 1);
    TEST_ASSERT_FALSE(m.aimed);
}

static void test_msw_slow_robot_does_not_activate_before_its_roll_out_comes_near(void)
{
    /* Obstacle 1 straight ahead at 0.49 < D_act, the robot closing at
     * v_trk = 0.1 m/s: its 1 s roll-out, 0.1 m, ends 0.39 from the centre,
     * beyond D_s + MSW_ACT_MARGIN = 0.38 (and the obstacle is beyond the
     * roll-out's reach plus that, 0.48, without a look along it): no
     * activation. At 0.2 m/s it ends 0.29 away: ACTIVATE. */
    const sup_obstacle_t o = obstacle(1, 0.49, 0.0, 0, 0);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    k.v_trk = 0.1;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
    k.v_trk = 0.2;
    k.t_us += 20000;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(1, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_ACTIVATE, ev[0].kind);
}

static void test_msw_no_activation_beside_a_clear_way(void)
{
    /* Closing within D_act, but the tracking command's roll-out (0.5 m
     * straight on along +x) passes obstacle 1 at (0.3, 0.39), 0.492 away,
     * at 0.39 > D_s + MSW_ACT_MARGIN = 0.38: no activation. At (0.3, 0.37)
     * (0.474 away) it passes at 0.37 < 0.38: ACTIVATE. */
    const sup_obstacle_t beside = obstacle(1, 0.3, 0.39, 0, 0);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, &beside, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
    setUp();
    const sup_obstacle_t nearer = obstacle(1, 0.3, 0.37, 0, 0);
    step(&k, &nearer, 1);
    TEST_ASSERT_EQUAL_size_t(1, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_EVENT_ACTIVATE, ev[0].kind);
}

static void test_msw_obstacle_the_filter_acted_on_activates_with_a_wider_margin(void)
{
    /* Obstacle 1 at (0.1, 0.42), 0.432 away (< D_act), closing; the
     * roll-out (0.5 m along +x) passes it at 0.42 > D_s + MSW_ACT_MARGIN =
     * 0.38: no activation. When the filter changed the previous step's
     * command for it (filtered = its id), the roll-out must keep D_s +
     * MSW_FILTERED_MARGIN = 0.45 > 0.42: ACTIVATE. The filter's acting on
     * another obstacle (id 2) changes nothing. */
    const sup_obstacle_t o = obstacle(1, 0.1, 0.42, 0, 0);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
    setUp();
    k.filtered = 2;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    setUp();
    k.filtered = 1;
    step(&k, &o, 1);
    expect_event(SUP_EVENT_ACTIVATE, 1, m.side);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    /* At (0.1, 0.46) (0.471 away) the roll-out passes at 0.46 > 0.45: no
     * activation even so. */
    setUp();
    const sup_obstacle_t farther = obstacle(1, 0.1, 0.46, 0, 0);
    step(&k, &farther, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
}

/* --------------------------------------------------------------- blocked */

static void test_msw_blocked_after_a_full_turn_around(void)
{
    /* Avoiding with the reference never past (p1 false: it sits behind at
     * (−1, 0)); the robot's heading turns by 0.5 rad a step. After 14 steps
     * it has turned 7 rad > MSW_LOOP = 6.8: BLOCKED, naming the member. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    activate_one(&o);
    size_t i = 1;
    for (; i <= 14; i++) {
        const double th = 0.5 * (double)i;
        /* The reference on its schedule, creeping on behind (one standing
         * still would wait for the robot, test_msw_held_*). */
        step_t k = at(0.45 - 0.41 * sin(th), 0.41 * cos(th), th, -1.0 + 0.001 * (double)i, 0.0, 0.0,
                      20000 * i);
        step(&k, &o, 1);
        if (n_ev != 0) {
            break;
        }
    }
    TEST_ASSERT_EQUAL_size_t(14, i);
    expect_event(SUP_EVENT_BLOCKED, 1, AVD_SIDE_NONE);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_BLOCKED, d.mode);
    TEST_ASSERT_NULL(d.followed);
}

static void test_msw_blocked_when_still_then_resumes_when_the_way_clears(void)
{
    /* Avoiding, with the reference at (0.45, 0.3) inside D_act of the
     * obstacle (no p1, no release), the robot held in place (by the filter,
     * say) at (0, −0.45): it got there at t = 0.02 s, and 5 s later without
     * moving 0.1 m it is BLOCKED. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    activate_one(&o);
    step_t k = at(0.0, -0.45, 0.0, 0.45, 0.3, 0.0, 0);
    for (uint64_t t = 20000; t < 5020000; t += 20000) {
        k.t_us = t;
        step(&k, &o, 1);
        TEST_ASSERT_EQUAL_size_t(0, n_ev);
    }
    k.t_us = 5020000;
    step(&k, &o, 1);
    expect_event(SUP_EVENT_BLOCKED, 1, AVD_SIDE_NONE);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_BLOCKED, d.mode);
    /* It waits while the tracking command would drive at the obstacle
     * (heading π/4 from (0, −0.45) points at its centre, 0.636 away: the
     * 0.5 m roll-out ends 0.136 from it, inside D_s + margin = 0.37), and
     * resumes when it would not (heading +x: the roll-out passes 0.45 from
     * the centre). The obstacle is beyond D_act + margin = 0.52, so only
     * D_s + margin applies. */
    k.robot = tu_pose(0.0, -0.45, TU_PI / 4);
    k.t_us += 20000;
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_BLOCKED, d.mode);
    k.robot = tu_pose(0.0, -0.45, 0.0);
    k.t_us += 20000;
    step(&k, &o, 1);
    expect_event(SUP_EVENT_RESUME, 0, AVD_SIDE_NONE);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_TRACK, d.mode);
}

static void test_msw_p3_stops_and_is_not_blocked(void)
{
    /* Avoiding (the reference inside D_act of the obstacle: no release),
     * then the reference stops (v_r = ω_r = 0): mode STOP, the avoidance
     * kept; standing still through p3 is no sign of a block. */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    activate_one(&o);
    step_t k = at(0.0, -0.45, 0.0, 0.45, 0.3, 0.0, 0);
    k.v_r = 0.0;
    for (uint64_t t = 20000; t <= 8000000; t += 20000) {
        k.t_us = t;
        step(&k, &o, 1);
        TEST_ASSERT_EQUAL_size_t(0, n_ev);
        TEST_ASSERT_EQUAL_INT(SUP_MODE_STOP, d.mode);
    }
    TEST_ASSERT_EQUAL_UINT8(MSW_AVOID, m.state);
    /* Tracking with p3: STOP too. */
    setUp();
    k.v_r = 0.0;
    step(&k, NULL, 0);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_STOP, d.mode);
}

/* ------------------------------------------------------------ more cases */

static void test_msw_ties_on_distance_keep_the_first_trigger_in_the_table(void)
{
    /* The nearer obstacle first in the table this time: it stays the
     * candidate when the farther one is examined. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.3, -0.294, 0, 0), obstacle(2, 0.3, 0.375, 0, 0) };
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_UINT8(1, ev[0].obstacle);
}

static void test_msw_side_of_an_obstacle_moving_along_the_heading_is_the_static_rule(void)
{
    /* Coming head-on along the robot's heading (no velocity across it): the
     * reference rule decides, as for a static obstacle 0.2 left of the
     * path: RIGHT. */
    sup_obstacle_t o = obstacle(1, 0.4, 0.2, -0.5, 0.0);
    TEST_ASSERT_EQUAL_INT(AVD_SIDE_RIGHT, side_for(0.0, 0.0, 0.5, &o, 1));
}

static void test_msw_a_clock_going_back_does_not_end_the_dwell(void)
{
    /* Activated at t = 1 s; a step stamped 0.5 s (the clock went back) with
     * everything else ready for the release: no release (0 s since). */
    const sup_obstacle_t o = obstacle(1, 0.45, 0.0, 0, 0);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 1000000);
    step(&k, &o, 1);
    k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, 500000);
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_release_judges_moving_obstacles_by_their_motion(void)
{
    /* Avoiding a moving obstacle (activated when it came within D_act):
     * p1 does not apply to it. Still closing on it within D_act +
     * MSW_CPA_REACH: no release; moving away (robot +x, obstacle going +y
     * away from the path, its closest approach now, 0.41 + ... clear):
     * release. */
    const sup_obstacle_t in_way = obstacle(1, 0.45, 0.0, 0.0, 0.3);
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, &in_way, 1);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    /* 1 s later: robot at (−0.15, 0.2) heading +x, the obstacle at
     * (0.45, 0.3): 0.608 away; the robot's velocity relative to it,
     * (0.5, −0.3), has dot 0.27 > 0 with (0.6, 0.1): closing, within
     * D_act + MSW_CPA_REACH = 1.5: no release. */
    sup_obstacle_t o = obstacle(1, 0.45, 0.3, 0.0, 0.3);
    k = at(-0.15, 0.2, 0.0, 2.0, -0.45, 0.0, 1000000);
    step(&k, &o, 1);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    /* Past it: robot at (0.6, −0.45), obstacle at (0.45, 0.6): relative
     * velocity of the robot (0.5, −0.3), dot with (−0.15, 1.05) < 0: not
     * closing; closest approach now, 1.06 > 0.42: release, though the
     * reference is nowhere past it. */
    o = obstacle(1, 0.45, 0.6, 0.0, 0.3);
    k = at(0.6, -0.45, 0.0, 0.45, 0.3, 0.0, 2000000);
    step(&k, &o, 1);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
}

/* Obstacle @p o (table entry @p i) reported on the way from where the
 * table has it to (@p x, @p y), at most 0.5 m a report: within the gate of a
 * moving obstacle at 1 m/s (0.1 + 1 × 0.5 = 0.6 m, sup.h), so it stays
 * itself, as a sensor that kept tracking it would report it. The strategy
 * does not run meanwhile. */
static void report_on_the_way(sup_obstacle_t o, uint8_t i, double x, double y, const pose_t *robot)
{
    const double x0 = tu_dbl(s.obs[i].o.x);
    const double y0 = tu_dbl(s.obs[i].o.y);
    const int n = (int)ceil(hypot(x - x0, y - y0) / 0.5);
    for (int j = 1; j <= n; j++) {
        o.x = tu_num(x0 + (x - x0) * j / n);
        o.y = tu_num(y0 + (y - y0) * j / n);
        sup_event_t scratch[SUP_MAX_EVENTS];
        size_t n_scratch = 0;
        sup_take_reports(&s, robot, &o, 1, 0, scratch, &n_scratch);
        TEST_ASSERT_EQUAL_size_t(0, n_scratch);
    }
    TEST_ASSERT_NUM_WITHIN(TOL_M, x, s.obs[i].o.x);
    TEST_ASSERT_NUM_WITHIN(TOL_M, y, s.obs[i].o.y);
}

static void test_msw_release_waits_for_a_fast_or_far_moving_obstacle(void)
{
    /* Avoiding a static obstacle with the release otherwise ready (the case
     * of test_msw_release_waits_for_the_dwell_then_completes). Another
     * obstacle, detected at (3, 0), since moved 40 m away at 1 m/s: out of
     * any reach, release. */
    sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.0, 0, 0), obstacle(2, 3.0, 0.0, -1.0, 0) };
    step_t k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_EQUAL_UINT8(2, s.n_obs);
    o[1] = obstacle(2, 40.0, 0.0, -1.0, 0);
    k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, 600000);
    report_on_the_way(o[1], 1, 40.0, 0.0, &k.robot);
    step(&k, o, 2);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
    /* The same 40 m away along y, moving along −y. */
    setUp();
    o[1] = obstacle(2, 3.0, 0.0, 0, -1.0);
    k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    o[1] = obstacle(2, 0.0, -40.0, 0, -1.0);
    k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, 600000);
    report_on_the_way(o[1], 1, 0.0, -40.0, &k.robot);
    step(&k, o, 2);
    expect_event(SUP_EVENT_COMPLETE, 1, AVD_SIDE_NONE);
    /* One 3 m away at 40 m/s: beyond what the closest-approach test can
     * tell in Q16.16 (|v| >= 32): assumed in the way, no release. */
    setUp();
    o[1] = obstacle(2, 3.0, 0.0, -40.0, 0);
    k = at(0, 0, 0, 0.1, 0.0, 0.0, 0);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    k = at(0.45, 0.41, 0.0, 1.2, 0.45, 0.0, 600000);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
}

static void test_msw_no_hand_over_to_a_farther_obstacle(void)
{
    /* Two static obstacles both within D_act of the robot are always one
     * cluster (their D_act exceed D_s by less than half the width), so the
     * farther candidate outside the cluster is a moving one, called by its
     * closest approach: obstacle 2 at (1.7, 0) coming at 0.5 m/s, 1.3 from
     * the robot at (0.4, 0) that follows 1 at the origin (boundary 0.05);
     * 2's boundary is 0.95: the avoidance of 1 goes on. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.0, 0.0, 0, 0), obstacle(2, 1.7, 0.0, -0.5, 0) };
    step_t a = at(-0.45, 0.0, 0.0, 5.0, 0.0, 0.0, 0);
    step(&a, o, 2);
    expect_event(SUP_EVENT_ACTIVATE, 1, AVD_SIDE_LEFT);
    step_t k = at(0.4, 0.0, 0.0, 5.0, 0.0, 0.0, 20000);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_size_t(0, n_ev);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_EQUAL_PTR(&s.obs[0], d.followed);
}

static void test_msw_obstacles_found_while_avoiding_join_the_cluster(void)
{
    /* Avoiding 1 at (0.45, 0); obstacle 2 at (0.45, 0.6) (0.6 apart:
     * overlapping circles) is reported only now: the cluster grows. */
    const sup_obstacle_t o[2] = { obstacle(1, 0.45, 0.0, 0, 0), obstacle(2, 0.45, 0.6, 0, 0) };
    activate_one(&o[0]);
    TEST_ASSERT_EQUAL_HEX64(0x0001u, m.cluster);
    step_t k = at(0.1, 0.1, 0.5, 0.1, 0.0, 0.0, 20000);
    step(&k, o, 2);
    TEST_ASSERT_EQUAL_INT(SUP_MODE_AVOID, d.mode);
    TEST_ASSERT_EQUAL_HEX64(0x0003u, m.cluster);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_msw_side_passes_where_the_cluster_leaves_the_path_nearer);
    RUN_TEST(test_msw_side_of_a_cluster_uses_its_whole_extent);
    RUN_TEST(test_msw_side_on_the_path_falls_back_to_the_heading_then_left);
    RUN_TEST(test_msw_side_passes_behind_a_crossing_obstacle);
    RUN_TEST(test_msw_activates_within_d_act_when_closing_whatever_the_reference);
    RUN_TEST(test_msw_does_not_activate_when_not_closing_or_beyond_d_act);
    RUN_TEST(test_msw_activates_the_nearest_boundary);
    RUN_TEST(test_msw_activates_early_for_a_moving_obstacle_on_a_collision_course);
    RUN_TEST(test_msw_moving_obstacle_judged_by_the_roll_out_chord);
    RUN_TEST(test_msw_gapped_cluster_widens_the_circle_followed);
    RUN_TEST(test_msw_follows_the_member_nearest_now_or_just_ahead);
    RUN_TEST(test_msw_release_waits_for_the_dwell_then_completes);
    RUN_TEST(test_msw_release_needs_p1);
    RUN_TEST(test_msw_release_needs_the_roll_out_clear);
    RUN_TEST(test_msw_no_obstacle_is_activated_more_than_twice);
    RUN_TEST(test_msw_an_obstacle_left_behind_is_met_afresh);
    RUN_TEST(test_msw_an_id_that_comes_back_elsewhere_is_met_afresh);
    RUN_TEST(test_msw_other_events_before_the_step_leave_the_counts);
    RUN_TEST(test_msw_keeps_its_cluster_near_an_obstacle_outside_it);
    RUN_TEST(test_msw_held_leaves_where_the_reference_moves_on_and_the_way_is_clear);
    RUN_TEST(test_msw_held_aims_at_the_reference_line_when_a_straight_way_is_clear);
    RUN_TEST(test_msw_held_takes_no_shortcut_past_an_obstacle);
    RUN_TEST(test_msw_held_circling_is_no_block);
    RUN_TEST(test_msw_held_turns_back_once_when_led_behind_the_reference);
    RUN_TEST(test_msw_held_leave_judges_its_own_cluster);
    RUN_TEST(test_msw_held_aimed_waits_for_a_clear_roll_out);
    RUN_TEST(test_msw_held_takes_no_shortcut_beyond_the_sensors_range);
    RUN_TEST(test_msw_held_on_the_line_aims_ahead_of_itself);
    RUN_TEST(test_msw_slow_robot_does_not_activate_before_its_roll_out_comes_near);
    RUN_TEST(test_msw_no_activation_beside_a_clear_way);
    RUN_TEST(test_msw_obstacle_the_filter_acted_on_activates_with_a_wider_margin);
    RUN_TEST(test_msw_blocked_after_a_full_turn_around);
    RUN_TEST(test_msw_blocked_when_still_then_resumes_when_the_way_clears);
    RUN_TEST(test_msw_p3_stops_and_is_not_blocked);
    RUN_TEST(test_msw_ties_on_distance_keep_the_first_trigger_in_the_table);
    RUN_TEST(test_msw_side_of_an_obstacle_moving_along_the_heading_is_the_static_rule);
    RUN_TEST(test_msw_a_clock_going_back_does_not_end_the_dwell);
    RUN_TEST(test_msw_release_judges_moving_obstacles_by_their_motion);
    RUN_TEST(test_msw_release_waits_for_a_fast_or_far_moving_obstacle);
    RUN_TEST(test_msw_no_hand_over_to_a_farther_obstacle);
    RUN_TEST(test_msw_obstacles_found_while_avoiding_join_the_cluster);
    return UNITY_END();
}
