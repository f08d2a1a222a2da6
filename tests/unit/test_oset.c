/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/ctrl/oset: the overflow-safe distance test, the
 * cluster grouping (safety circles that overlap or leave a gap narrower than
 * the robot), the closing test and the closest approach of a moving
 * obstacle.
 *
 * Expected values are hand derivations written beside each case (3-4-5
 * triangles and distances exact in binary, so that "at the threshold" means
 * exactly that in float and in Q16.16), and for the closest approach a
 * brute-force minimum over sampled times computed in double in this file.
 */
#include <stdio.h>
#include <string.h>

#include "ctrl/oset.h"
#include "test_util.h"
#include "unity.h"

/* ------------------------------------------------------------ tolerances */

/* Closest-approach time [s] and squared distance [m²] for |p|, |v| <= 4,
 * horizon <= 4. float: a division and a few products of values <= 16 (ulp/2
 * = 1e-6); fixed: Q16.16 roundings of products <= 16 and one division
 * (≈ 1e-4 relative). */
#define TOL_T  TU_TOL(1e-5, 2e-3)
#define TOL_D2 TU_TOL(1e-5, 2e-3)

void setUp(void) {}
void tearDown(void) {}

static sup_entry_t entry(uint8_t id, double x, double y, double d_s)
{
    sup_entry_t e;
    memset(&e, 0, sizeof e);
    e.o.id = id;
    e.o.x = tu_num(x);
    e.o.y = tu_num(y);
    e.o.radius = tu_num(0.1);
    e.d_s = tu_num(d_s);
    e.d_act = tu_num(d_s + 0.15);
    return e;
}

/* ------------------------------------------------------------ within */

static void test_oset_within_is_strict_and_exact_at_the_radius(void)
{
    /* (0.75, 1) has length 1.25 exactly (3-4-5 times 0.25). */
    TEST_ASSERT_FALSE(oset_within(tu_num(0.75), tu_num(1.0), tu_num(1.25)));
    TEST_ASSERT_TRUE(oset_within(tu_num(0.75), tu_num(1.0), tu_num(1.25 + 1.0 / 1024)));
    TEST_ASSERT_FALSE(oset_within(tu_num(0.75), tu_num(1.0), tu_num(1.25 - 1.0 / 1024)));
    /* Signs do not matter. */
    TEST_ASSERT_TRUE(oset_within(tu_num(-0.75), tu_num(-1.0), tu_num(1.5)));
    /* The bounding box alone: |dx| >= r. */
    TEST_ASSERT_FALSE(oset_within(tu_num(2.0), tu_num(0.0), tu_num(2.0)));
    TEST_ASSERT_FALSE(oset_within(tu_num(0.0), tu_num(-3.0), tu_num(2.0)));
    /* r <= 0 contains nothing, not even the origin. */
    TEST_ASSERT_FALSE(oset_within(NUM_ZERO, NUM_ZERO, NUM_ZERO));
    TEST_ASSERT_FALSE(oset_within(NUM_ZERO, NUM_ZERO, tu_num(-1.0)));
}

static void test_oset_within_large_radii_use_the_root_without_overflow(void)
{
    /* r >= 128: squares of 150 would saturate Q16.16. (96, 128) has length
     * 160 (3-4-5 times 32). */
    TEST_ASSERT_FALSE(oset_within(tu_num(96.0), tu_num(128.0), tu_num(160.0)));
    TEST_ASSERT_TRUE(oset_within(tu_num(96.0), tu_num(128.0), tu_num(160.5)));
    TEST_ASSERT_FALSE(oset_within(tu_num(96.0), tu_num(128.0), tu_num(159.5)));
    /* Far beyond: 10 km away, within 200 m? No. */
    TEST_ASSERT_FALSE(oset_within(tu_num(10000.0), tu_num(-10000.0), tu_num(200.0)));
}

