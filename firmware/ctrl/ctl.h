/* SPDX-License-Identifier: MIT */
/**
 * @file ctl.h
 * @brief The control step: supervisor, the active controller, kinematics.
 *
 * One call per control period. No clock reads, no heap, no platform headers:
 * time comes in as an argument and the caller owns every buffer.
 */
#ifndef MSTC_CTL_H
#define MSTC_CTL_H

#include <stddef.h>
#include <stdint.h>

#include "ctrl/act.h"
#include "ctrl/avd.h"
#include "ctrl/cbf.h"
#include "ctrl/ctl_limits.h"
#include "ctrl/msw.h"
#include "ctrl/sup.h"
#include "ctrl/trk.h"
#include "kin/kin.h"
#include "wheel/whl.h"

/** @brief Values of ctl_params_t::strategy (the DBC's value table Strategy). */
enum {
    CTL_STRATEGY_PAPER = 0, /**< the paper's switch strategy, exactly (sup.h) */
    CTL_STRATEGY_MSTC = 1,  /**< the safe strategy: msw.h, cbf.h (docs/strategy.md) */
};

/**
 * @brief Every parameter PARAM_SET sets: Table 1, the wheel geometry, the
 *        deceleration of a halt, the switch strategy and the wheel loop's.
 *        Their limits are one table, ctl_params.toml (docs/safety.md,
 *        "Parameters").
 */
typedef struct {
    num_t r_m;   /**< robot radius R_m [m] */
    num_t r_ob;  /**< default obstacle radius R_ob [m] */
    num_t d_det; /**< sensor range D_det [m]: centre distance at which an obstacle of radius
                      R_ob is detected; one of radius r at D_det + r - R_ob */
    num_t d_act; /**< activation distance D_act [m] */
    num_t d_s;   /**< safe distance D_s [m] */
    trk_gains_t trk;
    avd_gains_t avd;
    kin_params_t kin;
    /** Wheel deceleration of a halt [rad/s²]: not used by the control step
     *  but by the application's ramp (app.h); in the set because its bound
     *  depends on kin.max_wheel_speed. */
    num_t max_wheel_decel;
    /** CTL_STRATEGY_PAPER or CTL_STRATEGY_MSTC, held as a number like every
     *  parameter the table checks (an enumerated one: a whole number). */
    num_t strategy;
    /** What the wheels can do [rad/s²]: "mstc" changes no wheel command
     *  faster (act.h) and brakes with it in its safety filter (cbf.h); the
     *  boards' wheel loop ramps its setpoint at it (whl.h). */
    num_t wheel_accel;
    /** The wheels' lag to their command, delays included [s] (act.h). */
    num_t wheel_tau;
    /** The boards' wheel-speed loop (firmware/wheel, PARAM_SET 17..25): not
     *  used by the control step; in the set for its checks. */
    whl_params_t wheel;
} ctl_params_t;

/** @brief Operators of a relation between parameters. */
typedef enum {
    CTL_REL_GE = 0, /**< lhs >= rhs */
    CTL_REL_LT = 1, /**< lhs < rhs */
    CTL_REL_LE = 2, /**< lhs <= rhs */
} ctl_rel_op_t;

/** @brief The limits of one parameter: a row of ctl_params.toml. */
typedef struct {
    num_t min;        /**< smallest value accepted */
    num_t max;        /**< largest value accepted */
    num_t def;        /**< default (ctl_params_default) */
    bool held;        /**< ctl_params_t holds it (false: not yet; PARAM_SET answers
                           unknown_index) */
    bool control_law; /**< it changes what the controller commands: accepted
                           only while not armed (app.h) */
    bool integer;     /**< an enumerated parameter: a whole number in [min, max] */
} ctl_limit_t;

/** @brief A relation: p[lhs] op factor · (p[rhs[0]] + p[rhs[1]]), with the
 *         term rhs[1] absent when it is CTL_P_NONE. */
typedef struct {
    uint8_t lhs;    /**< CTL_P_* */
    uint8_t op;     /**< ctl_rel_op_t */
    num_t factor;   /**< > 0 */
    uint8_t rhs[2]; /**< CTL_P_*, or CTL_P_NONE for the second */
} ctl_relation_t;

