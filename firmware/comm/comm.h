/* SPDX-License-Identifier: MIT */
/**
 * @file comm.h
 * @brief The CAN protocol of mstc (mstc.dbc) for the firmware: E2E
 *        protection and checking, scaling between raw signals and num_t (in
 *        both numeric modes), saturation, and dispatch by identifier.
 *
 * E2E, in the style of AUTOSAR E2E: byte 0 of every frame is the CRC-8H2F
 * over the frame's 16-bit data ID (low byte, then high byte; the DBC
 * attribute E2EDataID of each message) followed by bytes 1..7; bits 8..11 are
 * a 4-bit alive counter, incremented by the sender for every frame of that
 * identifier.
 *
 * Thin hand-written adapters over the codec that cantools generates from
 * mstc.dbc (mstc_dbc.c/.h by tools/gen-codec, committed, never edited by
 * hand). Raw values are scaled with the DBC's factors, which are powers of two
 * (2^-k, k <= 16): in fixed mode a conversion is an exact shift of the Q16.16
 * value, in float mode an exact multiplication. Encoding rounds to the nearest
 * raw value (halves away from zero) and saturates to the signal's range, never
 * wraps; NaN (float mode) is sent as 0. A value beyond its signal's DBC range
 * (or NaN) is clipped, and the next STATUS says so in faults bit 5
 * (COMM_FAULT_CLIPPED). Decoding is exact.
 *
 * Not scaled, and so not saturated: STEP_time and EVENT_time (the low 32 bits
 * of a time in µs, which wrap after 4294.967296 s like the step counters) and
 * the parameter index, echoed as received so that an unknown one can be
 * answered. Decoded ids and enumerations are passed on as received, even when
 * out of their DBC range (an OBSTACLE id or radius of 0): validating them is
 * the receiver's job (sup_step() drops such reports and counts them).
 */
#ifndef MSTC_COMM_H
#define MSTC_COMM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "auth/auth.h"
#include "ctrl/ctl.h"
#include "hal/hal_can.h"

/** @brief Frame identifiers (mstc.dbc). */
enum {
    COMM_ID_ODOM_XY = 0x100,
    COMM_ID_ODOM_THETA = 0x101,
    COMM_ID_REF_XY = 0x102,
    COMM_ID_REF_MOTION = 0x103,
    COMM_ID_STEP = 0x104,
    COMM_ID_WHEEL_SPEED = 0x105,
    COMM_ID_OBSTACLE = 0x110,
    COMM_ID_OBSTACLE_VEL = 0x111,
    COMM_ID_PARAM_SET = 0x120,
    COMM_ID_PARAM_GET = 0x121,
    COMM_ID_PARAM_AUTH = 0x122,
    COMM_ID_FW_VERSION_GET = 0x123,
    COMM_ID_WHEEL_CMD = 0x180,
    COMM_ID_STATUS = 0x181,
    COMM_ID_STATUS_TRK = 0x182,
    COMM_ID_STATUS_COUNTERS = 0x183,
    COMM_ID_EVENT = 0x184,
    COMM_ID_HEARTBEAT = 0x185,
    COMM_ID_AUTH_STATUS = 0x186,
    COMM_ID_AUTH_CHALLENGE = 0x187,
    COMM_ID_PARAM_VALUE = 0x190,
    COMM_ID_FW_VERSION = 0x191,
};

/** @name Node ids (mstc.dbc, FW_VERSION): a board's identifiers are the
 *  COMM_ID_* plus COMM_NODE_STRIDE times its node id, so that up to
 *  COMM_MAX_NODE + 1 boards share a bus. @{ */
#define COMM_NODE_STRIDE 0x100u
#define COMM_MAX_NODE    6u
/** @} */

/** @brief The protocol the codec speaks: N of mstc.dbc's VERSION line ("mstc N"). */
#define COMM_PROTOCOL_VERSION 2u

/** @brief E2E data ID of PARAM_SET, also the data ID its MAC covers (auth.h). */
#define COMM_PARAM_SET_DATA_ID      0x1120u
/** @brief E2E data ID of AUTH_CHALLENGE, also the data ID the status MAC covers (auth.h). */
#define COMM_AUTH_CHALLENGE_DATA_ID 0x1187u

/** @brief Number of distinct frames in the protocol. */
#define COMM_N_FRAMES 22u