static void test_oset_distance_is_the_length_near_and_far(void)
{
    /* (0.75, 1) → 1.25 (the root of the squares); (96, 128) → 160 (3-4-5
     * times 32, beyond 128: num_hypot, no square that would saturate
     * Q16.16); (−3, 4) → 5. */
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-6, 4e-5), 1.25, oset_distance(tu_num(0.75), tu_num(1.0)));
    TEST_ASSERT_NUM_WITHIN(TU_TOL(2e-5, 4e-5), 160.0, oset_distance(tu_num(96.0), tu_num(128.0)));
    TEST_ASSERT_NUM_WITHIN(TU_TOL(2e-5, 4e-5), 160.0, oset_distance(tu_num(128.0), tu_num(-96.0)));
    TEST_ASSERT_NUM_WITHIN(TU_TOL(1e-6, 4e-5), 5.0, oset_distance(tu_num(-3.0), tu_num(4.0)));
    /* (90, −120) → 150 (3-4-5 times 30): both below 128, their squares'
     * sum 22500 above 128² (float mode: past the sum's own test, the bounds
     * decide: the root of the squares); (0, 0) → 0. */
    TEST_ASSERT_NUM_WITHIN(TU_TOL(2e-5, 4e-5), 150.0, oset_distance(tu_num(90.0), tu_num(-120.0)));
    TEST_ASSERT_NUM_WITHIN(TU_TOL(0.0, 0.0), 0.0, oset_distance(NUM_ZERO, NUM_ZERO));
}

/* oset_distance is the root of num_sum_sq_small below 128 in each
 * component and num_hypot beyond, bit for bit (float mode tests the sum
 * first: the same values, oset.h), over a grid of both signs reaching past
 * 128. */
static void test_oset_distance_is_its_two_definitions_bit_for_bit(void)
{
    unsigned long differ = 0;
    for (int i = -1400; i <= 1400; i += 7) {
        for (int j = -1400; j <= 1400; j += 11) {
            const num_t dx = tu_num((double)i * 0.1 + 0.013);
            const num_t dy = tu_num((double)j * 0.1 - 0.027);
            const bool small = num_below(dx, OSET_SQUARE_LIMIT) && num_below(dy, OSET_SQUARE_LIMIT);
            const num_t want = small ? num_sqrt(num_sum_sq_small(dx, dy)) : num_hypot(dx, dy);
            const num_t got = oset_distance(dx, dy);
            differ += memcmp(&want, &got, sizeof got) != 0;
        }
    }
    TEST_ASSERT_EQUAL_UINT32(0u, differ);
}

/* ------------------------------------------------------------- clusters */

static void test_oset_link_overlap_gap_and_apart(void)
{
    /* D_s 0.375 each, width 0.5: overlap below 0.75, one cluster below 1.25. */
    const num_t width = tu_num(0.5);
    const sup_entry_t a = entry(1, 0.0, 0.0, 0.375);
    sup_entry_t b = entry(2, 0.5, 0.0, 0.375);
    TEST_ASSERT_EQUAL_INT(OSET_OVERLAP, oset_link(&a, &b, width));
    /* Exactly touching: 0.75 is not < 0.75, a gap of zero. */
    b = entry(2, 0.75, 0.0, 0.375);
    TEST_ASSERT_EQUAL_INT(OSET_GAP, oset_link(&a, &b, width));
    /* Gap 0.25 < 0.5. */
    b = entry(2, 0.0, 1.0, 0.375);
    TEST_ASSERT_EQUAL_INT(OSET_GAP, oset_link(&a, &b, width));
    /* Gap exactly the width: (0.75, 1) is 1.25 away: apart (the robot fits). */
    b = entry(2, 0.75, 1.0, 0.375);
    TEST_ASSERT_EQUAL_INT(OSET_APART, oset_link(&a, &b, width));
    /* Each entry's own D_s counts: a large obstacle reaches further. */
    b = entry(2, 0.75, 1.0, 0.5);
    TEST_ASSERT_EQUAL_INT(OSET_GAP, oset_link(&a, &b, width));
    /* Symmetric. */
    TEST_ASSERT_EQUAL_INT(oset_link(&a, &b, width), oset_link(&b, &a, width));
}

