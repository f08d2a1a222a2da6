/* SPDX-License-Identifier: MIT */
/**
 * @file app.h
 * @brief The firmware application: receives the protocol's frames through the
 *        HAL, runs the control step, and sends wheel commands and telemetry.
 *
 * Lock-step (the simulator owns time): the plant sends ODOM_XY, ODOM_THETA,
 * REF_XY, REF_MOTION, OBSTACLE×n and then STEP; on STEP the firmware runs one
 * control step on the latest inputs, stamped with STEP's time, and answers
 * EVENT×n, STATUS, STATUS_TRK and last WHEEL_CMD echoing STEP's step.
 *
 * Real-time (boards): inputs arrive at their own pace; app_control_tick() runs
 * the control step on the caller's timer with the latest inputs.
 *
 * Safety supervisor (docs/safety.md): the wheels follow the controller only
 * while the application is armed and every input the step needs is valid:
 * odometry (ODOM_XY, ODOM_THETA) and reference (REF_XY, REF_MOTION), and in
 * lock-step the STEP frame; valid means its E2E window state machine is VALID
 * (comm.h) and an accepted frame arrived within the last APP_TIMEOUT_PERIODS
 * control steps and APP_TIMEOUT_US. Otherwise, and on CAN bus-off, the
 * application halts: it stops running the controller, ramps the wheel speeds
 * down to zero at the max_wheel_decel in force when the halt began, and
 * reports the reason in STATUS_halt. The halt latches until re-armed
 * (PARAM_SET index COMM_PARAM_ARM, value 1), which is accepted only while
 * odometry and reference are valid and each of their frames had
 * APP_REARM_FRAMES good frames in a row. It starts halted
 * (COMM_HALT_NOT_ARMED). The time base is the STEP time in lock-step and the
 * caller's now_us in real-time mode.
 *
 * Parameters (PARAM_SET, docs/safety.md "Parameters"): a value is taken as
 * the firmware will hold it (num_from_float) and the whole set that would
 * result is checked against the limits table (ctl_params_verdict): a
 * non-finite value or one outside its range is answered out_of_range, a set
 * that breaks a relation rejected, and nothing changes. While armed, a
 * parameter of the control law is answered armed and not changed; only
 * max_wheel_decel may change then.
 *
 * Authenticated commands (auth.h; docs/safety.md, "Threat model"): a
 * PARAM_SET (parameters and the arm command) is held until the PARAM_AUTH
 * that follows it, and acted on only when that verifies under the key given
 * by app_set_key(), for the current challenge of this start's session. One
 * without its PARAM_AUTH (another PARAM_SET first, or APP_AUTH_PENDING_STEPS
 * control steps), under another key, for another challenge (replayed,
 * recorded before a reset, stale) or while locked is answered
 * COMM_PARAM_UNAUTHENTICATED and counted. Every decision uses the challenge
 * up; one unused for APP_AUTH_CHALLENGE_US is replaced (expired). The status
 * (AUTH_STATUS and AUTH_CHALLENGE, which authenticates both) follows every
 * PARAM_VALUE and every refusal, and goes with HEARTBEAT. Without a key
 * every PARAM_SET is refused.
 *
 * Odometry plausibility (odo.h): while running, odometry that disagrees with
 * the motion commanded (a replayed recording, a stuck sensor) halts with
 * COMM_HALT_ODOMETRY_IMPLAUSIBLE.
 *
 * Measured wheel speeds come from one of two places, the port's choice
 * (app_set_wheel_source(); docs/wheel.md, "Two topologies"):
 * - external drives (APP_WHEELS_EXTERNAL, the default): WHEEL_SPEED frames,
 *   optional. A step on which one arrived hands it to the control step,
 *   which otherwise predicts the wheel speeds from its own commands
 *   (ctrl/act.h). Once the input has been valid (its E2E state machine
 *   VALID, fresh) at a step, it is watched like odometry: not valid or timed
 *   out (APP_TIMEOUT_PERIODS, APP_TIMEOUT_US) while the wheels move
 *   (commanded or measured speed not zero), it halts with
 *   COMM_HALT_WHEEL_SPEED; standing, it does not.
 * - the integrated board (APP_WHEELS_OWN): the port's own wheel loop hands
 *   its encoder estimate and its age before every control step
 *   (app_wheels_measured()), and the step takes that; WHEEL_SPEED frames are
 *   not its input (ignored). A step without one while the wheels move halts
 *   with COMM_HALT_WHEEL_SPEED, and every step sends what was measured, with
 *   the faults, as WHEEL_SPEED (first of the step's frames).
 * Either way a wheel fault the measurement reports (WHEEL_SPEED_faults: a
 * dead or implausible encoder, a stall) halts with COMM_HALT_WHEEL_SPEED.
 *
 * Every step's STATUS_TRK echoes the alive counter of the ODOM_XY frame whose
 * position the step used (STATUS_TRK_odom_counter), in both modes: in real
 * time the plant cannot know which of its frames a tick took, and the echo
 * tells it, so that it measures the latency from odometry to wheel command
 * exactly.
 */