/** @brief Parameter indices of PARAM_SET / PARAM_GET / PARAM_VALUE. */
typedef enum {
    COMM_PARAM_R_M = 0,
    COMM_PARAM_R_OB,
    COMM_PARAM_D_DET,
    COMM_PARAM_D_ACT,
    COMM_PARAM_D_S,
    COMM_PARAM_TRK_K1,
    COMM_PARAM_TRK_K2,
    COMM_PARAM_TRK_K3,
    COMM_PARAM_AVD_K1,
    COMM_PARAM_AVD_K2,
    COMM_PARAM_WHEEL_RADIUS,
    COMM_PARAM_TRACK_WIDTH,
    COMM_PARAM_MAX_WHEEL_SPEED,
    COMM_PARAM_MAX_WHEEL_DECEL, /**< ramp of a safety stop [rad/s²] (app.h) */
    COMM_PARAM_COUNT,
    /** A command, not a parameter: PARAM_SET value 1 re-arms, 0 disarms;
     *  PARAM_GET answers 1 while armed (app.h, docs/safety.md). */
    COMM_PARAM_ARM = 128,
} comm_param_t;

/** @brief Why the wheels are held at zero: STATUS_halt (mstc.dbc). */
typedef enum {
    COMM_HALT_NONE = 0,      /**< running */
    COMM_HALT_NOT_ARMED = 1, /**< start-up, or disarmed by command */
    COMM_HALT_ODOMETRY = 2,  /**< ODOM_XY or ODOM_THETA not valid or timed out */
    COMM_HALT_REFERENCE = 3, /**< REF_XY or REF_MOTION not valid or timed out */
    COMM_HALT_STEP = 4,      /**< STEP not valid (lock-step) */
    COMM_HALT_BUS_OFF = 5,   /**< the CAN controller went bus-off */
    /** Odometry disagrees with the motion commanded: replayed or stale (app.h) */
    COMM_HALT_ODOMETRY_IMPLAUSIBLE = 6,
    /** WHEEL_SPEED, once received, not valid or timed out while the wheels
     *  move (app.h) */
    COMM_HALT_WHEEL_SPEED = 7,
} comm_halt_t;

/** @brief Results in PARAM_VALUE (docs/safety.md, "Parameters"). */
typedef enum {
    COMM_PARAM_OK = 0,
    COMM_PARAM_UNKNOWN_INDEX = 1,
    /** Not finite, or outside the parameter's range once held as num_t; for
     *  the arm command a value other than 0 and 1. */
    COMM_PARAM_OUT_OF_RANGE = 2,
    /** Within its range but the set that would result breaks a relation; for
     *  the arm command: not ready (app_ready). */
    COMM_PARAM_REJECTED = 3,
    /** PARAM_SET without a PARAM_AUTH that verifies: MAC-less, another key,
     *  replayed or stale (auth.h); nothing changes. */
    COMM_PARAM_UNAUTHENTICATED = 4,
    /** A parameter of the control law, refused while armed (app.h). */
    COMM_PARAM_ARMED = 5,
} comm_param_result_t;

/** @brief STATUS_faults bit 5: a telemetry value sent since the previous
 *         STATUS (in it, or in STATUS_TRK and WHEEL_CMD before it) was beyond
 *         its signal's range and was clipped to it. Bits 0..2 are the
 *         controller's (CTL_FAULT_*), bit 3 a dropped frame, bit 4 the
 *         safety filter's. */
#define COMM_FAULT_CLIPPED 0x20u

/** @brief The largest obstacle id OBSTACLE, OBSTACLE_VEL, STATUS and EVENT
 *         carry (6 bits, 1..48 in mstc.dbc): as many as the supervisor's
 *         table holds (SUP_MAX_OBSTACLES, checked in comm.c). */
#define COMM_OBSTACLE_ID_MAX 48u

/** @brief Heartbeat states. */
typedef enum {
    COMM_STATE_INIT = 0,
    COMM_STATE_READY = 1,
    COMM_STATE_RUNNING = 2,
    COMM_STATE_STOPPED = 3,
    COMM_STATE_FAULT = 4,
} comm_state_t;

/** @brief Largest value of each drop counter (12 bits in STATUS_COUNTERS). */
#define COMM_DROP_COUNT_MAX 4095u

/** @brief Received frames dropped, by reason; each saturates at COMM_DROP_COUNT_MAX. */
typedef struct {
    uint16_t crc;     /**< CRC mismatch */
    uint16_t seq;     /**< alive counter repeated or out of sequence */
    uint16_t len;     /**< wrong DLC */
    uint16_t unknown; /**< identifier not received by the firmware */
} comm_counters_t;

