/* SPDX-License-Identifier: MIT */
/**
 * @file avd.h
 * @brief Obstacle avoidance by boundary following, paper eq. (9)-(24) with
 *        eq. (15) as corrected in docs/equations.md. Stateless: the side is chosen at
 *        activation by the supervisor and passed in.
 */
#ifndef MSTC_AVD_H
#define MSTC_AVD_H

#include "ctrl/pose.h"
#include "ctrl/trk.h"

/**
 * @brief Side of the avoidance: the sign of α in eq. (10)-(12).
 * LEFT (α = +π/2) turns the robot to its left, keeping the obstacle on its
 * right; RIGHT (α = −π/2) the reverse (docs/equations.md, "Side naming").
 */
typedef enum {
    AVD_SIDE_NONE = 0,
    AVD_SIDE_LEFT = 1,
    AVD_SIDE_RIGHT = -1,
} avd_side_t;

/** @brief Gains of eq. (23)-(24), both > 0 (Table 1: 3, 6). */
typedef struct {
    num_t k1; /**< [1/s], eq. (23) */
    num_t k2; /**< [1/s], eq. (24) */
} avd_gains_t;

/** @brief Desired direction of motion and its rate, eq. (9)-(22). */
typedef struct {
    num_t beta;     /**< β = atan2(u_y, u_x) [rad], eq. (14) */
    num_t beta_dot; /**< β̇ [rad/s], eq. (22) with the corrected (15) */
    num_t u_norm;   /**< |u| [m], u = u_p + u_f, eq. (13) */
} avd_dir_t;

/**
 * @brief Side of the avoidance, eq. (11)-(12) on the wrapped difference:
 *        LEFT when wrap(θ − φ) >= 0, else RIGHT, with φ = atan2(y0 − y, x0 − x).
 * @param robot robot pose.
 * @param ox,oy obstacle centre [m].
 */
avd_side_t avd_choose_side(const pose_t *robot, num_t ox, num_t oy);

/**
 * @brief Blending vector direction β and its time derivative β̇ for a robot
 *        moving at linear speed @p v along its heading.
 * @param robot robot pose.
 * @param ox,oy obstacle centre [m].
 * @param d_s   safe distance D_s [m], > 0.
 * @param side  LEFT or RIGHT.
 * @param v     robot linear speed [m/s] (q̇ = v [cos θ, sin θ]).
 * @param[out] dir β, β̇ and |u|. When the robot is at the obstacle centre
 *             (|u_mo| below 1 mm) β = θ and β̇ = 0, so the law commands no turn.
 */
void avd_direction(const pose_t *robot, num_t ox, num_t oy, num_t d_s, avd_side_t side, num_t v,
                   avd_dir_t *dir);

/**
 * @brief Avoidance control law, eq. (21)-(24).
 * @param g     gains.
 * @param robot robot pose.
 * @param err   tracking errors (e1 and e3 enter eq. (23)).
 * @param v_r   reference linear velocity [m/s].
 * @param ox,oy obstacle centre [m].
 * @param d_s   safe distance [m].
 * @param side  side held since activation.
 * @param[out] v linear velocity [m/s]: v_r cos e3 + k1 e1.
 * @param[out] w angular velocity [rad/s]: β̇ + k2 e, with β̇ from
 *             avd_direction() for the velocity @p v just computed (the motion
 *             this step commands).
 * @param[out] e heading error wrap(β − θ) [rad], eq. (21).
 */
void avd_control(const avd_gains_t *g, const pose_t *robot, const trk_err_t *err, num_t v_r,
                 num_t ox, num_t oy, num_t d_s, avd_side_t side, num_t *v, num_t *w, num_t *e);

/** @brief A circle to go around, possibly moving (avd_control_moving()). */
typedef struct {
    num_t x, y;   /**< centre [m] */
    num_t vx, vy; /**< velocity [m/s] */
    num_t d_s;    /**< radius of the circle followed [m], > 0 */
} avd_obstacle_t;

/**
 * @brief The turn of the avoidance law, eq. (21), (22) and (24), for a given
 *        linear velocity @p v, around a circle that may move at constant
 *        velocity ("mstc", docs/strategy.md): β̇ is taken for the robot's
 *        velocity relative to the circle's. For a static circle and the v of
 *        eq. (23) it is what avd_control() computes.
 * @param g     gains (k2).
 * @param robot robot pose.
 * @param cos_th,sin_th cos θ and sin θ of its heading (the caller has them).
 * @param o     the circle: centre, velocity, radius.
 * @param side  side held.
 * @param v     the linear velocity the robot is given [m/s].
 * @param[out] w angular velocity [rad/s]: β̇ + k2 e.
 * @param[out] e heading error wrap(β − θ) [rad].
 */
void avd_turn(const avd_gains_t *g, const pose_t *robot, num_t cos_th, num_t sin_th,
              const avd_obstacle_t *o, avd_side_t side, num_t v, num_t *w, num_t *e);

#endif /* MSTC_AVD_H */
