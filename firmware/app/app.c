/* SPDX-License-Identifier: MIT */
/* The firmware application: frames in, safety supervisor, control step,
 * frames out (app.h; docs/safety.md). */
#include "app/app.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>

#include "hal/hal_can.h"
#include "hal/hal_sys.h"

_Static_assert(APP_TIMEOUT_US == APP_TIMEOUT_PERIODS * APP_PERIOD_US, "timeout in periods");
_Static_assert((APP_OBSTACLE_IDS & (APP_OBSTACLE_IDS - 1u)) == 0u, "ids masked: a power of two");
_Static_assert(APP_OBSTACLE_IDS > COMM_OBSTACLE_ID_MAX, "a velocity for every id the frames carry");

/* The frame of each watched input (app.h, APP_IN_*). */
static const uint32_t input_id[APP_N_IN] = {
    COMM_ID_ODOM_XY,    COMM_ID_ODOM_THETA, COMM_ID_REF_XY,
    COMM_ID_REF_MOTION, COMM_ID_STEP,       COMM_ID_WHEEL_SPEED,
};

int app_init(app_t *a, const ctl_params_t *p)
{
    ctl_params_t defaults;
    ctl_params_default(&defaults);
    *a = (app_t){ .state = COMM_STATE_READY, .halt = (uint8_t)COMM_HALT_NOT_ARMED };
    comm_init(&a->comm);
    auth_init(&a->auth);
    odo_init(&a->odo);
    const int rc = ctl_init(&a->ctl, p != NULL ? p : &defaults);
    a->ramp_decel = a->ctl.p.max_wheel_decel;
    (void)comm_set_node(&a->comm, (uint8_t)APP_NODE);
    return rc;
}

int app_set_node(app_t *a, uint8_t node) { return comm_set_node(&a->comm, node); }

void app_set_key(app_t *a, const uint8_t key[AUTH_KEY_LEN], uint32_t session)
{
    /* At start (app.h): the challenge is issued at time 0, as app_init()
     * leaves challenge_us. */
    auth_set_key(&a->auth, key, session);
}

/* A frame that cannot be queued is lost; the bus is the only way out, so
 * there is nothing better to do than to carry on (the plant times out). */
static void send(const hal_can_frame_t *f) { (void)hal_can_send(f); }

/* FW_VERSION_GET: the version, build and node, at once (no authentication:
 * it changes nothing). */
static void send_fw_version(app_t *a)
{
    static const comm_fw_version_t version = {
        .major = (uint8_t)APP_VERSION_MAJOR,
        .minor = (uint8_t)APP_VERSION_MINOR,
        .patch = (uint8_t)APP_VERSION_PATCH,
        .dirty = APP_BUILD_DIRTY != 0u,
        .build = (uint32_t)APP_BUILD_ID,
#if defined(NUM_FIXED)
        .fixed = true,
#else
        .fixed = false,
#endif
    };
    hal_can_frame_t f;
    (void)comm_encode_fw_version(&a->comm, &version, &f);
    send(&f);
}

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

void app_set_wheel_source(app_t *a, app_wheel_source_t source)
{
    a->wheel_source = (uint8_t)source;
}

void app_wheels_measured(app_t *a, const kin_wheels_t *speed, uint8_t faults, uint32_t age_us)
{
    if (a->wheel_source != (uint8_t)APP_WHEELS_OWN) {
        return;
    }
    a->wheel_speed = *speed;
    a->wheel_faults = faults;
    a->wheel_age_us = age_us;
    a->wheels_handed = true;
}

/* The wheels move: commanded, or last measured, at a speed other than zero. */
static bool wheels_move(const app_t *a)
{
    return a->wheels.left != NUM_ZERO || a->wheels.right != NUM_ZERO ||
           a->wheel_speed.left != NUM_ZERO || a->wheel_speed.right != NUM_ZERO;
}

/* The measured wheel speeds fail (app.h): a wheel fault they report, or a
 * measurement missing while the wheels move: from the own wheel loop, none
 * handed since the last step; from the bus (@p bus_usable: WHEEL_SPEED at
 * this step), not valid or timed out once it has been valid. */
