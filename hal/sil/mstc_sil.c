/* SPDX-License-Identifier: MIT */
/* The control step as a shared library with a plain C ABI (mstc_sil.h). The
 * numeric conversions of the host side live here, outside the firmware. */
#include "mstc_sil.h"
#include "mstc_sil_wheel.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <string.h>

#include "app/app.h"
#include "auth/auth.h"
#include "ctrl/ctl.h"
#include "hal/hal_can.h"
#include "hal/hal_sys.h"
#include "hal_sil.h"

_Static_assert(MSTC_SIL_MAX_OBSTACLES == SUP_MAX_OBSTACLES, "obstacle table sizes differ");
_Static_assert(MSTC_SIL_MAX_EVENTS == SUP_MAX_EVENTS, "event buffer sizes differ");
_Static_assert(sizeof(mstc_sil_frame_t) == sizeof(hal_can_frame_t) &&
                   offsetof(mstc_sil_frame_t, dlc) == offsetof(hal_can_frame_t, dlc) &&
                   offsetof(mstc_sil_frame_t, data) == offsetof(hal_can_frame_t, data),
               "frame layouts differ");

/* The frame path's firmware instance: one per library, like one board. */
static app_t app;
/* The wheels of its board (mstc_sil_fw_wheels()), or NULL: external drives. */
static void *board_wheels;
/* The application's halt after the last frame or tick: a re-arm clears the
 * board's wheel faults, as hal/stm32/main.c does. */
static uint8_t last_halt;

#if defined(NUM_FIXED)
/* double to Q16.16: rounded to nearest, ties away from zero (as NUM_C and
 * num_from_float), saturated to [NUM_MIN, NUM_MAX]. d·2^16 is exact in double
 * (a power-of-two scale, or ±inf for huge d, which saturates). Q16.16 has no
 * NaN or inf, so ctl_step cannot see them: they give 0 here, which
 * ctl_params_check rejects for a parameter (every one must be > 0), and
 * mstc_sil_step catches them in poses, velocities and obstacle reports before
 * converting (input_finite, obstacle_id), taking the path the firmware takes
 * for them in float mode. */
static num_t from_d(double d)
{
    if (!isfinite(d)) {
        return NUM_ZERO;
    }
    const double v = d * 65536.0;
    if (v >= 2147483647.5) {
        return NUM_MAX;
    }
    if (v <= -2147483648.5) {
        return NUM_MIN;
    }
    return (num_t)round(v);
}
/* Q16.16 to double: exact. */
static double to_d(num_t n) { return (double)n / 65536.0; }

/* Float mode's ctl_step rejects a non-finite pose or velocity (mode STOP,
 * CTL_FAULT_INPUT_NONFINITE, supervisor untouched); fixed mode checks here. */
static bool input_finite(const mstc_sil_input_t *in)
{
    const double v[] = { in->robot[0],
                         in->robot[1],
                         in->robot[2],
                         in->ref[0],
                         in->ref[1],
                         in->ref[2],
                         in->v_r,
                         in->w_r,
                         in->wheel_measured != 0u ? in->wheel_speed[0] : 0.0,
                         in->wheel_measured != 0u ? in->wheel_speed[1] : 0.0 };
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++) {
        if (!isfinite(v[i])) {
            return false;
        }
    }
    return true;
}
#else
/* double to num_t; non-finite values are kept non-finite in float mode, so the
 * firmware's own input check sees them. */
static num_t from_d(double d) { return num_from_float((float)d); }
static double to_d(num_t n) { return (double)num_to_float(n); }
#endif

/* The obstacle id the firmware gets: 0 (a report it drops and counts) for an
 * id out of range and, in fixed mode, for a non-finite coordinate, radius or
 * velocity, which the step drops in float mode. */
static uint8_t obstacle_id(const mstc_sil_obstacle_t *o)
{
#if defined(NUM_FIXED)
    if (!isfinite(o->x) || !isfinite(o->y) || !isfinite(o->radius) || !isfinite(o->vx) ||
        !isfinite(o->vy)) {
        return 0u;
    }
#endif
    return o->id <= 255u ? (uint8_t)o->id : 0u;
}

size_t mstc_sil_size(void) { return sizeof(ctl_t); }

