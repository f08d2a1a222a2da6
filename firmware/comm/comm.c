/* SPDX-License-Identifier: MIT */
/*
 * The CAN protocol for the firmware (comm.h): E2E protection and checks,
 * scaling between raw signals and num_t, dispatch by identifier. Bit packing
 * is the generated codec's (mstc_dbc.c); this file only decides values.
 */
#include "comm/comm.h"

#include <errno.h>

#include "comm/mstc_dbc.h"

#ifndef NUM_FIXED
#include <math.h>
#endif

/* -------------------------------------------------------------- frame table */

/* The identifiers of comm.h are those of the DBC (the generated codec). */
_Static_assert(COMM_ID_ODOM_XY == MSTC_DBC_ODOM_XY_FRAME_ID, "ODOM_XY id");
_Static_assert(COMM_ID_ODOM_THETA == MSTC_DBC_ODOM_THETA_FRAME_ID, "ODOM_THETA id");
_Static_assert(COMM_ID_REF_XY == MSTC_DBC_REF_XY_FRAME_ID, "REF_XY id");
_Static_assert(COMM_ID_REF_MOTION == MSTC_DBC_REF_MOTION_FRAME_ID, "REF_MOTION id");
_Static_assert(COMM_ID_STEP == MSTC_DBC_STEP_FRAME_ID, "STEP id");
_Static_assert(COMM_ID_OBSTACLE == MSTC_DBC_OBSTACLE_FRAME_ID, "OBSTACLE id");
_Static_assert(COMM_ID_OBSTACLE_VEL == MSTC_DBC_OBSTACLE_VEL_FRAME_ID, "OBSTACLE_VEL id");
_Static_assert(COMM_ID_PARAM_SET == MSTC_DBC_PARAM_SET_FRAME_ID, "PARAM_SET id");
_Static_assert(COMM_ID_PARAM_GET == MSTC_DBC_PARAM_GET_FRAME_ID, "PARAM_GET id");
_Static_assert(COMM_ID_PARAM_AUTH == MSTC_DBC_PARAM_AUTH_FRAME_ID, "PARAM_AUTH id");
_Static_assert(COMM_ID_WHEEL_CMD == MSTC_DBC_WHEEL_CMD_FRAME_ID, "WHEEL_CMD id");
_Static_assert(COMM_ID_STATUS == MSTC_DBC_STATUS_FRAME_ID, "STATUS id");
_Static_assert(COMM_ID_STATUS_TRK == MSTC_DBC_STATUS_TRK_FRAME_ID, "STATUS_TRK id");
_Static_assert(COMM_ID_STATUS_COUNTERS == MSTC_DBC_STATUS_COUNTERS_FRAME_ID, "STATUS_COUNTERS id");
_Static_assert(COMM_ID_EVENT == MSTC_DBC_EVENT_FRAME_ID, "EVENT id");
_Static_assert(COMM_ID_HEARTBEAT == MSTC_DBC_HEARTBEAT_FRAME_ID, "HEARTBEAT id");
_Static_assert(COMM_ID_AUTH_STATUS == MSTC_DBC_AUTH_STATUS_FRAME_ID, "AUTH_STATUS id");
_Static_assert(COMM_ID_AUTH_CHALLENGE == MSTC_DBC_AUTH_CHALLENGE_FRAME_ID, "AUTH_CHALLENGE id");
_Static_assert(COMM_ID_PARAM_VALUE == MSTC_DBC_PARAM_VALUE_FRAME_ID, "PARAM_VALUE id");
_Static_assert(COMM_ID_WHEEL_SPEED == MSTC_DBC_WHEEL_SPEED_FRAME_ID, "WHEEL_SPEED id");
_Static_assert(COMM_ID_FW_VERSION_GET == MSTC_DBC_FW_VERSION_GET_FRAME_ID, "FW_VERSION_GET id");
_Static_assert(COMM_ID_FW_VERSION == MSTC_DBC_FW_VERSION_FRAME_ID, "FW_VERSION id");
_Static_assert(COMM_WHEEL_FAULTS_MASK == 15u, "WHEEL_SPEED_faults: 4 bits (mstc.dbc)");
_Static_assert(COMM_OBSTACLE_ID_MAX == SUP_MAX_OBSTACLES,
               "an entry of the supervisor's table for every id the frames carry");
/* So are the enumerations that go on the wire unchanged. */
_Static_assert(COMM_PARAM_MAX_WHEEL_SPEED ==
                       MSTC_DBC_PARAM_SET_PARAM_SET_INDEX_MAX_WHEEL_SPEED_CHOICE &&
                   COMM_PARAM_MAX_WHEEL_DECEL ==
                       MSTC_DBC_PARAM_SET_PARAM_SET_INDEX_MAX_WHEEL_DECEL_CHOICE &&
                   COMM_PARAM_ARM == MSTC_DBC_PARAM_SET_PARAM_SET_INDEX_ARM_CHOICE,
               "parameter indices");