static bool wheel_speeds_failed(const app_t *a, bool bus_usable)
{
    if (a->wheel_faults != 0u) {
        return true;
    }
    const bool missing = a->wheel_source == (uint8_t)APP_WHEELS_OWN
                             ? !a->wheels_handed
                             : a->wheel_speed_watched && !bus_usable;
    return missing && wheels_move(a);
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
    a->wheel_speed_watched = a->wheel_speed_watched || usable[APP_IN_WHEEL_SPEED];
    comm_halt_t why = COMM_HALT_NONE;
    if (bus_off(a)) {
        why = COMM_HALT_BUS_OFF;
    } else if (!usable[APP_IN_ODOM_XY] || !usable[APP_IN_ODOM_THETA]) {
        why = COMM_HALT_ODOMETRY;
    } else if (!usable[APP_IN_REF_XY] || !usable[APP_IN_REF_MOTION]) {
        why = COMM_HALT_REFERENCE;
    } else if (lockstep && !usable[APP_IN_STEP]) {
        why = COMM_HALT_STEP;
    } else if (wheel_speeds_failed(a, usable[APP_IN_WHEEL_SPEED])) {
        why = COMM_HALT_WHEEL_SPEED;
    } else {
        /* every input usable */
    }
    if (a->wheel_source != (uint8_t)APP_WHEELS_OWN && !usable[APP_IN_WHEEL_SPEED]) {
        /* Timed out: the last measurement is forgotten, and the watch with it
         * once the wheels stand. What a node sent ends when it stops
         * (docs/safety.md, "Threat model"), whoever it was. The own wheel
         * loop's estimate is no bus input: it is handed at every step. */
        a->wheel_speed = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
        a->wheel_speed_watched = a->wheel_speed_watched && wheels_move(a);
    }
    return why;
}

/* Halt with reason @p why unless already halted. The ramp keeps the
 * deceleration in force now: the wheels are within max_wheel_speed, which the
 * set's check bounds by it, so they stop within the bound of docs/safety.md;
 * a parameter set while halted (lowering both) cannot slow this stop. */
static void halt(app_t *a, comm_halt_t why)
{
    if (a->halt == (uint8_t)COMM_HALT_NONE) {
        a->halt = (uint8_t)why; /* latched until re-armed */
        a->ramp_decel = a->ctl.p.max_wheel_decel;
    }
}

/* Step the wheel speeds down towards zero by at most ramp_decel·dt, both by
 * one factor so that the curvature is kept (the robot stays on its arc). */
static void ramp_down(app_t *a, uint32_t dt_us)
{
    /* Through float in both modes: 1 µs is below Q16.16's resolution, so
     * num_from_int(1000000) cannot serve as the divisor. */
    const num_t dt = num_from_float((float)dt_us * 1.0e-6f);
    const num_t step = num_mul(a->ramp_decel, dt);
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
        halt(a, COMM_HALT_NOT_ARMED);
        return 0;
    }
    if (!app_ready(a)) {
        return -EAGAIN;
    }
    /* The timeouts are not reset: the next step needs fresh frames of its
     * own, as every step does. The plausibility check starts again from the
     * next full pose: the robot may have been moved while halted. */
    a->halt = (uint8_t)COMM_HALT_NONE;
    a->wheel_faults = 0u; /* a fault still there is reported again */
    odo_reset(&a->odo);
    return 0;
}

/* ------------------------------------------------------------ control step */

static void expire_pending(app_t *a);