static void test_oset_cluster_is_the_transitive_closure(void)
{
    /* D_s 0.375, width 0.5 (links below 1.25). A chain along x: A(0) — B(1)
     * gap — C(2) gap — D(3.5) apart from C (1.5 >= 1.25); E(0, 1) overlaps
     * nothing but is 1 from A: gap. F far away. */
    sup_entry_t e[6];
    e[0] = entry(1, 0.0, 0.0, 0.375);
    e[1] = entry(2, 1.0, 0.0, 0.375);
    e[2] = entry(3, 2.0, 0.0, 0.375);
    e[3] = entry(4, 3.5, 0.0, 0.375);
    e[4] = entry(5, 0.0, 1.0, 0.375);
    e[5] = entry(6, 10.0, 10.0, 0.375);
    bool gapped = false;
    const num_t width = tu_num(0.5);
    TEST_ASSERT_EQUAL_HEX64(0x0017u, oset_cluster(e, 6, 0, width, &gapped));
    TEST_ASSERT_TRUE(gapped);
    /* From another member: the same cluster. */
    TEST_ASSERT_EQUAL_HEX64(0x0017u, oset_cluster(e, 6, 2, width, &gapped));
    /* D and F stand alone. */
    TEST_ASSERT_EQUAL_HEX64(0x0008u, oset_cluster(e, 6, 3, width, &gapped));
    TEST_ASSERT_FALSE(gapped);
    TEST_ASSERT_EQUAL_HEX64(0x0020u, oset_cluster(e, 6, 5, width, &gapped));
    /* Only the first n entries count. */
    TEST_ASSERT_EQUAL_HEX64(0x0003u, oset_cluster(e, 2, 0, width, &gapped));
}

static void test_oset_cluster_of_overlapping_circles_has_no_gap(void)
{
    /* Three at 0.5 from each other: every pair overlaps (< 0.75). */
    sup_entry_t e[3];
    e[0] = entry(1, 0.0, 0.0, 0.375);
    e[1] = entry(2, 0.5, 0.0, 0.375);
    e[2] = entry(3, 0.25, 0.4375, 0.375); /* 0.504 from both */
    bool gapped = true;
    TEST_ASSERT_EQUAL_HEX64(0x0007u, oset_cluster(e, 3, 1, tu_num(0.5), &gapped));
    TEST_ASSERT_FALSE(gapped);
}

static void test_oset_cluster_sees_a_gap_between_two_members_found_through_a_third(void)
{
    /* B and C both overlap A (0.5 away), but B–C are 1.0 apart: a gap, which
     * the expansion from A alone would not test. */
    sup_entry_t e[3];
    e[0] = entry(1, 0.0, 0.0, 0.375);
    e[1] = entry(2, -0.5, 0.0, 0.375);
    e[2] = entry(3, 0.5, 0.0, 0.375);
    bool gapped = false;
    TEST_ASSERT_EQUAL_HEX64(0x0007u, oset_cluster(e, 3, 0, tu_num(0.5), &gapped));
    TEST_ASSERT_TRUE(gapped);
}

static void test_oset_cluster_of_a_full_table(void)
{
    /* SUP_MAX_OBSTACLES obstacles 0.5 apart in a row: one cluster, a bit
     * for each, found from the last one (both halves of the mask, sup.h).
     * Neighbours overlap; every second one is 1.0 apart, a gap (oset.h: any
     * pair of members counts, even where a third covers the gap). */
    sup_entry_t e[SUP_MAX_OBSTACLES];
    for (uint8_t i = 0; i < SUP_MAX_OBSTACLES; i++) {
        e[i] = entry((uint8_t)(i + 1u), 0.5 * i, 0.0, 0.375);
    }
    bool gapped = false;
    const uint64_t all =
        SUP_MAX_OBSTACLES == 64u ? UINT64_MAX : (UINT64_C(1) << SUP_MAX_OBSTACLES) - 1u;
    TEST_ASSERT_EQUAL_HEX64(
        all, oset_cluster(e, SUP_MAX_OBSTACLES, SUP_MAX_OBSTACLES - 1u, tu_num(0.5), &gapped));
    TEST_ASSERT_TRUE(gapped);
    /* The row cut by moving entries k and k + 1 away (k = 40 of 48: the
     * cut within the upper half, the part below it across both): 1.5 apart
     * at the cut, beyond 0.75 + 0.5, so two clusters, each found from
     * either end, and the two moved entries alone. */
    const unsigned k = SUP_MAX_OBSTACLES - 8u;
    e[k] = entry((uint8_t)(k + 1u), 0.5 * k, 5.0, 0.375);
    e[k + 1u] = entry((uint8_t)(k + 2u), 0.5 * (k + 1u), -5.0, 0.375);
    const uint64_t below = (UINT64_C(1) << k) - 1u;
    const uint64_t above = all & ~below & ~(UINT64_C(3) << k);
    TEST_ASSERT_EQUAL_HEX64(below, oset_cluster(e, SUP_MAX_OBSTACLES, 0, tu_num(0.5), &gapped));
    TEST_ASSERT_EQUAL_HEX64(
        below, oset_cluster(e, SUP_MAX_OBSTACLES, (uint8_t)(k - 1u), tu_num(0.5), &gapped));
    TEST_ASSERT_EQUAL_HEX64(
        above, oset_cluster(e, SUP_MAX_OBSTACLES, (uint8_t)(k + 2u), tu_num(0.5), &gapped));
    TEST_ASSERT_EQUAL_HEX64(
        above, oset_cluster(e, SUP_MAX_OBSTACLES, SUP_MAX_OBSTACLES - 1u, tu_num(0.5), &gapped));
    TEST_ASSERT_EQUAL_HEX64(
        UINT64_C(1) << (k + 1u),
        oset_cluster(e, SUP_MAX_OBSTACLES, (uint8_t)(k + 1u), tu_num(0.5), &gapped));
    TEST_ASSERT_FALSE(gapped);
    /* Spaced 0.25: neighbours up to the fourth overlap (< 0.75); the
     * fourth is 1.0 away: still a gap. Spaced 0.125 and only five: every
     * pair within 0.5, no gap. */
    for (uint8_t i = 0; i < 5u; i++) {
        e[i] = entry((uint8_t)(i + 1u), 0.125 * i, 0.0, 0.375);
    }
    TEST_ASSERT_EQUAL_HEX64(0x001Fu, oset_cluster(e, 5, 0, tu_num(0.5), &gapped));
    TEST_ASSERT_FALSE(gapped);
}

