/* SPDX-License-Identifier: MIT */
/**
 * @file whl.h
 * @brief The wheel-speed loop: each wheel's speed measured from its encoder,
 *        held at the control step's wheel command by a PI controller with a
 *        feed-forward from the motor constant, driving hal_motor.
 *
 * One call of whl_step() per wheel period (whl_params_t::rate, 1 kHz by
 * default), from the board's main loop (never an interrupt). Per wheel:
 *
 * 1. **Speed** from the encoder's running count (hal_encoder.h): the count
 *    difference over the last W periods, W = window·rate (1..WHL_MAX_WINDOW),
 *    times 2π/(counts·W/rate). Chosen over a tracking loop (ODrive's PLL) by
 *    the measurement in docs/wheel.md: at 1,920 counts/rev and the same noise
 *    it lags less.
 * 2. **Setpoint ramp**: the command moves towards the control step's wheel
 *    speed by at most accel/rate a period (ODrive's vel_ramp_rate, VESC's
 *    s_pid_ramp_erpms_s), accel being what the wheels can do: the control
 *    step's wheel_accel (ctl.h), handed to whl_init() and whl_set_params()
 *    beside the loop's own parameters.
 * 3. **Drive** u = ω_sp/free_speed + kp·e + I, e = ω_sp − ω̂, clamped to
 *    [−1, 1] (full drive). The feed-forward term is the drive that holds
 *    ω_sp with no load (the motor constant: speed proportional to voltage).
 *    Anti-windup: I integrates ki·e/rate only while u is not saturated, or
 *    when e would bring it back (conditional integration), and is clamped to
 *    [−1, 1]: ODrive's controller.cpp stops integrating while limited and
 *    clamps (vel_integrator_limit); VESC's speed PID clamps its I term.
 * 4. **Release at standstill**: a zero setpoint with the wheel below one
 *    count per window gives u = 0 and I = 0 (VESC's s_pid_min_erpm), so a
 *    stopped robot does not hum.
 * 5. **Faults**, latched: a *stall* (|u| ≥ WHL_STALL_DRIVE and ω̂ below
 *    WHL_STALL_SPEED in the drive's direction, for stall_time: a wheel that
 *    barely creeps under its load, or an encoder that counts backwards), a
 *    *dead encoder* (|u| ≥ WHL_DEAD_DRIVE in one direction for WHL_DEAD_TIME
 *    without a single count: dead from the start, dead while turning, or a
 *    wheel held so rigidly that it does not turn) and an *implausible
 *    encoder* (more counts in a period than WHL_MAX_SPEED_FACTOR times the
 *    free speed gives). Any stops both wheels (u = 0) until
 *    whl_clear_faults(): a robot with one wheel driven turns on the spot.
 *
 * Both numeric modes (num.h). No clock, no heap: the period is the
 * parameter rate, the caller keeps the time.
 */
#ifndef MSTC_WHL_H
#define MSTC_WHL_H

#include <stdbool.h>
#include <stdint.h>

#include "num/num.h"

/** @brief Wheels: left, then right (as kin_wheels_t). */
#define WHL_N 2u

/** @brief Longest speed window [periods]. */
#define WHL_MAX_WINDOW 32u

/** @name Fault thresholds (docs/wheel.md, "Faults"). @{ */
/** Full drive, for a stall: |u| at least this. */
#define WHL_STALL_DRIVE      NUM_C(0.95)
/** No motion, for a stall: |ω̂| below this [rad/s] (3 % of the default
 *  motor's free speed). */
#define WHL_STALL_SPEED      NUM_C(1.0)
/** Drive, for a dead encoder: |u| at least this, in one direction. */
#define WHL_DEAD_DRIVE       NUM_C(0.25)
/** ... for this long without a count [s]: a quarter of full drive moves a
 *  healthy wheel by many counts within it (docs/wheel.md). */
#define WHL_DEAD_TIME        NUM_C(0.1)
/** Counts a period beyond this many times the free speed's are implausible:
 *  the wheel cannot turn that fast, even driven by the robot's motion. */
#define WHL_MAX_SPEED_FACTOR NUM_C(2.0)
/** @} */

/** @brief Fault bits (whl_t::faults, WHEEL_SPEED's fault field). */
enum whl_fault {
    WHL_FAULT_STALL_LEFT = 1u << 0,   /**< left wheel stalled */
    WHL_FAULT_STALL_RIGHT = 1u << 1,  /**< right wheel stalled */
    WHL_FAULT_ENCODER_LEFT = 1u << 2, /**< left encoder dead or implausible */
    WHL_FAULT_ENCODER_RIGHT = 1u << 3 /**< right encoder dead or implausible */
};

/**
 * @brief The wheel loop's own parameters (PARAM_SET indexes 17..25, the rows
 *        wheel_* of firmware/ctrl/ctl_params.toml, which hold their ranges
 *        and defaults: the Pololu 37D 30:1 gearmotor of docs/wheel.md). Its
 *        setpoint ramp is not among them: it is what the wheels can do, the
 *        control step's wheel_accel, one parameter for one fact.
 */