/** @brief A decoded frame received by the firmware. */
typedef struct {
    uint32_t id; /**< COMM_ID_* */
    union {
        struct {
            num_t x, y;
        } xy;        /**< ODOM_XY, REF_XY [m] */
        num_t theta; /**< ODOM_THETA [rad] */
        struct {
            num_t theta, v, w;
        } ref_motion; /**< REF_MOTION */
        struct {
            uint16_t step;
            uint32_t time_us;
        } step;                  /**< STEP */
        sup_obstacle_t obstacle; /**< OBSTACLE */
        struct {
            uint8_t id;
            num_t vx, vy; /**< [m/s] */
        } obstacle_vel;   /**< OBSTACLE_VEL */
        struct {
            uint8_t index;
            float value;
            uint8_t auth_data[AUTH_DATA_LEN]; /**< bytes 2..7, as the MAC covers them */
        } param_set;                          /**< PARAM_SET */
        struct {
            uint32_t freshness_low;    /**< the freshness value, AUTH_FV_BITS bits */
            uint8_t mac[AUTH_MAC_LEN]; /**< bytes 4..7: the truncated CMAC */
        } param_auth;                  /**< PARAM_AUTH */
        uint8_t param_get;             /**< PARAM_GET index */
        struct {
            kin_wheels_t speed; /**< measured [rad/s] */
            uint8_t faults;     /**< the sender's wheel faults (WHL_FAULT_* bits) */
        } wheel_speed;          /**< WHEEL_SPEED */
    } u;
} comm_msg_t;

/**
 * @brief E2E check status of one received frame, or of a check cycle that
 *        received none (AUTOSAR E2E profile statuses; docs/safety.md).
 */
typedef enum {
    COMM_E2E_OK = 0,             /**< counter advanced by 1, or the identifier's first frame */
    COMM_E2E_OK_SOME_LOST = 1,   /**< advanced by 2..COMM_MAX_COUNTER_JUMP: frames were lost */
    COMM_E2E_REPEATED = 2,       /**< same counter as the last frame with a good CRC */
    COMM_E2E_WRONG_SEQUENCE = 3, /**< advanced by more than COMM_MAX_COUNTER_JUMP */
    COMM_E2E_ERROR = 4,          /**< CRC mismatch */
    COMM_E2E_LENGTH = 5,         /**< DLC other than 8 */
    COMM_E2E_NO_NEW_DATA = 6,    /**< no frame of the identifier in a check cycle */
} comm_e2e_status_t;

/** @brief State of an identifier's window state machine (AUTOSAR E2E SM). */
typedef enum {
    COMM_SM_NODATA = 0,  /**< no usable frame since comm_init() */
    COMM_SM_INIT = 1,    /**< frames arrive; not yet enough good ones */
    COMM_SM_VALID = 2,   /**< the data may be used */
    COMM_SM_INVALID = 3, /**< too many errors or too few good frames in the window */
} comm_sm_state_t;

/** @name Window state machine configuration (docs/safety.md, E2E).
 * Over the last COMM_SM_WINDOW statuses of an identifier, ok counts OK and
 * OK_SOME_LOST, err counts ERROR and LENGTH; REPEATED, WRONG_SEQUENCE and
 * NO_NEW_DATA count as neither (too many of them starve ok). @{ */
#define COMM_SM_WINDOW          4u
#define COMM_SM_MIN_OK_INIT     1u
#define COMM_SM_MAX_ERR_INIT    0u
#define COMM_SM_MIN_OK_VALID    2u
#define COMM_SM_MAX_ERR_VALID   1u
#define COMM_SM_MIN_OK_INVALID  3u
#define COMM_SM_MAX_ERR_INVALID 0u
/** @} */

/** @brief Receive side of one identifier: sequence, window state machine. */
typedef struct {
    uint8_t counter;                /**< alive counter of the last frame with a good CRC */
    uint8_t seen;                   /**< 1 once a frame with a good CRC arrived */
    uint8_t state;                  /**< comm_sm_state_t */
    uint8_t status;                 /**< comm_e2e_status_t of the last status fed */
    uint8_t window[COMM_SM_WINDOW]; /**< the last statuses, a ring */
    uint8_t n;                      /**< statuses in the window */
    uint8_t head;                   /**< next slot of the ring */
    uint8_t ok_run;                 /**< consecutive OK / OK_SOME_LOST, saturating at 255 */
    uint8_t frames;                 /**< frames (any status) since the last check cycle */
    uint8_t accepted;               /**< of which accepted */
} comm_rx_t;