static void control_step(app_t *a, uint16_t step, uint64_t t_us, bool lockstep)
{
    app_housekeeping(a, t_us); /* moves the application's time to t_us */
    const uint64_t dt64 = a->stepped && t_us > a->last_step_us ? t_us - a->last_step_us : 0u;
    const uint32_t dt_us = dt64 < APP_MAX_DT_US ? (uint32_t)dt64 : APP_MAX_DT_US;
    a->last_step_us = t_us;
    a->stepped = true;

    expire_pending(a);
    if (dt64 > APP_TIMEOUT_US) {
        /* Over such a gap (a time jump, a stall) the commanded motion says
         * nothing of where the robot is: the plausibility check starts again
         * from the next full pose. */
        odo_reset(&a->odo);
    }
    comm_halt_t why = check_inputs(a, t_us, lockstep);
    /* Speeds the wheels measured, when they came with this step (the own
     * wheel loop's, or WHEEL_SPEED's over the period that just ended, its
     * state machine VALID: check_inputs() forgot one that is not): the
     * motion odometry must follow. Otherwise the commands: wheels that lag
     * them would make odometry look implausible. */
    const bool own = a->wheel_source == (uint8_t)APP_WHEELS_OWN;
    const bool measured =
        own ? a->wheels_handed
            : a->in[APP_IN_WHEEL_SPEED].ever && a->in[APP_IN_WHEEL_SPEED].missed == 0u &&
                  comm_rx(&a->comm, COMM_ID_WHEEL_SPEED)->state == (uint8_t)COMM_SM_VALID;
    if (a->halt == (uint8_t)COMM_HALT_NONE && why == COMM_HALT_NONE &&
        odo_step(&a->odo, &a->ctl.p.kin, measured ? &a->wheel_speed : &a->wheels,
                 num_from_float((float)dt_us * 1.0e-6f), &a->odom,
                 a->in[APP_IN_ODOM_XY].missed == 0u, a->in[APP_IN_ODOM_THETA].missed == 0u)) {
        why = COMM_HALT_ODOMETRY_IMPLAUSIBLE;
    }
    if (why != COMM_HALT_NONE) {
        halt(a, why);
    }

    /* Static, not on the stack: with a table of 48 its events and
     * distances are 1.1 KB (the F103's stack, docs/performance.md). The
     * control step runs from one context only (app.h). */
    static ctl_output_t out;
    if (a->halt == (uint8_t)COMM_HALT_NONE) {
        for (uint8_t i = 0; i < a->n_reports; i++) {
            sup_obstacle_t *o = &a->reports[i];
            const uint8_t id = o->id & (uint8_t)(APP_OBSTACLE_IDS - 1u); /* 6 bits, as sent */
            o->vx = a->obstacle_v[id][0];
            o->vy = a->obstacle_v[id][1];
        }
        const ctl_input_t in = {
            .robot = a->odom,
            .ref = a->ref,
            .v_r = a->v_r,
            .w_r = a->w_r,
            .obstacles = a->reports,
            .n_obstacles = a->n_reports,
            .t_us = t_us,
            .wheels = a->wheel_speed,
            .wheels_measured = measured,
            /* Through float in both modes (as ramp_down's dt); 0 (half the
             * period) for WHEEL_SPEED. */
            .wheels_age = own ? num_from_float((float)a->wheel_age_us * 1.0e-6f) : NUM_ZERO,
        };
        ctl_step(&a->ctl, &in, &out);
        a->wheels = out.wheels;
        a->state = out.status.mode == SUP_MODE_STOP ? COMM_STATE_STOPPED : COMM_STATE_RUNNING;
    } else {
        /* Halted: the controller does not run (its state stays as it was),
         * the wheels ramp down from where they were. */
        out = (ctl_output_t){ .status = { .mode = SUP_MODE_STOP, .side = AVD_SIDE_NONE } };
        ramp_down(a, dt_us);
        ctl_sync_wheels(&a->ctl, &a->wheels);
        out.wheels = a->wheels;
        a->state = a->halt == (uint8_t)COMM_HALT_NOT_ARMED ? COMM_STATE_READY : COMM_STATE_FAULT;
    }
    a->n_reports = 0;
    a->step = step;
    a->steps++;

    hal_can_frame_t f;
    if (own && a->wheels_handed) {
        /* What the board measured, first: nobody else says it (a CAN
         * controller does not receive its own frames, the plant and the
         * tools do). */
        (void)comm_encode_wheel_speed_faults(&a->comm, &a->wheel_speed, a->wheel_faults, &f);
        send(&f);
    }
    a->wheels_handed = false;
    for (size_t i = 0; i < out.n_events; i++) {
        (void)comm_encode_event(&a->comm, &out.events[i], &f);
        send(&f);
    }
    /* STATUS_TRK and WHEEL_CMD are encoded before STATUS, so that a value
     * either clips is flagged in this step's STATUS (comm.h); they go out
     * after it, WHEEL_CMD last: it tells a lock-step plant that the step's
     * telemetry is out. */
    hal_can_frame_t trk;
    hal_can_frame_t cmd;
    (void)comm_encode_status_trk(&a->comm, &out.status.err, a->odom_counter, &trk);
    (void)comm_encode_wheel_cmd(&a->comm, step, &out.wheels, &cmd);
    (void)comm_encode_status(&a->comm, &out.status, step, a->frame_dropped, a->halt, &f);
    send(&f);
    a->frame_dropped = false;
    send(&trk);
    send(&cmd);
}