const char *mstc_sil_numeric(void) { return NUM_MODE_NAME; }

void mstc_sil_defaults(mstc_sil_params_t *p)
{
    ctl_params_t c;
    ctl_params_default(&c);
    *p = (mstc_sil_params_t){
        .r_m = to_d(c.r_m),
        .r_ob = to_d(c.r_ob),
        .d_det = to_d(c.d_det),
        .d_act = to_d(c.d_act),
        .d_s = to_d(c.d_s),
        .trk_k = { to_d(c.trk.k1), to_d(c.trk.k2), to_d(c.trk.k3) },
        .avd_k = { to_d(c.avd.k1), to_d(c.avd.k2) },
        .wheel_radius = to_d(c.kin.wheel_radius),
        .track_width = to_d(c.kin.track_width),
        .max_wheel_speed = to_d(c.kin.max_wheel_speed),
        .strategy = ctl_is_mstc(&c) ? (uint32_t)CTL_STRATEGY_MSTC : (uint32_t)CTL_STRATEGY_PAPER,
        .wheel_accel = to_d(c.wheel_accel),
        .wheel_tau = to_d(c.wheel_tau),
    };
}

static ctl_params_t params_from(const mstc_sil_params_t *p)
{
    /* What the ABI does not carry (max_wheel_decel) keeps its default. */
    ctl_params_t c;
    ctl_params_default(&c);
    c.r_m = from_d(p->r_m);
    c.r_ob = from_d(p->r_ob);
    c.d_det = from_d(p->d_det);
    c.d_act = from_d(p->d_act);
    c.d_s = from_d(p->d_s);
    c.trk = (trk_gains_t){ from_d(p->trk_k[0]), from_d(p->trk_k[1]), from_d(p->trk_k[2]) };
    c.avd = (avd_gains_t){ from_d(p->avd_k[0]), from_d(p->avd_k[1]) };
    /* A strategy beyond 1 becomes 2, outside the table's range: refused. */
    c.strategy = num_from_int(p->strategy <= 2u ? (int32_t)p->strategy : 2);
    c.kin = (kin_params_t){ from_d(p->wheel_radius), from_d(p->track_width),
                            from_d(p->max_wheel_speed) };
    c.wheel_accel = from_d(p->wheel_accel);
    c.wheel_tau = from_d(p->wheel_tau);
    return c;
}

int mstc_sil_init(void *mem, const mstc_sil_params_t *p)
{
    if (mem == NULL || p == NULL) {
        return -EINVAL;
    }
    const ctl_params_t c = params_from(p);
    return ctl_init((ctl_t *)mem, &c);
}

int mstc_sil_fw_init(const mstc_sil_params_t *p)
{
    hal_sil_reset();
    board_wheels = NULL;
    const ctl_params_t c = p != NULL ? params_from(p) : (ctl_params_t){ 0 };
    const int rc = app_init(&app, p != NULL ? &c : NULL);
    last_halt = app.halt;
    return rc;
}

int mstc_sil_fw_wheels(void *mem)
{
    board_wheels = mem;
    app_set_wheel_source(&app, mem != NULL ? APP_WHEELS_OWN : APP_WHEELS_EXTERNAL);
    return 0;
}

/* Before a control step: the board's wheel loop's measurement, as a board's
 * main loop hands it. */
static void hand_wheels(void)
{
    kin_wheels_t speed;
    uint8_t faults;
    uint32_t age_us;
    if (board_wheels != NULL &&
        hal_sil_wheels_measurement(board_wheels, &speed, &faults, &age_us)) {
        app_wheels_measured(&app, &speed, faults, age_us);
    }
}

/* After the application ran: a re-arm (the halt cleared) clears the wheel
 * loop's faults, as on a board. */
static void after_app(void)
{
    if (board_wheels != NULL && last_halt != (uint8_t)COMM_HALT_NONE &&
        app.halt == (uint8_t)COMM_HALT_NONE) {
        (void)mstc_sil_wheels_clear_faults(board_wheels);
    }
    last_halt = app.halt;
}

int mstc_sil_fw_set_node(uint8_t node) { return app_set_node(&app, node); }

