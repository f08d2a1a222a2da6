/* SPDX-License-Identifier: MIT */
/**
 * @file rol.h
 * @brief Forward roll-out of a constant command for the "mstc" strategy
 *        (docs/strategy.md): the path a unicycle follows when (v, ω) is held
 *        for a short horizon T, in closed form, and whether it keeps a given
 *        distance from a point. As Nav2's regulated pure pursuit projects its
 *        command forward before it drives, the release of an avoidance
 *        checks the tracking command this way.
 *
 * The path is an arc of centre C = p + (v/ω)[−sin θ, cos θ] and radius
 * |v/ω|, swept through Φ = ω T, or, when |Φ| <= ROL_STRAIGHT_TURN, the
 * segment from p along the heading of length |v| T widened by L|Φ|/2, the
 * most an arc of that turn leaves its tangent. No sampling and no square root
 * per point: at most one pair of sine and cosine per path.
 *
 * Conservative where a cheap exact answer is not at hand: a path longer than
 * ROL_MAX_LENGTH, or an arc of more than half a turn whose circle passes
 * within the distance of the point, is "not clear".
 */
#ifndef MSTC_ROL_H
#define MSTC_ROL_H

#include <stdbool.h>

#include "ctrl/pose.h"

/** @brief Largest |Φ| = |ω| T [rad] treated as a straight segment. */
#define ROL_STRAIGHT_TURN NUM_C(0.1)
/** @brief Longest path |v| T [m] the roll-out decides on; longer is not clear. */
#define ROL_MAX_LENGTH    NUM_C(10.0)

/** @brief Kinds of path. */
typedef enum {
    ROL_SEGMENT = 0, /**< |Φ| <= ROL_STRAIGHT_TURN */
    ROL_ARC = 1,     /**< |Φ| > ROL_STRAIGHT_TURN */
    ROL_TOO_LONG = 2 /**< |v| T > ROL_MAX_LENGTH: nothing is clear */
} rol_kind_t;

/** @brief A rolled-out path. */
typedef struct {
    rol_kind_t kind;
    num_t x, y;     /**< start p [m] */
    num_t ex, ey;   /**< ROL_SEGMENT: unit direction of motion (± heading) */
    num_t length;   /**< ROL_SEGMENT: |v| T [m] */
    num_t widen;    /**< ROL_SEGMENT: L |Φ| / 2 [m] */
    num_t cx, cy;   /**< ROL_ARC: centre C [m] */
    num_t radius;   /**< ROL_ARC: |v/ω| [m] */
    num_t s0x, s0y; /**< ROL_ARC: p − C */
    num_t s1x, s1y; /**< ROL_ARC: end − C */
    bool ccw;       /**< ROL_ARC: ω > 0 */
    bool whole;     /**< ROL_ARC: |Φ| > π (the sector test does not apply) */
    num_t reach;    /**< no point of the path (widened) is farther from p [m]; NUM_MAX
                         for ROL_TOO_LONG */
} rol_path_t;

/**
 * @brief Roll out (v, ω) from @p p for @p horizon seconds.
 * @param[out] path the path.
 * @param p        start pose.
 * @param cos_th,sin_th cos θ, sin θ of @p p (the caller has them).
 * @param v        linear velocity [m/s], any sign.
 * @param w        angular velocity [rad/s].
 * @param horizon  T [s], in (0, 10].
 */
void rol_path(rol_path_t *path, const pose_t *p, num_t cos_th, num_t sin_th, num_t v, num_t w,
              num_t horizon);

/**
 * @brief Whether every point of @p path is at least @p clear from (ox, oy).
 *        A point at least path->reach + clear from the start is clear
 *        without this call.
 * @param path  from rol_path().
 * @param ox,oy the point [m].
 * @param clear distance [m], >= 0, < 110.
 * @retval true  the path keeps the distance (for ROL_SEGMENT, with its widening).
 * @retval false it comes closer, or the roll-out cannot tell (see rol.h).
 */
bool rol_clears(const rol_path_t *path, num_t ox, num_t oy, num_t clear);

#endif /* MSTC_ROL_H */
