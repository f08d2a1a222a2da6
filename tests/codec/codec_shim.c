/* SPDX-License-Identifier: MIT */
/*
 * A plain C ABI over the generated codec (mstc_dbc.c) and the protocol
 * adapter (comm.c), for tests/python/test_codec.py, which builds it as a
 * shared library with the project's warnings and loads it with ctypes.
 *
 * Values cross the ABI as arrays of double: every raw signal of the DBC (at
 * most 32 bits, or an IEEE single) is exact in a double. This is test code;
 * the firmware itself has no double.
 */
#include <errno.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "comm/comm.h"
#include "comm/mstc_dbc.h"

/* The exported functions are this file's interface; they need no header. */
#pragma GCC diagnostic ignored "-Wmissing-prototypes"

/* ------------------------------------------------------ generated codec */

typedef enum { K_U8, K_U16, K_U32, K_I16, K_I32, K_F32 } kind_t;

typedef struct {
    const char *name; /* the generated struct member: the DBC name in snake case */
    size_t offset;
    kind_t kind;
} field_t;

typedef struct {
    uint32_t id;
    size_t size;
    const field_t *fields;
    size_t n_fields;
    int (*pack)(uint8_t *dst, const void *src);
    int (*unpack)(void *dst, const uint8_t *src);
} msg_t;

#define KIND_OF(expr)                                                                              \
    _Generic((expr), uint8_t                                                                       \
             : K_U8, uint16_t                                                                      \
             : K_U16, uint32_t                                                                     \
             : K_U32, int16_t                                                                      \
             : K_I16, int32_t                                                                      \
             : K_I32, float                                                                        \
             : K_F32)
