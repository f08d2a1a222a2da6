/* SPDX-License-Identifier: MIT */
/* The control step: supervisor, active controller, kinematics. */
#include "ctrl/ctl.h"

#include <errno.h>

#include "ctrl/oset.h"

/* Avoiding, a heading error e with cos e below this slows the robot by
 * cos e / this (to a turn in place beyond a right angle): the circle's
 * direction is met by turning, not by a wide arc into the next member. */
#define CTL_TURN_FIRST NUM_C(0.7)

/* Round a moving obstacle, wheels whose lag is within this (2/α, the time
 * of motion the safety filter watches ahead: cbf.c's reach) do not turn
 * first (ctl_turn_first()). */
#define CTL_TURN_FIRST_LAG NUM_C(2.0 / CBF_ALPHA_PER_S)

num_t ctl_turn_first(num_t cos_e, bool moving, num_t wheel_tau)
{
    if (cos_e >= CTL_TURN_FIRST || (moving && wheel_tau <= CTL_TURN_FIRST_LAG)) {
        return NUM_ONE;
    }
    return num_max(num_div(cos_e, CTL_TURN_FIRST), NUM_ZERO);
}

/* |x| <= lim, for a finite x only, without FE_INVALID for a NaN (num.h). */
static bool within(num_t x, num_t lim) { return num_within(x, lim); }

/* The gap between two obstacles' D_s circles below which they form one
 * cluster: where the circles the robot follows round them (D_s +
 * MSW_FOLLOW_OFFSET) overlap, so that following one leads into the other. */
static num_t cluster_gap(void) { return num_add(MSW_FOLLOW_OFFSET, MSW_FOLLOW_OFFSET); }

static sup_params_t sup_params_of(const ctl_params_t *p)
{
    return (sup_params_t){ .r_ob = p->r_ob, .d_det = p->d_det, .d_act = p->d_act, .d_s = p->d_s };
}

/* Forget what the memo holds (ctl_memo_t) and compute what depends on the
 * parameters alone: after act_configure(). */
static void memo_reset(ctl_t *c)
{
    const num_t gamma = c->act.lim.gamma;
    c->memo = (ctl_memo_t){ .avoid_most = num_div(num_add(gamma, gamma), c->p.avd.k2) };
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
    msw_init(&c->msw, cluster_gap());
    cbf_init(&c->cbf);
    act_init(&c->act);
    act_configure(&c->act, &c->p.kin, c->p.wheel_accel, CBF_LOOKAHEAD);
    memo_reset(c);
    c->last_t_us = 0u;
    c->stepped = false;
    c->filtered = 0u;
    return rc;
}

void ctl_sync_wheels(ctl_t *c, const kin_wheels_t *w)
{
    act_sync(&c->act, w);
    c->memo.cmd_known = false;
}

int ctl_set_params(ctl_t *c, const ctl_params_t *p)
{
    int rc = ctl_params_check(p);
    if (rc == 0) {
        const bool new_strategy = p->strategy != c->p.strategy;
        c->p = *p;
        const sup_params_t sp = sup_params_of(p);
        sup_set_params(&c->sup, &sp);
        c->msw.width = cluster_gap();
        act_configure(&c->act, &p->kin, p->wheel_accel, CBF_LOOKAHEAD);
        /* A lowered max_wheel_speed holds from the next step: the rate
         * limiter starts from commands within it. */
        (void)kin_saturate(&p->kin, &c->act.cmd);
        (void)kin_saturate(&p->kin, &c->act.est);
        memo_reset(c);
        if (new_strategy) {
            msw_reset(&c->msw);
            cbf_reset(&c->cbf);
            c->filtered = 0u;
        }
    }
    return rc;
}

void ctl_reset(ctl_t *c)
{
    sup_reset(&c->sup);
    msw_reset(&c->msw);
    cbf_reset(&c->cbf);
    c->filtered = 0u;
}

static bool inputs_in_range(const ctl_input_t *in)
{
    return within(in->robot.x, CTL_MAX_ABS_POSITION) && within(in->robot.y, CTL_MAX_ABS_POSITION) &&
           within(in->robot.theta, CTL_MAX_ABS_ANGLE) && within(in->ref.x, CTL_MAX_ABS_POSITION) &&
           within(in->ref.y, CTL_MAX_ABS_POSITION) && within(in->ref.theta, CTL_MAX_ABS_ANGLE) &&
           within(in->v_r, CTL_MAX_ABS_SPEED) && within(in->w_r, CTL_MAX_ABS_SPEED) &&
           (!in->wheels_measured ||
            (within(in->wheels.left, CTL_MAX_ABS_WHEEL_SPEED) &&
             within(in->wheels.right, CTL_MAX_ABS_WHEEL_SPEED) && in->wheels_age >= NUM_ZERO &&
             within(in->wheels_age, CTL_MAX_WHEELS_AGE)));
}