#ifndef MSTC_APP_H
#define MSTC_APP_H

#include <stdbool.h>
#include <stdint.h>

#include "app/odo.h"
#include "auth/auth.h"
#include "comm/comm.h"
#include "ctrl/ctl.h"

/** @brief Period of HEARTBEAT and STATUS_COUNTERS [µs] (their DBC cycle time). */
#define APP_HOUSEKEEPING_PERIOD_US 100000u

/** @brief Nominal control period [µs]: the DBC cycle time of the inputs. */
#define APP_PERIOD_US       20000u
/** @brief An input not received for this many control steps halts the robot. */
#define APP_TIMEOUT_PERIODS 3u
/** @brief ... or for this long [µs]: APP_TIMEOUT_PERIODS nominal periods,
 *         whichever comes first. */
#define APP_TIMEOUT_US      60000u
/** @brief Good frames in a row each input frame needs before a re-arm. */
#define APP_REARM_FRAMES    5u
/** @brief Longest step interval the ramp uses [µs]; a longer one (a time
 *         jump) ramps as this one, and a shorter steps the robot down faster
 *         in time, never slower. */
#define APP_MAX_DT_US       1000000u

/** @brief Obstacle ids the 6-bit id of OBSTACLE and OBSTACLE_VEL can hold:
 *         0..63 (the DBC's range is 1..COMM_OBSTACLE_ID_MAX). */
#define APP_OBSTACLE_IDS 64u

/** @brief A PARAM_SET whose PARAM_AUTH has not come by the start of this many
 *         control steps after it is refused (2: one full period, whatever
 *         the phase of the tick). */
#define APP_AUTH_PENDING_STEPS 2u

/** @brief A challenge unused for this long is replaced at the next
 *         housekeeping [µs of the application's time] (so it is accepted at
 *         most this plus one housekeeping period and one control period after
 *         it was announced). */
#define APP_AUTH_CHALLENGE_US 500000u

/** @brief A PARAM_SET waiting for its PARAM_AUTH. */
typedef struct {
    bool waiting;
    uint8_t index;
    float value;
    uint8_t data[AUTH_DATA_LEN]; /**< PARAM_SET bytes 2..7, which the MAC covers */
    uint8_t steps;               /**< control steps begun since it arrived */
} app_pending_t;

/** @brief Inputs watched by the safety supervisor, in the order of app_t::in. */
enum {
    APP_IN_ODOM_XY = 0,
    APP_IN_ODOM_THETA,
    APP_IN_REF_XY,
    APP_IN_REF_MOTION,
    APP_IN_STEP,
    APP_IN_WHEEL_SPEED, /**< optional until the first frame (app_t::wheel_speed) */
    APP_N_IN,
};

/** @brief Where the control step's measured wheel speeds come from (app.h's
 *         file comment; docs/wheel.md, "Two topologies"). */
typedef enum {
    APP_WHEELS_EXTERNAL = 0, /**< external drives: WHEEL_SPEED frames (the default) */
    APP_WHEELS_OWN = 1,      /**< the integrated board: its own wheel loop */
} app_wheel_source_t;

/** @brief Freshness of one input frame. */
typedef struct {
    uint8_t missed;   /**< control steps since the last one with an accepted frame (saturating) */
    bool ever;        /**< an accepted frame was seen at a control step */
    uint64_t last_us; /**< time of the last control step with an accepted frame */
} app_input_t;

