/* SPDX-License-Identifier: MIT */
/* The firmware application: frames in, safety supervisor, control step,
 * frames out (app.h; docs/safety.md). */
#include "app/app.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

#include "hal/hal_can.h"

_Static_assert(APP_TIMEOUT_US == APP_TIMEOUT_PERIODS * APP_PERIOD_US, "timeout in periods");

/* The frame of each watched input (app.h, APP_IN_*). */
static const uint32_t input_id[APP_N_IN] = {
    COMM_ID_ODOM_XY, COMM_ID_ODOM_THETA, COMM_ID_REF_XY, COMM_ID_REF_MOTION, COMM_ID_STEP,
};

int app_init(app_t *a, const ctl_params_t *p)
{
    ctl_params_t defaults;
    ctl_params_default(&defaults);
    *a = (app_t){ .state = COMM_STATE_READY,
                  .halt = (uint8_t)COMM_HALT_NOT_ARMED,
                  .max_decel = num_from_float(APP_DEFAULT_MAX_WHEEL_DECEL) };
    comm_init(&a->comm);
    return ctl_init(&a->ctl, p != NULL ? p : &defaults);
}

/* A frame that cannot be queued is lost; the bus is the only way out, so
 * there is nothing better to do than to carry on (the plant times out). */
static void send(const hal_can_frame_t *f) { (void)hal_can_send(f); }

/* ------------------------------------------------------- safety supervisor */

/* Close the E2E check cycle of input @p k at time @p t_us and say whether it
 * is usable: its state machine VALID and an accepted frame within the
 * timeout, counted in control steps and in time. */
static bool input_usable(app_t *a, size_t k, uint64_t t_us)
{
    app_input_t *in = &a->in[k];
    if (comm_e2e_cycle(&a->comm, input_id[k])) {
        in->missed = 0u;
        in->ever = true;
        in->last_us = t_us;
    } else if (in->missed < UINT8_MAX) {
        in->missed++;
    } else {
        /* saturated: already timed out */
    }
    const comm_rx_t *r = comm_rx(&a->comm, input_id[k]);
    const bool fresh =
        in->ever && in->missed < APP_TIMEOUT_PERIODS && t_us - in->last_us < APP_TIMEOUT_US;
    /* STEP triggers the step it is checked at, so it is fresh and was
     * accepted; its machine may still be in INIT at the first STEP after
     * start-up (the window judges from the second frame on: comm.c). */
    const bool valid = r->state == (uint8_t)COMM_SM_VALID ||
                       (k == (size_t)APP_IN_STEP && r->state == (uint8_t)COMM_SM_INIT);
    return fresh && valid;
}

/* Bus-off now, or since the last look (the count moved). */
static bool bus_off(app_t *a)
{
    hal_can_status_t st;
    if (hal_can_status(&st) != 0) {
        return false; /* -ENOTSUP: a port without a controller (SIL, host) */
    }
    const bool moved = a->bus_off_known && st.bus_off != a->bus_off_count;
    a->bus_off_known = true;
    a->bus_off_count = st.bus_off;
    return moved || st.state == HAL_CAN_STATE_BUS_OFF;
}

/* Why the robot must not move at this step, COMM_HALT_NONE if it may. Every
 * input's cycle is closed whatever the verdict, so that each step feeds each
 * state machine exactly once. */
static comm_halt_t check_inputs(app_t *a, uint64_t t_us, bool lockstep)
{
    bool usable[APP_N_IN];
    for (size_t k = 0; k < APP_N_IN; k++) {
        usable[k] = input_usable(a, k, t_us);
    }
    comm_halt_t why = COMM_HALT_NONE;
    if (bus_off(a)) {
        why = COMM_HALT_BUS_OFF;
    } else if (!usable[APP_IN_ODOM_XY] || !usable[APP_IN_ODOM_THETA]) {
        why = COMM_HALT_ODOMETRY;
    } else if (!usable[APP_IN_REF_XY] || !usable[APP_IN_REF_MOTION]) {
        why = COMM_HALT_REFERENCE;
    } else if (lockstep && !usable[APP_IN_STEP]) {
        why = COMM_HALT_STEP;
    } else {
        /* every input usable */
    }
    return why;
}