/* ------------------------------------------------------------- closing */

static void test_oset_closing_is_the_sign_of_the_radial_velocity(void)
{
    /* Obstacle at (1, 0) from the robot. */
    const num_t dx = tu_num(1.0), dy = NUM_ZERO;
    TEST_ASSERT_TRUE(oset_closing(dx, dy, tu_num(0.5), NUM_ZERO));    /* straight at it */
    TEST_ASSERT_TRUE(oset_closing(dx, dy, tu_num(0.1), tu_num(1.0))); /* mostly across */
    TEST_ASSERT_FALSE(oset_closing(dx, dy, NUM_ZERO, tu_num(0.5)));   /* tangent */
    TEST_ASSERT_FALSE(oset_closing(dx, dy, tu_num(-0.5), NUM_ZERO));  /* away */
    TEST_ASSERT_FALSE(oset_closing(dx, dy, NUM_ZERO, NUM_ZERO));      /* still */
    /* Off the axes: obstacle (0.6, 0.8), velocity (−0.8, 0.6) is tangent;
     * (−0.8, 0.7) has dot 0.08 > 0. */
    TEST_ASSERT_FALSE(oset_closing(tu_num(0.6), tu_num(0.8), tu_num(-0.75), tu_num(0.5625)));
    TEST_ASSERT_TRUE(oset_closing(tu_num(0.6), tu_num(0.8), tu_num(-0.75), tu_num(0.625)));
}

/* ---------------------------------------------------- closest approach */

/* Brute force in double: the smallest |p + v t|² over t in [0, T], sampled
 * every 1e-4 s, and where it is reached. */
static double brute_cpa(double px, double py, double vx, double vy, double horizon, double *t_at)
{
    double best = INFINITY;
    for (double t = 0.0; t <= horizon + 1e-12; t += 1e-4) {
        const double x = px + vx * t, y = py + vy * t;
        const double d2 = x * x + y * y;
        if (d2 < best) {
            best = d2;
            *t_at = t;
        }
    }
    return best;
}