/** @brief Protocol state: alive counters per frame, receivers, drop counters. */
typedef struct {
    uint8_t tx_counter[COMM_N_FRAMES];
    comm_rx_t rx[COMM_N_FRAMES];
    comm_counters_t drops;
    bool clipped; /**< a value was clipped since the last STATUS (COMM_FAULT_CLIPPED) */
    uint8_t node; /**< node id, 0..COMM_MAX_NODE: offsets the identifiers (comm_set_node()) */
} comm_t;

/** @brief The firmware's version and identity, as FW_VERSION carries them. */
typedef struct {
    uint8_t major, minor, patch; /**< version (at most 15, 63, 31: larger saturate) */
    bool dirty;                  /**< built from a work tree with changes not committed */
    uint32_t build;              /**< build id: the commit's first 7 hex digits (28 bits) */
    bool fixed;                  /**< NUMERIC=fixed (Q16.16), else float */
} comm_fw_version_t;

/** @brief Reset counters and sequence state: the next frame of every
 *         identifier is accepted whatever its alive counter, and every
 *         identifier's first frame sent carries counter 0. */
void comm_init(comm_t *c);

/**
 * @brief Set the node id: every identifier sent and received is offset by
 *        COMM_NODE_STRIDE times @p node. Frames of another node's
 *        identifiers are ignored by comm_decode() (-EXDEV), not counted.
 *        Call after comm_init(), which sets node 0. Task context.
 * @param node 0 .. COMM_MAX_NODE.
 * @retval 0 set.
 * @retval -EINVAL @p node out of range: nothing changed.
 */
int comm_set_node(comm_t *c, uint8_t node);

/**
 * @brief E2E data ID of a frame (the DBC attribute E2EDataID).
 * @param id frame identifier, COMM_ID_*.
 * @param[out] data_id its data ID.
 * @retval 0 found. @retval -ENOENT @p id is not a frame of the protocol.
 */
int comm_data_id(uint32_t id, uint16_t *data_id);

/**
 * @brief CRC-8H2F of @p len bytes: polynomial 0x2F, init 0xFF, final xor
 *        0xFF (AUTOSAR Crc_CalculateCRC8H2F; check value 0xDF for "123456789").
 */
uint8_t comm_crc8h2f(const uint8_t *data, size_t len);

/**
 * @brief Check and decode a frame addressed to the firmware.
 *
 * Order of checks: identifier known and received by the firmware, DLC = 8,
 * CRC over the frame's data ID and bytes 1..7, alive counter (repeated →
 * drop; a jump of more than COMM_MAX_COUNTER_JUMP → drop; the counter is
 * resynchronised on every frame with a good CRC, so the frame after a dropped
 * jump is accepted again; the first frame of an identifier after comm_init()
 * is accepted). A dropped frame is counted in c->drops, once, under the first
 * check it fails, and leaves @p msg unchanged.
 *
 * For a known identifier the firmware receives, the frame's E2E status
 * (LENGTH, ERROR, REPEATED, WRONG_SEQUENCE, OK or OK_SOME_LOST) is fed to the
 * identifier's window state machine (comm_rx()).
 * @param c   protocol state.
 * @param f   the received frame.
 * @param[out] msg the decoded frame.
 * @retval 0 @p msg holds the frame.
 * @retval -ENOENT unknown identifier (or one the firmware only sends).
 * @retval -EMSGSIZE wrong length.
 * @retval -EBADMSG CRC mismatch.
 * @retval -EALREADY repeated counter. @retval -ERANGE counter jump too large.
 */
int comm_decode(comm_t *c, const hal_can_frame_t *f, comm_msg_t *msg);

/** @brief Largest accepted alive-counter increment (1 = no frame lost). */
#define COMM_MAX_COUNTER_JUMP 3u

/**
 * @brief Close the check cycle of identifier @p id (once per control step for
 *        each input the step needs): when no frame of @p id arrived since the
 *        previous call, NO_NEW_DATA is fed to its state machine.
 * @retval true at least one frame of @p id was accepted since the previous call.
 * @retval false none was, or @p id is not a frame the firmware receives.
 */
bool comm_e2e_cycle(comm_t *c, uint32_t id);

/**
 * @brief Receive state of identifier @p id (its state machine, last status,
 *        run of good frames), or NULL when the firmware does not receive @p id.
 */