_Static_assert(COMM_HALT_NOT_ARMED == MSTC_DBC_STATUS_STATUS_HALT_NOT_ARMED_CHOICE &&
                   COMM_HALT_ODOMETRY == MSTC_DBC_STATUS_STATUS_HALT_ODOMETRY_CHOICE &&
                   COMM_HALT_REFERENCE == MSTC_DBC_STATUS_STATUS_HALT_REFERENCE_CHOICE &&
                   COMM_HALT_STEP == MSTC_DBC_STATUS_STATUS_HALT_STEP_CHOICE &&
                   COMM_HALT_BUS_OFF == MSTC_DBC_STATUS_STATUS_HALT_BUS_OFF_CHOICE &&
                   COMM_HALT_ODOMETRY_IMPLAUSIBLE ==
                       MSTC_DBC_STATUS_STATUS_HALT_ODOMETRY_IMPLAUSIBLE_CHOICE &&
                   COMM_HALT_WHEEL_SPEED == MSTC_DBC_STATUS_STATUS_HALT_WHEEL_SPEED_CHOICE,
               "halt reasons");
_Static_assert(COMM_PARAM_REJECTED == MSTC_DBC_PARAM_VALUE_PARAM_VALUE_RESULT_REJECTED_CHOICE &&
                   COMM_PARAM_UNAUTHENTICATED ==
                       MSTC_DBC_PARAM_VALUE_PARAM_VALUE_RESULT_UNAUTHENTICATED_CHOICE &&
                   COMM_PARAM_ARMED == MSTC_DBC_PARAM_VALUE_PARAM_VALUE_RESULT_ARMED_CHOICE,
               "parameter results");
/* The parameter indices are the limits table's (ctl_limits.h, checked
 * against the DBC by tools/gen-limits). */
_Static_assert((int)COMM_PARAM_R_M == (int)CTL_P_R_M &&
                   (int)COMM_PARAM_MAX_WHEEL_SPEED == (int)CTL_P_MAX_WHEEL_SPEED &&
                   (int)COMM_PARAM_MAX_WHEEL_DECEL == (int)CTL_P_MAX_WHEEL_DECEL &&
                   (unsigned)COMM_PARAM_COUNT <= CTL_N_PARAMS &&
                   (unsigned)COMM_PARAM_ARM >= CTL_N_PARAMS,
               "parameter indices of the limits table");
_Static_assert(AUTH_OK == MSTC_DBC_AUTH_STATUS_AUTH_STATUS_LAST_OK_CHOICE &&
                   AUTH_MISSING == MSTC_DBC_AUTH_STATUS_AUTH_STATUS_LAST_MISSING_CHOICE &&
                   AUTH_MAC == MSTC_DBC_AUTH_STATUS_AUTH_STATUS_LAST_MAC_CHOICE &&
                   AUTH_STALE == MSTC_DBC_AUTH_STATUS_AUTH_STATUS_LAST_STALE_CHOICE &&
                   AUTH_NO_KEY == MSTC_DBC_AUTH_STATUS_AUTH_STATUS_LAST_NO_KEY_CHOICE &&
                   AUTH_LOCKED == MSTC_DBC_AUTH_STATUS_AUTH_STATUS_LAST_LOCKED_CHOICE &&
                   AUTH_EXPIRED == MSTC_DBC_AUTH_STATUS_AUTH_STATUS_LAST_EXPIRED_CHOICE,
               "decision outcomes");
_Static_assert(AUTH_REFUSED_MAX == (1u << 15) - 1u, "15-bit refusal count");
_Static_assert(AUTH_FV_BITS == 20u, "PARAM_AUTH and AUTH_CHALLENGE carry 20 bits of freshness");
_Static_assert(COMM_STATE_FAULT == MSTC_DBC_HEARTBEAT_HEARTBEAT_STATE_FAULT_CHOICE,
               "heartbeat states");
_Static_assert(SUP_MODE_TRACK == MSTC_DBC_STATUS_STATUS_MODE_TRACK_CHOICE &&
                   SUP_MODE_AVOID == MSTC_DBC_STATUS_STATUS_MODE_AVOID_CHOICE &&
                   SUP_MODE_STOP == MSTC_DBC_STATUS_STATUS_MODE_STOP_CHOICE,
               "modes");
_Static_assert(SUP_EVENT_DETECT == MSTC_DBC_EVENT_EVENT_KIND_DETECT_CHOICE &&
                   SUP_EVENT_ACTIVATE == MSTC_DBC_EVENT_EVENT_KIND_ACTIVATE_CHOICE &&
                   SUP_EVENT_COMPLETE == MSTC_DBC_EVENT_EVENT_KIND_COMPLETE_CHOICE &&
                   SUP_EVENT_FILTER == MSTC_DBC_EVENT_EVENT_KIND_FILTER_CHOICE &&
                   SUP_EVENT_INFEASIBLE == MSTC_DBC_EVENT_EVENT_KIND_INFEASIBLE_CHOICE,
               "event kinds");

/* Every frame is 8 bytes: E2E needs bytes 0 and 1, and a fixed length is
 * what lets the DLC check catch truncated frames. */
#define FRAME_LEN 8u

typedef struct {
    uint32_t id;
    uint16_t data_id; /* E2EDataID in mstc.dbc; tests/python/test_codec.py compares */
    bool rx;          /* received by the firmware; the others it only sends */
} frame_t;

/* Indexed like comm_t's counter arrays. WHEEL_SPEED is received, and sent by
 * a board that measures its own wheels (mstc.dbc). Two pairs a row;
 * WHEEL_SPEED and AUTH_CHALLENGE added at the end, on rows of their own. */
