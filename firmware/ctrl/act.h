/* SPDX-License-Identifier: MIT */
/**
 * @file act.h
 * @brief What the "mstc" strategy knows of its wheels (docs/strategy.md,
 *        "Real wheels"): the rate limiter on its wheel commands, the wheel
 *        speeds it expects now, and the time it takes to brake.
 *
 * The model the firmware assumes of each wheel (parameters wheel_accel a and
 * wheel_tau τ, ctl.h): its speed ω follows its command u at least as fast as
 * a first-order lag of τ (delays included), and can change by a per second.
 *
 * - **Rate limiter** (act_limit()): a command differs from the previous one
 *   by at most a·dt on each wheel; when one wheel would change more, both
 *   changes are scaled by one factor, so the change keeps its direction in
 *   wheel space and a wheel that saturates does not bend the heading (the
 *   per-wheel speed limiter of ros2_control's diff_drive_controller, issue
 *   #470, with a common factor).
 * - **Estimate** (act_estimate()): the wheel speeds now. Measured
 *   (WHEEL_SPEED: each wheel's mean speed over the period that just ended)
 *   when the step has them; otherwise predicted from the commands by the
 *   lag, in its implicit-Euler form ω ← (τ ω + dt u) / (τ + dt) with u the
 *   command that was in force over the period (exact in the limits τ → 0 and
 *   τ → ∞, never overshooting).
 * - **Braking time** (act_brake_time()): braking along the path, the
 *   commands ramp down by one factor at a on the faster wheel, so every
 *   speed of the robot falls linearly to zero in T_s = max|u| / a and the
 *   distance still covered is the speed times T_s / 2; a command held for
 *   the period before the ramp starts adds half a period (the ramp's first
 *   command is already a·dt lower). The filter uses T_b = (T_s + dt) / 2.
 */
#ifndef MSTC_ACT_H
#define MSTC_ACT_H

#include <stdbool.h>
#include <stddef.h>

#include "ctrl/pose.h"
#include "kin/kin.h"
#include "num/num.h"

/** @brief Longest period the rate limiter and the estimate take [s]: a longer
 *         gap between two steps (a time jump) counts as this one. */
#define ACT_MAX_DT NUM_C(0.1)

/** @brief Share of the wheels' acceleration the control laws may ask for
 *         (ctl.c): the rest is for the lag and for the safety filter. */
#define ACT_LAW_SHARE NUM_C(0.5)

/** @brief A pose carried forward (act_predict()), with cos and sin of its heading. */
typedef struct {
    pose_t p;
    num_t c, s;
} act_pose_t;

/** @brief What a parameter set gives, computed once (act_configure()). */
typedef struct {
    num_t inv_accel;  /**< 1 / wheel_accel [s²/rad] */
    num_t inv_av;     /**< 1 / (r wheel_accel): a speed's braking time per m/s [s²/m] */
    num_t law_accel;  /**< ACT_LAW_SHARE × r a: the laws' linear acceleration [m/s²] */
    num_t gamma;      /**< ACT_LAW_SHARE × 2 r a / L: their angular acceleration [rad/s²] */
    num_t sqrt_gamma; /**< sqrt(gamma) [rad/s] */
    num_t side;       /**< min(1, 2 l / L): the share of r a a point l ahead of the
                           axle can accelerate across the heading (cbf.c) */
    num_t inv_side;   /**< 1 / side */
} act_limits_t;

/** @brief The wheels as the firmware knows them. */
typedef struct {
    kin_wheels_t cmd; /**< the last command sent [rad/s]: the rate limiter's base */
    kin_wheels_t est; /**< the wheel speeds estimated at the last step [rad/s] */
    act_limits_t lim; /**< of the parameters in force */
} act_t;

/** @brief Standstill: commands and estimate zero (a->lim untouched). */
void act_init(act_t *a);

/** @brief The constants of the wheels' parameters (@p kin, @p accel =
 *         wheel_accel > 0) and of the point @p lever ahead of the axle that
 *         the safety filter steers (> 0) into a->lim: once per parameter
 *         set. */
void act_configure(act_t *a, const kin_params_t *kin, num_t accel, num_t lever);

/** @brief The wheels were commanded @p w by someone else (a halt's ramp):
 *         the next command starts from there, and so does the estimate. */
void act_sync(act_t *a, const kin_wheels_t *w);

/**
 * @brief The wheel speeds now, into a->est.
 * @param a   state: a->cmd is the command in force over the last period.
 * @param tau wheel_tau [s], >= 0.
 * @param dt  the period since the last step [s], in [0, ACT_MAX_DT].
 * @param meas the measured speeds (each wheel's mean over the last period), or NULL.
 */
void act_estimate(act_t *a, num_t tau, num_t dt, const kin_wheels_t *meas);

/** @brief The lag's factor τ / (τ + dt) of act_estimate() (0 when both are
 *         0): what act_estimate_lag() takes. */
num_t act_lag(num_t tau, num_t dt);

/** @brief act_estimate() with its factor @p k = act_lag(tau, dt) computed by
 *         the caller (ctl.c keeps it from one period to the next). */
