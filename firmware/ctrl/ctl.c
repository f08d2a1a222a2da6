/* SPDX-License-Identifier: MIT */
/* The control step: supervisor, active controller, kinematics. */
#include "ctrl/ctl.h"

#include <errno.h>

#include "ctrl/oset.h"

/* |x| <= lim, for a finite x only: num_is_finite() first, since an ordered
 * comparison with NaN raises FE_INVALID. */
static bool within(num_t x, num_t lim) { return num_is_finite(x) && num_abs(x) <= lim; }

/* The robot's width 2 R_m: the gap below which obstacles form a cluster. */
static num_t robot_width(const ctl_params_t *p) { return num_add(p->r_m, p->r_m); }

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
    msw_init(&c->msw, robot_width(&c->p));
    cbf_init(&c->cbf);
    return rc;
}

int ctl_set_params(ctl_t *c, const ctl_params_t *p)
{
    int rc = ctl_params_check(p);
    if (rc == 0) {
        const bool new_strategy = p->strategy != c->p.strategy;
        c->p = *p;
        const sup_params_t sp = sup_params_of(p);
        sup_set_params(&c->sup, &sp);
        c->msw.width = robot_width(p);
        if (new_strategy) {
            msw_reset(&c->msw);
            cbf_reset(&c->cbf);
        }
    }
    return rc;
}

void ctl_reset(ctl_t *c)
{
    sup_reset(&c->sup);
    msw_reset(&c->msw);
    cbf_reset(&c->cbf);
}

static bool inputs_in_range(const ctl_input_t *in)
{
    return within(in->robot.x, CTL_MAX_ABS_POSITION) && within(in->robot.y, CTL_MAX_ABS_POSITION) &&
           within(in->robot.theta, CTL_MAX_ABS_ANGLE) && within(in->ref.x, CTL_MAX_ABS_POSITION) &&
           within(in->ref.y, CTL_MAX_ABS_POSITION) && within(in->ref.theta, CTL_MAX_ABS_ANGLE) &&
           within(in->v_r, CTL_MAX_ABS_SPEED) && within(in->w_r, CTL_MAX_ABS_SPEED);
}

/* A report the supervisor may compute with; the others reach it as id 0 with
 * zero values, which it drops and counts without touching them. "paper"
 * ignores velocities: they reach it as 0. */