/* clang-format off */
static const frame_t frames[COMM_N_FRAMES] = {
    { COMM_ID_ODOM_XY, 0x1100u, true },      { COMM_ID_ODOM_THETA, 0x1101u, true },
    { COMM_ID_REF_XY, 0x1102u, true },       { COMM_ID_REF_MOTION, 0x1103u, true },
    { COMM_ID_STEP, 0x1104u, true },         { COMM_ID_OBSTACLE, 0x1110u, true },
    { COMM_ID_OBSTACLE_VEL, 0x1111u, true }, { COMM_ID_PARAM_SET, COMM_PARAM_SET_DATA_ID, true },
    { COMM_ID_PARAM_GET, 0x1121u, true },    { COMM_ID_PARAM_AUTH, 0x1122u, true },
    { COMM_ID_WHEEL_CMD, 0x1180u, false },   { COMM_ID_STATUS, 0x1181u, false },
    { COMM_ID_STATUS_TRK, 0x1182u, false },  { COMM_ID_STATUS_COUNTERS, 0x1183u, false },
    { COMM_ID_EVENT, 0x1184u, false },       { COMM_ID_HEARTBEAT, 0x1185u, false },
    { COMM_ID_AUTH_STATUS, 0x1186u, false }, { COMM_ID_PARAM_VALUE, 0x1190u, false },
    { COMM_ID_WHEEL_SPEED, 0x1105u, true },
    { COMM_ID_AUTH_CHALLENGE, COMM_AUTH_CHALLENGE_DATA_ID, false },
    { COMM_ID_FW_VERSION_GET, 0x1123u, true }, { COMM_ID_FW_VERSION, 0x1191u, false },
};
/* clang-format on */

/* Index of @p id in frames[], or COMM_N_FRAMES when it is not a protocol frame. */
static size_t frame_index(uint32_t id)
{
    size_t i = 0;
    while (i < COMM_N_FRAMES && frames[i].id != id) {
        i++;
    }
    return i;
}

int comm_data_id(uint32_t id, uint16_t *data_id)
{
    const size_t i = frame_index(id);
    if (i == COMM_N_FRAMES) {
        return -ENOENT;
    }
    *data_id = frames[i].data_id;
    return 0;
}

/* ---------------------------------------------------------------------- E2E */

/* The alive counter is bits 8..11: the low nibble of byte 1. */
#define COUNTER_MASK 0x0Fu

uint8_t comm_crc8h2f(const uint8_t *data, size_t len)
{
    /* Bitwise, MSB first, not reflected: nine bytes a frame do not justify a
     * 256-byte table, and this form can be checked against the polynomial by
     * reading it. */
    uint8_t crc = 0xFFu;
    for (size_t i = 0; i < len; i++) {
        crc ^= data[i];
        for (unsigned b = 0; b < 8u; b++) {
            crc = (crc & 0x80u) != 0u ? (uint8_t)(((unsigned)crc << 1) ^ 0x2Fu)
                                      : (uint8_t)((unsigned)crc << 1);
        }
    }
    return (uint8_t)(crc ^ 0xFFu);
}

/* CRC of a frame: over its data ID (low byte first) and payload bytes 1..7.
 * The data ID makes a frame that lands under the wrong identifier (a
 * corrupted ID, a misconfigured sender) fail the CRC. */
static uint8_t frame_crc(uint16_t data_id, const uint8_t *payload)
{
    uint8_t buf[2u + FRAME_LEN - 1u];
    buf[0] = (uint8_t)(data_id & 0xFFu);
    buf[1] = (uint8_t)(data_id >> 8);
    for (size_t i = 1; i < FRAME_LEN; i++) {
        buf[1u + i] = payload[i];
    }
    return comm_crc8h2f(buf, sizeof buf);
}

/* Counter, then CRC (the CRC covers the counter) on a packed payload. */
static void e2e_protect(comm_t *c, size_t i, hal_can_frame_t *f)
{
    f->id = frames[i].id + (uint32_t)c->node * COMM_NODE_STRIDE;
    f->dlc = FRAME_LEN;
    f->data[1] = (uint8_t)((f->data[1] & ~COUNTER_MASK) | c->tx_counter[i]);
    c->tx_counter[i] = (uint8_t)((c->tx_counter[i] + 1u) & COUNTER_MASK);
    f->data[0] = frame_crc(frames[i].data_id, f->data);
}

static void count_drop(uint16_t *n)
{
    if (*n < COMM_DROP_COUNT_MAX) {
        (*n)++;
    }
}

void comm_init(comm_t *c) { *c = (comm_t){ 0 }; }

int comm_set_node(comm_t *c, uint8_t node)
{
    if (node > COMM_MAX_NODE) {
        return -EINVAL;
    }
    c->node = node;
    return 0;
}

/* Whether @p id is a protocol identifier of node @p node. */
static bool of_node(uint32_t id, uint32_t node)
{
    const uint32_t offset = node * COMM_NODE_STRIDE;
    return id >= offset && frame_index(id - offset) < COMM_N_FRAMES;
}

/* ------------------------------------------------------------------ scaling */

/* A scaled signal of mstc.dbc: resolution 2^-frac_bits, raw range [lo, hi]
 * (the DBC's [min|max] divided by the resolution). */
typedef struct {
    uint8_t frac_bits;
    int32_t lo, hi;
} scale_t;

#define SIGNED_BITS(frac, bits)                                                                    \
    {                                                                                              \
        (frac), -(INT32_C(1) << ((bits)-1)), (INT32_C(1) << ((bits)-1)) - 1                        \
    }

