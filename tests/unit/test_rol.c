/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/rol: the forward roll-out of a constant
 * command in closed form, and whether it keeps a distance from a point.
 *
 * Expected values: hand derivations for straight and circular paths, and an
 * independent computation in double in this file: the unicycle's closed-form
 * position p(t) = p + (v/ω)[sin(θ+ωt) − sin θ, cos θ − cos(θ+ωt)] (or
 * p + v t [cos θ, sin θ]) sampled every millisecond, whose smallest distance
 * to the point is compared with rol_clears()' verdict.
 */
#include <stdio.h>

#include "ctrl/rol.h"
#include "test_util.h"
#include "unity.h"

/* Distances [m] within which the sampled minimum may disagree with the
 * closed form: sampling every 1 ms at <= 3 m/s moves 3 mm, so the sampled
 * minimum overestimates by at most 1.5 mm; float adds ~1e-6; fixed adds
 * Q16.16 roundings of products of values <= 10 and of sin/cos (1e-4 × 10). */
#define TOL_CLEAR TU_TOL(2e-3, 4e-3)

void setUp(void) {}
void tearDown(void) {}

static bool clears(double x, double y, double th, double v, double w, double horizon, double ox,
                   double oy, double clear)
{
    const pose_t p = tu_pose(x, y, th);
    rol_path_t path;
    rol_path(&path, &p, num_cos(p.theta), num_sin(p.theta), tu_num(v), tu_num(w), tu_num(horizon));
    return rol_clears(&path, tu_num(ox), tu_num(oy), tu_num(clear));
}

/* The smallest distance from (ox, oy) to the path, sampled in double. */
static double sampled_min(double x, double y, double th, double v, double w, double horizon,
                          double ox, double oy)
{
    double best = INFINITY;
    for (double t = 0.0; t <= horizon + 1e-12; t += 1e-3) {
        double px, py;
        if (fabs(w) < 1e-9) {
            px = x + v * t * cos(th);
            py = y + v * t * sin(th);
        } else {
            px = x + v / w * (sin(th + w * t) - sin(th));
            py = y + v / w * (cos(th) - cos(th + w * t));
        }
        best = fmin(best, hypot(px - ox, py - oy));
    }
    return best;
}

/* ------------------------------------------------------------- segment */

static void test_rol_straight_segment_hand_values(void)
{
    /* From the origin along +x at 0.5 m/s for 1 s: the segment (0,0)–(0.5,0). */
    /* Beside its middle, 0.3 away. */
    TEST_ASSERT_TRUE(clears(0, 0, 0, 0.5, 0, 1, 0.25, 0.3, 0.29));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 0.5, 0, 1, 0.25, 0.3, 0.31));
    /* Beyond its end: (0.8, 0) is 0.3 from (0.5, 0). */
    TEST_ASSERT_TRUE(clears(0, 0, 0, 0.5, 0, 1, 0.8, 0.0, 0.29));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 0.5, 0, 1, 0.8, 0.0, 0.31));
    /* Behind the start: (−0.2, 0) is 0.2 from the start. */
    TEST_ASSERT_TRUE(clears(0, 0, 0, 0.5, 0, 1, -0.2, 0.0, 0.19));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 0.5, 0, 1, -0.2, 0.0, 0.21));
    /* Backwards (v < 0): the segment runs to (−0.5, 0); (−0.8, 0) is 0.3 from
     * its end, (0.2, 0) 0.2 from its start. */
    TEST_ASSERT_TRUE(clears(0, 0, 0, -0.5, 0, 1, -0.8, 0.0, 0.29));
    TEST_ASSERT_FALSE(clears(0, 0, 0, -0.5, 0, 1, -0.8, 0.0, 0.31));
    TEST_ASSERT_FALSE(clears(0, 0, 0, -0.5, 0, 1, 0.2, 0.0, 0.21));
    /* Far away: beyond the whole path's reach. */
    TEST_ASSERT_TRUE(clears(0, 0, 0, 0.5, 0, 1, 5.0, 5.0, 0.4));
}

static void test_rol_slight_turn_is_a_widened_segment(void)
{
    /* ω T = 0.08 <= 0.1: a segment of length 0.5 widened by 0.5·0.08/2 = 0.02.
     * Beside the middle at 0.3: clear of 0.27 (0.27 + 0.02 < 0.3), not of
     * 0.29 (0.31 > 0.3) although the true arc may be further: conservative. */
    TEST_ASSERT_TRUE(clears(0, 0, 0, 0.5, 0.08, 1, 0.25, -0.3, 0.27));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 0.5, 0.08, 1, 0.25, -0.3, 0.29));
    /* The true path bends left, away from (0.25, −0.3): the sampled distance
     * is above 0.3, so the verdict is on the safe side. */
    TEST_ASSERT_TRUE(sampled_min(0, 0, 0, 0.5, 0.08, 1, 0.25, -0.3) > 0.3);
}

/* ------------------------------------------------------------------ arc */