/* Step the wheel speeds down towards zero by at most max_decel·dt, both by
 * one factor so that the curvature is kept (the robot stays on its arc). */
static void ramp_down(app_t *a, uint32_t dt_us)
{
    /* Through float in both modes: 1 µs is below Q16.16's resolution, so
     * num_from_int(1000000) cannot serve as the divisor. */
    const num_t dt = num_from_float((float)dt_us * 1.0e-6f);
    const num_t step = num_mul(a->max_decel, dt);
    const num_t l = num_abs(a->wheels.left);
    const num_t r = num_abs(a->wheels.right);
    const num_t m = num_max(l, r);
    if (m <= step) {
        a->wheels = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
    } else {
        const num_t k = num_div(num_sub(m, step), m);
        a->wheels.left = num_mul(a->wheels.left, k);
        a->wheels.right = num_mul(a->wheels.right, k);
    }
}

bool app_ready(const app_t *a)
{
    for (size_t k = 0; k < APP_IN_STEP; k++) {
        const comm_rx_t *r = comm_rx(&a->comm, input_id[k]);
        if (r->state != (uint8_t)COMM_SM_VALID || r->ok_run < APP_REARM_FRAMES) {
            return false;
        }
    }
    hal_can_status_t st;
    return hal_can_status(&st) != 0 || st.state != HAL_CAN_STATE_BUS_OFF;
}

int app_arm(app_t *a, bool arm)
{
    if (!arm) {
        if (a->halt == (uint8_t)COMM_HALT_NONE) {
            a->halt = (uint8_t)COMM_HALT_NOT_ARMED;
        }
        return 0;
    }
    if (!app_ready(a)) {
        return -EAGAIN;
    }
    /* The timeouts are not reset: the next step needs fresh frames of its
     * own, as every step does. */
    a->halt = (uint8_t)COMM_HALT_NONE;
    return 0;
}

/* ------------------------------------------------------------ control step */

static void control_step(app_t *a, uint16_t step, uint64_t t_us, bool lockstep)
{
    app_housekeeping(a, t_us);
    const uint64_t dt64 = a->stepped && t_us > a->last_step_us ? t_us - a->last_step_us : 0u;
    const uint32_t dt_us = dt64 < APP_MAX_DT_US ? (uint32_t)dt64 : APP_MAX_DT_US;
    a->last_step_us = t_us;
    a->stepped = true;

    const comm_halt_t why = check_inputs(a, t_us, lockstep);
    if (a->halt == (uint8_t)COMM_HALT_NONE && why != COMM_HALT_NONE) {
        a->halt = (uint8_t)why; /* latched until re-armed */
    }

    ctl_output_t out;
    if (a->halt == (uint8_t)COMM_HALT_NONE) {
        const ctl_input_t in = {
            .robot = a->odom,
            .ref = a->ref,
            .v_r = a->v_r,
            .w_r = a->w_r,
            .obstacles = a->reports,
            .n_obstacles = a->n_reports,
            .t_us = t_us,
        };
        ctl_step(&a->ctl, &in, &out);
        a->wheels = out.wheels;
        a->state = out.status.mode == SUP_MODE_STOP ? COMM_STATE_STOPPED : COMM_STATE_RUNNING;
    } else {
        /* Halted: the controller does not run (its state stays as it was),
         * the wheels ramp down from where they were. */
        out = (ctl_output_t){ .status = { .mode = SUP_MODE_STOP, .side = AVD_SIDE_NONE } };
        ramp_down(a, dt_us);
        out.wheels = a->wheels;
        a->state = a->halt == (uint8_t)COMM_HALT_NOT_ARMED ? COMM_STATE_READY : COMM_STATE_FAULT;
    }
    a->n_reports = 0;
    a->step = step;
    a->steps++;

    hal_can_frame_t f;
    for (size_t i = 0; i < out.n_events; i++) {
        (void)comm_encode_event(&a->comm, &out.events[i], &f);
        send(&f);
    }
    (void)comm_encode_status(&a->comm, &out.status, step, a->frame_dropped, a->halt, &f);
    send(&f);
    a->frame_dropped = false;
    (void)comm_encode_status_trk(&a->comm, &out.status.err, a->odom_counter, &f);
    send(&f);
    /* Last: it tells a lock-step plant that the step's telemetry is out. */
    (void)comm_encode_wheel_cmd(&a->comm, step, &out.wheels, &f);
    send(&f);
}