static const scale_t s_pos = SIGNED_BITS(16, 24);       /* ODOM_XY, REF_XY x, y [m] */
static const scale_t s_theta = SIGNED_BITS(16, 20);     /* ODOM_THETA [rad] */
static const scale_t s_ref_theta = SIGNED_BITS(15, 18); /* REF_MOTION theta [rad] */
static const scale_t s_ref_vw = SIGNED_BITS(12, 17);    /* REF_MOTION v [m/s], w [rad/s] */
static const scale_t s_obs_xy = SIGNED_BITS(11, 19);    /* OBSTACLE x, y [m] */
static const scale_t s_obs_v = SIGNED_BITS(10, 16);     /* OBSTACLE_VEL vx, vy [m/s] */
static const scale_t s_wheel = SIGNED_BITS(10, 18);     /* WHEEL_CMD, WHEEL_SPEED [rad/s] */
static const scale_t s_angle13 = SIGNED_BITS(13, 16);   /* STATUS_TRK e3 [rad] */
static const scale_t s_angle11 = SIGNED_BITS(11, 14);   /* STATUS e [rad] */
static const scale_t s_err = SIGNED_BITS(10, 16);       /* STATUS_TRK e1, e2 [m] */
static const scale_t s_distance = { 10, 0, 65535 };     /* STATUS distance [m] */

#ifdef NUM_FIXED

/* Q16.16: num_t is the raw int32 value, so a DBC resolution of 2^-k is a
 * shift by 16 - k, exact in both directions except for the rounding of the
 * bits an encoder drops. */
_Static_assert(sizeof(num_t) == sizeof(int32_t) && (num_t)-1 < 0 && (num_t)1 / 2 == 0 &&
                   NUM_FRAC_BITS == 16,
               "fixed mode: num_t must be the Q16.16 int32");

static num_t num_from_raw(int32_t raw, const scale_t *s)
{
    /* |raw| < 2^23 and shift <= 16 - k keep the product inside int32 for
     * every signal (at most 24 significant bits). Multiplication, because a
     * left shift of a negative value is undefined. */
    return (num_t)(raw * (INT32_C(1) << (NUM_FRAC_BITS - s->frac_bits)));
}

static int32_t raw_from_num(comm_t *c, num_t v, const scale_t *s)
{
    const unsigned shift = (unsigned)(NUM_FRAC_BITS - s->frac_bits);
    const int64_t unit = INT64_C(1) << shift; /* one raw step in Q16.16 */
    /* Beyond the signal's range [lo, hi]·2^-frac_bits: clipped. Within it,
     * the rounding below stays within [lo, hi]. */
    if ((int64_t)v < (int64_t)s->lo * unit) {
        c->clipped = true;
        return s->lo;
    }
    if ((int64_t)v > (int64_t)s->hi * unit) {
        c->clipped = true;
        return s->hi;
    }
    int64_t r = (int64_t)v;
    if (shift > 0u) {
        /* Round halves away from zero, as roundf() does in float mode. */
        const int64_t half = INT64_C(1) << (shift - 1u);
        r = r >= 0 ? (r + half) >> shift : -((-r + half) >> shift);
    }
    return (int32_t)r;
}

#else

static num_t num_from_raw(int32_t raw, const scale_t *s)
{
    /* Exact: |raw| < 2^24 fits the float significand, and the scale is a
     * power of two. */
    return num_from_float(ldexpf((float)raw, -(int)s->frac_bits));
}

static int32_t raw_from_num(comm_t *c, num_t v, const scale_t *s)
{
    const float x = num_to_float(v);
    /* Saturate before scaling: ldexpf() of a value beyond the range could
     * overflow (FE_OVERFLOW), and converting an out-of-range float to an
     * integer is undefined. lo and hi have at most 24 bits, so they and their
     * scaled values are exact in float; isnan() raises nothing, and after it
     * the comparisons are ordered. Beyond [lo, hi]·2^-frac_bits, or NaN: a
     * clip. Within it, the rounding stays within [lo, hi]. */
    if (isnan(x) != 0) {
        c->clipped = true;
        return 0;
    }
    if (x < ldexpf((float)s->lo, -(int)s->frac_bits)) {
        c->clipped = true;
        return s->lo;
    }
    if (x > ldexpf((float)s->hi, -(int)s->frac_bits)) {
        c->clipped = true;
        return s->hi;
    }
    return (int32_t)roundf(ldexpf(x, (int)s->frac_bits)); /* exact scaling */
}

#endif

/* OBSTACLE radius: centimetres, the one decimal resolution of mstc.dbc, so a
 * radius of 0.1 m arrives as exactly the value NUM_C(0.1) and a parameter
 * R_ob of 0.1 have (the supervisor compares them). */
static num_t radius_from_cm(uint8_t cm)
{
#ifdef NUM_FIXED
    /* Round to nearest: cm·2^16/100, at most 255·65536 + 50 < 2^31. */
    return (num_t)(((int32_t)cm * 65536 + 50) / 100);
#else
    return num_from_float((float)cm / 100.0f); /* correctly rounded */
#endif
}

/* An unscaled unsigned field: values above its largest saturate. */
static uint8_t sat_u8(uint32_t v, uint8_t max) { return v > max ? max : (uint8_t)v; }

/* avd_side_t (0, +1, -1) to the wire's none/left/right (0, 1, 2). */
static uint8_t side_to_wire(int side)
{
    return side == AVD_SIDE_LEFT    ? (uint8_t)MSTC_DBC_STATUS_STATUS_SIDE_LEFT_CHOICE
           : side == AVD_SIDE_RIGHT ? (uint8_t)MSTC_DBC_STATUS_STATUS_SIDE_RIGHT_CHOICE
                                    : (uint8_t)MSTC_DBC_STATUS_STATUS_SIDE_NONE_CHOICE;
}