/* -------------------------------------------------------------- parameters */

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

/* Set parameter @p index (held: ctl_param_slot() is not NULL) to @p value
 * if the whole set that results passes the check; else change nothing. */
static comm_param_result_t set_param(app_t *a, uint8_t index, float value)
{
    if (a->halt == (uint8_t)COMM_HALT_NONE && ctl_limits[index].control_law) {
        return COMM_PARAM_ARMED;
    }
    /* isfinite() first: NaN has no Q16.16 value (num_from_float gives 0). */
    if (!isfinite(value)) {
        return COMM_PARAM_OUT_OF_RANGE;
    }
    ctl_params_t p = a->ctl.p;
    /* The value as it will be held: a float rounded to Q16.16 in fixed mode
     * (1e-6 becomes 0) is checked after rounding, never before. */
    *ctl_param_slot(&p, index) = num_from_float(value);
    const ctl_params_verdict_t verdict = ctl_params_verdict(&p);
    if (verdict == CTL_PARAMS_RANGE) {
        return COMM_PARAM_OUT_OF_RANGE;
    }
    if (verdict == CTL_PARAMS_RELATION) {
        return COMM_PARAM_REJECTED;
    }
    (void)ctl_set_params(&a->ctl, &p); /* passes: the same check */
    return COMM_PARAM_OK;
}

/* The status, both halves: AUTH_CHALLENGE authenticates AUTH_STATUS. */
static void send_auth_status(app_t *a)
{
    hal_can_frame_t f[2];
    (void)comm_encode_auth_status(&a->comm, &a->auth, f);
    send(&f[0]);
    send(&f[1]);
}

/* A challenge was decided (or expired): the next one is issued now. */
static void next_challenge(app_t *a) { a->challenge_us = a->now_us; }

/* PARAM_SET (with @p set) or PARAM_GET: answer PARAM_VALUE with the value in
 * force afterwards, then AUTH_STATUS. A PARAM_SET that is not @p authentic
 * changes nothing and is answered COMM_PARAM_UNAUTHENTICATED. */
static void on_param(app_t *a, uint8_t index, bool set, bool authentic, float value)
{
    const bool apply = set && authentic;
    comm_param_result_t result = COMM_PARAM_OK;
    float now = 0.0f;
    if (index == (uint8_t)COMM_PARAM_ARM) {
        result = apply ? on_arm(a, value) : COMM_PARAM_OK;
        now = a->halt == (uint8_t)COMM_HALT_NONE ? 1.0f : 0.0f;
    } else {
        const num_t *held = ctl_param_slot(&a->ctl.p, index);
        if (held == NULL) {
            result = COMM_PARAM_UNKNOWN_INDEX;
        } else {
            if (apply) {
                result = set_param(a, index, value);
            }
            now = num_to_float(*held);
        }
    }
    if (set && !authentic) {
        result = COMM_PARAM_UNAUTHENTICATED;
    }
    hal_can_frame_t f;
    (void)comm_encode_param_value(&a->comm, index, result, now, &f);
    send(&f);
    send_auth_status(a);
}

/* --------------------------------------------- authenticated commands */

/* Refuse the waiting PARAM_SET: its PARAM_AUTH did not come. */
static void refuse_pending(app_t *a)
{
    a->pending.waiting = false;
    auth_refuse(&a->auth, AUTH_MISSING);
    next_challenge(a);
    on_param(a, a->pending.index, true, false, a->pending.value);
}

/* A control step begins: a PARAM_SET waiting that long has lost its PARAM_AUTH. */
static void expire_pending(app_t *a)
{
    if (a->pending.waiting) {
        a->pending.steps++;
        if (a->pending.steps >= APP_AUTH_PENDING_STEPS) {
            refuse_pending(a);
        }
    }
}

/* PARAM_SET: held until its PARAM_AUTH; one still waiting had none. */
static void on_param_set(app_t *a, const comm_msg_t *m)
{
    if (a->pending.waiting) {
        refuse_pending(a);
    }
    a->pending = (app_pending_t){ .waiting = true,
                                  .index = m->u.param_set.index,
                                  .value = m->u.param_set.value };
    for (size_t i = 0; i < AUTH_DATA_LEN; i++) {
        a->pending.data[i] = m->u.param_set.auth_data[i];
    }
}

