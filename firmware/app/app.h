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
 * Until each of odometry (both frames) and the reference (both frames) has
 * been received, a control step commands zero wheel speed (mode STOP).
 */
#ifndef MSTC_APP_H
#define MSTC_APP_H

#include <stdbool.h>
#include <stdint.h>

#include "comm/comm.h"
#include "ctrl/ctl.h"

/** @brief Period of HEARTBEAT and STATUS_COUNTERS [µs] (their DBC cycle time). */
#define APP_HOUSEKEEPING_PERIOD_US 100000u

/** @brief Application state. */
typedef struct {
    ctl_t ctl;
    comm_t comm;
    pose_t odom;     /**< latest robot pose */
    pose_t ref;      /**< latest reference pose */
    num_t v_r;       /**< latest reference velocities */
    num_t w_r;
    uint8_t have;    /**< APP_HAVE_* bits of the inputs received so far */
    sup_obstacle_t reports[SUP_MAX_OBSTACLES]; /**< obstacles reported since the last step */
    uint8_t n_reports;
    uint16_t step;          /**< step of the last control step */
    uint32_t time_raw;      /**< last STEP time [µs], as sent (wraps at 2^32) */
    uint32_t time_wraps;    /**< wraps of time_raw seen, for a 64-bit time */
    bool time_valid;
    bool frame_dropped;     /**< a received frame was dropped since the last STATUS */
    comm_state_t state;
    uint64_t next_housekeeping_us;
    uint32_t steps;         /**< control steps run */
    kin_wheels_t wheels;    /**< wheel speeds of the last control step [rad/s]; 0 before the first */
} app_t;

/** @brief Bits of app_t::have. */
enum {
    APP_HAVE_ODOM_XY = 1u << 0,
    APP_HAVE_ODOM_THETA = 1u << 1,
    APP_HAVE_REF_XY = 1u << 2,
    APP_HAVE_REF_MOTION = 1u << 3,
    APP_HAVE_ALL = 0x0Fu,
};

/**
 * @brief Initialise with parameters @p p (NULL: Table 1 defaults).
 * @retval 0 ready. @retval -EINVAL @p p rejected; the defaults are used.
 */
int app_init(app_t *a, const ctl_params_t *p);

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
 *        inputs; sends EVENT×n, STATUS, STATUS_TRK, WHEEL_CMD.
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

#endif /* MSTC_APP_H */