/* ------------------------------------------------------------------- decode */

static void decode_payload(uint32_t id, const uint8_t *d, comm_msg_t *m)
{
    /* The unpackers cannot fail: the frame is FRAME_LEN bytes (checked). */
    switch (id) {
    case COMM_ID_ODOM_XY: {
        struct mstc_dbc_odom_xy_t s;
        (void)mstc_dbc_odom_xy_unpack(&s, d, FRAME_LEN);
        m->u.xy.x = num_from_raw(s.odom_xy_x, &s_pos);
        m->u.xy.y = num_from_raw(s.odom_xy_y, &s_pos);
        break;
    }
    case COMM_ID_ODOM_THETA: {
        struct mstc_dbc_odom_theta_t s;
        (void)mstc_dbc_odom_theta_unpack(&s, d, FRAME_LEN);
        m->u.theta = num_from_raw(s.odom_theta_theta, &s_theta);
        break;
    }
    case COMM_ID_REF_XY: {
        struct mstc_dbc_ref_xy_t s;
        (void)mstc_dbc_ref_xy_unpack(&s, d, FRAME_LEN);
        m->u.xy.x = num_from_raw(s.ref_xy_x, &s_pos);
        m->u.xy.y = num_from_raw(s.ref_xy_y, &s_pos);
        break;
    }
    case COMM_ID_REF_MOTION: {
        struct mstc_dbc_ref_motion_t s;
        (void)mstc_dbc_ref_motion_unpack(&s, d, FRAME_LEN);
        m->u.ref_motion.theta = num_from_raw(s.ref_motion_theta, &s_ref_theta);
        m->u.ref_motion.v = num_from_raw(s.ref_motion_v, &s_ref_vw);
        m->u.ref_motion.w = num_from_raw(s.ref_motion_w, &s_ref_vw);
        break;
    }
    case COMM_ID_STEP: {
        struct mstc_dbc_step_t s;
        (void)mstc_dbc_step_unpack(&s, d, FRAME_LEN);
        m->u.step.step = s.step_step;
        m->u.step.time_us = s.step_time;
        break;
    }
    case COMM_ID_OBSTACLE: {
        struct mstc_dbc_obstacle_t s;
        (void)mstc_dbc_obstacle_unpack(&s, d, FRAME_LEN);
        m->u.obstacle.id = s.obstacle_id;
        m->u.obstacle.x = num_from_raw(s.obstacle_x, &s_obs_xy);
        m->u.obstacle.y = num_from_raw(s.obstacle_y, &s_obs_xy);
        m->u.obstacle.radius = radius_from_cm(s.obstacle_radius);
        m->u.obstacle.vx = NUM_ZERO; /* OBSTACLE carries no velocity: a static obstacle */
        m->u.obstacle.vy = NUM_ZERO;
        break;
    }
    case COMM_ID_OBSTACLE_VEL: {
        struct mstc_dbc_obstacle_vel_t s;
        (void)mstc_dbc_obstacle_vel_unpack(&s, d, FRAME_LEN);
        m->u.obstacle_vel.id = s.obstacle_vel_id;
        m->u.obstacle_vel.vx = num_from_raw(s.obstacle_vel_vx, &s_obs_v);
        m->u.obstacle_vel.vy = num_from_raw(s.obstacle_vel_vy, &s_obs_v);
        break;
    }
    case COMM_ID_PARAM_SET: {
        struct mstc_dbc_param_set_t s;
        (void)mstc_dbc_param_set_unpack(&s, d, FRAME_LEN);
        m->u.param_set.index = s.param_set_index;
        m->u.param_set.value = s.param_set_value;
        /* The bytes as sent, spare bits included: the MAC covers them. */
        for (size_t i = 0; i < AUTH_DATA_LEN; i++) {
            m->u.param_set.auth_data[i] = d[2u + i];
        }
        break;
    }
    case COMM_ID_PARAM_AUTH:
        /* By hand, not mstc_dbc_param_auth_unpack(): the MAC is bytes 4..7
         * in order and the freshness bits 12..31 (mstc.dbc), and the 32 KB
         * budget has no room for a second copy of what these lines do
         * (test_comm.c checks them against the codec). */
        m->u.param_auth.freshness_low =
            (uint32_t)(d[1] >> 4) | (uint32_t)d[2] << 4 | (uint32_t)d[3] << 12;
        for (size_t i = 0; i < AUTH_MAC_LEN; i++) {
            m->u.param_auth.mac[i] = d[4u + i];
        }
        break;
    case COMM_ID_WHEEL_SPEED: {
        struct mstc_dbc_wheel_speed_t s;
        (void)mstc_dbc_wheel_speed_unpack(&s, d, FRAME_LEN);
        m->u.wheel_speed.speed.left = num_from_raw(s.wheel_speed_left, &s_wheel);
        m->u.wheel_speed.speed.right = num_from_raw(s.wheel_speed_right, &s_wheel);
        m->u.wheel_speed.faults = (uint8_t)(s.wheel_speed_faults & COMM_WHEEL_FAULTS_MASK);
        break;
    }
    case COMM_ID_FW_VERSION_GET: break; /* no payload */
    default: { /* COMM_ID_PARAM_GET, the last frame comm_decode() lets through */
        struct mstc_dbc_param_get_t s;
        (void)mstc_dbc_param_get_unpack(&s, d, FRAME_LEN);
        m->u.param_get = s.param_get_index;
        break;
    }
    }
    m->id = id;
}