/** @brief The limits of every parameter, by index (ctl_limits.c, generated). */
extern const ctl_limit_t ctl_limits[CTL_N_PARAMS];
/** @brief The relations, in the order they are checked (ctl_limits.c). */
extern const ctl_relation_t ctl_relations[CTL_N_RELATIONS];

/** @brief What ctl_params_verdict() found. */
typedef enum {
    CTL_PARAMS_OK = 0,       /**< every value in its range, every relation holds */
    CTL_PARAMS_RANGE = 1,    /**< a value is non-finite or outside its range */
    CTL_PARAMS_RELATION = 2, /**< the values are in range but a relation fails */
} ctl_params_verdict_t;

/** @brief Status bits in ctl_status_t::faults. */
enum {
    CTL_FAULT_INPUT_NONFINITE = 1u << 0,  /**< a pose or velocity was NaN, inf or out of
                                               range: robot stopped */
    CTL_FAULT_OBSTACLE_DROPPED = 1u << 1, /**< an obstacle report was rejected (see sup_step) */
    CTL_FAULT_SATURATED = 1u << 2,        /**< wheel speeds were scaled to the limit */
    CTL_FAULT_OUTPUT_INVALID = 1u << 3,   /**< the wheel speeds came out non-finite or beyond
                                               the limit: zero instead (a defence that the
                                               ranges below should make unreachable; not
                                               on the wire) */
    CTL_FAULT_FILTER = 1u << 4,           /**< "mstc": the safety filter changed the command
                                               this step (cbf.h) */
};

/** @name Ranges of the step's inputs (docs/safety.md). Within them and the
 * parameters' (ctl_limits[]) no intermediate of the control laws overflows a
 * float, so every output is finite; outside them a step stops
 * (CTL_FAULT_INPUT_NONFINITE), an obstacle report is dropped. All are within
 * Q16.16's range too. @{ */
#define CTL_MAX_ABS_POSITION    NUM_C(10000.0) /**< |x|, |y| of poses and obstacles [m] */
#define CTL_MAX_ABS_ANGLE       NUM_C(1000.0)  /**< |θ| [rad], wrapped by the controllers */
#define CTL_MAX_ABS_SPEED       NUM_C(100.0) /**< |v_r| [m/s], |ω_r| [rad/s], obstacle |vx|, |vy| */
#define CTL_MAX_RADIUS          NUM_C(100.0)  /**< obstacle radius [m] */
#define CTL_MAX_ABS_WHEEL_SPEED NUM_C(1000.0) /**< measured wheel speeds [rad/s] */
#define CTL_MAX_WHEELS_AGE      NUM_C(1.0)    /**< their age, in [0, 1) [s] */
/** @} */

/** @brief Inputs of one step. */
typedef struct {
    pose_t robot;                    /**< measured robot pose */
    pose_t ref;                      /**< reference pose */
    num_t v_r;                       /**< reference linear velocity [m/s] */
    num_t w_r;                       /**< reference angular velocity [rad/s] */
    const sup_obstacle_t *obstacles; /**< obstacles the sensor reports now */
    size_t n_obstacles;
    uint64_t t_us; /**< step time [µs] */
    /** Measured wheel speeds [rad/s], when wheels_measured: from the bus
     *  (WHEEL_SPEED: each wheel's mean over the period that just ended), or
     *  a board's own wheel loop (app.h); "mstc" predicts them from its own
     *  commands otherwise (act.h). */
    kin_wheels_t wheels;
    bool wheels_measured;
    /** How old wheels is [s]: from the middle of the time it averages to
     *  t_us (a board's own wheel loop: half its speed window, and the time
     *  since its last period); 0: half the period (WHEEL_SPEED's). */
    num_t wheels_age;
} ctl_input_t;

/** @brief What the step did, for telemetry. ctl_step() clears it member by
 *         member (no memset on a Cortex-M): a member added here is cleared
 *         there too. obstacle_id[] and distance[] hold n_obstacles entries;
 *         the ones past them are not written (whatever the caller's buffer
 *         held stays). */