static sup_obstacle_t screened(const sup_obstacle_t *o, bool with_velocity)
{
    bool ok = within(o->x, CTL_MAX_ABS_POSITION) && within(o->y, CTL_MAX_ABS_POSITION) &&
              within(o->radius, CTL_MAX_RADIUS);
    sup_obstacle_t r = *o;
    if (with_velocity) {
        ok = ok && within(o->vx, CTL_MAX_ABS_SPEED) && within(o->vy, CTL_MAX_ABS_SPEED);
    } else {
        r.vx = NUM_ZERO;
        r.vy = NUM_ZERO;
    }
    return ok ? r : (sup_obstacle_t){ .id = 0u };
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

/* The step's reports into the table (sup_take_reports), screened: at most
 * SUP_MAX_OBSTACLES, the rest dropped (CTL_FAULT_OBSTACLE_DROPPED, as for a
 * report the table rejects). Their DETECT events start out->events. A
 * function of its own, so that the copy of the reports (384 bytes) is off
 * the stack before the strategy runs. */
static void take_reports(ctl_t *c, const ctl_input_t *in, bool with_velocity, ctl_output_t *out)
{
    const size_t n_reports =
        in->n_obstacles < SUP_MAX_OBSTACLES ? in->n_obstacles : SUP_MAX_OBSTACLES;
    const uint16_t dropped_before = c->sup.dropped;
    sup_obstacle_t reports[SUP_MAX_OBSTACLES];
    /* cppcheck-suppress knownConditionTrueFalse ; false positive: n_reports is up to 16 */
    for (size_t i = 0; i < n_reports; i++) {
        reports[i] = screened(&in->obstacles[i], with_velocity);
    }
    size_t n_ev = 0;
    sup_take_reports(&c->sup, &in->robot, reports, n_reports, in->t_us, out->events, &n_ev);
    out->n_events = n_ev;
    if (c->sup.dropped != dropped_before || in->n_obstacles > n_reports) {
        out->status.faults |= CTL_FAULT_OBSTACLE_DROPPED;
    }
}

/* Wheel speeds for (v, ω), saturated (CTL_FAULT_SATURATED when scaled). */
static void wheels_for(const ctl_t *c, num_t v, num_t w, kin_wheels_t *wheels, uint8_t *faults)
{
    kin_wheels_from_vw(&c->p.kin, v, w, wheels);
    if (kin_saturate(&c->p.kin, wheels)) {
        *faults |= CTL_FAULT_SATURATED;
    }
}

/* The last defence of the output range (ctl.h), and the body velocity the
 * wheels give, for the status. */
static void finish(const ctl_t *c, ctl_output_t *out)
{
    ctl_status_t *st = &out->status;
    if (!within(out->wheels.left, c->p.kin.max_wheel_speed) ||
        !within(out->wheels.right, c->p.kin.max_wheel_speed)) {
        out->wheels = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
        st->faults |= CTL_FAULT_OUTPUT_INVALID;
    }
    kin_vw_from_wheels(&c->p.kin, &out->wheels, &st->v, &st->w);
}

/* Largest linear speed of "mstc": |v_r| + MSW_CATCH_UP, enough to catch up
 * with the reference after a detour, never racing past obstacles (the
 * roll-out and the filter see what the robot really does). */
static num_t speed_limit(num_t v_r) { return num_add(num_abs(v_r), MSW_CATCH_UP); }

/* Linear velocity while tracking near obstacles ("mstc"): eq. (2) held within
 * [0, speed_limit] (or [−speed_limit, 0] for a reference that drives
 * backwards): a robot ahead of its reference waits for it, turning, rather
 * than reversing into what it has just gone around, and one far behind
 * catches up no faster than speed_limit. */
static num_t track_speed(num_t v, num_t v_r)
{
    return v_r < NUM_ZERO ? num_clamp(v, num_neg(speed_limit(v_r)), NUM_ZERO)
                          : num_clamp(v, NUM_ZERO, speed_limit(v_r));
}

/* Linear velocity while avoiding ("mstc"): eq. (23), v_r cos e3 + k1 e1, held
 * within [MSW_SPEED_MIN |v_r|, speed_limit]: never backwards along a
 * boundary (the blending law assumes forward motion, docs/strategy.md). */
static num_t avoid_speed(const ctl_params_t *p, const trk_err_t *err, num_t v_r)
{
    const num_t v = num_add(num_mul(v_r, num_cos(err->e3)), num_mul(p->avd.k1, err->e1));
    return num_clamp(v, num_mul(MSW_SPEED_MIN, num_abs(v_r)), speed_limit(v_r));
}

/* The "mstc" step (ctl.h): the table, the strategy, the active controller,
 * kinematics, then the safety filter on what the wheels will do. */
static void mstc_step(ctl_t *c, const ctl_input_t *in, ctl_output_t *out)
{
    ctl_status_t *st = &out->status;
    take_reports(c, in, true, out);
    size_t n_ev = out->n_events;
    const num_t cos_th = num_cos(in->robot.theta);
    const num_t sin_th = num_sin(in->robot.theta);
    trk_errors_cs(&in->robot, cos_th, sin_th, &in->ref, &st->err);
    num_t v_trk;
    num_t w_trk;
    trk_control(&c->p.trk, &st->err, in->v_r, in->w_r, &v_trk, &w_trk);
    /* Centre distances first: the strategy uses them, the status reports them
     * (oset_distance: as fill_distances, the cheaper way). Some obstacle
     * within its D_act + MSW_REGULATE: the tracking speed is regulated
     * (track_speed); elsewhere tracking is eq. (2)-(3) as is. */
    st->n_obstacles = c->sup.n_obs;
    bool near = false;
    for (uint8_t i = 0; i < c->sup.n_obs; i++) {
        const sup_entry_t *e = &c->sup.obs[i];
        st->obstacle_id[i] = e->o.id;
        st->distance[i] = oset_distance(num_sub(e->o.x, in->robot.x), num_sub(e->o.y, in->robot.y));
        near = near || st->distance[i] < num_add(e->d_act, MSW_REGULATE);
    }
    if (near) {
        v_trk = track_speed(v_trk, in->v_r);
    }
    const msw_input_t mi = { .robot = &in->robot,
                             .ref = &in->ref,
                             .v_r = in->v_r,
                             .w_r = in->w_r,
                             .cos_th = cos_th,
                             .sin_th = sin_th,
                             .v_trk = v_trk,
                             .w_trk = w_trk,
                             .dist = st->distance,
                             .t_us = in->t_us };
    msw_decision_t d;
    msw_step(&c->msw, &c->sup, &mi, out->events, &n_ev, &d);

    st->mode = d.mode;
    num_t v = NUM_ZERO;
    num_t w = NUM_ZERO;
    if (d.mode == SUP_MODE_TRACK) {
        v = v_trk;
        w = w_trk;
    } else if (d.mode == SUP_MODE_AVOID && d.followed != NULL) { /* msw_step sets both */
        st->active_obstacle = d.followed->o.id;
        st->side = d.side;
        v = avoid_speed(&c->p, &st->err, in->v_r);
        avd_turn(&c->p.avd, &in->robot, cos_th, sin_th, &d.circle, d.side, v, &w, &st->e);
    } else {
        /* STOP (p3) and BLOCKED: v = ω = 0. */
    }
    wheels_for(c, v, w, &out->wheels, &st->faults);
    /* The filter sees what the wheels will do. */
    kin_vw_from_wheels(&c->p.kin, &out->wheels, &v, &w);
    cbf_result_t fr;
    cbf_step(&c->cbf, &in->robot, cos_th, sin_th, c->sup.obs, st->distance, c->sup.n_obs, &v, &w,
             &fr);
    if (fr.changed) {
        st->faults |= CTL_FAULT_FILTER;
        wheels_for(c, v, w, &out->wheels, &st->faults);
        if (fr.new_episode) {
            out->events[n_ev] = (sup_event_t){ .t_us = in->t_us,
                                               .kind = (uint8_t)SUP_EVENT_FILTER,
                                               .obstacle = fr.obstacle,
                                               .side = (int8_t)AVD_SIDE_NONE };
            n_ev++;
        }
    }
    out->n_events = n_ev;
    finish(c, out);
}

/* The "paper" step: the paper's supervisor and controllers, as they have
 * always run. */
static void paper_step(ctl_t *c, const ctl_input_t *in, ctl_output_t *out)
{
    ctl_status_t *st = &out->status;
    /* sup_step() in its two halves, the reports taken one at a time. */
    take_reports(c, in, false, out);
    sup_decision_t d;
    sup_decide(&c->sup, &in->robot, &in->ref, in->v_r, in->w_r, in->t_us, out->events,
               out->n_events, &d);
    out->n_events = d.n_events;

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

    wheels_for(c, v, w, &out->wheels, &st->faults);
    finish(c, out);
    fill_distances(c, &in->robot, st);
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
    if (ctl_is_mstc(&c->p)) {
        mstc_step(c, in, out);
    } else {
        paper_step(c, in, out);
    }
}