static void test_oset_closest_approach_hand_values(void)
{
    num_t t, d2;
    /* Obstacle 2 ahead and 1 to the left, coming at 1 m/s: t* = 2, passes
     * at 1 m: d² = 1. */
    oset_closest_approach(tu_num(2.0), tu_num(1.0), tu_num(-1.0), NUM_ZERO, tu_num(3.0), &t, &d2);
    TEST_ASSERT_NUM_WITHIN(TOL_T, 2.0, t);
    TEST_ASSERT_NUM_WITHIN(TOL_D2, 1.0, d2);
    /* Horizon 1.5: t = 1.5, at (0.5, 1): d² = 1.25. */
    oset_closest_approach(tu_num(2.0), tu_num(1.0), tu_num(-1.0), NUM_ZERO, tu_num(1.5), &t, &d2);
    TEST_ASSERT_NUM_WITHIN(TOL_T, 1.5, t);
    TEST_ASSERT_NUM_WITHIN(TOL_D2, 1.25, d2);
    /* Receding: t* = 0, d² = |p|² = 5. */
    oset_closest_approach(tu_num(2.0), tu_num(1.0), tu_num(1.0), NUM_ZERO, tu_num(3.0), &t, &d2);
    TEST_ASSERT_NUM_WITHIN(TOL_T, 0.0, t);
    TEST_ASSERT_NUM_WITHIN(TOL_D2, 5.0, d2);
    /* No relative motion (below 1 cm/s): t* = 0. */
    oset_closest_approach(tu_num(2.0), tu_num(1.0), tu_num(-0.005), NUM_ZERO, tu_num(3.0), &t, &d2);
    TEST_ASSERT_NUM_WITHIN(TOL_T, 0.0, t);
    TEST_ASSERT_NUM_WITHIN(TOL_D2, 5.0, d2);
    /* Head-on: collision at t = 0.8 (d² = 0). */
    oset_closest_approach(tu_num(0.4), NUM_ZERO, tu_num(-0.5), NUM_ZERO, tu_num(3.0), &t, &d2);
    TEST_ASSERT_NUM_WITHIN(TOL_T, 0.8, t);
    TEST_ASSERT_NUM_WITHIN(TOL_D2, 0.0, d2);
}

static void test_oset_closest_approach_matches_brute_force(void)
{
    /* Deterministic pseudo-random cases, |p| <= 4, |v| <= 2. */
    uint32_t s = 12345u;
    char msg[128];
    for (int k = 0; k < 200; k++) {
        double r[5];
        for (int j = 0; j < 5; j++) {
            s = s * 1664525u + 1013904223u;
            r[j] = (double)(s >> 8) / 16777216.0; /* [0, 1) */
        }
        const double px = tu_q(8.0 * r[0] - 4.0), py = tu_q(8.0 * r[1] - 4.0);
        const double vx = tu_q(4.0 * r[2] - 2.0), vy = tu_q(4.0 * r[3] - 2.0);
        const double horizon = tu_q(0.5 + 3.0 * r[4]);
        double t_at = 0.0;
        const double best = brute_cpa(px, py, vx, vy, horizon, &t_at);
        num_t t, d2;
        oset_closest_approach(tu_num(px), tu_num(py), tu_num(vx), tu_num(vy), tu_num(horizon), &t,
                              &d2);
        snprintf(msg, sizeof msg, "p (%g, %g) v (%g, %g) T %g", px, py, vx, vy, horizon);
        /* The sampling is 1e-4 s apart: the brute minimum is within
         * |v|² (1e-4)² + 2|p||v|·1e-4 ≈ 2e-3 of the true one, above it. */
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(TOL_D2 + 2e-3, best, tu_dbl(d2), msg);
        TEST_ASSERT_TRUE_MESSAGE(tu_dbl(d2) <= best + TOL_D2, msg);
        TEST_ASSERT_TRUE_MESSAGE(tu_dbl(t) >= 0.0 && tu_dbl(t) <= horizon + TOL_T, msg);
    }
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_oset_within_is_strict_and_exact_at_the_radius);
    RUN_TEST(test_oset_within_large_radii_use_the_root_without_overflow);
    RUN_TEST(test_oset_distance_is_the_length_near_and_far);
    RUN_TEST(test_oset_distance_is_its_two_definitions_bit_for_bit);
    RUN_TEST(test_oset_link_overlap_gap_and_apart);
    RUN_TEST(test_oset_cluster_is_the_transitive_closure);
    RUN_TEST(test_oset_cluster_of_overlapping_circles_has_no_gap);
    RUN_TEST(test_oset_cluster_sees_a_gap_between_two_members_found_through_a_third);
    RUN_TEST(test_oset_cluster_of_a_full_table);
    RUN_TEST(test_oset_closing_is_the_sign_of_the_radial_velocity);
    RUN_TEST(test_oset_closest_approach_hand_values);
    RUN_TEST(test_oset_closest_approach_matches_brute_force);
    return UNITY_END();
}