/* PARAM_AUTH: verify the waiting PARAM_SET, then act on it or refuse it. */
static void on_param_auth(app_t *a, const comm_msg_t *m)
{
    if (!a->pending.waiting) {
        auth_refuse(&a->auth, AUTH_MISSING);
        next_challenge(a);
        send_auth_status(a);
        return;
    }
    a->pending.waiting = false;
    const auth_result_t r =
        auth_verify(&a->auth, COMM_PARAM_SET_DATA_ID, a->pending.data,
                    m->u.param_auth.freshness_low, m->u.param_auth.mac, a->now_us);
    next_challenge(a);
    on_param(a, a->pending.index, true, r == AUTH_OK, a->pending.value);
}

/* ---------------------------------------------------------------- frames in */

/* The velocity of obstacle m.u.obstacle_vel.id, kept until the next one: the
 * plant sends it after the obstacle's OBSTACLE frame, each step it moves. */
static void on_obstacle_vel(app_t *a, const comm_msg_t *m)
{
    /* The frame's id is 6 bits: the mask only says so to the compiler. */
    const uint8_t id = m->u.obstacle_vel.id & (uint8_t)(APP_OBSTACLE_IDS - 1u);
    a->obstacle_v[id][0] = m->u.obstacle_vel.vx;
    a->obstacle_v[id][1] = m->u.obstacle_vel.vy;
}

static void on_obstacle(app_t *a, const sup_obstacle_t *o)
{
    /* Static unless its OBSTACLE_VEL follows: an id the sensor gives to
     * another obstacle carries no velocity over (docs/protocol.md). */
    const uint8_t id = o->id & (uint8_t)(APP_OBSTACLE_IDS - 1u); /* 6 bits, as sent */
    a->obstacle_v[id][0] = NUM_ZERO;
    a->obstacle_v[id][1] = NUM_ZERO;
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
    if (rc == -EXDEV) {
        return rc; /* another board's frame on a shared bus: not for us, not a fault */
    }
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
    case COMM_ID_OBSTACLE_VEL: on_obstacle_vel(a, &m); break;
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
    case COMM_ID_PARAM_SET: on_param_set(a, &m); break;
    case COMM_ID_PARAM_AUTH: on_param_auth(a, &m); break;
    case COMM_ID_WHEEL_SPEED:
        /* The input of the external drives' topology only: a board that
         * measures its own wheels takes no one else's word for them. */
        if (a->wheel_source != (uint8_t)APP_WHEELS_OWN) {
            a->wheel_speed = m.u.wheel_speed.speed;
            a->wheel_faults = m.u.wheel_speed.faults;
        }
        break;
    case COMM_ID_FW_VERSION_GET: send_fw_version(a); break;
    default: /* COMM_ID_PARAM_GET: comm_decode only returns frames the firmware receives */
        on_param(a, m.u.param_get, false, false, 0.0f);
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
    if (now_us > a->now_us) {
        a->now_us = now_us; /* the application's time: never back */
    }
    if (now_us < a->next_housekeeping_us) {
        return;
    }
    a->next_housekeeping_us = now_us + APP_HOUSEKEEPING_PERIOD_US;
    uint32_t session;
    if (auth_spent(&a->auth) && hal_sys_boot_nonce(&session) == 0) {
        /* 2^20 decisions: a new session (without a value for one, nothing
         * more is accepted: AUTH_NO_KEY). */
        auth_new_session(&a->auth, session);
        next_challenge(a);
    } else if (a->now_us - a->challenge_us >= APP_AUTH_CHALLENGE_US) {
        /* Unused for that long: a command signed for it and held back by a
         * node on the bus would be accepted late. Replace it. */
        auth_refuse(&a->auth, AUTH_EXPIRED);
        next_challenge(a);
    } else {
        /* the challenge stands */
    }
    hal_can_frame_t f;
    (void)comm_encode_heartbeat(&a->comm, a->state, &f);
    send(&f);
    (void)comm_encode_counters(&a->comm, &f);
    send(&f);
    send_auth_status(a);
}
