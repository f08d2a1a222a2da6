/* The control step as a shared library with a plain C ABI (mstc_sil.h). The
 * numeric conversions of the host side live here, outside the firmware. */
#include "mstc_sil.h"

#include <errno.h>
#include <math.h>

#include "ctrl/ctl.h"

_Static_assert(MSTC_SIL_MAX_OBSTACLES == SUP_MAX_OBSTACLES, "obstacle table sizes differ");
_Static_assert(MSTC_SIL_MAX_EVENTS == SUP_MAX_EVENTS, "event buffer sizes differ");

/* double to num_t; non-finite values are kept non-finite in float mode, so the
 * firmware's own input check sees them. */
static num_t from_d(double d) { return num_from_float((float)d); }
static double to_d(num_t n) { return (double)num_to_float(n); }

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
        .trk_k = {to_d(c.trk.k1), to_d(c.trk.k2), to_d(c.trk.k3)},
        .avd_k = {to_d(c.avd.k1), to_d(c.avd.k2)},
        .wheel_radius = to_d(c.kin.wheel_radius),
        .track_width = to_d(c.kin.track_width),
        .max_wheel_speed = to_d(c.kin.max_wheel_speed),
    };
}

int mstc_sil_init(void *mem, const mstc_sil_params_t *p)
{
    if (mem == NULL || p == NULL) {
        return -EINVAL;
    }
    const ctl_params_t c = {
        .r_m = from_d(p->r_m),
        .r_ob = from_d(p->r_ob),
        .d_det = from_d(p->d_det),
        .d_act = from_d(p->d_act),
        .d_s = from_d(p->d_s),
        .trk = {from_d(p->trk_k[0]), from_d(p->trk_k[1]), from_d(p->trk_k[2])},
        .avd = {from_d(p->avd_k[0]), from_d(p->avd_k[1])},
        .kin = {from_d(p->wheel_radius), from_d(p->track_width), from_d(p->max_wheel_speed)},
    };
    return ctl_init((ctl_t *)mem, &c);
}

int mstc_sil_step(void *mem, const mstc_sil_input_t *in, mstc_sil_output_t *out)
{
    if (mem == NULL || in == NULL || out == NULL || in->n_obstacles > MSTC_SIL_MAX_OBSTACLES ||
        (in->n_obstacles > 0 && in->obstacles == NULL)) {
        return -EINVAL;
    }
    sup_obstacle_t obs[MSTC_SIL_MAX_OBSTACLES];
    for (uint32_t i = 0; i < in->n_obstacles; i++) {
        const mstc_sil_obstacle_t *o = &in->obstacles[i];
        obs[i] = (sup_obstacle_t){.id = o->id <= 255u ? (uint8_t)o->id : 0u,
                                  .x = from_d(o->x),
                                  .y = from_d(o->y),
                                  .radius = from_d(o->radius)};
    }
    const ctl_input_t ci = {
        .robot = {from_d(in->robot[0]), from_d(in->robot[1]), from_d(in->robot[2])},
        .ref = {from_d(in->ref[0]), from_d(in->ref[1]), from_d(in->ref[2])},
        .v_r = from_d(in->v_r),
        .w_r = from_d(in->w_r),
        .obstacles = obs,
        .n_obstacles = in->n_obstacles,
        .t_us = in->t_us,
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
            .t_us = e->t_us, .kind = e->kind, .obstacle = e->obstacle, .side = e->side};
    }
    return 0;
}