static void test_rol_arc_hand_values(void)
{
    /* From the origin heading +x, v = 1, ω = 1, T = 1: the arc of centre
     * (0, 1), radius 1, from angle −π/2 to −π/2 + 1. */
    /* Its centre is 1 from every point of it. */
    TEST_ASSERT_TRUE(clears(0, 0, 0, 1, 1, 1, 0.0, 1.0, 0.99));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 1, 1, 1, 0.0, 1.0, 1.01));
    /* Outside the circle, facing the middle of the arc (angle −π/2 + 0.5),
     * 0.25 beyond it: clear of 0.24, not of 0.26. */
    const double a = -TU_PI / 2 + 0.5;
    const double ox = 1.25 * cos(a), oy = 1.0 + 1.25 * sin(a);
    TEST_ASSERT_TRUE(clears(0, 0, 0, 1, 1, 1, ox, oy, 0.24));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 1, 1, 1, ox, oy, 0.26));
    /* On the circle but outside the swept sector (angle −π/2 + 2): the
     * nearest point is the end, at chord 2 sin(0.5) = 0.9589. */
    const double b = -TU_PI / 2 + 2.0;
    const double px = cos(b), py = 1.0 + sin(b);
    TEST_ASSERT_TRUE(clears(0, 0, 0, 1, 1, 1, px, py, 0.95));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 1, 1, 1, px, py, 0.97));
    /* Clockwise (ω = −1): the mirror image; (ox, −oy) as above. */
    TEST_ASSERT_TRUE(clears(0, 0, 0, 1, -1, 1, ox, -oy, 0.24));
    TEST_ASSERT_FALSE(clears(0, 0, 0, 1, -1, 1, ox, -oy, 0.26));
}

static void test_rol_more_than_half_a_turn_is_judged_on_the_whole_circle(void)
{
    /* ω T = 4 > π: a point near the circle but far from the swept arc is
     * "not clear" (conservative), one away from the circle is clear. Centre
     * (0, 0.25), radius 0.25 (v = 1, ω = 4). */
    TEST_ASSERT_FALSE(clears(0, 0, 0, 1, 4, 1, 0.0, 0.52, 0.05));
    TEST_ASSERT_TRUE(clears(0, 0, 0, 1, 4, 1, 0.0, 0.25, 0.2));
    TEST_ASSERT_TRUE(clears(0, 0, 0, 1, 4, 1, 2.0, 0.0, 0.5));
}

static void test_rol_turning_on_the_spot_is_the_start_point(void)
{
    /* v = 0, ω = 1: the robot stays at (1, 2). */
    TEST_ASSERT_TRUE(clears(1, 2, 0.3, 0, 1, 1, 1.3, 2.4, 0.49));
    TEST_ASSERT_FALSE(clears(1, 2, 0.3, 0, 1, 1, 1.3, 2.4, 0.51));
}

static void test_rol_too_long_a_path_is_never_clear(void)
{
    /* |v| T = 12 m > ROL_MAX_LENGTH. */
    TEST_ASSERT_FALSE(clears(0, 0, 0, 12.0, 0, 1, 100.0, 100.0, 0.4));
}

/* ------------------------------------------------------- independently */

static void test_rol_never_clear_when_the_sampled_path_comes_closer(void)
{
    /* Pseudo-random poses, commands and points: whenever rol_clears() says
     * clear, the sampled path keeps the distance; and whenever the sampled
     * path keeps it with room to spare (twice the segment's widening: the
     * arc may lie that far on the near side of its tangent, which is then
     * held to the widened distance; none on an exact arc of at most half a
     * turn), rol_clears() says clear. */
    uint32_t s = 2024u;
    int n_clear = 0, n_not = 0;
    char msg[160];
    for (int k = 0; k < 3000; k++) {
        double r[7];
        for (int j = 0; j < 7; j++) {
            s = s * 1664525u + 1013904223u;
            r[j] = (double)(s >> 8) / 16777216.0;
        }
        const double th = tu_q(6.0 * r[0] - 3.0);
        const double v = tu_q(3.0 * r[1] - 1.0);
        const double w = tu_q(r[2] < 0.2 ? 0.15 * r[3] - 0.075 : 6.0 * r[3] - 3.0);
        const double ox = tu_q(3.0 * r[4] - 1.5), oy = tu_q(3.0 * r[5] - 1.5);
        const double clear = tu_q(0.05 + 0.95 * r[6]);
        const double horizon = 1.0;
        const double best = sampled_min(0, 0, th, v, w, horizon, ox, oy);
        const bool got = clears(0, 0, th, v, w, horizon, ox, oy, clear);
        snprintf(msg, sizeof msg, "th %g v %g w %g o (%g, %g) clear %g: sampled %g, got %d", th, v,
                 w, ox, oy, clear, best, got);
        if (got) {
            TEST_ASSERT_TRUE_MESSAGE(best >= clear - TOL_CLEAR, msg);
            n_clear++;
        } else {
            n_not++;
        }
        const double turn = fabs(w * horizon);
        const double widen = turn <= 0.1 ? fabs(v) * horizon * turn / 2.0 : 0.0;
        if (turn <= TU_PI && best >= clear + 2.0 * widen + TOL_CLEAR) {
            TEST_ASSERT_TRUE_MESSAGE(got, msg);
        }
    }
    /* Both verdicts occurred often enough for the test to mean something
     * (2398 and 602 with this seed). */
    TEST_ASSERT_TRUE(n_clear > 500);
    TEST_ASSERT_TRUE(n_not > 500);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_rol_straight_segment_hand_values);
    RUN_TEST(test_rol_slight_turn_is_a_widened_segment);
    RUN_TEST(test_rol_arc_hand_values);
    RUN_TEST(test_rol_more_than_half_a_turn_is_judged_on_the_whole_circle);
    RUN_TEST(test_rol_turning_on_the_spot_is_the_start_point);
    RUN_TEST(test_rol_too_long_a_path_is_never_clear);
    RUN_TEST(test_rol_never_clear_when_the_sampled_path_comes_closer);
    return UNITY_END();
}