/* -------------------------------------------------------------- parameters */

static num_t *param_slot(ctl_params_t *p, uint8_t index)
{
    switch (index) {
    case COMM_PARAM_R_M: return &p->r_m;
    case COMM_PARAM_R_OB: return &p->r_ob;
    case COMM_PARAM_D_DET: return &p->d_det;
    case COMM_PARAM_D_ACT: return &p->d_act;
    case COMM_PARAM_D_S: return &p->d_s;
    case COMM_PARAM_TRK_K1: return &p->trk.k1;
    case COMM_PARAM_TRK_K2: return &p->trk.k2;
    case COMM_PARAM_TRK_K3: return &p->trk.k3;
    case COMM_PARAM_AVD_K1: return &p->avd.k1;
    case COMM_PARAM_AVD_K2: return &p->avd.k2;
    case COMM_PARAM_WHEEL_RADIUS: return &p->kin.wheel_radius;
    case COMM_PARAM_TRACK_WIDTH: return &p->kin.track_width;
    case COMM_PARAM_MAX_WHEEL_SPEED: return &p->kin.max_wheel_speed;
    default: return NULL;
    }
}

/* The arm command (PARAM_SET): 1 arms, 0 disarms, anything else is out of
 * range. Answers with the armed state afterwards. */
static comm_param_result_t on_arm(app_t *a, float value)
{
    if (value == 1.0f) {
        return app_arm(a, true) == 0 ? COMM_PARAM_OK : COMM_PARAM_REJECTED;
    }
    if (value == 0.0f) {
        (void)app_arm(a, false);
        return COMM_PARAM_OK;
    }
    return COMM_PARAM_OUT_OF_RANGE;
}

/* max_wheel_decel: finite, > 0 and at most APP_MAX_WHEEL_DECEL_LIMIT. */
static comm_param_result_t on_decel(app_t *a, float value)
{
    /* isfinite() first: an ordered comparison with NaN would raise
     * FE_INVALID. */
    if (!isfinite(value) || value <= 0.0f || value > APP_MAX_WHEEL_DECEL_LIMIT) {
        return COMM_PARAM_REJECTED;
    }
    a->max_decel = num_from_float(value);
    return COMM_PARAM_OK;
}

/* PARAM_SET (with @p set) or PARAM_GET: answer PARAM_VALUE with the value in
 * force afterwards. */
static void on_param(app_t *a, uint8_t index, bool set, float value)
{
    comm_param_result_t result = COMM_PARAM_OK;
    float now;
    if (index == (uint8_t)COMM_PARAM_ARM) {
        result = set ? on_arm(a, value) : COMM_PARAM_OK;
        now = a->halt == (uint8_t)COMM_HALT_NONE ? 1.0f : 0.0f;
    } else if (index == (uint8_t)COMM_PARAM_MAX_WHEEL_DECEL) {
        result = set ? on_decel(a, value) : COMM_PARAM_OK;
        now = num_to_float(a->max_decel);
    } else {
        ctl_params_t p = a->ctl.p;
        num_t *slot = param_slot(&p, index);
        now = 0.0f;
        if (slot == NULL) {
            result = COMM_PARAM_UNKNOWN_INDEX;
        } else {
            if (set) {
                *slot = num_from_float(value);
                if (ctl_set_params(&a->ctl, &p) != 0) {
                    result = COMM_PARAM_REJECTED;
                }
            }
            now = num_to_float(*param_slot(&a->ctl.p, index));
        }
    }
    hal_can_frame_t f;
    (void)comm_encode_param_value(&a->comm, index, result, now, &f);
    send(&f);
}