const comm_rx_t *comm_rx(const comm_t *c, uint32_t id);

/* Encoders for the frames the firmware sends. Each fills @p f (id, dlc 8,
 * payload with CRC and the next alive counter) and returns 0. Values outside a
 * signal's range saturate and are flagged in the next STATUS
 * (COMM_FAULT_CLIPPED); ids and enumerations beyond their largest value
 * saturate too (not the parameter index, echoed as received). */

/** @brief WHEEL_CMD: wheel speeds echoing @p step. */
int comm_encode_wheel_cmd(comm_t *c, uint16_t step, const kin_wheels_t *w, hal_can_frame_t *f);
/** @brief WHEEL_SPEED: the measured wheel speeds @p w [rad/s], for a board
 *         that measures its own wheels (mstc.dbc names the sender of each
 *         setup); the spare bits are 0. */
int comm_encode_wheel_speed(comm_t *c, const kin_wheels_t *w, hal_can_frame_t *f);
/** @brief The bits WHEEL_SPEED_faults carries: a wheel loop's WHL_FAULT_*
 *         (firmware/wheel/whl.h, the same bit order). */
#define COMM_WHEEL_FAULTS_MASK 0x0Fu
/** @brief WHEEL_SPEED as comm_encode_wheel_speed(), with the sender's wheel
 *         loop faults @p faults (COMM_WHEEL_FAULTS_MASK of them) in
 *         WHEEL_SPEED_faults: a board that runs its own wheel loop. */
int comm_encode_wheel_speed_faults(comm_t *c, const kin_wheels_t *w, uint8_t faults,
                                   hal_can_frame_t *f);
/**
 * @brief STATUS from the status of a step.
 *
 * mode and side from @p st; obstacle = st->active_obstacle (saturated at
 * COMM_OBSTACLE_ID_MAX);
 * faults = st->faults bits 0..2 and 4 (CTL_FAULT_*), bit 3 = @p frame_faults, bit 5
 * = a value clipped since the previous STATUS, this one's e and distance
 * included (then cleared); e; distance = centre distance to the active
 * obstacle, else to the nearest one remembered, else the signal's maximum
 * (63.999 m, meaning none: not a clip); the low 3 bits of @p step; halt =
 * @p halt (saturated at COMM_HALT_WHEEL_SPEED).
 * @param frame_faults a received frame was dropped since the last STATUS.
 * @param halt comm_halt_t: why the wheels are held at zero.
 */
int comm_encode_status(comm_t *c, const ctl_status_t *st, uint16_t step, bool frame_faults,
                       uint8_t halt, hal_can_frame_t *f);
/**
 * @brief STATUS_TRK: e1, e2, e3 and the odometry echo.
 * @param odom_counter alive counter of the ODOM_XY frame whose position the
 *        step used (its low 4 bits): a real-time plant matches it with the
 *        frames it sent to measure the latency from odometry to wheel
 *        command exactly, whatever the phase between its clock and the
 *        firmware's.
 */
int comm_encode_status_trk(comm_t *c, const trk_err_t *err, uint8_t odom_counter,
                           hal_can_frame_t *f);
/** @brief STATUS_COUNTERS from c->drops. */
int comm_encode_counters(comm_t *c, hal_can_frame_t *f);
/** @brief EVENT: kind (saturated at the DBC's largest kind), side, obstacle
 *         (saturated at 15) and the low 32 bits of e->t_us. */
int comm_encode_event(comm_t *c, const sup_event_t *e, hal_can_frame_t *f);
/** @brief HEARTBEAT. */
int comm_encode_heartbeat(comm_t *c, comm_state_t state, hal_can_frame_t *f);
/** @brief The status of @p s, both halves: f[0] AUTH_STATUS (outcome of the
 *         last decision, session, refusals), f[1] AUTH_CHALLENGE (the
 *         freshness last decided, and the status MAC, auth_status_mac(),
 *         which authenticates both). Send them in that order. */
int comm_encode_auth_status(comm_t *c, const auth_t *s, hal_can_frame_t f[2]);
/** @brief FW_VERSION: @p v, the node id and COMM_PROTOCOL_VERSION. */
int comm_encode_fw_version(comm_t *c, const comm_fw_version_t *v, hal_can_frame_t *f);
/** @brief PARAM_VALUE. */
int comm_encode_param_value(comm_t *c, uint8_t index, comm_param_result_t result, float value,
                            hal_can_frame_t *f);

#endif /* MSTC_COMM_H */