/* ------------------------------------------------- E2E receiver, per identifier */

/* ok and err of a status in the window (comm.h: NO_NEW_DATA, REPEATED and
 * WRONG_SEQUENCE are neither). */
static bool status_ok(uint8_t st) { return st <= (uint8_t)COMM_E2E_OK_SOME_LOST; }
static bool status_err(uint8_t st)
{
    return st == (uint8_t)COMM_E2E_ERROR || st == (uint8_t)COMM_E2E_LENGTH;
}

/* The state a window leads to from INIT, VALID or INVALID (docs/safety.md). */
static uint8_t sm_next(const comm_rx_t *r)
{
    unsigned ok = 0u;
    unsigned err = 0u;
    for (unsigned k = 0u; k < r->n; k++) {
        ok += status_ok(r->window[k]) ? 1u : 0u;
        err += status_err(r->window[k]) ? 1u : 0u;
    }
    uint8_t next;
    if (r->state == (uint8_t)COMM_SM_INIT) {
        if (err > COMM_SM_MAX_ERR_INIT) {
            next = (uint8_t)COMM_SM_INVALID;
        } else {
            next = ok >= COMM_SM_MIN_OK_INIT ? (uint8_t)COMM_SM_VALID : (uint8_t)COMM_SM_INIT;
        }
    } else if (r->state == (uint8_t)COMM_SM_VALID) {
        next = (err <= COMM_SM_MAX_ERR_VALID && ok >= COMM_SM_MIN_OK_VALID)
                   ? (uint8_t)COMM_SM_VALID
                   : (uint8_t)COMM_SM_INVALID;
    } else { /* COMM_SM_INVALID */
        /* cppcheck-suppress unsignedLessThanZero ; a configuration constant, 0 today */
        next = (err <= COMM_SM_MAX_ERR_INVALID && ok >= COMM_SM_MIN_OK_INVALID)
                   ? (uint8_t)COMM_SM_VALID
                   : (uint8_t)COMM_SM_INVALID;
    }
    return next;
}

/* Feed one status to an identifier's state machine. */
static void sm_feed(comm_rx_t *r, comm_e2e_status_t status)
{
    const uint8_t st = (uint8_t)status;
    r->status = st;
    if (status_ok(st)) {
        r->ok_run = (uint8_t)(r->ok_run < UINT8_MAX ? r->ok_run + 1u : UINT8_MAX);
    } else {
        r->ok_run = 0u;
    }
    if (r->state == (uint8_t)COMM_SM_NODATA) {
        /* As AUTOSAR's E2E_SMCheck: a status other than ERROR, LENGTH and
         * NO_NEW_DATA (a frame with a good CRC) starts the machine, in INIT
         * with an empty window; the window judges from the next status on. */
        if (st != (uint8_t)COMM_E2E_ERROR && st != (uint8_t)COMM_E2E_LENGTH &&
            st != (uint8_t)COMM_E2E_NO_NEW_DATA) {
            r->n = 0u;
            r->head = 0u;
            r->state = (uint8_t)COMM_SM_INIT;
        }
        return;
    }
    r->window[r->head] = st;
    r->head = (uint8_t)((r->head + 1u) % COMM_SM_WINDOW);
    if (r->n < COMM_SM_WINDOW) {
        r->n++;
    }
    r->state = sm_next(r);
}

/* The sequence check of a frame with a good CRC. The counter is genuine, so
 * the sequence follows it whether or not the frame is accepted: one lost
 * burst costs one frame, not a stream. */
static comm_e2e_status_t sequence(comm_rx_t *r, uint8_t counter)
{
    const uint8_t delta = (uint8_t)((counter - r->counter) & COUNTER_MASK);
    const bool first = r->seen == 0u;
    r->counter = counter;
    r->seen = 1u;
    comm_e2e_status_t st;
    if (first || delta == 1u) {
        st = COMM_E2E_OK;
    } else if (delta == 0u) {
        st = COMM_E2E_REPEATED;
    } else if (delta <= COMM_MAX_COUNTER_JUMP) {
        st = COMM_E2E_OK_SOME_LOST;
    } else {
        st = COMM_E2E_WRONG_SEQUENCE;
    }
    return st;
}

int comm_decode(comm_t *c, const hal_can_frame_t *f, comm_msg_t *msg)
{
    const uint32_t offset = (uint32_t)c->node * COMM_NODE_STRIDE;
    const uint32_t id = f->id >= offset ? f->id - offset : UINT32_MAX;
    const size_t i = frame_index(id);
    if (i == COMM_N_FRAMES || !frames[i].rx) {
        for (uint32_t n = 0; n <= COMM_MAX_NODE && i == COMM_N_FRAMES; n++) {
            if (n != c->node && of_node(f->id, n)) {
                return -EXDEV; /* another board's, on a shared bus: not ours to count */
            }
        }
        count_drop(&c->drops.unknown);
        return -ENOENT;
    }
    comm_rx_t *r = &c->rx[i];
    r->frames = (uint8_t)(r->frames < UINT8_MAX ? r->frames + 1u : UINT8_MAX);
    comm_e2e_status_t st;
    int rc = 0;
    if (f->dlc != FRAME_LEN) {
        count_drop(&c->drops.len);
        st = COMM_E2E_LENGTH;
        rc = -EMSGSIZE;
    } else if (f->data[0] != frame_crc(frames[i].data_id, f->data)) {
        count_drop(&c->drops.crc);
        st = COMM_E2E_ERROR;
        rc = -EBADMSG;
    } else {
        st = sequence(r, (uint8_t)(f->data[1] & COUNTER_MASK));
        if (st == COMM_E2E_REPEATED) {
            count_drop(&c->drops.seq);
            rc = -EALREADY;
        } else if (st == COMM_E2E_WRONG_SEQUENCE) {
            count_drop(&c->drops.seq);
            rc = -ERANGE;
        } else {
            r->accepted = (uint8_t)(r->accepted < UINT8_MAX ? r->accepted + 1u : UINT8_MAX);
            decode_payload(id, f->data, msg);
        }
    }
    sm_feed(r, st);
    return rc;
}