/** @brief Application state. */
typedef struct {
    ctl_t ctl;
    comm_t comm;
    pose_t odom; /**< latest robot pose */
    pose_t ref;  /**< latest reference pose */
    num_t v_r;   /**< latest reference velocities */
    num_t w_r;
    sup_obstacle_t reports[SUP_MAX_OBSTACLES]; /**< obstacles reported since the last step */
    uint8_t n_reports;
    /** OBSTACLE_VEL of each id (the frame's 6-bit id), vx then vy [m/s],
     *  set to zero by each OBSTACLE frame of the id: a report without one
     *  after it is a static obstacle (docs/protocol.md). */
    num_t obstacle_v[APP_OBSTACLE_IDS][2];
    uint16_t step;       /**< step of the last control step */
    uint32_t time_raw;   /**< last STEP time [µs], as sent (wraps at 2^32) */
    uint32_t time_wraps; /**< wraps of time_raw seen, for a 64-bit time */
    bool time_valid;
    bool frame_dropped; /**< a received frame was dropped since the last STATUS */
    comm_state_t state;
    uint64_t next_housekeeping_us;
    uint32_t steps;      /**< control steps run */
    kin_wheels_t wheels; /**< wheel speeds of the last control step [rad/s]; 0 before the first */
    uint8_t halt;        /**< comm_halt_t: latched reason, COMM_HALT_NONE while running */
    num_t ramp_decel;    /**< deceleration of the halt under way: max_wheel_decel when it
                              began [rad/s²] */
    app_input_t in[APP_N_IN];
    uint64_t last_step_us;  /**< time of the last control step */
    bool stepped;           /**< a control step has run */
    bool bus_off_known;     /**< bus_off_count holds a reading */
    uint32_t bus_off_count; /**< hal_can_status() bus_off at the last look */
    auth_t auth;            /**< key, session, challenge, refusals of authenticated commands */
    uint64_t now_us;        /**< the application's latest time: steps and housekeeping */
    uint64_t challenge_us;  /**< when the current challenge was issued */
    app_pending_t pending;  /**< PARAM_SET waiting for its PARAM_AUTH */
    odo_t odo;              /**< odometry plausibility */
    /** Alive counter of the ODOM_XY frame odom.x and odom.y came from (0
     *  before the first), echoed in STATUS_TRK. */
    uint8_t odom_counter;
    /** Latest measured wheel speeds [rad/s]: WHEEL_SPEED's (each wheel's mean
     *  over the sender's last period), handed to the control step when one
     *  arrived since the last step; or the own wheel loop's
     *  (app_wheels_measured()). */
    kin_wheels_t wheel_speed;
    /** app_wheel_source_t: where they come from. */
    uint8_t wheel_source;
    /** The wheel faults they came with (WHL_FAULT_* bits, WHEEL_SPEED_faults);
     *  forgotten at a re-arm. */
    uint8_t wheel_faults;
    /** APP_WHEELS_OWN: a measurement was handed since the last step ... */
    bool wheels_handed;
    /** ... of this age at the step [µs]. */
    uint32_t wheel_age_us;
    /** WHEEL_SPEED has been valid at a step (its E2E state machine VALID,
     *  fresh): from then on it is watched like odometry, until it times out
     *  while the wheels stand (then optional again, and wheel_speed zero). */
    bool wheel_speed_watched;
} app_t;

/**
 * @brief Initialise with parameters @p p (NULL: Table 1 defaults).
 * @retval 0 ready. @retval -EINVAL @p p rejected; the defaults are used.
 */
int app_init(app_t *a, const ctl_params_t *p);

/**
 * @brief Give the device key, at start (after app_init(), before the first
 *        frame): PARAM_SET is acted on only when authenticated under @p key
 *        for the current challenge of session @p session, a value for this
 *        start (hal_sys_boot_nonce(); docs/safety.md, "Sessions").
 */
void app_set_key(app_t *a, const uint8_t key[AUTH_KEY_LEN], uint32_t session);

/** @name The firmware's version and build id, answered in FW_VERSION
 *  (comm.h): the build defines them (mk/compile.mk: the package's version,
 *  the git commit's first 7 hex digits, whether the tree had changes). @{ */