/* A report the supervisor may compute with: its values within their ranges
 * ("paper" ignores velocities: they reach it as 0, unchecked). */
static inline bool report_ok(const sup_obstacle_t *o, bool with_velocity)
{
    const bool ok = within(o->x, CTL_MAX_ABS_POSITION) && within(o->y, CTL_MAX_ABS_POSITION) &&
                    within(o->radius, CTL_MAX_RADIUS);
    return with_velocity
               ? ok && within(o->vx, CTL_MAX_ABS_SPEED) && within(o->vy, CTL_MAX_ABS_SPEED)
               : ok;
}

/* A report as the supervisor gets it, into *r: the others reach it as id 0
 * with zero values, which it drops and counts without touching them; without
 * velocities, they are 0. */
static void screen(const sup_obstacle_t *o, bool with_velocity, sup_obstacle_t *r)
{
    if (!report_ok(o, with_velocity)) {
        *r = (sup_obstacle_t){ .id = 0u };
        return;
    }
    *r = *o;
    if (!with_velocity) {
        r->vx = NUM_ZERO;
        r->vy = NUM_ZERO;
    }
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

/* Reports screened into a copy this many at a time: the copy (384 bytes) is
 * all of them the stack holds, whatever the table's size (the F103's stack,
 * docs/performance.md). */
#define CTL_SCREEN_CHUNK 16u

/* The step's reports into the table (sup_take_reports), screened: at most
 * SUP_MAX_OBSTACLES, the rest dropped (CTL_FAULT_OBSTACLE_DROPPED, as for a
 * report the table rejects). Their DETECT events start out->events. A
 * function of its own, so that the copy of the reports is off the stack
 * before the strategy runs; the table takes them in order, so taking them
 * CTL_SCREEN_CHUNK at a time gives the table and the events of taking them
 * at once. */
static void take_reports(ctl_t *c, const ctl_input_t *in, bool with_velocity, ctl_output_t *out)
{
    const size_t n_reports =
        in->n_obstacles < SUP_MAX_OBSTACLES ? in->n_obstacles : SUP_MAX_OBSTACLES;
    const uint16_t dropped_before = c->sup.dropped;
    /* Reports that screening leaves as they are (velocities kept, every value
     * in range) go to the table uncopied. */
    bool as_they_are = with_velocity;
    /* cppcheck-suppress knownConditionTrueFalse ; false positive: n_reports is up to 48 */
    for (size_t i = 0; as_they_are && i < n_reports; i++) {
        as_they_are = report_ok(&in->obstacles[i], true);
    }
    size_t n_ev = 0;
    if (as_they_are) {
        /* "mstc" (with velocities) averages the reports of static obstacles. */
        sup_take_averaged_reports(&c->sup, &in->robot, in->obstacles, n_reports, in->t_us,
                                  out->events, &n_ev);
    } else {
        /* cppcheck-suppress knownConditionTrueFalse ; false positive: n_reports is up to 48 */
        for (size_t at = 0; at < n_reports; at += CTL_SCREEN_CHUNK) {
            const size_t n = n_reports - at < CTL_SCREEN_CHUNK ? n_reports - at : CTL_SCREEN_CHUNK;
            sup_obstacle_t reports[CTL_SCREEN_CHUNK];
            /* Screened: every value finite (within()), or the report is id 0. */
            /* cppcheck-suppress knownConditionTrueFalse ; false positive: n is 1 to 16 here */
            for (size_t i = 0; i < n; i++) {
                screen(&in->obstacles[at + i], with_velocity, &reports[i]);
            }
            if (with_velocity) {
                sup_take_averaged_reports(&c->sup, &in->robot, reports, n, in->t_us, out->events,
                                          &n_ev);
            } else {
                sup_take_finite_reports(&c->sup, &in->robot, reports, n, in->t_us, out->events,
                                        &n_ev);
            }
        }
    }
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
 * wheels give, for the status: @p body's when it holds it for these wheels. */
static void finish(const ctl_t *c, const cbf_body_t *body, ctl_output_t *out)
{
    ctl_status_t *st = &out->status;
    if (!within(out->wheels.left, c->p.kin.max_wheel_speed) ||
        !within(out->wheels.right, c->p.kin.max_wheel_speed)) {
        out->wheels = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
        st->faults |= CTL_FAULT_OUTPUT_INVALID;
    } else if (body->known) {
        st->v = body->v;
        st->w = body->w;
        return;
    } else {
        /* computed below */
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

/* Key of the first step's period in step_dt(): no period of microseconds. */
#define CTL_FIRST_KEY UINT64_MAX

/* The period since the last step [s], within [0, ACT_MAX_DT]; CTL_FIRST_DT
 * at the first. Through float in both modes, as the application's ramp.
 * *key names the period: equal keys, equal periods. */
static num_t step_dt(ctl_t *c, uint64_t t_us, uint64_t *key)
{
    num_t dt = CTL_FIRST_DT;
    *key = CTL_FIRST_KEY;
    if (c->stepped) {
        const uint64_t us = t_us > c->last_t_us ? t_us - c->last_t_us : 0u;
        *key = us >= 100000u ? 100000u : us;
        ctl_memo_t *mo = &c->memo;
        if (us >= 100000u) {
            dt = ACT_MAX_DT;
        } else if (mo->dt_known && mo->dt_us == us) {
            dt = mo->dt; /* the same period again: soft float on a Cortex-M3 */
        } else {
            dt = num_from_float((float)us * 1.0e-6f);
            mo->dt = dt;
            mo->dt_us = us;
            mo->dt_known = true;
        }
    }
    c->last_t_us = t_us;
    c->stepped = true;
    return dt;
}

/* The rate limiter's step wheel_accel × dt for the period @p dt of key @p key
 * (step_dt()), from its microseconds: in Q16.16, a·dt would carry dt's
 * rounding times a (num_mul_period()). */
static num_t accel_step(const ctl_t *c, num_t dt, uint64_t key)
{
    return num_mul_period(c->p.wheel_accel, dt,
                          key == CTL_FIRST_KEY ? CTL_FIRST_US : (uint32_t)key);
}

/* The look-ahead velocity u = v e_θ + l ω e⊥ of a body velocity (@p kv = v
 * and @p klw = l ω, each times a factor k), in the world frame. */
static void lookahead_velocity(num_t kv, num_t klw, num_t cos_th, num_t sin_th, num_t *ux,
                               num_t *uy)
{
    *ux = num_sub(num_mul(kv, cos_th), num_mul(klw, sin_th));
    *uy = num_add(num_mul(kv, sin_th), num_mul(klw, cos_th));
}

/* What the wheels do to this step ("mstc", docs/strategy.md "Real wheels"):
 * the period, the horizon of the wheels' lag, the estimated body velocity and
 * the pose it carries the robot to, the command in force, its body velocity
 * and its braking time. */
typedef struct {
    num_t dt;      /* [s] */
    num_t step;    /* wheel_accel × dt: the rate limiter's step [rad/s] */
    num_t horizon; /* T_p [s] */
    num_t v, w;    /* estimated body velocity now [m/s], [rad/s] */
    act_pose_t at; /* the pose the lag carries the robot to */
    num_t vc, wc;  /* the command in force's body velocity */
    num_t brake_t; /* T_b of the command in force [s] */
} wheels_now_t;

static void wheels_now(ctl_t *c, const ctl_input_t *in, num_t cos_th, num_t sin_th,
                       wheels_now_t *wn)
{
    const ctl_params_t *p = &c->p;
    ctl_memo_t *mo = &c->memo;
    uint64_t key;
    wn->dt = step_dt(c, in->t_us, &key);
    /* The lag's factor and the rate limiter's step of the same period again
     * (the period's key, and wheel_tau and wheel_accel, which only a
     * parameter set changes: memo_reset()). */
    if (!mo->period_known || mo->period_us != key) {
        mo->lag_k = act_lag(p->wheel_tau, wn->dt);
        mo->step = accel_step(c, wn->dt, key);
        mo->period_us = key;
        mo->period_known = true;
    }
    wn->step = mo->step;
    act_estimate_lag(&c->act, mo->lag_k, in->wheels_measured ? &in->wheels : NULL);
    wn->horizon = act_horizon(p->wheel_tau, wn->dt, in->wheels_age, in->wheels_measured);
    kin_vw_from_wheels(&p->kin, &c->act.est, &wn->v, &wn->w);
    act_predict(&in->robot, cos_th, sin_th, wn->v, wn->w, wn->horizon, &wn->at);
    /* The command in force is the last step's: its body velocity is the one
     * finish() gave the status then, unless act.cmd changed since. */
    if (mo->cmd_known) {
        wn->vc = mo->cmd_v;
        wn->wc = mo->cmd_w;
    } else {
        kin_vw_from_wheels(&p->kin, &c->act.cmd, &wn->vc, &wn->wc);
    }
    wn->brake_t = act_brake_time(&c->act.cmd, c->act.lim.inv_accel, wn->dt);
}

/* The tracking errors carried over the horizon T_p by their kinematics
 * (Kanayama: ė1 = ω e2 − v + v_r cos e3, ė2 = −ω e1 + v_r sin e3,
 * ė3 = ω_r − ω, at the estimated (v, ω)), to first order; cos and sin of
 * the new e3 by rotating those of e3 (act_predict()'s rotation). */
typedef struct {
    trk_err_t e;
    num_t c3, s3; /* cos e3, sin e3 */
} pred_err_t;

static void predict_errors(const ctl_input_t *in, const wheels_now_t *wn, const trk_err_t *e,
                           pred_err_t *pe)
{
    num_t s3;
    num_t c3;
    num_sincos(e->e3, &s3, &c3);
    const num_t t = wn->horizon;
    const num_t e1d = num_add(num_sub(num_mul(wn->w, e->e2), wn->v), num_mul(in->v_r, c3));
    const num_t e2d = num_add(num_neg(num_mul(wn->w, e->e1)), num_mul(in->v_r, s3));
    pe->e.e1 = num_add(e->e1, num_mul(t, e1d));
    pe->e.e2 = num_add(e->e2, num_mul(t, e2d));
    act_pose_t r;
    act_predict_heading(e->e3, c3, s3, num_sub(in->w_r, wn->w), t, &r);
    pe->e.e3 = r.p.theta;
    pe->c3 = r.c;
    pe->s3 = r.s;
}

/* The least tracking speed near obstacles ("mstc", applied after the
 * strategy's decision): where eq. (2) held within [0, speed_limit]
 * (track_speed()) stops the robot to turn in place (v_r cos e3 + k1 e1 <= 0:
 * |e3| > π/2, the reference beside it and heading away), a robot behind its
 * reference (the reference ahead of it along the reference's own heading,
 * e1 cos e3 + e2 sin e3 > 0 on the predicted errors) keeps the speed its
 * wheels have, up to |v_r|, while it turns towards the reference: stopping,
 * spinning and driving off cost wheels that accelerate at a few rad/s²
 * seconds while the reference drives away. Never more than it has: a robot
 * that something brakes (the filter, the guard) slows, and turns in place
 * once standing. Only when every obstacle within D_act + MSW_REGULATE
 * (@p dist: centre distances) is static. Mirrored for a reference that
 * drives backwards. Returns the tracking speed @p v, or that least speed. */
static num_t track_least_speed(const ctl_t *c, const ctl_input_t *in, const wheels_now_t *wn,
                               const pred_err_t *pe, const num_t *dist, num_t v)
{
    const bool back = in->v_r < NUM_ZERO;
    /* Speeds along the reference's direction of motion. */
    const num_t has = back ? num_neg(wn->v) : wn->v;
    const num_t least = num_min(num_abs(in->v_r), has);
    if ((back ? num_neg(v) : v) > NUM_ZERO || least <= NUM_ZERO) {
        return v; /* eq. (2) drives on, or nothing to keep */
    }
    const num_t along = num_add(num_mul(pe->e.e1, pe->c3), num_mul(pe->e.e2, pe->s3));
    if (back ? along >= NUM_ZERO : along <= NUM_ZERO) {
        return v; /* ahead of its reference: it waits */
    }
    if (back ? pe->e.e1 > NUM_ZERO : pe->e.e1 < NUM_ZERO) {
        return v; /* its reference behind its direction of motion: it turns first */
    }
    const unsigned n = c->sup.n_obs;
    for (unsigned i = 0; i < n; i++) {
        const sup_entry_t *e = &c->sup.obs[i];
        if (dist[i] < num_add(e->d_act, MSW_REGULATE) && msw_moving(e)) {
            return v; /* the speed kept would carry it into the way */
        }
    }
    return back ? num_neg(least) : least;
}

/* A robot within this of its reference's line (|e2| [m]) and heading
 * (|sin e3|, cos e3 > 0) is aligned with it (ctl_most_speed()). */
#define CTL_ALIGNED NUM_C(0.1)

/* a'' / a': the braking curve of an aligned robot decelerates at
 * a'' = 0.75 r a, not at a' = ACT_LAW_SHARE × r a = 0.5 r a. */
#define CTL_ALIGNED_GAIN NUM_C(1.5)

num_t ctl_most_speed(num_t law_accel, const trk_err_t *e, num_t cos_e3, num_t sin_e3)
{
    num_t twice_a = num_add(law_accel, law_accel);
    if (cos_e3 > NUM_ZERO && num_abs(sin_e3) < CTL_ALIGNED && num_abs(e->e2) < CTL_ALIGNED) {
        twice_a = num_mul(twice_a, CTL_ALIGNED_GAIN);
    }
    return num_sqrt(num_mul(twice_a, num_abs(e->e1)));
}

/* The tracking command through the wheels' limits ("mstc"): eq. (2)-(3) on
 * the errors the lag carries the robot to (predict_errors()); the turn
 * beyond ω_r held within 2γ'/(k3 |v_r|) and the speed beyond v_r cos e3
 * within sqrt(2 a' |e1|): the largest corrections a heading (or distance)
 * error can be brought to zero with, decelerating at γ' (a'), without
 * overshoot (a braking curve; for a law of gain K the curve
 * |x| <= sqrt(2 γ' |x| / K) is the bound 2γ'/K); an aligned robot's speed
 * on a steeper curve (ctl_most_speed()). */
static void track_command(ctl_t *c, const ctl_input_t *in, const pred_err_t *pe, num_t *v, num_t *w)
{
    const act_limits_t *lim = &c->act.lim;
    const trk_gains_t *g = &c->p.trk;
    const num_t ff = num_mul(in->v_r, pe->c3);
    const num_t most_v = ctl_most_speed(lim->law_accel, &pe->e, pe->c3, pe->s3);
    *v = num_add(ff, num_clamp(num_mul(g->k1, pe->e.e1), num_neg(most_v), most_v));
    const num_t turn = num_mul(in->v_r, num_add(num_mul(g->k2, pe->e.e2), num_mul(g->k3, pe->s3)));
    const num_t k3v = num_mul(g->k3, num_abs(in->v_r));
    num_t most_w = NUM_MAX;
    if (k3v > NUM_ZERO) {
        /* The same bound while |v_r| stays (γ' and k3 change only with the
         * parameters: memo_reset()); k3v > 0, so equal values have equal
         * bits. */
        ctl_memo_t *mo = &c->memo;
        if (!mo->turn_known || mo->turn_k3v != k3v) {
            mo->turn_most = num_div(num_add(lim->gamma, lim->gamma), k3v);
            mo->turn_k3v = k3v;
            mo->turn_known = true;
        }
        most_w = mo->turn_most;
    }
    *w = num_add(in->w_r, num_clamp(turn, num_neg(most_w), most_w));
}

/* The avoidance command through the wheels' limits ("mstc"): eq. (23) on the
 * predicted errors, within [MSW_SPEED_MIN |v_r|, speed_limit] as
 * avoid_speed() and no faster than ρ sqrt(γ') on a circle of radius ρ (a
 * turn onto it the wheels can build: ω = v/ρ <= sqrt(γ')); eq. (24) at the
 * predicted pose with its correction k2 e held within 2γ'/k2 (as
 * track_command()). */
static void avoid_command(const ctl_t *c, const ctl_input_t *in, const wheels_now_t *wn,
                          const pred_err_t *pe, const msw_decision_t *d, num_t *v, num_t *w,
                          num_t *e)
{
    const act_limits_t *lim = &c->act.lim;
    const num_t v23 = num_add(num_mul(in->v_r, pe->c3), num_mul(c->p.avd.k1, pe->e.e1));
    const num_t slowest = c->msw.held ? num_abs(in->v_r) : num_mul(MSW_SPEED_MIN, num_abs(in->v_r));
    const num_t cap = num_max(num_mul(d->circle.d_s, lim->sqrt_gamma), slowest);
    *v = num_clamp(v23, slowest, num_min(speed_limit(in->v_r), cap));
    avd_turn(&c->p.avd, &wn->at.p, wn->at.c, wn->at.s, &d->circle, d->side, *v, w, e);
    const num_t slow = ctl_turn_first(num_cos(*e), msw_moving(d->followed), c->p.wheel_tau);
    if (slow < NUM_ONE) {
        *v = num_mul(*v, slow);
    }
    const num_t corr = num_mul(c->p.avd.k2, *e);
    const num_t most = c->memo.avoid_most; /* 2γ'/k2 */
    *w = num_add(num_sub(*w, corr), num_clamp(corr, num_neg(most), most));
}

/* How much farther than D_act a closing obstacle activates: the distance the
 * command in force needs to stop, |v| (wheel_tau + T_b). */
static num_t activation_reach(const ctl_t *c, const wheels_now_t *wn)
{
    return num_mul(num_abs(wn->vc), num_add(c->p.wheel_tau, wn->brake_t));
}

/* What the filter needs of the wheels (cbf.h): the look-ahead point where the
 * lag carries it, the command in force, its braking time, the acceleration. */
static void filter_motion(const ctl_t *c, const wheels_now_t *wn, num_t cos_th, num_t sin_th,
                          cbf_motion_t *m)
{
    /* The shift: u of the estimate times T_p; q: u of the command in force. */
    lookahead_velocity(num_mul(wn->horizon, wn->v),
                       num_mul(num_mul(wn->horizon, CBF_LOOKAHEAD), wn->w), cos_th, sin_th,
                       &m->shift_x, &m->shift_y);
    lookahead_velocity(wn->vc, num_mul(CBF_LOOKAHEAD, wn->wc), cos_th, sin_th, &m->qx, &m->qy);
    m->brake_t = wn->brake_t;
    m->inv_accel = c->act.lim.inv_av;
    m->side = c->act.lim.side;
    m->inv_side = c->act.lim.inv_side;
    m->gap = num_sub(c->p.d_s, num_add(c->p.r_m, c->p.r_ob));
    m->horizon = wn->horizon;
}

/* The rate limiter and the braking guard (cbf_guard()). */
static bool limit_and_guard(ctl_t *c, const wheels_now_t *wn, const num_t *dist,
                            kin_wheels_t *wheels, cbf_body_t *body)
{
    const cbf_guard_t g = { .kin = &c->p.kin,
                            .step = wn->step,
                            .inv_accel = c->act.lim.inv_accel,
                            .dt = wn->dt,
                            .start = wn->at.p,
                            .c = wn->at.c,
                            .s = wn->at.s,
                            .lead = num_mul(num_abs(wn->v), wn->horizon) };
    return cbf_guard(&c->act, &g, c->sup.obs, dist, c->sup.n_obs, wheels, body);
}

/* Id of the nearest obstacle (the one a guard's braking concerns, when the
 * filter named none), 0 when none. */
static uint8_t nearest_id(const ctl_t *c, const ctl_status_t *st)
{
    uint8_t id = 0u;
    num_t best = NUM_MAX;
    for (uint8_t i = 0; i < c->sup.n_obs; i++) {
        if (st->distance[i] < best) {
            best = st->distance[i];
            id = c->sup.obs[i].o.id;
        }
    }
    return id;
}

/* The "mstc" step (ctl.h): the table, the strategy, the active controller
 * through the wheels' limits, kinematics, then the safety filter on what the
 * wheels will do, the rate limiter and the braking guard. */
/* The input with the reference replaced by the strategy's aim while it
 * holds (msw.h: the reference waits, and the robot goes to a point of its
 * line ahead), else @p in. */
static const ctl_input_t *aimed_input(ctl_t *c, const ctl_input_t *in, ctl_input_t *copy)
{
    msw_t *m = &c->msw;
    if (!m->aimed) {
        return in;
    }
    if (in->ref.x != m->aim_rx || in->ref.y != m->aim_ry) {
        m->aimed = false; /* the reference moved on */
        return in;
    }
    msw_slide_aim(m, &in->robot, &in->ref);
    *copy = *in;
    copy->ref = m->aim;
    copy->w_r = NUM_ZERO;
    return copy;
}

/* How far the obstacles are known [m]: D_det, or when the sensor reported
 * as many as the table holds, the farthest report (nearer first). */
static num_t known_range(const ctl_t *c, const ctl_input_t *in)
{
    if (in->n_obstacles < SUP_MAX_OBSTACLES) {
        return c->p.d_det;
    }
    num_t far = NUM_ZERO;
    for (size_t i = 0; i < in->n_obstacles; i++) {
        far = num_max(far, oset_distance(num_sub(in->obstacles[i].x, in->robot.x),
                                         num_sub(in->obstacles[i].y, in->robot.y)));
    }
    return num_min(far, c->p.d_det);
}

static void mstc_step(ctl_t *c, const ctl_input_t *in0, ctl_output_t *out)
{
    ctl_input_t copy;
    const ctl_input_t *in = aimed_input(c, in0, &copy);
    ctl_status_t *st = &out->status;
    size_t n_ev = out->n_events;
    num_t sin_th;
    num_t cos_th;
    num_sincos(in->robot.theta, &sin_th, &cos_th);
    trk_errors_cs(&in->robot, cos_th, sin_th, &in->ref, &st->err);
    wheels_now_t wn;
    wheels_now(c, in, cos_th, sin_th, &wn);
    pred_err_t pe;
    predict_errors(in, &wn, &st->err, &pe);
    num_t v_trk;
    num_t w_trk;
    track_command(c, in, &pe, &v_trk, &w_trk);
    /* Centre distances first: the strategy uses them, the status reports them
     * (oset_distance: as fill_distances, the cheaper way). Some obstacle
     * within its D_act + MSW_REGULATE: the tracking speed is regulated
     * (track_speed); elsewhere tracking is eq. (2)-(3) as is. */
    const uint8_t n = c->sup.n_obs; /* a local: the id stores (bytes) may alias it */
    const num_t rx = in->robot.x;
    const num_t ry = in->robot.y;
    st->n_obstacles = n;
    bool near = false;
    for (unsigned i = 0; i < n; i++) {
        const sup_entry_t *e = &c->sup.obs[i];
        const num_t d = oset_distance(num_sub(e->o.x, rx), num_sub(e->o.y, ry));
        st->obstacle_id[i] = e->o.id;
        st->distance[i] = d;
        near = near || d < num_add(e->d_act, MSW_REGULATE);
    }
    if (near) {
        v_trk = track_speed(v_trk, in->v_r);
    }
    const msw_input_t mi = { .robot = &in->robot,
                             .ref = &in->ref,
                             .host = &in0->ref,
                             .range = known_range(c, in0),
                             .v_r = in->v_r,
                             .w_r = in->w_r,
                             .cos_th = cos_th,
                             .sin_th = sin_th,
                             .v_trk = v_trk,
                             .w_trk = w_trk,
                             .dist = st->distance,
                             .t_us = in->t_us,
                             .reach = activation_reach(c, &wn),
                             .filtered = c->filtered };
    msw_decision_t d;
    msw_step(&c->msw, &c->sup, &mi, out->events, &n_ev, &d);

    st->mode = d.mode;
    num_t v = NUM_ZERO;
    num_t w = NUM_ZERO;
    if (d.mode == SUP_MODE_TRACK) {
        v = v_trk;
        w = w_trk;
        if (near) {
            /* Not in v_trk: the release's roll-out judges the turn in place,
             * so a robot facing an obstacle is not held in avoidance by a
             * speed it would not keep. */
            v = track_least_speed(c, in, &wn, &pe, st->distance, v);
        }
    } else if (d.mode == SUP_MODE_AVOID && d.followed != NULL) { /* msw_step sets both */
        st->active_obstacle = d.followed->o.id;
        st->side = d.side;
        avoid_command(c, in, &wn, &pe, &d, &v, &w, &st->e);
    } else {
        /* STOP (p3) and BLOCKED: v = ω = 0. */
    }
    wheels_for(c, v, w, &out->wheels, &st->faults);
    /* The filter sees what the wheels will do. */
    kin_vw_from_wheels(&c->p.kin, &out->wheels, &v, &w);
    cbf_body_t body = { .v = v, .w = w, .known = true }; /* of out->wheels */
    cbf_motion_t motion;
    filter_motion(c, &wn, cos_th, sin_th, &motion);
    cbf_result_t fr;
    const bool was_infeasible = c->cbf.infeasible;
    const bool was_active = c->cbf.active; /* cbf_step sets it for this step */
    cbf_step(&c->cbf, &in->robot, cos_th, sin_th, &motion, c->sup.obs, st->distance, c->sup.n_obs,
             &v, &w, &fr);
    if (fr.changed) {
        wheels_for(c, v, w, &out->wheels, &st->faults);
        body.known = false;
    }
    /* A moving obstacle no command within the wheels' limits keeps away. */
    const uint8_t unreachable =
        cbf_unreachable(&c->cbf, c->sup.obs, c->sup.n_obs, &c->p.kin, &c->act.cmd, wn.step);
    if (unreachable != 0u) {
        fr.infeasible = true;
        fr.new_infeasible = !was_infeasible;
        c->cbf.infeasible = true;
    }
    if (limit_and_guard(c, &wn, st->distance, &out->wheels, &body)) {
        fr.changed = true;
        fr.new_episode = !was_active;
        c->cbf.active = true;
        fr.obstacle = fr.obstacle != 0u ? fr.obstacle : nearest_id(c, st);
    }
    c->filtered = fr.changed ? fr.obstacle : 0u; /* the next step's msw_input_t::filtered */
    if (fr.changed) {
        st->faults |= CTL_FAULT_FILTER;
        if (fr.new_episode && n_ev < SUP_MAX_EVENTS) {
            out->events[n_ev] = (sup_event_t){ .t_us = in->t_us,
                                               .kind = (uint8_t)SUP_EVENT_FILTER,
                                               .obstacle = fr.obstacle,
                                               .side = (int8_t)AVD_SIDE_NONE };
            n_ev++;
        }
    }
    if (fr.new_infeasible && n_ev < SUP_MAX_EVENTS) {
        out->events[n_ev] =
            (sup_event_t){ .t_us = in->t_us,
                           .kind = (uint8_t)SUP_EVENT_INFEASIBLE,
                           .obstacle = unreachable != 0u ? unreachable : fr.obstacle,
                           .side = (int8_t)AVD_SIDE_NONE };
        n_ev++;
    }
    out->n_events = n_ev;
    finish(c, &body, out);
    c->act.cmd = out->wheels; /* zero when finish() had to */
    c->memo.cmd_v = st->v;
    c->memo.cmd_w = st->w;
    c->memo.cmd_known = true;
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
    const cbf_body_t unknown = { .known = false };
    finish(c, &unknown, out);
    fill_distances(c, &in->robot, st);
}

void ctl_step(ctl_t *c, const ctl_input_t *in, ctl_output_t *out)
{
    ctl_status_t *st = &out->status;
    /* (ctl_status_t){ .mode = SUP_MODE_STOP, .side = AVD_SIDE_NONE }, member
     * by member: the whole status in one literal is a call to memset, some
     * 130 instructions a step on a Cortex-M (the loop stays one: the
     * Makefile's SRC_CFLAGS for this file). */
    st->mode = SUP_MODE_STOP;
    st->active_obstacle = 0u;
    st->side = AVD_SIDE_NONE;
    st->err = (trk_err_t){ NUM_ZERO, NUM_ZERO, NUM_ZERO };
    st->e = NUM_ZERO;
    st->v = NUM_ZERO;
    st->w = NUM_ZERO;
    st->faults = 0u;
    /* obstacle_id[] and distance[] hold n_obstacles entries, written by the
     * strategy's step; the rest are left as they were (ctl.h): clearing all
     * SUP_MAX_OBSTACLES of them cost about 100 instructions a step on a Cortex-M4F
     * (make bench). */
    st->n_obstacles = 0u;
    out->n_events = 0;
    out->wheels = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };

    if (!inputs_in_range(in)) {
        /* Bad data from outside: stop, and leave the supervisor as it was;
         * "mstc" brakes as fast as its wheels can (act.h). */
        st->faults = CTL_FAULT_INPUT_NONFINITE;
        if (ctl_is_mstc(&c->p)) {
            uint64_t key;
            const num_t dt = step_dt(c, in->t_us, &key);
            (void)act_limit(&c->act, accel_step(c, dt, key), &out->wheels);
            c->memo.cmd_known = false;
        }
        return;
    }
    if (ctl_is_mstc(&c->p)) {
        /* The reports first, from here: their screening copy is off the
         * stack before mstc_step's frame is on it (the F103's stack). */
        take_reports(c, in, true, out);
        mstc_step(c, in, out);
    } else {
        paper_step(c, in, out);
    }
}