typedef struct {
    sup_mode_t mode;
    uint8_t active_obstacle; /**< id of the obstacle avoided (followed, "mstc"), 0 when none */
    avd_side_t side;         /**< its side */
    trk_err_t err;           /**< e1, e2, e3 */
    num_t e;                 /**< avoidance heading error [rad], 0 unless avoiding */
    num_t v;                 /**< commanded linear velocity after saturation [m/s] */
    num_t w;                 /**< commanded angular velocity after saturation [rad/s] */
    uint8_t faults;          /**< CTL_FAULT_* bits of this step */
    uint8_t n_obstacles;     /**< obstacles remembered: entries of the two below */
    uint8_t obstacle_id[SUP_MAX_OBSTACLES]; /**< id of each table entry */
    num_t distance[SUP_MAX_OBSTACLES];      /**< centre distance to each [m] */
} ctl_status_t;

/** @brief Outputs of one step. */
typedef struct {
    kin_wheels_t wheels; /**< wheel angular speed commands [rad/s] */
    ctl_status_t status;
    sup_event_t events[SUP_MAX_EVENTS];
    size_t n_events;
} ctl_output_t;

/** @brief What "mstc" keeps so as not to compute it again (ctl.c): each value
 *         is what the same operations on the same operands gave, so the
 *         results of a step never depend on whether it was kept. Forgotten
 *         whenever what it depends on may change (parameters, act.cmd). */
typedef struct {
    num_t cmd_v, cmd_w; /**< kin_vw_from_wheels() of act.cmd */
    num_t lag_k;        /**< act_lag(wheel_tau, dt) for the period of key period_us */
    num_t turn_k3v;     /**< k3 |v_r| for which turn_most holds */
    num_t turn_most;    /**< 2γ' / (k3 |v_r|): the tracking turn's bound */
    num_t avoid_most;   /**< 2γ' / k2: the avoidance turn's bound */
    num_t dt;           /**< the period of dt_us microseconds [s] (step_dt()) */
    num_t step;         /**< wheel_accel × dt for the period of key period_us */
    uint64_t dt_us;     /**< [µs] */
    uint64_t period_us; /**< the period's key (ctl.c, step_dt()) */
    bool cmd_known;     /**< cmd_v, cmd_w hold */
    bool dt_known;      /**< dt holds */
    bool period_known;  /**< lag_k and step hold */
    bool turn_known;    /**< turn_most holds */
} ctl_memo_t;

/** @brief Controller state. */
typedef struct {
    ctl_params_t p;
    sup_t sup;          /**< obstacle table; the paper's switch strategy */
    msw_t msw;          /**< the "mstc" switch strategy */
    cbf_t cbf;          /**< the "mstc" safety filter */
    act_t act;          /**< the "mstc" wheels: rate limiter base and estimate */
    ctl_memo_t memo;    /**< values "mstc" keeps (ctl_memo_t) */
    uint64_t last_t_us; /**< time of the last step [µs] */
    bool stepped;       /**< a step has run since init or reset */
    uint8_t filtered;   /**< id the filter changed the last step's command for, or 0 */
} ctl_t;

/** @brief The period the first "mstc" step assumes [s]: the inputs' DBC cycle
 *         time (the period before it is unknown). */
#define CTL_FIRST_DT NUM_C(0.02)
/** @brief CTL_FIRST_DT in microseconds. */
#define CTL_FIRST_US 20000u

/** @brief The defaults of the table: Table 1, with wheel geometry that never
 *         saturates in the paper's scenarios (r = 0.05 m, L = 0.3 m,
 *         100 rad/s), a halt's deceleration of 125 rad/s² and the "mstc"
 *         strategy (the board images' default; the paper's scenario files
 *         select "paper"). */
void ctl_params_default(ctl_params_t *p);

/**
 * @brief The member of @p p behind parameter index @p index (CTL_P_*), or
 *        NULL for an index that is unknown or not held yet (generated with
 *        the table, ctl_limits.c).
 */
num_t *ctl_param_slot(ctl_params_t *p, unsigned index);

/**
 * @brief Check a whole parameter set against the table: first every value
 *        held, in index order, finite and within [min, max]; then every
 *        relation, in order (docs/safety.md, "Parameters"). The values are
 *        checked as held, after rounding to num_t.
 */
