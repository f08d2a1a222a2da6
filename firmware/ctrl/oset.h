/* SPDX-License-Identifier: MIT */
/**
 * @file oset.h
 * @brief Geometry of the obstacle set for the "mstc" strategy
 *        (docs/strategy.md): distance tests that cannot overflow in Q16.16,
 *        clusters of obstacles that must be gone around as one, the closing
 *        test and the closest approach of a moving obstacle. Stateless.
 *
 * Distances are compared through squares where that is exact, so no square
 * root is taken per obstacle and per step; the squares are only formed once
 * both coordinates are known to be small enough for Q16.16 (|value| < 128).
 */
#ifndef MSTC_OSET_H
#define MSTC_OSET_H

#include <stdbool.h>
#include <stdint.h>

#include "ctrl/sup.h"

/** @brief Below this radius, dx² + dy² < 2 r² < 32768 cannot saturate
 *         Q16.16 (oset_within(), oset_distance()). */
#define OSET_SQUARE_LIMIT NUM_C(128.0)

/**
 * @brief |(dx, dy)| < r, decided without overflow in either numeric mode.
 *        A bounding-box test first (|dx| >= r or |dy| >= r: false); then
 *        squares when r < 128 (so dx² + dy² < 2 r² fits Q16.16), num_hypot
 *        otherwise. Inline: called for every obstacle, several times a step.
 * @param dx,dy vector [m], finite.
 * @param r     radius [m]; r <= 0 gives false.
 */
static inline bool oset_within(num_t dx, num_t dy, num_t r)
{
    if (!num_below(dx, r) || !num_below(dy, r)) {
        return false; /* also every r <= 0 */
    }
    if (r < OSET_SQUARE_LIMIT) {
        return num_sum_sq_small(dx, dy) < num_sq_small(r); /* |dx|, |dy| < r < 128 */
    }
    return num_hypot(dx, dy) < r;
}

/**
 * @brief |(dx, dy)|, the cheaper way that cannot overflow: the root of
 *        dx² + dy² when |dx|, |dy| < 128 (a square root instruction in float
 *        mode, against a library hypot three times longer on a Cortex-M4F),
 *        num_hypot() otherwise. Within 1.5 float ulp (float) or 0.5 LSB
 *        plus a product's rounding (Q16.16) of the exact length. Inline, as
 *        oset_within().
 */
static inline num_t oset_distance(num_t dx, num_t dy)
{
#if !defined(NUM_FIXED)
    /* Float: a sum of squares below 128² has |dx|, |dy| < 128 (a square is
     * at most the sum: rounding is monotonic), where the root of that same
     * sum is the value below; the two bounds tested only past it (5
     * instructions fewer a distance on a Cortex-M4F). */
    const num_t d2 = num_sum_sq(dx, dy);
    if (d2 < NUM_C(16384.0)) {
        return num_sqrt_nonneg(d2);
    }
#endif
    if (num_below(dx, OSET_SQUARE_LIMIT) && num_below(dy, OSET_SQUARE_LIMIT)) {
        return num_norm_small(dx, dy);
    }
    return num_hypot(dx, dy);
}

/** @brief How two obstacles stand to each other (oset_link()). */
typedef enum {
    OSET_APART = 0,   /**< separate: the robot passes between them */
    OSET_OVERLAP = 1, /**< one cluster: their safety circles overlap */
    OSET_GAP = 2,     /**< one cluster: a gap narrower than the robot's width */
} oset_link_t;

/**
 * @brief Whether two obstacles belong to one cluster: their safety circles
 *        (each entry's own D_s) overlap or leave a gap narrower than
 *        @p width, i.e. |c_a − c_b| < d_s,a + d_s,b + width; and which.
 * @param a,b   table entries.
 * @param width the robot's width 2 R_m [m].
 * @retval OSET_APART   |c_a − c_b| >= d_s,a + d_s,b + width.
 * @retval OSET_OVERLAP |c_a − c_b| <  d_s,a + d_s,b.
 * @retval OSET_GAP     in between.
 */
oset_link_t oset_link(const sup_entry_t *a, const sup_entry_t *b, num_t width);

/**
 * @brief The cluster of entry @p seed: every entry linked to it by a chain of
 *        oset_link() pairs that are not OSET_APART, as a bit mask over the
 *        table's indices (bit i = e[i]). At most n² / 2 pair tests.
 * @param e      table entries.
 * @param n      entries used, <= SUP_MAX_OBSTACLES.
 * @param seed   index of the first member, < n.
 * @param width  the robot's width 2 R_m [m].
 * @param[out] gapped whether some pair of members is OSET_GAP (the circles
 *             followed around the cluster must then be widened to close it).
 *             Conservative: a pair counts even where other members cover
 *             the space between them (every second obstacle of a row).
 */
sup_mask_t oset_cluster(const sup_entry_t *e, uint8_t n, uint8_t seed, num_t width, bool *gapped);

/**
 * @brief Closing test: the robot moving at @p vx, @p vy relative to the
 *        obstacle (its velocity minus the obstacle's) approaches the obstacle
 *        at @p dx, @p dy from it (obstacle centre − robot): d/dt |d| < 0, that
 *        is (dx, dy)·(vx, vy) > 0.
 */
bool oset_closing(num_t dx, num_t dy, num_t vx, num_t vy);

/**
 * @brief Closest approach of an obstacle moving at constant relative
 *        velocity: with p = obstacle − robot and v = obstacle velocity −
 *        robot velocity, t* = −p·v / |v|² clamped into [0, @p horizon], and
 *        the squared distance |p + v t*|² then.
 * @param px,py   relative position [m], |px|, |py| < 64.
 * @param vx,vy   relative velocity [m/s], |vx|, |vy| < 64.
 * @param horizon largest time considered [s], >= 0, < 64.
 * @param[out] t  t* [s]; 0 when |v| is below 1 cm/s (no relative motion).
 * @param[out] d2 squared distance at t* [m²] (saturates at NUM_MAX in Q16.16
 *                when beyond 181 m, which callers treat as far).
 */
void oset_closest_approach(num_t px, num_t py, num_t vx, num_t vy, num_t horizon, num_t *t,
                           num_t *d2);

#endif /* MSTC_OSET_H */