typedef struct {
    num_t kp;         /**< proportional gain [drive per rad/s] */
    num_t ki;         /**< integral gain [drive per rad] */
    num_t free_speed; /**< wheel speed at full drive, no load [rad/s]: the feed-forward */
    num_t motor_tau;  /**< mechanical time constant of the loaded motor, open loop [s]:
                           the acceleration feed-forward */
    num_t counts;     /**< encoder counts per wheel revolution (×4 quadrature) */
    num_t rate;       /**< loop rate [Hz] */
    num_t window;     /**< speed window [s] */
    num_t stall_time; /**< full drive without motion for this long is a stall [s] */
} whl_params_t;

/** @brief State of one wheel. */
typedef struct {
    int32_t hist[WHL_MAX_WINDOW];  /**< running counts of the last periods, a ring */
    num_t speed;                   /**< speed estimate ω̂ [rad/s] */
    num_t setpoint;                /**< ramped setpoint [rad/s] */
    num_t sp_hist[WHL_MAX_WINDOW]; /**< ramped setpoints of the last periods, a ring */
    num_t sp_sum;                  /**< their sum over the speed window */
    num_t integ;                   /**< integral term I [drive] */
    num_t drive;                   /**< drive u of the last step, [−1, 1] */
    uint16_t stall_periods;        /**< periods in the stall condition */
    uint16_t dead_periods;         /**< periods in a row driven one way without a count */
    bool dead_fwd;                 /**< ... the way they were driven */
} whl_wheel_t;

/** @brief The loop: both wheels and what the parameters give. */
typedef struct {
    whl_params_t p;
    num_t accel; /**< setpoint ramp [rad/s²] (wheel_accel) */
    whl_wheel_t w[WHL_N];
    uint8_t head;          /**< ring index of the latest count */
    uint8_t window;        /**< W [periods] */
    bool primed;           /**< a count has been read */
    uint8_t faults;        /**< WHL_FAULT_* bits, latched */
    num_t speed_per_count; /**< 2π·rate/(counts·W) [rad/s per count of the window] */
    num_t inv_window;      /**< 1/W */
    num_t inv_free_speed;  /**< 1/free_speed */
    num_t accel_ff;        /**< rate·motor_tau/free_speed [drive per rad/s of ramp step] */
    num_t ramp_step;       /**< accel/rate [rad/s] */
    num_t ki_dt;           /**< ki/rate [drive per rad/s] */
    uint16_t stall_limit;  /**< stall_time·rate [periods] */
    uint16_t dead_limit;   /**< WHL_DEAD_TIME·rate [periods] */
    int32_t max_step;      /**< most counts a period can bring */
} whl_t;

/** @brief What one step takes. */
typedef struct {
    num_t setpoint[WHL_N]; /**< wheel speeds wanted [rad/s], positive forward */
    int32_t count[WHL_N];  /**< encoders' running counts (hal_encoder_read()) */
} whl_input_t;

/** @brief What one step gives. */
typedef struct {
    num_t drive[WHL_N]; /**< drive u, [−1, 1] */
    int16_t cmd[WHL_N]; /**< the same for hal_motor_set(): ±HAL_MOTOR_FULL_SCALE */
    num_t speed[WHL_N]; /**< measured speeds ω̂ [rad/s] */
    uint8_t faults;     /**< WHL_FAULT_* bits in force */
} whl_output_t;

/**
 * @brief Start at rest with parameters @p p (which ctl_params_check() has
 *        accepted: every one positive, within its range) and the setpoint
 *        ramp @p accel [rad/s²] (wheel_accel, > 0).
 */
void whl_init(whl_t *w, const whl_params_t *p, num_t accel);

/**
 * @brief Take new parameters and ramp (as whl_init()), keeping the state
 *        (speeds, integrators, faults). Cheap enough to call every control
 *        period.
 */
void whl_set_params(whl_t *w, const whl_params_t *p, num_t accel);

/** @brief Forget the faults (a re-arm): the wheels may be driven again. */
void whl_clear_faults(whl_t *w);

/** @brief Latch faults found outside the loop: @p faults (WHL_FAULT_* bits),
 *         such as an encoder its driver could not read (hal_encoder.h), as
 *         the loop's own until whl_clear_faults(); the next whl_step() stops
 *         both wheels. */
void whl_latch_faults(whl_t *w, uint8_t faults);

/** @brief Period [µs] of the loop at the parameters' rate, rounded. */
uint32_t whl_period_us(const whl_params_t *p);

/**
 * @brief Age of the speed estimate at the period it was made [µs]: half its
 *        window (W periods), the middle of the time it averages. A caller
 *        that uses it later adds the time since that period.
 */
uint32_t whl_age_us(const whl_t *w);

/**
 * @brief One period. Total: a non-finite setpoint counts as 0; a count that
 *        jumps is taken as it comes (the caller reads the encoders at least
 *        as often as hal_encoder.h requires).
 */
void whl_step(whl_t *w, const whl_input_t *in, whl_output_t *out);

/** @brief The drive @p u ∈ [−1, 1] as a hal_motor command, rounded. */
int16_t whl_motor_cmd(num_t u);

#endif /* MSTC_WHL_H */
