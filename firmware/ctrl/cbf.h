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

#include "ctrl/act.h"
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
/** @brief A moving obstacle's braking margin is σ max(CBF_MOVING_BRAKE
 *         T_b, G σ/a_β), G = CBF_MOVING_GAIN + CBF_MOVING_RISE cos β_b, β_b
 *         the obstacle's bearing from the heading (cos β_b = −Δ·[cos θ,
 *         sin θ] / |Δ|, Δ = p_l − c): G is 4 dead ahead, 2.75 beside, 1.5
 *         dead behind (docs/strategy.md, "The choices under real wheels":
 *         against 1.5, 2 and 3 in every direction and gains by half-planes
 *         on the suite's moving family). Literals: cbf.c derives the
 *         largest gain from them. */
#define CBF_MOVING_GAIN_X 2.75
#define CBF_MOVING_RISE_X 1.25
#define CBF_MOVING_GAIN   NUM_C(CBF_MOVING_GAIN_X)
#define CBF_MOVING_RISE   NUM_C(CBF_MOVING_RISE_X)
/** @brief The braking time T_b in a moving obstacle's margin is taken this
 *         many times (as every part of it was before the gain by bearing;
 *         with fast wheels, where σ/a_β is next to nothing, the margin is
 *         what it was). */
#define CBF_MOVING_BRAKE  NUM_C(1.5)

/**
 * @brief What the wheels do to the barrier (docs/strategy.md, "Real
 *        wheels"): the look-ahead point is taken where the lagging wheels
 *        carry it, and an obstacle the command in force closes on at σ gets
 *        its ρ widened by σ T_b, the distance braking still covers. NULL
 *        (or all zero): wheels that follow at once, the filter as above.
 */
typedef struct {
    num_t shift_x, shift_y; /**< p_l's shift by the prediction [m] */
    num_t qx, qy;           /**< look-ahead velocity u of the command in force [m/s] */
    num_t brake_t;          /**< T_b [s] (act_brake_time()) */
    num_t inv_accel;        /**< 1 / a_v: a_v = r wheel_accel, how fast the
                                 look-ahead point's speed can change along
                                 the heading [s²/m] */
    num_t side;             /**< across the heading it changes at a_v side at
                                 most (act_limits_t) */
    num_t inv_side;         /**< 1 / side */
    num_t gap;              /**< D_s − R_m − R_ob: an obstacle's d_s less its
                                 contact distance R_m + r [m] */
    num_t horizon;          /**< T_p [s], the prediction's horizon: a moving
                                 obstacle is taken where it will be then,
                                 c + w T_p, as the look-ahead point is */
} cbf_motion_t;

/** @brief One obstacle's constraint on the command: g1 v + g2 l ω >= b. */
typedef struct {
    num_t g1, g2, b;
} cbf_constraint_t;

/** @brief Filter state: whether the previous step intervened, and the
 *         constraints of this step, computed once each (they depend on the
 *         pose and the obstacle, not on the command being tested). */
typedef struct {
    bool active;       /**< an intervention episode is running */
    bool infeasible;   /**< the previous step found a constraint it could not meet */
    sup_mask_t cached; /**< entry i in it: k[i] holds entry i's constraint of this step */
    sup_mask_t doomed; /**< entry i in it: and its obstacle closes faster than the robot
                            can null before the bodies touch (cbf_unreachable()) */
    cbf_constraint_t k[SUP_MAX_OBSTACLES];
} cbf_t;

/** @brief The braking guard's margin beyond D_s [m] (cbf_brake_clear()). */
#define CBF_GUARD_MARGIN NUM_C(0.04)
/** @brief Inside the margin, the guard lets no path come closer than now
 *         less this [m]. */
#define CBF_GUARD_SLACK  NUM_C(0.001)

/**
 * @brief What the braking guard checks (cbf_brake_clear()): the command's
 *        body velocity (v, ω), braked along its path after being held a
 *        period, from the pose the wheels' lag carries the robot to.
 */
typedef struct {
    pose_t start;   /**< the predicted pose (act_predict()) */
    num_t c, s;     /**< cos, sin of its heading */
    num_t lead;     /**< the robot's travel to it, |v̂| T_p [m] */
    num_t v, w;     /**< the command's body velocity [m/s], [rad/s] */
    num_t travel_t; /**< dt + T_s/2: the path's length over |v| [s] (act.h) */
} cbf_brake_t;

