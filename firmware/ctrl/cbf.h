/* SPDX-License-Identifier: MIT */
/**
 * @file cbf.h
 * @brief Last-line safety filter of the "mstc" strategy (docs/strategy.md):
 *        a control-barrier-function filter on (v, ω) in closed form, no
 *        solver.
 *
 * Look-ahead point p_l = p + l [cos θ, sin θ], whose velocity
 * u = v [cos θ, sin θ] + l ω [−sin θ, cos θ] sets both v and ω
 * (v = [cos θ, sin θ]·u, ω = [−sin θ, cos θ]·u / l). For each obstacle i
 * (centre c_i, velocity w_i, safe distance s_i):
 *
 *     h_i = |p_l − c_i|² − (s_i + l)²       (h_i >= 0 gives |p − c_i| >= s_i)
 *     a_i = 2 (p_l − c_i)
 *     constraint: a_i·u >= b_i = a_i·w_i − α h_i   (ḣ_i >= −α h_i)
 *
 * In (v, ω) the constraint reads g1 v + g2 l ω >= b_i, g1 = a_i·[cos θ,
 * sin θ], g2 = a_i·[−sin θ, cos θ]. The most violated constraint is met
 * exactly with the least change of (v, ω) in the norm Δv² + κ² Δω²
 * (κ = CBF_TURN_WEIGHT_M: turning is not made cheap by a short l). If
 * another constraint is then violated, the least change meeting the two:
 * the projection onto either if it meets the other, else their vertex. What
 * is still violated among the constraints with b_i <= 0 is met by scaling
 * (v, ω) down, by the largest factor in [0, 1] that meets them all (braking
 * along the path: v and ω shrink together; (0, 0) meets them all while
 * h_i >= 0). A constraint with b_i > 0 still violated (an obstacle moving
 * in faster than the robot can leave) is reported as infeasible; the
 * command is then the best found.
 *
 * Scaling (v, ω), so u, by a factor in [0, 1] keeps every met constraint
 * with b_i <= 0 met, so the wheel saturation after the filter (which scales
 * v and ω by one factor, kin.h) keeps them too.
 */
#ifndef MSTC_CBF_H
#define MSTC_CBF_H

#include <stdbool.h>
#include <stdint.h>

#include "ctrl/sup.h"

/** @brief Look-ahead distance l [m] (a literal: cbf.c derives 1/l from it). */
#define CBF_LOOKAHEAD_M   0.05
/** @brief Barrier rate α [1/s]; α·dt <= 1 for every control period up to
 *         CBF_MAX_PERIOD_MS (a literal: cbf.c derives 2/α from it). */
#define CBF_ALPHA_PER_S   20.0
/** @brief The longest control period for which the filter's guarantee holds
 *         [ms]: 1/α. mstc-fw --period-ms and the scenario loader (sim.dt)
 *         refuse longer ones (docs/strategy.md). */
#define CBF_MAX_PERIOD_MS 50u
/** @brief κ [m]: a change of ω weighs as a change of v of κ Δω (a literal). */
#define CBF_TURN_WEIGHT_M 0.3
/** @brief l as num_t. */
#define CBF_LOOKAHEAD     NUM_C(CBF_LOOKAHEAD_M)
/** @brief α as num_t. */
#define CBF_ALPHA         NUM_C(CBF_ALPHA_PER_S)
/** @brief Violations of a_i·u >= b_i below this [m²/s] are left alone, so
 *         that rounding (float or Q16.16) never counts as an intervention. */
#define CBF_TOLERANCE     NUM_C(0.0005)

/** @brief Filter state: whether the previous step intervened. */
typedef struct {
    bool active; /**< an intervention episode is running */
} cbf_t;

/** @brief What one step of the filter did. */
typedef struct {
    bool changed;     /**< the command was changed */
    bool new_episode; /**< changed, and the previous step was not */
    bool infeasible;  /**< a constraint with b_i > 0 could not be met */
    uint8_t obstacle; /**< id of the most violated obstacle when changed, else 0 */
} cbf_result_t;

/** @brief Initialise: no episode running. */
void cbf_init(cbf_t *f);

/** @brief End any episode. */
void cbf_reset(cbf_t *f);

/**
 * @brief Filter the command (v, ω) of one step against every obstacle.
 * @param f        state.
 * @param robot    robot pose.
 * @param cos_th,sin_th cos θ and sin θ of the robot's heading.
 * @param e        table entries (position, velocity, own D_s).
 * @param dist     centre distance from the robot to each entry [m] (what
 *                 ctl_status_t::distance holds): obstacles far enough for
 *                 their constraint not to bind are skipped on it.
 * @param n        entries used.
 * @param[in,out] v linear velocity [m/s].
 * @param[in,out] w angular velocity [rad/s].
 * @param[out] r   what was done.
 */
void cbf_step(cbf_t *f, const pose_t *robot, num_t cos_th, num_t sin_th, const sup_entry_t *e,
              const num_t *dist, uint8_t n, num_t *v, num_t *w, cbf_result_t *r);

/**
 * @brief The barrier h_i of obstacle @p o for the robot at @p robot, and its
 *        gradient a_i, as the filter computes them (for tests and tools).
 * @param[out] h  h_i [m²].
 * @param[out] ax,ay a_i [m].
 */
void cbf_barrier(const pose_t *robot, num_t cos_th, num_t sin_th, const sup_entry_t *o, num_t *h,
                 num_t *ax, num_t *ay);

#endif /* MSTC_CBF_H */