#ifndef APP_VERSION_MAJOR
#define APP_VERSION_MAJOR 0u
#endif
#ifndef APP_VERSION_MINOR
#define APP_VERSION_MINOR 0u
#endif
#ifndef APP_VERSION_PATCH
#define APP_VERSION_PATCH 0u
#endif
#ifndef APP_BUILD_ID
#define APP_BUILD_ID 0u
#endif
#ifndef APP_BUILD_DIRTY
#define APP_BUILD_DIRTY 0u
#endif
/** The node id of a build that is not told another (make NODE=n). */
#ifndef APP_NODE
#define APP_NODE 0u
#endif
/** @} */

/**
 * @brief Set the node id (comm_set_node()): the board's identifiers are
 *        mstc.dbc's plus 0x100 times @p node. At start, after app_init()
 *        (which sets APP_NODE), before the first frame.
 * @retval 0 set.
 * @retval -EINVAL @p node above COMM_MAX_NODE: nothing changed.
 */
int app_set_node(app_t *a, uint8_t node);

/**
 * @brief Where the measured wheel speeds come from: the port's choice, once,
 *        at start (after app_init(), before the first frame). A board whose
 *        own wheel loop reads the encoders says APP_WHEELS_OWN; without a
 *        call, APP_WHEELS_EXTERNAL.
 */
void app_set_wheel_source(app_t *a, app_wheel_source_t source);

/**
 * @brief APP_WHEELS_OWN: the wheel loop's measurement, before a control step
 *        (the next one takes it): the speeds @p speed [rad/s] estimated at
 *        the loop's last period, its fault bits @p faults (WHL_FAULT_*), and
 *        the estimate's age @p age_us at the step [µs] (half its speed
 *        window, plus the time since that period). Ignored with
 *        APP_WHEELS_EXTERNAL. Task context.
 */
void app_wheels_measured(app_t *a, const kin_wheels_t *speed, uint8_t faults, uint32_t age_us);

/**
 * @brief Handle one received frame; replies go out through hal_can_send().
 *        A frame that fails its checks is dropped and counted.
 * @retval 0 handled. @retval negative errno from comm_decode() when dropped.
 */
int app_on_frame(app_t *a, const hal_can_frame_t *f);

/**
 * @brief Receive and handle every frame the HAL has queued, waiting at most
 *        @p timeout_us for the first one.
 * @return frames handled.
 */
unsigned app_poll(app_t *a, uint32_t timeout_us);

/**
 * @brief Real-time mode: one control step at time @p now_us on the latest
 *        inputs; sends EVENT×n, STATUS, STATUS_TRK, WHEEL_CMD. STEP frames
 *        are not needed in this mode.
 */
void app_control_tick(app_t *a, uint64_t now_us);

/**
 * @brief Send HEARTBEAT and STATUS_COUNTERS when their period has elapsed at
 *        @p now_us (at most once per period). Every control step calls it
 *        first, with the step's time; call it between steps to keep the
 *        heartbeat going while no step runs.
 */
void app_housekeeping(app_t *a, uint64_t now_us);

/**
 * @brief Wheel speeds [rad/s] commanded by the last control step (zero before
 *        the first), for a board's motor outputs: the same values as the
 *        step's WHEEL_CMD, before the frame's scaling.
 */
static inline const kin_wheels_t *app_last_wheels(const app_t *a) { return &a->wheels; }

/**
 * @brief The setpoint ramp of a board's wheel loop [rad/s²] (whl.h):
 *        wheel_accel, what the wheels can do; while halted at least the
 *        halt's deceleration, so that the wheel loop passes the halt's ramp
 *        on unslowed (the wheels then brake as fast as they can).
 */
static inline num_t app_wheel_accel(const app_t *a)
{
    const num_t accel = a->ctl.p.wheel_accel;
    return a->halt != (uint8_t)COMM_HALT_NONE ? num_max(accel, a->ramp_decel) : accel;
}

/**
 * @brief Re-arm (@p arm true) or disarm. Disarming halts (COMM_HALT_NOT_ARMED,
 *        ramped) unless already halted. Re-arming clears the halt when
 *        app_ready() holds.
 * @retval 0 done. @retval -EAGAIN re-arm refused: not ready; nothing changes.
 */
int app_arm(app_t *a, bool arm);

/**
 * @brief Whether a re-arm would be accepted now: odometry and reference
 *        frames each VALID with at least APP_REARM_FRAMES good frames in a
 *        row, and the CAN controller not bus-off.
 */
bool app_ready(const app_t *a);

#endif /* MSTC_APP_H */