/** @brief What one step of the filter did. */
typedef struct {
    bool changed;        /**< the command was changed */
    bool new_episode;    /**< changed, and the previous step was not */
    bool infeasible;     /**< a constraint with b_i > 0 could not be met */
    bool new_infeasible; /**< infeasible, and the previous step was not */
    uint8_t obstacle;    /**< id of the most violated obstacle when changed, else 0 */
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
 * @param m        the wheels' motion, or NULL for wheels that follow at once.
 * @param e        table entries (position, velocity, own D_s).
 * @param dist     centre distance from the robot to each entry [m] (what
 *                 ctl_status_t::distance holds): obstacles far enough for
 *                 their constraint not to bind are skipped on it.
 * @param n        entries used.
 * @param[in,out] v linear velocity [m/s].
 * @param[in,out] w angular velocity [rad/s].
 * @param[out] r   what was done.
 */
void cbf_step(cbf_t *f, const pose_t *robot, num_t cos_th, num_t sin_th, const cbf_motion_t *m,
              const sup_entry_t *e, const num_t *dist, uint8_t n, num_t *v, num_t *w,
              cbf_result_t *r);

/**
 * @brief The barrier h_i of obstacle @p o for the robot at @p robot with
 *        the wheels' motion @p m (NULL: none), and its gradient a_i, as the
 *        filter computes them (for tests and tools).
 * @param[out] h  h_i [m²].
 * @param[out] ax,ay a_i [m].
 */
void cbf_barrier(const pose_t *robot, num_t cos_th, num_t sin_th, const cbf_motion_t *m,
                 const sup_entry_t *o, num_t *h, num_t *ax, num_t *ay);

/**
 * @brief The braking guard ("backup" barrier under braking along the path,
 *        docs/strategy.md): whether the robot, given the command of @p b for
 *        one period and then braked along its path by ramping both wheels
 *        down together at wheel_accel, keeps every static obstacle beyond
 *        its D_s + CBF_GUARD_MARGIN (an obstacle already closer: no closer
 *        than now). The path is the arc of the command's curvature from the
 *        predicted pose, of length |v| (dt + T_s/2) (rol.h). Moving obstacles
 *        are left to the filter: stopping in their way does not help.
 * @param b    the command and the predicted pose.
 * @param e    table entries. @param dist centre distances from the robot.
 * @param n    entries used.
 * @retval true the path keeps the distance from every static obstacle.
 */
bool cbf_brake_clear(const cbf_brake_t *b, const sup_entry_t *e, const num_t *dist, uint8_t n);

/** @brief A wheel command's body velocity (kin_vw_from_wheels() of it), when
 *         known: passed along so that it is not computed twice. */
typedef struct {
    num_t v, w; /**< [m/s], [rad/s] */
    bool known; /**< v and w hold */
} cbf_body_t;

/** @brief The command's rate limit and where the braking guard starts from
 *         (cbf_guard()). */
typedef struct {
    const kin_params_t *kin; /**< wheel geometry */
    num_t step;              /**< wheel_accel × dt: the rate limiter's step [rad/s] */
    num_t inv_accel;         /**< 1 / wheel_accel */
    num_t dt;                /**< the period [s] */
    pose_t start;            /**< the predicted pose (act_predict()) */
    num_t c, s;              /**< cos, sin of its heading */
    num_t lead;              /**< the robot's travel to it [m] */
} cbf_guard_t;

/**
 * @brief The rate limiter and the braking guard, the last stage of "mstc"
 *        (docs/strategy.md, "Real wheels"): @p wheels rate-limited from
 *        a->cmd (act_limit()) if cbf_brake_clear() passes for it; else the
 *        same turn with the speed braked, (0, ω), rate-limited, if that
 *        passes; else a->cmd ramped down towards zero at the limit (braking
 *        along the path: it continues the braking that the previous step's
 *        command was checked with, so it is always available). a->cmd holds
 *        the result.
 * @param[in,out] body the body velocity of @p wheels, if known; on return,
 *        that of the result, if known.
 * @retval true the guard changed the command.
 */
bool cbf_guard(act_t *a, const cbf_guard_t *g, const sup_entry_t *e, const num_t *dist, uint8_t n,
               kin_wheels_t *wheels, cbf_body_t *body);

/**
 * @brief A moving obstacle that no command within the wheels' limits keeps
 *        away this period: of the constraints cbf_step() computed this step
 *        (the cache in @p f), one of a moving obstacle that every wheel
 *        command within @p step [rad/s] of @p base (the rate limiter's box)
 *        falls short of by more than the filter's tolerance. A constraint is
 *        linear in the wheel speeds, so its largest value over the box is
 *        at a corner: a·u(base) + step (|c_L| + |c_R|), c_L, c_R its
 *        coefficients on the left and right wheel.
 * @return the obstacle's id, or 0 when there is none.
 */
uint8_t cbf_unreachable(const cbf_t *f, const sup_entry_t *e, uint8_t n, const kin_params_t *kin,
                        const kin_wheels_t *base, num_t step);

#endif /* MSTC_CBF_H */