ctl_params_verdict_t ctl_params_verdict(const ctl_params_t *p);

/**
 * @brief ctl_params_verdict() as an error code.
 * @retval 0       valid.
 * @retval -EINVAL a value is out of range or a relation fails.
 */
int ctl_params_check(const ctl_params_t *p);

/**
 * @brief Initialise the controller.
 * @retval 0       ready.
 * @retval -EINVAL @p p fails ctl_params_check(); @p c is then left reset with
 *                 default parameters, so a step stays safe.
 */
int ctl_init(ctl_t *c, const ctl_params_t *p);

/**
 * @brief Replace the parameters, keeping the supervisor's state (obstacles,
 *        mode, side), as when a board is tuned over the bus. A change of
 *        strategy restarts the "mstc" strategy and filter in tracking.
 * @retval 0 applied. @retval -EINVAL rejected by ctl_params_check(); nothing
 *         changes.
 */
int ctl_set_params(ctl_t *c, const ctl_params_t *p);

/** @brief Forget obstacles and return to tracking. */
void ctl_reset(ctl_t *c);

/** @brief The wheels were commanded @p w without the control step (the
 *         application's halt ramp): "mstc"'s next command starts from
 *         there (act_sync()). */
void ctl_sync_wheels(ctl_t *c, const kin_wheels_t *w);

/**
 * @brief One control step, with the strategy of the parameters: "paper"
 *        (sup_step(), then the active controller and kinematics, exactly as
 *        the paper) or "mstc" (msw_step(), the active controller, kinematics,
 *        then the safety filter cbf_step() after wheel saturation, and the
 *        saturation again). Total: never fails, and the wheel speeds are
 *        always finite and within ±max_wheel_speed. A non-finite or
 *        out-of-range pose or velocity gives zero wheel speeds, mode STOP and
 *        CTL_FAULT_INPUT_NONFINITE, and leaves the supervisor untouched. An
 *        obstacle report with a non-finite or out-of-range value is dropped
 *        (counted by the supervisor, CTL_FAULT_OBSTACLE_DROPPED); reports
 *        beyond SUP_MAX_OBSTACLES are dropped too. "paper" ignores obstacle
 *        velocities; "mstc" drops a report whose velocity is out of range.
 */
void ctl_step(ctl_t *c, const ctl_input_t *in, ctl_output_t *out);

/**
 * @brief The factor on the avoidance's speed for a heading error e off the
 *        circle's direction ("mstc", docs/strategy.md "The turn first"):
 *        cos e / 0.7 when cos e < 0.7 (none below zero: a turn in place
 *        beyond a right angle), else 1. Not round a moving obstacle
 *        (@p moving) when the wheels' lag @p wheel_tau is within 2/α = 0.1 s,
 *        the time of motion the safety filter watches ahead: such wheels
 *        carry out its corrections, and slowing only holds the robot while
 *        the obstacle comes; slower wheels turn first round every obstacle.
 */
num_t ctl_turn_first(num_t cos_e, bool moving, num_t wheel_tau);

/**
 * @brief The largest correction of the tracking speed beyond v_r cos e3
 *        ("mstc", docs/strategy-wheels.md, step 2): sqrt(2 a |e1|),
 *        the speed an error e1 can be brought to zero from decelerating at
 *        a without overshoot (a braking curve). a is the laws' share
 *        @p law_accel = a' = ACT_LAW_SHARE r a; for a robot aligned with its
 *        reference (|e2| < 0.1 m, |sin e3| < 0.1 and cos e3 > 0: the errors
 *        @p e, @p cos_e3, @p sin_e3), whose turn corrections need little of
 *        the wheels, 1.5 a' = 0.75 r a: catching up after a detour, it brakes
 *        onto the reference later and arrives sooner.
 */
num_t ctl_most_speed(num_t law_accel, const trk_err_t *e, num_t cos_e3, num_t sin_e3);

/** @brief Whether @p p selects the "mstc" strategy (ctl_params_check() has
 *         made strategy a whole 0 or 1). */
static inline bool ctl_is_mstc(const ctl_params_t *p)
{
    return p->strategy == num_from_int((int32_t)CTL_STRATEGY_MSTC);
}

#endif /* MSTC_CTL_H */
