/* SPDX-License-Identifier: MIT */
/* The control step: supervisor, active controller, kinematics. */
#include "ctrl/ctl.h"

#include <errno.h>

/* |x| <= lim, for a finite x only: num_is_finite() first, since an ordered
 * comparison with NaN raises FE_INVALID. */
static bool within(num_t x, num_t lim) { return num_is_finite(x) && num_abs(x) <= lim; }

static sup_params_t sup_params_of(const ctl_params_t *p)
{
    return (sup_params_t){ .r_ob = p->r_ob, .d_det = p->d_det, .d_act = p->d_act, .d_s = p->d_s };
}

int ctl_init(ctl_t *c, const ctl_params_t *p)
{
    int rc = ctl_params_check(p);
    if (rc == 0) {
        c->p = *p;
    } else {
        ctl_params_default(&c->p);
    }
    const sup_params_t sp = sup_params_of(&c->p);
    sup_init(&c->sup, &sp);
    return rc;
}

int ctl_set_params(ctl_t *c, const ctl_params_t *p)
{
    int rc = ctl_params_check(p);
    if (rc == 0) {
        c->p = *p;
        const sup_params_t sp = sup_params_of(p);
        sup_set_params(&c->sup, &sp);
    }
    return rc;
}

void ctl_reset(ctl_t *c) { sup_reset(&c->sup); }

static bool inputs_in_range(const ctl_input_t *in)
{
    return within(in->robot.x, CTL_MAX_ABS_POSITION) && within(in->robot.y, CTL_MAX_ABS_POSITION) &&
           within(in->robot.theta, CTL_MAX_ABS_ANGLE) && within(in->ref.x, CTL_MAX_ABS_POSITION) &&
           within(in->ref.y, CTL_MAX_ABS_POSITION) && within(in->ref.theta, CTL_MAX_ABS_ANGLE) &&
           within(in->v_r, CTL_MAX_ABS_SPEED) && within(in->w_r, CTL_MAX_ABS_SPEED);
}

/* A report the supervisor may compute with; the others reach it as id 0 with
 * zero values, which it drops and counts without touching them. */
static sup_obstacle_t screened(const sup_obstacle_t *o)
{
    const bool ok = within(o->x, CTL_MAX_ABS_POSITION) && within(o->y, CTL_MAX_ABS_POSITION) &&
                    within(o->radius, CTL_MAX_RADIUS);
    return ok ? *o : (sup_obstacle_t){ .id = 0u };
}

static void fill_distances(const ctl_t *c, const pose_t *robot, ctl_status_t *st)
{
    st->n_obstacles = c->sup.n_obs;
    for (uint8_t i = 0; i < c->sup.n_obs; i++) {
        const sup_obstacle_t *o = &c->sup.obs[i].o;
        st->obstacle_id[i] = o->id;
        st->distance[i] = num_hypot(num_sub(o->x, robot->x), num_sub(o->y, robot->y));
    }
}

void ctl_step(ctl_t *c, const ctl_input_t *in, ctl_output_t *out)
{
    ctl_status_t *st = &out->status;
    *st = (ctl_status_t){ .mode = SUP_MODE_STOP, .side = AVD_SIDE_NONE };
    out->n_events = 0;
    out->wheels = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };

    if (!inputs_in_range(in)) {
        /* Bad data from outside: stop, and leave the supervisor as it was. */
        st->faults = CTL_FAULT_INPUT_NONFINITE;
        return;
    }

    sup_obstacle_t reports[SUP_MAX_OBSTACLES];
    const size_t n_reports =
        in->n_obstacles < SUP_MAX_OBSTACLES ? in->n_obstacles : SUP_MAX_OBSTACLES;
    /* cppcheck-suppress knownConditionTrueFalse ; false positive: n_reports is up to 16 */
    for (size_t i = 0; i < n_reports; i++) {
        reports[i] = screened(&in->obstacles[i]);
    }
    const uint16_t dropped_before = c->sup.dropped;
    sup_decision_t d;
    sup_step(&c->sup, &in->robot, &in->ref, in->v_r, in->w_r, reports, n_reports, in->t_us,
             out->events, &d);
    out->n_events = d.n_events;
    if (c->sup.dropped != dropped_before || in->n_obstacles > n_reports) {
        st->faults |= CTL_FAULT_OBSTACLE_DROPPED;
    }

    trk_errors(&in->robot, &in->ref, &st->err);
    st->mode = d.mode;
    num_t v = NUM_ZERO;
    num_t w = NUM_ZERO;
    if (d.active != NULL) {
        st->active_obstacle = d.active->o.id;
        st->side = d.side;
    }
    if (d.mode == SUP_MODE_TRACK) {
        trk_control(&c->p.trk, &st->err, in->v_r, in->w_r, &v, &w);
    } else if (d.mode == SUP_MODE_AVOID && d.active != NULL) { /* sup_step sets both */
        avd_control(&c->p.avd, &in->robot, &st->err, in->v_r, d.active->o.x, d.active->o.y,
                    d.active->d_s, d.side, &v, &w, &st->e);
    } /* SUP_MODE_STOP, p3: v = ω = 0. */

    kin_wheels_from_vw(&c->p.kin, v, w, &out->wheels);
    if (kin_saturate(&c->p.kin, &out->wheels)) {
        st->faults |= CTL_FAULT_SATURATED;
    }
    if (!within(out->wheels.left, c->p.kin.max_wheel_speed) ||
        !within(out->wheels.right, c->p.kin.max_wheel_speed)) {
        /* The last defence of the output range (ctl.h). */
        out->wheels = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
        st->faults |= CTL_FAULT_OUTPUT_INVALID;
    }
    kin_vw_from_wheels(&c->p.kin, &out->wheels, &st->v, &st->w);
    fill_distances(c, &in->robot, st);
}