bool comm_e2e_cycle(comm_t *c, uint32_t id)
{
    const size_t i = frame_index(id);
    if (i == COMM_N_FRAMES || !frames[i].rx) {
        return false;
    }
    comm_rx_t *r = &c->rx[i];
    if (r->frames == 0u) {
        sm_feed(r, COMM_E2E_NO_NEW_DATA);
    }
    const bool accepted = r->accepted != 0u;
    r->frames = 0u;
    r->accepted = 0u;
    return accepted;
}

const comm_rx_t *comm_rx(const comm_t *c, uint32_t id)
{
    const size_t i = frame_index(id);
    return (i == COMM_N_FRAMES || !frames[i].rx) ? NULL : &c->rx[i];
}

/* ------------------------------------------------------------------ encoders */

int comm_encode_wheel_cmd(comm_t *c, uint16_t step, const kin_wheels_t *w, hal_can_frame_t *f)
{
    const struct mstc_dbc_wheel_cmd_t s = {
        .wheel_cmd_step = step,
        .wheel_cmd_left = raw_from_num(c, w->left, &s_wheel),
        .wheel_cmd_right = raw_from_num(c, w->right, &s_wheel),
    };
    (void)mstc_dbc_wheel_cmd_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_WHEEL_CMD), f);
    return 0;
}

int comm_encode_wheel_speed(comm_t *c, const kin_wheels_t *w, hal_can_frame_t *f)
{
    return comm_encode_wheel_speed_faults(c, w, 0u, f);
}

int comm_encode_wheel_speed_faults(comm_t *c, const kin_wheels_t *w, uint8_t faults,
                                   hal_can_frame_t *f)
{
    const struct mstc_dbc_wheel_speed_t s = {
        .wheel_speed_left = raw_from_num(c, w->left, &s_wheel),
        .wheel_speed_right = raw_from_num(c, w->right, &s_wheel),
        .wheel_speed_faults = (uint8_t)(faults & COMM_WHEEL_FAULTS_MASK),
    };
    (void)mstc_dbc_wheel_speed_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_WHEEL_SPEED), f);
    return 0;
}

/* STATUS_distance, raw: the active obstacle's distance, else the nearest
 * one's; with none known, the signal's maximum, which means "none" (not a
 * clip). */
static uint16_t status_distance(comm_t *c, const ctl_status_t *st)
{
    if (st->n_obstacles == 0u) {
        return (uint16_t)s_distance.hi;
    }
    const size_t n = st->n_obstacles < SUP_MAX_OBSTACLES ? st->n_obstacles : SUP_MAX_OBSTACLES;
    num_t d = st->distance[0];
    /* cppcheck-suppress knownConditionTrueFalse ; false positive: n is up to 48 */
    for (size_t i = 0; i < n; i++) {
        if (st->active_obstacle != 0u && st->obstacle_id[i] == st->active_obstacle) {
            d = st->distance[i];
            break;
        }
        d = num_min(d, st->distance[i]);
    }
    return (uint16_t)raw_from_num(c, d, &s_distance);
}

int comm_encode_status(comm_t *c, const ctl_status_t *st, uint16_t step, bool frame_faults,
                       uint8_t halt, hal_can_frame_t *f)
{
    /* Bits 3 and 5 are this layer's; the controller's own are 0..2 and 4
     * (its bit 3, CTL_FAULT_OUTPUT_INVALID, is not on the wire). */
    const uint8_t ctl_faults =
        (uint8_t)(st->faults & (CTL_FAULT_INPUT_NONFINITE | CTL_FAULT_OBSTACLE_DROPPED |
                                CTL_FAULT_SATURATED | CTL_FAULT_FILTER));
    const int16_t e = (int16_t)raw_from_num(c, st->e, &s_angle11);
    const uint16_t distance = status_distance(c, st);
    const struct mstc_dbc_status_t s = {
        .status_mode = sat_u8((uint32_t)st->mode, MSTC_DBC_STATUS_STATUS_MODE_BLOCKED_CHOICE),
        .status_side = side_to_wire(st->side),
        .status_obstacle = sat_u8(st->active_obstacle, COMM_OBSTACLE_ID_MAX),
        .status_faults = (uint8_t)(ctl_faults | (frame_faults ? 0x08u : 0u) |
                                   (c->clipped ? COMM_FAULT_CLIPPED : 0u)),
        .status_e = e,
        .status_distance = distance,
        .status_step = (uint8_t)(step & 0x07u),
        .status_halt = sat_u8(halt, (uint8_t)COMM_HALT_WHEEL_SPEED),
    };
    c->clipped = false;
    (void)mstc_dbc_status_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_STATUS), f);
    return 0;
}

