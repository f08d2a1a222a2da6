/* SPDX-License-Identifier: MIT */
/**
 * @file odo.h
 * @brief Odometry plausibility: does the pose odometry reports follow from
 *        the motion the firmware commanded? (docs/safety.md, "Replayed
 *        odometry").
 *
 * From each odometry pose the firmware predicts the next one by dead
 * reckoning with the wheel speeds it commanded since (the unicycle of eq. 4,
 * midpoint heading). Each new pose is compared with the prediction; the
 * difference e, less an allowance for noise, slip and timing (ODO_TOL_* a
 * step plus ODO_TOL_REL of the commanded travel or turn), is summed in a
 * one-sided CUSUM, s = max(0, s + e − allowance), position and heading
 * apart; odometry is implausible when a sum passes its ODO_LIMIT_*. So one
 * large jump (a recorded loop starting over: the pose goes back by the loop's
 * whole travel) and a steady disagreement (a pose that stands still or lags
 * while the wheels turn fast) are both caught, while noise and slip within
 * the allowance never add up.
 *
 * It is a model check, not authentication: a recording made while the robot
 * stood still or crept, replayed while it does the same, agrees with the
 * model and passes; so does odometry forged in real time to follow the
 * commands. docs/safety.md, "Threat model", says what stops what.
 */
#ifndef MSTC_ODO_H
#define MSTC_ODO_H

#include <stdbool.h>

#include "ctrl/pose.h"
#include "kin/kin.h"
#include "num/num.h"

/** @brief Allowance a step for position noise and timing [m]. */
#define ODO_TOL_M     0.02
/** @brief Allowance a step for heading noise and timing [rad]. */
#define ODO_TOL_RAD   0.02
/** @brief Allowance for slip and tracking: this fraction of the commanded
 *         travel [m] or turn [rad] of the step. */
#define ODO_TOL_REL   0.5
/** @brief Position disagreement, beyond the allowances, that is implausible [m]. */
#define ODO_LIMIT_M   0.1
/** @brief Heading disagreement, beyond the allowances, that is implausible [rad]. */
#define ODO_LIMIT_RAD 0.2

/** @brief Plausibility state. */
typedef struct {
    pose_t pred;       /**< the pose the commanded motion leads to since the last odometry */
    bool have;         /**< a full pose (position and heading) was seen since the reset */
    num_t allow_xy;    /**< allowance gathered since the last position [m] */
    num_t allow_theta; /**< ... since the last heading [rad] */
    num_t s_xy;        /**< CUSUM of the position disagreement [m] */
    num_t s_theta;     /**< CUSUM of the heading disagreement [rad] */
} odo_t;

/** @brief Forget everything: the next full pose starts the prediction. */
void odo_reset(odo_t *o);

/** @brief Same as odo_reset(). */
void odo_init(odo_t *o);

/**
 * @brief One control step.
 * @param o state.
 * @param p wheel geometry.
 * @param w wheel speeds commanded over the interval that just ended [rad/s].
 * @param dt that interval [s], >= 0.
 * @param odom the latest odometry pose.
 * @param fresh_xy its position arrived in this step.
 * @param fresh_theta its heading arrived in this step.
 * @retval true odometry is implausible.
 */
bool odo_step(odo_t *o, const kin_params_t *p, const kin_wheels_t *w, num_t dt, const pose_t *odom,
              bool fresh_xy, bool fresh_theta);

#endif /* MSTC_ODO_H */