/* ---------------------------------------------------------------- frames in */

static void on_obstacle(app_t *a, const sup_obstacle_t *o)
{
    /* One report per id per step: a repeat replaces the earlier one. */
    for (uint8_t i = 0; i < a->n_reports; i++) {
        if (a->reports[i].id == o->id) {
            a->reports[i] = *o;
            return;
        }
    }
    if (a->n_reports < SUP_MAX_OBSTACLES) {
        a->reports[a->n_reports] = *o;
        a->n_reports++;
    }
}

int app_on_frame(app_t *a, const hal_can_frame_t *f)
{
    comm_msg_t m;
    const int rc = comm_decode(&a->comm, f, &m);
    if (rc != 0) {
        a->frame_dropped = true;
        return rc;
    }
    switch (m.id) {
    case COMM_ID_ODOM_XY:
        a->odom.x = m.u.xy.x;
        a->odom.y = m.u.xy.y;
        /* The frame was just accepted, so its receiver's counter is this
         * frame's (comm.c follows every frame with a good CRC). */
        a->odom_counter = comm_rx(&a->comm, COMM_ID_ODOM_XY)->counter;
        break;
    case COMM_ID_ODOM_THETA: a->odom.theta = m.u.theta; break;
    case COMM_ID_REF_XY:
        a->ref.x = m.u.xy.x;
        a->ref.y = m.u.xy.y;
        break;
    case COMM_ID_REF_MOTION:
        a->ref.theta = m.u.ref_motion.theta;
        a->v_r = m.u.ref_motion.v;
        a->w_r = m.u.ref_motion.w;
        break;
    case COMM_ID_OBSTACLE: on_obstacle(a, &m.u.obstacle); break;
    case COMM_ID_OBSTACLE_VEL:
        /* Accepted and counted by the E2E receiver; the velocity of moving
         * obstacles is not used by the paper's strategy. */
        break;
    case COMM_ID_STEP: {
        /* The simulator's time, extended past the 32-bit wrap (71.6 min). A
         * time that goes back is taken as a wrap: a jump forward, which times
         * the inputs out rather than holding them. */
        if (a->time_valid && m.u.step.time_us < a->time_raw) {
            a->time_wraps++;
        }
        a->time_raw = m.u.step.time_us;
        a->time_valid = true;
        const uint64_t t_us = ((uint64_t)a->time_wraps << 32) | a->time_raw;
        control_step(a, m.u.step.step, t_us, true);
        break;
    }
    case COMM_ID_PARAM_SET: on_param(a, m.u.param_set.index, true, m.u.param_set.value); break;
    default: /* COMM_ID_PARAM_GET: comm_decode only returns frames the firmware receives */
        on_param(a, m.u.param_get, false, 0.0f);
        break;
    }
    return 0;
}

unsigned app_poll(app_t *a, uint32_t timeout_us)
{
    unsigned n = 0;
    hal_can_frame_t f;
    while (hal_can_recv(&f, n == 0u ? timeout_us : 0u) == 0) {
        (void)app_on_frame(a, &f);
        n++;
    }
    return n;
}

void app_control_tick(app_t *a, uint64_t now_us)
{
    control_step(a, (uint16_t)(a->step + 1u), now_us, false);
}

void app_housekeeping(app_t *a, uint64_t now_us)
{
    if (now_us < a->next_housekeeping_us) {
        return;
    }
    a->next_housekeeping_us = now_us + APP_HOUSEKEEPING_PERIOD_US;
    hal_can_frame_t f;
    (void)comm_encode_heartbeat(&a->comm, a->state, &f);
    send(&f);
    (void)comm_encode_counters(&a->comm, &f);
    send(&f);
}