static inline void act_estimate_lag(act_t *a, num_t k, const kin_wheels_t *meas)
{
    if (meas != NULL) {
        a->est = *meas;
        return;
    }
    a->est.left = num_add(a->cmd.left, num_mul(num_sub(a->est.left, a->cmd.left), k));
    a->est.right = num_add(a->cmd.right, num_mul(num_sub(a->est.right, a->cmd.right), k));
}

/**
 * @brief Rate-limit the command @p w against a->cmd, then store it as a->cmd.
 * @param a     state.
 * @param step  a·dt, the most a wheel may change this period [rad/s], >= 0:
 *        wheel_accel times the period since the last step (in [0,
 *        ACT_MAX_DT]), num_mul_period() of it (ctl.c).
 * @param[in,out] w the command [rad/s]: unchanged when within a·dt of a->cmd
 *        on both wheels, else a->cmd + k (w − a->cmd) with the largest
 *        k in [0, 1) that keeps both within.
 * @retval true @p w was limited.
 */
static inline bool act_limit(act_t *a, num_t step, kin_wheels_t *w)
{
    const num_t dl = num_sub(w->left, a->cmd.left);
    const num_t dr = num_sub(w->right, a->cmd.right);
    const num_t most = num_max(num_abs(dl), num_abs(dr));
    bool limited = false;
    if (most > step) {
        /* most > step >= 0: the factor lies in [0, 1). */
        const num_t k = num_div(step, most);
        w->left = num_add(a->cmd.left, num_mul(k, dl));
        w->right = num_add(a->cmd.right, num_mul(k, dr));
        limited = true;
    }
    a->cmd = *w;
    return limited;
}

/**
 * @brief The horizon over which the wheels' lag carries the robot on [s]:
 *        wheel_tau, plus the measurement's age when the speeds are measured:
 *        @p age when one is given (> 0: a board's own wheel loop, from the
 *        middle of its speed window to the step, app.h), else half the
 *        period @p dt (WHEEL_SPEED: a period's mean is half a period old).
 */
static inline num_t act_horizon(num_t tau, num_t dt, num_t age, bool measured)
{
    if (!measured) {
        return tau;
    }
    return num_add(tau, age > NUM_ZERO ? age : num_mul(dt, NUM_C(0.5)));
}

/* The rotation of act_predict() (in this header, as the functions below it:
 * each runs once a step in ctl.c, where inline they cost 28 instructions a
 * step fewer on the M4F's load-8 scene, make bench): out->c, out->s;
 * returns δ = ωt. */
static inline num_t act_rotate(num_t c0, num_t s0, num_t w, num_t t, act_pose_t *out)
{
    const num_t d = num_mul(w, t);
    const num_t d2 = num_mul(d, d);
    const num_t cd = num_sub(NUM_ONE, num_mul(d2, NUM_C(0.5)));
    const num_t sd = num_mul(d, num_sub(NUM_ONE, num_mul(d2, NUM_C(1.0 / 6.0))));
    out->c = num_sub(num_mul(c0, cd), num_mul(s0, sd));
    out->s = num_add(num_mul(s0, cd), num_mul(c0, sd));
    return d;
}

/**
 * @brief The pose @p p0 (cos and sin of its heading @p c0, @p s0) carried
 *        over @p t seconds at constant (v, ω): heading θ + ωt, position along
 *        the heading half-way through the turn; the new heading's cos and sin
 *        by rotating @p c0, @p s0 by δ = ωt with cos δ ≈ 1 − δ²/2,
 *        sin δ ≈ δ − δ³/6 (no trigonometric call; error below δ⁴/24, 1 % of
 *        the rotation at δ = 0.5 rad), the mid heading to first order.
 */
static inline void act_predict(const pose_t *p0, num_t c0, num_t s0, num_t v, num_t w, num_t t,
                               act_pose_t *out)
{
    const num_t d = act_rotate(c0, s0, w, t, out);
    const num_t hd = num_mul(d, NUM_C(0.5));
    const num_t l = num_mul(v, t);
    out->p.x = num_add(p0->x, num_mul(l, num_sub(c0, num_mul(s0, hd))));
    out->p.y = num_add(p0->y, num_mul(l, num_add(s0, num_mul(c0, hd))));
    out->p.theta = num_add(p0->theta, d);
}

/** @brief The heading of act_predict() alone, from heading @p theta: out->c,
 *         out->s and out->p.theta as act_predict() gives them (out->p.x and
 *         out->p.y are not written). */
static inline void act_predict_heading(num_t theta, num_t c0, num_t s0, num_t w, num_t t,
                                       act_pose_t *out)
{
    out->p.theta = num_add(theta, act_rotate(c0, s0, w, t, out));
}

/**
 * @brief T_b = (max(|u_L|, |u_R|) / accel + dt) / 2 [s]: how long, in
 *        distance, the speeds of the command @p u still carry the robot
 *        when it brakes along its path from the next step (the file's
 *        comment). @p inv_accel is 1 / accel (act_limits_t).
 */
static inline num_t act_brake_time(const kin_wheels_t *u, num_t inv_accel, num_t dt)
{
    const num_t top = num_max(num_abs(u->left), num_abs(u->right));
    return num_mul(num_add(num_mul(top, inv_accel), dt), NUM_C(0.5));
}

#endif /* MSTC_ACT_H */