int comm_encode_status_trk(comm_t *c, const trk_err_t *err, uint8_t odom_counter,
                           hal_can_frame_t *f)
{
    const struct mstc_dbc_status_trk_t s = {
        .status_trk_odom_counter = (uint8_t)(odom_counter & COUNTER_MASK),
        .status_trk_e1 = (int16_t)raw_from_num(c, err->e1, &s_err),
        .status_trk_e2 = (int16_t)raw_from_num(c, err->e2, &s_err),
        .status_trk_e3 = (int16_t)raw_from_num(c, err->e3, &s_angle13),
    };
    (void)mstc_dbc_status_trk_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_STATUS_TRK), f);
    return 0;
}

int comm_encode_counters(comm_t *c, hal_can_frame_t *f)
{
    const struct mstc_dbc_status_counters_t s = {
        .status_counters_crc_errors = c->drops.crc,
        .status_counters_seq_errors = c->drops.seq,
        .status_counters_len_errors = c->drops.len,
        .status_counters_unknown_ids = c->drops.unknown,
    };
    (void)mstc_dbc_status_counters_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_STATUS_COUNTERS), f);
    return 0;
}

int comm_encode_event(comm_t *c, const sup_event_t *e, hal_can_frame_t *f)
{
    const struct mstc_dbc_event_t s = {
        .event_kind = sat_u8(e->kind, MSTC_DBC_EVENT_EVENT_KIND_INFEASIBLE_CHOICE),
        .event_side = side_to_wire(e->side),
        .event_obstacle = sat_u8(e->obstacle, COMM_OBSTACLE_ID_MAX),
        /* A time stamp wraps with the STEP time it answers (comm.h). */
        .event_time = (uint32_t)(e->t_us & UINT32_MAX),
    };
    (void)mstc_dbc_event_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_EVENT), f);
    return 0;
}

int comm_encode_heartbeat(comm_t *c, comm_state_t state, hal_can_frame_t *f)
{
    const struct mstc_dbc_heartbeat_t s = {
        .heartbeat_state = sat_u8((uint32_t)state, MSTC_DBC_HEARTBEAT_HEARTBEAT_STATE_FAULT_CHOICE),
    };
    (void)mstc_dbc_heartbeat_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_HEARTBEAT), f);
    return 0;
}

int comm_encode_auth_status(comm_t *c, const auth_t *s, hal_can_frame_t f[2])
{
    /* By hand, not with the generated packers, for the 32 KB budget (the
     * layout is mstc.dbc's; test_comm.c checks both frames against the
     * codec). AUTH_STATUS: last bits 12..15, session 16..47, refused 48..62,
     * refused_saturated 63. AUTH_CHALLENGE: freshness bits 12..31, the MAC
     * in bytes 4..7 in order. */
    f[0].data[1] = (uint8_t)(s->outcome << 4);
    for (size_t i = 0; i < 4u; i++) {
        f[0].data[2u + i] = (uint8_t)(s->session >> (8u * i));
    }
    f[0].data[6] = (uint8_t)(s->refused & 0xFFu);
    f[0].data[7] =
        (uint8_t)(((unsigned)s->refused >> 8) & 0x7Fu) | (s->refused_saturated ? 0x80u : 0u);
    e2e_protect(c, frame_index(COMM_ID_AUTH_STATUS), &f[0]);
    f[1].data[1] = (uint8_t)((s->fv & 0x0Fu) << 4);
    f[1].data[2] = (uint8_t)((s->fv >> 4) & 0xFFu);
    f[1].data[3] = (uint8_t)((s->fv >> 12) & 0xFFu);
    auth_status_mac(s, COMM_AUTH_CHALLENGE_DATA_ID, &f[1].data[4]);
    e2e_protect(c, frame_index(COMM_ID_AUTH_CHALLENGE), &f[1]);
    return 0;
}

int comm_encode_param_value(comm_t *c, uint8_t index, comm_param_result_t result, float value,
                            hal_can_frame_t *f)
{
    const struct mstc_dbc_param_value_t s = {
        .param_value_index = index, /* echoed as received (comm.h) */
        .param_value_result =
            sat_u8((uint32_t)result, MSTC_DBC_PARAM_VALUE_PARAM_VALUE_RESULT_ARMED_CHOICE),
        .param_value_value = value,
    };
    (void)mstc_dbc_param_value_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_PARAM_VALUE), f);
    return 0;
}

int comm_encode_fw_version(comm_t *c, const comm_fw_version_t *v, hal_can_frame_t *f)
{
    const struct mstc_dbc_fw_version_t s = {
        .fw_version_node = c->node,
        .fw_version_numeric = v->fixed ? 1u : 0u,
        .fw_version_protocol = (uint8_t)COMM_PROTOCOL_VERSION,
        .fw_version_major = sat_u8(v->major, 15u),
        .fw_version_minor = sat_u8(v->minor, 63u),
        .fw_version_patch = sat_u8(v->patch, 31u),
        .fw_version_dirty = v->dirty ? 1u : 0u,
        .fw_version_build = v->build & 0x0FFFFFFFu,
    };
    (void)mstc_dbc_fw_version_pack(f->data, &s, FRAME_LEN);
    e2e_protect(c, frame_index(COMM_ID_FW_VERSION), f);
    return 0;
}