_Static_assert(MSTC_SIL_KEY_LEN == AUTH_KEY_LEN, "key lengths differ");

int mstc_sil_fw_set_key(const uint8_t *key, size_t len)
{
    if (key == NULL || len != MSTC_SIL_KEY_LEN) {
        return -EINVAL;
    }
    uint32_t session;
    if (hal_sys_boot_nonce(&session) != 0) {
        return -EIO;
    }
    app_set_key(&app, key, session);
    return 0;
}

int mstc_sil_fw_set_session(uint32_t session)
{
    if (!app.auth.keyed) {
        return -EINVAL;
    }
    auth_new_session(&app.auth, session);
    return 0;
}

int mstc_sil_cmac(const uint8_t *key, const uint8_t *msg, size_t len, uint8_t *mac)
{
    if (key == NULL || mac == NULL || (msg == NULL && len > 0u)) {
        return -EINVAL;
    }
    auth_t s;
    auth_init(&s);
    auth_set_key(&s, key, 0u);
    return auth_cmac(&s, msg, len, mac);
}

int mstc_sil_fw_send(const mstc_sil_frame_t *f)
{
    if (f == NULL) {
        return -EINVAL;
    }
    hal_can_frame_t hf = { .id = f->id, .dlc = f->dlc };
    memcpy(hf.data, f->data, sizeof hf.data);
    if (hf.id == COMM_ID_STEP) {
        hand_wheels(); /* a STEP runs a control step */
    }
    const int rc = hal_sil_to_fw(&hf);
    if (rc == 0) {
        (void)app_poll(&app, 0);
        after_app();
    }
    return rc;
}

int mstc_sil_fw_recv(mstc_sil_frame_t *f)
{
    if (f == NULL) {
        return -EINVAL;
    }
    hal_can_frame_t hf;
    const int rc = hal_sil_from_fw(&hf);
    if (rc == 0) {
        *f = (mstc_sil_frame_t){ .id = hf.id, .dlc = hf.dlc };
        memcpy(f->data, hf.data, sizeof f->data);
    }
    return rc;
}

void mstc_sil_fw_tick(uint64_t now_us)
{
    hand_wheels();
    app_control_tick(&app, now_us);
    after_app();
}

int mstc_sil_step(void *mem, const mstc_sil_input_t *in, mstc_sil_output_t *out)
{
    if (mem == NULL || in == NULL || out == NULL || in->n_obstacles > MSTC_SIL_MAX_OBSTACLES ||
        (in->n_obstacles > 0 && in->obstacles == NULL)) {
        return -EINVAL;
    }
#if defined(NUM_FIXED)
    if (!input_finite(in)) {
        *out = (mstc_sil_output_t){ .mode = (int32_t)SUP_MODE_STOP,
                                    .faults = CTL_FAULT_INPUT_NONFINITE };
        return 0;
    }
#endif
    sup_obstacle_t obs[MSTC_SIL_MAX_OBSTACLES];
    for (uint32_t i = 0; i < in->n_obstacles; i++) {
        const mstc_sil_obstacle_t *o = &in->obstacles[i];
        obs[i] = (sup_obstacle_t){ .id = obstacle_id(o),
                                   .x = from_d(o->x),
                                   .y = from_d(o->y),
                                   .radius = from_d(o->radius),
                                   .vx = from_d(o->vx),
                                   .vy = from_d(o->vy) };
    }
    const ctl_input_t ci = {
        .robot = { from_d(in->robot[0]), from_d(in->robot[1]), from_d(in->robot[2]) },
        .ref = { from_d(in->ref[0]), from_d(in->ref[1]), from_d(in->ref[2]) },
        .v_r = from_d(in->v_r),
        .w_r = from_d(in->w_r),
        .obstacles = obs,
        .n_obstacles = in->n_obstacles,
        .t_us = in->t_us,
        .wheels = { from_d(in->wheel_speed[0]), from_d(in->wheel_speed[1]) },
        .wheels_measured = in->wheel_measured != 0u,
        /* As the application takes a board's: through float in both modes. */
        .wheels_age = num_from_float((float)in->wheel_age_us * 1.0e-6f),
    };
    ctl_output_t co;
    ctl_step((ctl_t *)mem, &ci, &co);

    const ctl_status_t *st = &co.status;
    out->wheel_left = to_d(co.wheels.left);
    out->wheel_right = to_d(co.wheels.right);
    out->mode = (int32_t)st->mode;
    out->active_obstacle = st->active_obstacle;
    out->side = (int32_t)st->side;
    out->faults = st->faults;
    out->e1 = to_d(st->err.e1);
    out->e2 = to_d(st->err.e2);
    out->e3 = to_d(st->err.e3);
    out->e = to_d(st->e);
    out->v = to_d(st->v);
    out->w = to_d(st->w);
    out->n_obstacles = st->n_obstacles;
    for (uint32_t i = 0; i < st->n_obstacles; i++) {
        out->obstacle_id[i] = st->obstacle_id[i];
        out->distance[i] = to_d(st->distance[i]);
    }
    out->n_events = (uint32_t)co.n_events;
    for (size_t i = 0; i < co.n_events; i++) {
        const sup_event_t *e = &co.events[i];
        out->events[i] = (mstc_sil_event_t){
            .t_us = e->t_us, .kind = e->kind, .obstacle = e->obstacle, .side = e->side
        };
    }
    return 0;
}

