/* SPDX-License-Identifier: MIT */
/**
 * @file trk.h
 * @brief Trajectory tracking (Kanayama et al.), paper eq. (1)-(3).
 *        Stateless: the functions are pure.
 */
#ifndef MSTC_TRK_H
#define MSTC_TRK_H

#include "ctrl/pose.h"

/** @brief Tracking errors in the robot's body frame, eq. (1). */
typedef struct {
    num_t e1; /**< along the heading [m] */
    num_t e2; /**< to the left of the heading [m] */
    num_t e3; /**< wrap(θ_r − θ) [rad], in (-π, π] (docs/equations.md erratum 2) */
} trk_err_t;

/** @brief Gains of eq. (2)-(3), all > 0 (Table 1: 3, 12, 6). */
typedef struct {
    num_t k1; /**< [1/s] */
    num_t k2; /**< [rad/m²] */
    num_t k3; /**< [rad/m] */
} trk_gains_t;

/**
 * @brief Tracking errors of @p robot with respect to @p ref, eq. (1).
 * @param robot the robot's pose.
 * @param ref   the virtual reference robot's pose.
 * @param[out] err e1, e2 [m] and e3 [rad].
 */
void trk_errors(const pose_t *robot, const pose_t *ref, trk_err_t *err);

/**
 * @brief trk_errors() for a caller that has cos θ and sin θ of the robot's
 *        heading already (the same numbers, one sine and cosine fewer).
 *        Inline: once a step in ctl.c's "mstc" step.
 * @param robot the robot's pose.
 * @param c,s   cos θ, sin θ of robot->theta (num_cos, num_sin).
 * @param ref   the reference pose.
 * @param[out] err e1, e2 [m] and e3 [rad].
 */
static inline void trk_errors_cs(const pose_t *robot, num_t c, num_t s, const pose_t *ref,
                                 trk_err_t *err)
{
    /* eq. (1): the world-frame position error rotated into the body frame. */
    const num_t dx = num_sub(ref->x, robot->x);
    const num_t dy = num_sub(ref->y, robot->y);
    err->e1 = num_add(num_mul(c, dx), num_mul(s, dy));
    err->e2 = num_sub(num_mul(c, dy), num_mul(s, dx));
    /* docs/equations.md erratum 2: e3 only makes sense wrapped. */
    err->e3 = num_wrap(num_sub(ref->theta, robot->theta));
}

/**
 * @brief Tracking control law, eq. (2)-(3).
 * @param g   gains.
 * @param err tracking errors from trk_errors().
 * @param v_r reference linear velocity [m/s].
 * @param w_r reference angular velocity [rad/s].
 * @param[out] v linear velocity command [m/s]: v_r cos e3 + k1 e1.
 * @param[out] w angular velocity command [rad/s]: ω_r + k2 v_r e2 + k3 v_r sin e3.
 */
void trk_control(const trk_gains_t *g, const trk_err_t *err, num_t v_r, num_t w_r, num_t *v,
                 num_t *w);

#endif /* MSTC_TRK_H */
