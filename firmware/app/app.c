/* The firmware application: frames in, control step, frames out. */
#include "app/app.h"

#include <errno.h>
#include <stddef.h>

#include "hal/hal_can.h"

int app_init(app_t *a, const ctl_params_t *p)
{
    ctl_params_t defaults;
    ctl_params_default(&defaults);
    *a = (app_t){.state = COMM_STATE_READY};
    comm_init(&a->comm);
    return ctl_init(&a->ctl, p != NULL ? p : &defaults);
}

/* A frame that cannot be queued is lost; the bus is the only way out, so
 * there is nothing better to do than to carry on (the plant times out). */
static void send(const hal_can_frame_t *f) { (void)hal_can_send(f); }

static void control_step(app_t *a, uint16_t step, uint64_t t_us)
{
    app_housekeeping(a, t_us);
    const ctl_input_t in = {
        .robot = a->odom,
        .ref = a->ref,
        .v_r = a->v_r,
        .w_r = a->w_r,
        .obstacles = a->reports,
        .n_obstacles = a->n_reports,
        .t_us = t_us,
    };
    ctl_output_t out;
    if (a->have == APP_HAVE_ALL) {
        ctl_step(&a->ctl, &in, &out);
        a->state = out.status.mode == SUP_MODE_STOP ? COMM_STATE_STOPPED : COMM_STATE_RUNNING;
    } else {
        /* No complete input yet: stand still. */
        out = (ctl_output_t){.status = {.mode = SUP_MODE_STOP, .side = AVD_SIDE_NONE}};
        a->state = COMM_STATE_READY;
    }
    a->n_reports = 0;
    a->wheels = out.wheels;
    a->step = step;
    a->steps++;

    hal_can_frame_t f;
    for (size_t i = 0; i < out.n_events; i++) {
        comm_encode_event(&a->comm, &out.events[i], &f);
        send(&f);
    }
    comm_encode_status(&a->comm, &out.status, step, a->frame_dropped, &f);
    send(&f);
    a->frame_dropped = false;
    comm_encode_status_trk(&a->comm, &out.status.err, &f);
    send(&f);
    /* Last: it tells a lock-step plant that the step's telemetry is out. */
    comm_encode_wheel_cmd(&a->comm, step, &out.wheels, &f);
    send(&f);
}

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

/* PARAM_SET (with @p set) or PARAM_GET: answer PARAM_VALUE with the value in
 * force afterwards. */
static void on_param(app_t *a, uint8_t index, bool set, float value)
{
    ctl_params_t p = a->ctl.p;
    num_t *slot = param_slot(&p, index);
    comm_param_result_t result = COMM_PARAM_OK;
    float now = 0.0f;
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
    hal_can_frame_t f;
    comm_encode_param_value(&a->comm, index, result, now, &f);
    send(&f);
}

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
        a->reports[a->n_reports++] = *o;
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
        a->have |= APP_HAVE_ODOM_XY;
        break;
    case COMM_ID_ODOM_THETA:
        a->odom.theta = m.u.theta;
        a->have |= APP_HAVE_ODOM_THETA;
        break;
    case COMM_ID_REF_XY:
        a->ref.x = m.u.xy.x;
        a->ref.y = m.u.xy.y;
        a->have |= APP_HAVE_REF_XY;
        break;
    case COMM_ID_REF_MOTION:
        a->ref.theta = m.u.ref_motion.theta;
        a->v_r = m.u.ref_motion.v;
        a->w_r = m.u.ref_motion.w;
        a->have |= APP_HAVE_REF_MOTION;
        break;
    case COMM_ID_OBSTACLE:
        on_obstacle(a, &m.u.obstacle);
        break;
    case COMM_ID_STEP: {
        /* The simulator's time, extended past the 32-bit wrap (71.6 min). */
        if (a->time_valid && m.u.step.time_us < a->time_raw) {
            a->time_wraps++;
        }
        a->time_raw = m.u.step.time_us;
        a->time_valid = true;
        const uint64_t t_us = ((uint64_t)a->time_wraps << 32) | a->time_raw;
        control_step(a, m.u.step.step, t_us);
        break;
    }
    case COMM_ID_PARAM_SET:
        on_param(a, m.u.param_set.index, true, m.u.param_set.value);
        break;
    case COMM_ID_PARAM_GET:
        on_param(a, m.u.param_get, false, 0.0f);
        break;
    default:
        break; /* comm_decode only returns frames the firmware receives */
    }
    return 0;
}

unsigned app_poll(app_t *a, uint32_t timeout_us)
{
    unsigned n = 0;
    hal_can_frame_t f;
    while (hal_can_recv(&f, n == 0 ? timeout_us : 0u) == 0) {
        (void)app_on_frame(a, &f);
        n++;
    }
    return n;
}

void app_control_tick(app_t *a, uint64_t now_us) { control_step(a, (uint16_t)(a->step + 1u), now_us); }

void app_housekeeping(app_t *a, uint64_t now_us)
{
    if (now_us < a->next_housekeeping_us) {
        return;
    }
    a->next_housekeeping_us = now_us + APP_HOUSEKEEPING_PERIOD_US;
    hal_can_frame_t f;
    comm_encode_heartbeat(&a->comm, a->state, &f);
    send(&f);
    comm_encode_counters(&a->comm, &f);
    send(&f);
}