size_t mstc_sil_batch_stride(void) { return (sizeof(ctl_t) + 15u) & ~(size_t)15u; }

/* A table that fits, and nothing reported beyond it. */
static bool batch_input_valid(const mstc_sil_batch_input_t *in)
{
    const uint32_t n = in->in.n_obstacles;
    if (n > MSTC_SIL_MAX_OBSTACLES) {
        return false;
    }
    for (uint32_t j = n; j < MSTC_SIL_MAX_OBSTACLES; j++) {
        if (in->reported[j] != 0u) {
            return false;
        }
    }
    return true;
}

int mstc_sil_step_batch(void *mem, size_t n, const mstc_sil_batch_input_t *in,
                        const uint8_t *active, mstc_sil_output_t *out)
{
    if (n == 0u) {
        return 0;
    }
    if (mem == NULL || in == NULL || out == NULL) {
        return -EINVAL;
    }
    for (size_t i = 0; i < n; i++) {
        if ((active == NULL || active[i] != 0u) && !batch_input_valid(&in[i])) {
            return -EINVAL;
        }
    }
    const size_t stride = mstc_sil_batch_stride();
    for (size_t i = 0; i < n; i++) {
        if (active != NULL && active[i] == 0u) {
            continue;
        }
        /* The reported entries, in table order: the list mstc_sil_step gets. */
        mstc_sil_obstacle_t seen[MSTC_SIL_MAX_OBSTACLES];
        uint32_t count = 0u;
        for (uint32_t j = 0; j < in[i].in.n_obstacles; j++) {
            if (in[i].reported[j] != 0u) {
                seen[count++] = in[i].table[j];
            }
        }
        mstc_sil_input_t one = in[i].in;
        one.n_obstacles = count;
        one.obstacles = seen;
        (void)mstc_sil_step((unsigned char *)mem + i * stride, &one, &out[i]);
    }
    return 0;
}

/* The layout table of mstc_sil_layout(). A field added to a struct of
 * mstc_sil.h is added here too; the Python bindings refuse a library whose
 * table and their own structs disagree, naming the struct and field. */
#define LAYOUT_STRUCT(t)   MSTC_SIL_LAYOUT_STRUCT(t)
#define LAYOUT_FIELD(t, f) MSTC_SIL_LAYOUT_FIELD(t, f)