#define FIELD(msg, member)                                                                         \
    {                                                                                              \
#member, offsetof(struct mstc_dbc_##msg##_t, member),                                      \
            KIND_OF(((struct mstc_dbc_##msg##_t *)0)->member)                                      \
    }
/* One message: its fields in DBC order, and pack/unpack wrappers of one type. */
#define MSG(msg, ...)                                                                              \
    static const field_t msg##_fields[] = { __VA_ARGS__ };                                         \
    static int msg##_pack(uint8_t *dst, const void *src)                                           \
    {                                                                                              \
        return mstc_dbc_##msg##_pack(dst, src, 8);                                                 \
    }                                                                                              \
    static int msg##_unpack(void *dst, const uint8_t *src)                                         \
    {                                                                                              \
        return mstc_dbc_##msg##_unpack(dst, src, 8);                                               \
    }
#define ENTRY(msg, MSG_UPPER)                                                                      \
    {                                                                                              \
        MSTC_DBC_##MSG_UPPER##_FRAME_ID, sizeof(struct mstc_dbc_##msg##_t), msg##_fields,          \
            sizeof msg##_fields / sizeof msg##_fields[0], msg##_pack, msg##_unpack                 \
    }

MSG(odom_xy, FIELD(odom_xy, odom_xy_crc), FIELD(odom_xy, odom_xy_counter),
    FIELD(odom_xy, odom_xy_x), FIELD(odom_xy, odom_xy_y))
MSG(odom_theta, FIELD(odom_theta, odom_theta_crc), FIELD(odom_theta, odom_theta_counter),
    FIELD(odom_theta, odom_theta_theta))
MSG(ref_xy, FIELD(ref_xy, ref_xy_crc), FIELD(ref_xy, ref_xy_counter), FIELD(ref_xy, ref_xy_x),
    FIELD(ref_xy, ref_xy_y))
MSG(ref_motion, FIELD(ref_motion, ref_motion_crc), FIELD(ref_motion, ref_motion_counter),
    FIELD(ref_motion, ref_motion_theta), FIELD(ref_motion, ref_motion_v),
    FIELD(ref_motion, ref_motion_w))
MSG(step, FIELD(step, step_crc), FIELD(step, step_counter), FIELD(step, step_step),
    FIELD(step, step_time))
MSG(obstacle, FIELD(obstacle, obstacle_crc), FIELD(obstacle, obstacle_counter),
    FIELD(obstacle, obstacle_id), FIELD(obstacle, obstacle_x), FIELD(obstacle, obstacle_y),
    FIELD(obstacle, obstacle_radius))
MSG(obstacle_vel, FIELD(obstacle_vel, obstacle_vel_crc), FIELD(obstacle_vel, obstacle_vel_counter),
    FIELD(obstacle_vel, obstacle_vel_id), FIELD(obstacle_vel, obstacle_vel_vx),
    FIELD(obstacle_vel, obstacle_vel_vy))
MSG(wheel_speed, FIELD(wheel_speed, wheel_speed_crc), FIELD(wheel_speed, wheel_speed_counter),
    FIELD(wheel_speed, wheel_speed_left), FIELD(wheel_speed, wheel_speed_right),
    FIELD(wheel_speed, wheel_speed_faults))
MSG(param_set, FIELD(param_set, param_set_crc), FIELD(param_set, param_set_counter),
    FIELD(param_set, param_set_index), FIELD(param_set, param_set_value))
MSG(param_get, FIELD(param_get, param_get_crc), FIELD(param_get, param_get_counter),
    FIELD(param_get, param_get_index))
MSG(param_auth, FIELD(param_auth, param_auth_crc), FIELD(param_auth, param_auth_counter),
    FIELD(param_auth, param_auth_freshness), FIELD(param_auth, param_auth_mac))
MSG(wheel_cmd, FIELD(wheel_cmd, wheel_cmd_crc), FIELD(wheel_cmd, wheel_cmd_counter),
    FIELD(wheel_cmd, wheel_cmd_step), FIELD(wheel_cmd, wheel_cmd_left),
    FIELD(wheel_cmd, wheel_cmd_right))
MSG(status, FIELD(status, status_crc), FIELD(status, status_counter), FIELD(status, status_mode),
    FIELD(status, status_side), FIELD(status, status_obstacle), FIELD(status, status_faults),
    FIELD(status, status_e), FIELD(status, status_distance), FIELD(status, status_step),
    FIELD(status, status_halt))
MSG(status_trk, FIELD(status_trk, status_trk_crc), FIELD(status_trk, status_trk_counter),
    FIELD(status_trk, status_trk_odom_counter), FIELD(status_trk, status_trk_e1),
    FIELD(status_trk, status_trk_e2), FIELD(status_trk, status_trk_e3))
MSG(status_counters, FIELD(status_counters, status_counters_crc),
    FIELD(status_counters, status_counters_counter),
    FIELD(status_counters, status_counters_crc_errors),
    FIELD(status_counters, status_counters_seq_errors),
    FIELD(status_counters, status_counters_len_errors),
    FIELD(status_counters, status_counters_unknown_ids))
MSG(event, FIELD(event, event_crc), FIELD(event, event_counter), FIELD(event, event_kind),
    FIELD(event, event_side), FIELD(event, event_obstacle), FIELD(event, event_time))
MSG(heartbeat, FIELD(heartbeat, heartbeat_crc), FIELD(heartbeat, heartbeat_counter),
    FIELD(heartbeat, heartbeat_state))
MSG(auth_status, FIELD(auth_status, auth_status_crc), FIELD(auth_status, auth_status_counter),
    FIELD(auth_status, auth_status_last), FIELD(auth_status, auth_status_session),
    FIELD(auth_status, auth_status_refused), FIELD(auth_status, auth_status_refused_saturated))
MSG(auth_challenge, FIELD(auth_challenge, auth_challenge_crc),
    FIELD(auth_challenge, auth_challenge_counter), FIELD(auth_challenge, auth_challenge_freshness),
    FIELD(auth_challenge, auth_challenge_mac))
MSG(param_value, FIELD(param_value, param_value_crc), FIELD(param_value, param_value_counter),
    FIELD(param_value, param_value_index), FIELD(param_value, param_value_result),
    FIELD(param_value, param_value_value))

MSG(fw_version_get, FIELD(fw_version_get, fw_version_get_crc),
    FIELD(fw_version_get, fw_version_get_counter))
MSG(fw_version, FIELD(fw_version, fw_version_crc), FIELD(fw_version, fw_version_counter),
    FIELD(fw_version, fw_version_node), FIELD(fw_version, fw_version_numeric),
    FIELD(fw_version, fw_version_protocol), FIELD(fw_version, fw_version_major),
    FIELD(fw_version, fw_version_minor), FIELD(fw_version, fw_version_patch),
    FIELD(fw_version, fw_version_dirty), FIELD(fw_version, fw_version_build))

static const msg_t msgs[] = {
    ENTRY(odom_xy, ODOM_XY),
    ENTRY(odom_theta, ODOM_THETA),
    ENTRY(ref_xy, REF_XY),
    ENTRY(ref_motion, REF_MOTION),
    ENTRY(step, STEP),
    ENTRY(wheel_speed, WHEEL_SPEED),
    ENTRY(obstacle, OBSTACLE),
    ENTRY(obstacle_vel, OBSTACLE_VEL),
    ENTRY(param_set, PARAM_SET),
    ENTRY(param_get, PARAM_GET),
    ENTRY(param_auth, PARAM_AUTH),
    ENTRY(wheel_cmd, WHEEL_CMD),
    ENTRY(status, STATUS),
    ENTRY(status_trk, STATUS_TRK),
    ENTRY(status_counters, STATUS_COUNTERS),
    ENTRY(event, EVENT),
    ENTRY(heartbeat, HEARTBEAT),
    ENTRY(auth_status, AUTH_STATUS),
    ENTRY(auth_challenge, AUTH_CHALLENGE),
    ENTRY(param_value, PARAM_VALUE),
    ENTRY(fw_version_get, FW_VERSION_GET),
    ENTRY(fw_version, FW_VERSION),
};
#define N_MSGS (sizeof msgs / sizeof msgs[0])

/* Room for any generated struct (checked against msg_t.size), aligned for all. */
typedef union {
    uint64_t align;
    unsigned char bytes[64];
} any_msg_t;

static const msg_t *find(uint32_t id)
{
    for (size_t i = 0; i < N_MSGS; i++) {
        if (msgs[i].id == id) {
            return &msgs[i];
        }
    }
    return NULL;
}

/** Number of messages the shim knows. */
int shim_n_messages(void) { return (int)N_MSGS; }

/** Identifier of message @p i. */
uint32_t shim_message_id(int i) { return msgs[i].id; }

/** Number of signals of message @p id, or -ENOENT. */
int shim_n_fields(uint32_t id)
{
    const msg_t *m = find(id);
    return m != NULL ? (int)m->n_fields : -ENOENT;
}

/** The generated member name of signal @p i of message @p id. */
const char *shim_field_name(uint32_t id, int i) { return find(id)->fields[i].name; }

/** Pack @p values (raw, DBC signal order) with the generated packer. */
int shim_pack(uint32_t id, const double *values, uint8_t *out)
{
    const msg_t *m = find(id);
    if (m == NULL || m->size > sizeof(any_msg_t)) {
        return -ENOENT;
    }
    any_msg_t s;
    memset(&s, 0, sizeof s);
    for (size_t i = 0; i < m->n_fields; i++) {
        unsigned char *p = s.bytes + m->fields[i].offset;
        const double v = values[i];
        switch (m->fields[i].kind) {
        case K_U8: *(uint8_t *)p = (uint8_t)v; break;
        case K_U16: memcpy(p, &(uint16_t){ (uint16_t)v }, 2); break;
        case K_U32: memcpy(p, &(uint32_t){ (uint32_t)v }, 4); break;
        case K_I16: memcpy(p, &(int16_t){ (int16_t)v }, 2); break;
        case K_I32: memcpy(p, &(int32_t){ (int32_t)v }, 4); break;
        case K_F32: memcpy(p, &(float){ (float)v }, 4); break;
        }
    }
    return m->pack(out, &s);
}

/** Unpack @p in with the generated unpacker into @p values (raw, DBC order). */
int shim_unpack(uint32_t id, const uint8_t *in, double *values)
{
    const msg_t *m = find(id);
    if (m == NULL || m->size > sizeof(any_msg_t)) {
        return -ENOENT;
    }
    any_msg_t s;
    memset(&s, 0, sizeof s);
    const int rc = m->unpack(&s, in);
    for (size_t i = 0; i < m->n_fields; i++) {
        const unsigned char *p = s.bytes + m->fields[i].offset;
        switch (m->fields[i].kind) {
        case K_U8: values[i] = (double)*p; break;
        case K_U16: {
            uint16_t v;
            memcpy(&v, p, 2);
            values[i] = (double)v;
            break;
        }
        case K_U32: {
            uint32_t v;
            memcpy(&v, p, 4);
            values[i] = (double)v;
            break;
        }
        case K_I16: {
            int16_t v;
            memcpy(&v, p, 2);
            values[i] = (double)v;
            break;
        }
        case K_I32: {
            int32_t v;
            memcpy(&v, p, 4);
            values[i] = (double)v;
            break;
        }
        case K_F32: {
            float v;
            memcpy(&v, p, 4);
            values[i] = (double)v;
            break;
        }
        }
    }
    return rc;
}

/* ------------------------------------------------------------ comm.c */

static comm_t comm;

/** comm_init() of the shim's one protocol state. */
void shim_comm_init(void) { comm_init(&comm); }

/** comm_data_id(): the data ID, or a negative errno. */
int shim_data_id(uint32_t id)
{
    uint16_t did;
    const int rc = comm_data_id(id, &did);
    return rc != 0 ? rc : (int)did;
}

/** The drop counters: crc, seq, len, unknown. */
void shim_comm_drops(unsigned out[4])
{
    out[0] = comm.drops.crc;
    out[1] = comm.drops.seq;
    out[2] = comm.drops.len;
    out[3] = comm.drops.unknown;
}

static num_t num(double v) { return num_from_float((float)v); }

/**
 * Encode a frame the firmware sends, from physical inputs:
 *   WHEEL_CMD       step, left, right
 *   WHEEL_SPEED     left, right, faults
 *   STATUS          mode, side (avd_side_t), active obstacle, ctl faults, e,
 *                   distance (of the only obstacle remembered, id max(active, 1)),
 *                   step, frame_faults, halt
 *   STATUS_TRK      e1, e2, e3
 *   STATUS_COUNTERS crc, seq, len, unknown (set as the drop counts)
 *   EVENT           kind, side (avd_side_t), obstacle, t_us
 *   HEARTBEAT       state
 *   AUTH_STATUS     last, session, refused, refused_saturated
 *   AUTH_CHALLENGE  the same, then freshness (the status MAC under the
 *                   all-zero key)
 *   PARAM_VALUE     index, result, value
 *   FW_VERSION      major, minor, patch, dirty, build, fixed (node 0)
 * @retval the encoder's result, or -ENOENT for another identifier.
 */
int shim_comm_encode(uint32_t id, const double *in, uint8_t *out)
{
    hal_can_frame_t f;
    int rc;
    switch (id) {
    case COMM_ID_WHEEL_CMD: {
        const kin_wheels_t w = { num(in[1]), num(in[2]) };
        rc = comm_encode_wheel_cmd(&comm, (uint16_t)in[0], &w, &f);
        break;
    }
    case COMM_ID_WHEEL_SPEED: {
        const kin_wheels_t w = { num(in[0]), num(in[1]) };
        rc = comm_encode_wheel_speed_faults(&comm, &w, (uint8_t)in[2], &f);
        break;
    }
    case COMM_ID_STATUS: {
        ctl_status_t st;
        memset(&st, 0, sizeof st);
        st.mode = (sup_mode_t)in[0];
        st.side = (avd_side_t)in[1];
        st.active_obstacle = (uint8_t)in[2];
        st.faults = (uint8_t)in[3];
        st.e = num(in[4]);
        st.n_obstacles = 1;
        st.obstacle_id[0] = st.active_obstacle != 0u ? st.active_obstacle : 1u;
        st.distance[0] = num(in[5]);
        rc = comm_encode_status(&comm, &st, (uint16_t)in[6], in[7] != 0.0, (uint8_t)in[8], &f);
        break;
    }
    case COMM_ID_STATUS_TRK: {
        const trk_err_t e = { num(in[0]), num(in[1]), num(in[2]) };
        rc = comm_encode_status_trk(&comm, &e, (uint8_t)in[3], &f);
        break;
    }
    case COMM_ID_STATUS_COUNTERS:
        comm.drops =
            (comm_counters_t){ (uint16_t)in[0], (uint16_t)in[1], (uint16_t)in[2], (uint16_t)in[3] };
        rc = comm_encode_counters(&comm, &f);
        break;
    case COMM_ID_EVENT: {
        const sup_event_t e = { .kind = (uint8_t)in[0],
                                .side = (int8_t)in[1],
                                .obstacle = (uint8_t)in[2],
                                .t_us = (uint64_t)in[3] };
        rc = comm_encode_event(&comm, &e, &f);
        break;
    }
    case COMM_ID_HEARTBEAT: rc = comm_encode_heartbeat(&comm, (comm_state_t)in[0], &f); break;
    case COMM_ID_AUTH_STATUS:
    case COMM_ID_AUTH_CHALLENGE: {
        static const uint8_t zero_key[AUTH_KEY_LEN] = { 0 };
        auth_t s;
        auth_init(&s);
        auth_set_key(&s, zero_key, (uint32_t)in[1]);
        s.outcome = (uint8_t)in[0];
        s.session = (uint32_t)in[1];
        s.refused = (uint16_t)in[2];
        s.refused_saturated = in[3] != 0.0;
        s.fv = id == COMM_ID_AUTH_CHALLENGE ? (uint32_t)in[4] : 0u;
        hal_can_frame_t two[2];
        rc = comm_encode_auth_status(&comm, &s, two);
        f = two[id == COMM_ID_AUTH_CHALLENGE ? 1 : 0];
        break;
    }
    case COMM_ID_PARAM_VALUE:
        rc = comm_encode_param_value(&comm, (uint8_t)in[0], (comm_param_result_t)in[1],
                                     (float)in[2], &f);
        break;
    case COMM_ID_FW_VERSION: {
        const comm_fw_version_t v = { .major = (uint8_t)in[0],
                                      .minor = (uint8_t)in[1],
                                      .patch = (uint8_t)in[2],
                                      .dirty = in[3] != 0.0,
                                      .build = (uint32_t)in[4],
                                      .fixed = in[5] != 0.0 };
        rc = comm_encode_fw_version(&comm, &v, &f);
        break;
    }
    default: return -ENOENT;
    }
    if (f.id != id || f.dlc != 8u) {
        return -EPROTO;
    }
    memcpy(out, f.data, 8);
    return rc;
}

/**
 * comm_decode() of a frame; on success @p out holds:
 *   ODOM_XY, REF_XY x, y; ODOM_THETA theta; REF_MOTION theta, v, w;
 *   STEP step, time_us; WHEEL_SPEED left, right; OBSTACLE id, x, y, radius;
 *   OBSTACLE_VEL id, vx, vy;
 *   PARAM_SET index, value; PARAM_GET index; PARAM_AUTH freshness, mac (bytes 4..7
 *   read little-endian, as the DBC's signal).
 * @retval comm_decode()'s result.
 */
int shim_comm_decode(uint32_t id, uint8_t dlc, const uint8_t *data, double *out)
{
    hal_can_frame_t f = { .id = id, .dlc = dlc };
    memcpy(f.data, data, dlc <= 8u ? dlc : 8u);
    comm_msg_t m;
    const int rc = comm_decode(&comm, &f, &m);
    if (rc != 0) {
        return rc;
    }
    switch (m.id) {
    case COMM_ID_ODOM_XY:
    case COMM_ID_REF_XY:
        out[0] = (double)num_to_float(m.u.xy.x);
        out[1] = (double)num_to_float(m.u.xy.y);
        break;
    case COMM_ID_ODOM_THETA: out[0] = (double)num_to_float(m.u.theta); break;
    case COMM_ID_REF_MOTION:
        out[0] = (double)num_to_float(m.u.ref_motion.theta);
        out[1] = (double)num_to_float(m.u.ref_motion.v);
        out[2] = (double)num_to_float(m.u.ref_motion.w);
        break;
    case COMM_ID_STEP:
        out[0] = (double)m.u.step.step;
        out[1] = (double)m.u.step.time_us;
        break;
    case COMM_ID_OBSTACLE:
        out[0] = (double)m.u.obstacle.id;
        out[1] = (double)num_to_float(m.u.obstacle.x);
        out[2] = (double)num_to_float(m.u.obstacle.y);
        out[3] = (double)num_to_float(m.u.obstacle.radius);
        break;
    case COMM_ID_WHEEL_SPEED:
        out[0] = (double)num_to_float(m.u.wheel_speed.speed.left);
        out[1] = (double)num_to_float(m.u.wheel_speed.speed.right);
        break;
    case COMM_ID_OBSTACLE_VEL:
        out[0] = (double)m.u.obstacle_vel.id;
        out[1] = (double)num_to_float(m.u.obstacle_vel.vx);
        out[2] = (double)num_to_float(m.u.obstacle_vel.vy);
        break;
    case COMM_ID_PARAM_SET:
        out[0] = (double)m.u.param_set.index;
        out[1] = (double)m.u.param_set.value;
        break;
    case COMM_ID_PARAM_GET: out[0] = (double)m.u.param_get; break;
    case COMM_ID_FW_VERSION_GET: break; /* no signal but CRC and counter */
    case COMM_ID_PARAM_AUTH:
        out[0] = (double)m.u.param_auth.freshness_low;
        out[1] =
            (double)((uint32_t)m.u.param_auth.mac[0] | (uint32_t)m.u.param_auth.mac[1] << 8 |
                     (uint32_t)m.u.param_auth.mac[2] << 16 | (uint32_t)m.u.param_auth.mac[3] << 24);
        break;
    default: return -EPROTO; /* comm_decode() returned a frame it must not */
    }
    return 0;
}