static const mstc_sil_layout_t layout[] = {
    LAYOUT_STRUCT(mstc_sil_params_t),
    LAYOUT_FIELD(mstc_sil_params_t, r_m),
    LAYOUT_FIELD(mstc_sil_params_t, r_ob),
    LAYOUT_FIELD(mstc_sil_params_t, d_det),
    LAYOUT_FIELD(mstc_sil_params_t, d_act),
    LAYOUT_FIELD(mstc_sil_params_t, d_s),
    LAYOUT_FIELD(mstc_sil_params_t, trk_k),
    LAYOUT_FIELD(mstc_sil_params_t, avd_k),
    LAYOUT_FIELD(mstc_sil_params_t, wheel_radius),
    LAYOUT_FIELD(mstc_sil_params_t, track_width),
    LAYOUT_FIELD(mstc_sil_params_t, max_wheel_speed),
    LAYOUT_FIELD(mstc_sil_params_t, strategy),
    LAYOUT_FIELD(mstc_sil_params_t, wheel_accel),
    LAYOUT_FIELD(mstc_sil_params_t, wheel_tau),

    LAYOUT_STRUCT(mstc_sil_obstacle_t),
    LAYOUT_FIELD(mstc_sil_obstacle_t, id),
    LAYOUT_FIELD(mstc_sil_obstacle_t, x),
    LAYOUT_FIELD(mstc_sil_obstacle_t, y),
    LAYOUT_FIELD(mstc_sil_obstacle_t, radius),
    LAYOUT_FIELD(mstc_sil_obstacle_t, vx),
    LAYOUT_FIELD(mstc_sil_obstacle_t, vy),

    LAYOUT_STRUCT(mstc_sil_input_t),
    LAYOUT_FIELD(mstc_sil_input_t, robot),
    LAYOUT_FIELD(mstc_sil_input_t, ref),
    LAYOUT_FIELD(mstc_sil_input_t, v_r),
    LAYOUT_FIELD(mstc_sil_input_t, w_r),
    LAYOUT_FIELD(mstc_sil_input_t, t_us),
    LAYOUT_FIELD(mstc_sil_input_t, n_obstacles),
    LAYOUT_FIELD(mstc_sil_input_t, obstacles),
    LAYOUT_FIELD(mstc_sil_input_t, wheel_speed),
    LAYOUT_FIELD(mstc_sil_input_t, wheel_measured),
    LAYOUT_FIELD(mstc_sil_input_t, wheel_age_us),

    LAYOUT_STRUCT(mstc_sil_event_t),
    LAYOUT_FIELD(mstc_sil_event_t, t_us),
    LAYOUT_FIELD(mstc_sil_event_t, kind),
    LAYOUT_FIELD(mstc_sil_event_t, obstacle),
    LAYOUT_FIELD(mstc_sil_event_t, side),

    LAYOUT_STRUCT(mstc_sil_output_t),
    LAYOUT_FIELD(mstc_sil_output_t, wheel_left),
    LAYOUT_FIELD(mstc_sil_output_t, wheel_right),
    LAYOUT_FIELD(mstc_sil_output_t, mode),
    LAYOUT_FIELD(mstc_sil_output_t, active_obstacle),
    LAYOUT_FIELD(mstc_sil_output_t, side),
    LAYOUT_FIELD(mstc_sil_output_t, faults),
    LAYOUT_FIELD(mstc_sil_output_t, e1),
    LAYOUT_FIELD(mstc_sil_output_t, e2),
    LAYOUT_FIELD(mstc_sil_output_t, e3),
    LAYOUT_FIELD(mstc_sil_output_t, e),
    LAYOUT_FIELD(mstc_sil_output_t, v),
    LAYOUT_FIELD(mstc_sil_output_t, w),
    LAYOUT_FIELD(mstc_sil_output_t, n_obstacles),
    LAYOUT_FIELD(mstc_sil_output_t, obstacle_id),
    LAYOUT_FIELD(mstc_sil_output_t, distance),
    LAYOUT_FIELD(mstc_sil_output_t, n_events),
    LAYOUT_FIELD(mstc_sil_output_t, events),

    LAYOUT_STRUCT(mstc_sil_batch_input_t),
    LAYOUT_FIELD(mstc_sil_batch_input_t, in),
    LAYOUT_FIELD(mstc_sil_batch_input_t, reported),
    LAYOUT_FIELD(mstc_sil_batch_input_t, table),

    LAYOUT_STRUCT(mstc_sil_frame_t),
    LAYOUT_FIELD(mstc_sil_frame_t, id),
    LAYOUT_FIELD(mstc_sil_frame_t, dlc),
    LAYOUT_FIELD(mstc_sil_frame_t, data),
};

const mstc_sil_layout_t *mstc_sil_layout(size_t *n)
{
    if (n != NULL) {
        *n = sizeof layout / sizeof layout[0];
    }
    return layout;
}
