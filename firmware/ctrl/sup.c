/* SPDX-License-Identifier: MIT */
/* Switch strategy, paper section 4, with the choices of docs/equations.md. */
#include "ctrl/sup.h"

bool sup_p1(const pose_t *robot, const pose_t *ref, num_t ox, num_t oy, num_t d_act)
{
    /* u1 = q − O, u2 = q_r − O; eq. (19) |u2| > D_act, eq. (20) u1·u2 > 0. */
    const num_t u1x = num_sub(robot->x, ox);
    const num_t u1y = num_sub(robot->y, oy);
    const num_t u2x = num_sub(ref->x, ox);
    const num_t u2y = num_sub(ref->y, oy);
    return num_hypot(u2x, u2y) > d_act && num_add(num_mul(u1x, u2x), num_mul(u1y, u2y)) > NUM_ZERO;
}

bool sup_p2(const pose_t *robot, const pose_t *ref, num_t ox, num_t oy, num_t d_act)
{
    const num_t d = num_hypot(num_sub(robot->x, ox), num_sub(robot->y, oy));
    return d < d_act && !sup_p1(robot, ref, ox, oy, d_act);
}

bool sup_p3(num_t v_r, num_t w_r) { return v_r == NUM_ZERO && w_r == NUM_ZERO; }

void sup_init(sup_t *s, const sup_params_t *p)
{
    s->p = *p;
    s->revision = 0u;
    sup_reset(s);
}

void sup_reset(sup_t *s)
{
    s->n_obs = 0;
    s->avoiding = 0;
    s->active = 0;
    s->side = AVD_SIDE_NONE;
    s->dropped = 0;
    s->revision++;
    for (size_t i = 0; i < sizeof s->slot; i++) {
        s->slot[i] = 0u;
    }
}

static void set_entry(const sup_t *s, sup_entry_t *e, const sup_obstacle_t *o);

void sup_set_params(sup_t *s, const sup_params_t *p)
{
    s->p = *p;
    for (uint8_t i = 0; i < s->n_obs; i++) {
        const sup_obstacle_t o = s->obs[i].o;
        set_entry(s, &s->obs[i], &o);
    }
    s->revision++;
}

/* A report the table takes: @p finite when the caller has found its values
 * finite already. */
static bool report_valid(const sup_obstacle_t *o, bool finite)
{
    return o->id != 0 &&
           (finite || (num_is_finite(o->x) && num_is_finite(o->y) && num_is_finite(o->radius))) &&
           o->radius > NUM_ZERO;
}

/* A report that moves an obstacle or changes its size (what clusters are
 * made of; a velocity alone does not). */
static bool moved(const sup_obstacle_t *was, const sup_obstacle_t *now)
{
    return was->x != now->x || was->y != now->y || was->radius != now->radius;
}

static sup_entry_t *find(sup_t *s, uint8_t id)
{
    const uint8_t k = s->slot[id];
    return k != 0u ? &s->obs[k - 1u] : NULL;
}

static void emit(sup_event_t *events, size_t *n, uint64_t t_us, sup_event_kind_t kind, uint8_t id,
                 avd_side_t side)
{
    events[*n] =
        (sup_event_t){ .t_us = t_us, .kind = (uint8_t)kind, .obstacle = id, .side = (int8_t)side };
    (*n)++;
}

static void set_entry(const sup_t *s, sup_entry_t *e, const sup_obstacle_t *o)
{
    /* A larger obstacle moves both thresholds out by its extra radius. */
    const num_t extra = num_sub(o->radius, s->p.r_ob);
    e->o = *o;
    e->d_s = num_add(s->p.d_s, extra);
    e->d_act = num_add(s->p.d_act, extra);
}

/* 1 / n for n = 1 .. SUP_AVG_MAX: the weights of the running mean. */
static const num_t avg_weight[] = {
    NUM_C(0.0),       NUM_C(1.0),       NUM_C(1.0 / 2.0), NUM_C(1.0 / 3.0), NUM_C(1.0 / 4.0),
    NUM_C(1.0 / 5.0), NUM_C(1.0 / 6.0), NUM_C(1.0 / 7.0), NUM_C(1.0 / 8.0),
};
_Static_assert(sizeof avg_weight / sizeof avg_weight[0] == SUP_AVG_MAX + 1u,
               "a weight for each count");

/* Whether report @p o of entry @p e's id is another obstacle (sup.h,
 * "an id that comes back elsewhere"): farther from the entry's centre than
 * SUP_AVG_GATE in x or in y; when either moves, than SUP_AVG_GATE plus the
 * distance the faster of the two covers along that axis in
 * SUP_MOVING_GATE_TIME. */
static bool elsewhere(const sup_entry_t *e, const sup_obstacle_t *o)
{
    num_t gate_x = SUP_AVG_GATE;
    num_t gate_y = SUP_AVG_GATE;
    if (num_any_nonzero(o->vx, o->vy) || num_any_nonzero(e->o.vx, e->o.vy)) {
        gate_x = num_add(gate_x,
                         num_mul(num_max(num_abs(o->vx), num_abs(e->o.vx)), SUP_MOVING_GATE_TIME));
        gate_y = num_add(gate_y,
                         num_mul(num_max(num_abs(o->vy), num_abs(e->o.vy)), SUP_MOVING_GATE_TIME));
    }
    return num_abs(num_sub(o->x, e->o.x)) > gate_x || num_abs(num_sub(o->y, e->o.y)) > gate_y;
}

/* Definition 1's range for report @p o, moved out by its extra radius as
 * D_s and D_act are (set_entry): D_det is the centre distance at which an
 * obstacle of radius R_ob is seen, so the range counts from the obstacle's
 * boundary. Avoidance then starts within the range for every radius
 * (D_act <= D_det), as for R_ob. */
static bool in_range(const sup_t *s, const pose_t *robot, const sup_obstacle_t *o)
{
    const num_t range = num_add(s->p.d_det, num_sub(o->radius, s->p.r_ob));
    return num_hypot(num_sub(o->x, robot->x), num_sub(o->y, robot->y)) <= range;
}

/* The report @p o, which moves static entry @p e and is not elsewhere(),
 * averaged into its centre when it may be (sup_take_averaged_reports()),
 * @p n its count of reports averaged; false: take it as it comes. */
static bool average_into(sup_entry_t *e, uint8_t *n, const sup_obstacle_t *o)
{
    const num_t dx = num_sub(o->x, e->o.x);
    const num_t dy = num_sub(o->y, e->o.y);
    if (o->vx != NUM_ZERO || o->vy != NUM_ZERO || e->o.vx != NUM_ZERO || e->o.vy != NUM_ZERO ||
        o->radius != e->o.radius) {
        return false;
    }
    if (*n < SUP_AVG_MAX) {
        (*n)++;
    }
    const num_t k = avg_weight[*n];
    e->o.x = num_add(e->o.x, num_mul(dx, k));
    e->o.y = num_add(e->o.y, num_mul(dy, k));
    return true;
}

/* take_reports() once in each of its callers, its flags constants there
 * (the reports of "mstc" take the averaged path: 34 instructions a step
 * fewer on the M4F's load-8 scene, make bench; the same code, the same
 * bits). Not when optimising nothing (the coverage build, -O0), where gcov
 * would count its branches once per caller (as CBF_INLINE, cbf.c). */
#if defined(__GNUC__) && defined(__OPTIMIZE__)
#define SUP_INLINE static inline __attribute__((always_inline))
#else
#define SUP_INLINE static
#endif

/* Definition 1: remember each reported obstacle from the first step at which
 * it lies within D_det; a known id reported elsewhere() names a new obstacle,
 * which takes its entry (sup.h). At most one detect event per report, so at
 * most SUP_MAX_OBSTACLES per step (ctl.c passes no more reports). */
SUP_INLINE void take_reports(sup_t *s, const pose_t *robot, const sup_obstacle_t *reports,
                             size_t n_reports, uint64_t t_us, sup_event_t *events, size_t *n_ev,
                             bool finite, bool average)
{
    for (size_t i = 0; i < n_reports; i++) {
        const sup_obstacle_t *o = &reports[i];
        if (!report_valid(o, finite)) {
            s->dropped++;
            continue;
        }
        sup_entry_t *e = find(s, o->id);
        if (e != NULL) {
            if (moved(&e->o, o)) {
                uint8_t *n = &s->n_avg[s->slot[o->id] - 1u];
                if (elsewhere(e, o)) {
                    /* The id came back elsewhere: a new obstacle, detected
                     * as an unknown id is (within range; until then the
                     * entry stays the obstacle it was). */
                    if (in_range(s, robot, o)) {
                        set_entry(s, e, o);
                        *n = 1u;
                        s->revision++;
                        emit(events, n_ev, t_us, SUP_EVENT_DETECT, o->id, AVD_SIDE_NONE);
                    }
                    continue;
                }
                s->revision++;
                if (!average || !average_into(e, n, o)) {
                    set_entry(s, e, o);
                    *n = 1u;
                }
            } else {
                /* Same place and size, so the same thresholds: only the
                 * velocity can differ (the cheaper way, every step). */
                e->o.vx = o->vx;
                e->o.vy = o->vy;
            }
            continue;
        }
        if (!in_range(s, robot, o)) {
            continue; /* reported, but not yet detected */
        }
        if (s->n_obs >= SUP_MAX_OBSTACLES) {
            s->dropped++;
            continue;
        }
        set_entry(s, &s->obs[s->n_obs], o);
        s->n_avg[s->n_obs] = 1u;
        s->n_obs++;
        s->slot[o->id] = s->n_obs;
        s->revision++;
        emit(events, n_ev, t_us, SUP_EVENT_DETECT, o->id, AVD_SIDE_NONE);
    }
}

void sup_take_reports(sup_t *s, const pose_t *robot, const sup_obstacle_t *reports,
                      size_t n_reports, uint64_t t_us, sup_event_t *events, size_t *n_ev)
{
    take_reports(s, robot, reports, n_reports, t_us, events, n_ev, false, false);
}

void sup_take_finite_reports(sup_t *s, const pose_t *robot, const sup_obstacle_t *reports,
                             size_t n_reports, uint64_t t_us, sup_event_t *events, size_t *n_ev)
{
    take_reports(s, robot, reports, n_reports, t_us, events, n_ev, true, false);
}

void sup_take_averaged_reports(sup_t *s, const pose_t *robot, const sup_obstacle_t *reports,
                               size_t n_reports, uint64_t t_us, sup_event_t *events, size_t *n_ev)
{
    take_reports(s, robot, reports, n_reports, t_us, events, n_ev, true, true);
}

void sup_step(sup_t *s, const pose_t *robot, const pose_t *ref, num_t v_r, num_t w_r,
              const sup_obstacle_t *reports, size_t n_reports, uint64_t t_us, sup_event_t *events,
              sup_decision_t *d)
{
    size_t n_ev = 0;
    sup_take_reports(s, robot, reports, n_reports, t_us, events, &n_ev);
    sup_decide(s, robot, ref, v_r, w_r, t_us, events, n_ev, d);
}

void sup_decide(sup_t *s, const pose_t *robot, const pose_t *ref, num_t v_r, num_t w_r,
                uint64_t t_us, sup_event_t *events, size_t n_events, sup_decision_t *d)
{
    size_t n_ev = n_events;
    /* docs/equations.md, several obstacles: completion of the active obstacle first. */
    if (s->avoiding != 0) {
        const sup_entry_t *a = &s->obs[s->active];
        if (sup_p1(robot, ref, a->o.x, a->o.y, a->d_act)) {
            emit(events, &n_ev, t_us, SUP_EVENT_COMPLETE, a->o.id, AVD_SIDE_NONE);
            s->avoiding = 0;
            s->side = AVD_SIDE_NONE;
        }
    }
    /* Then, when tracking, the nearest obstacle satisfying p2. */
    if (s->avoiding == 0) {
        int best = -1;
        num_t best_d = NUM_ZERO;
        for (uint8_t i = 0; i < s->n_obs; i++) {
            const sup_entry_t *e = &s->obs[i];
            const num_t dist = num_hypot(num_sub(robot->x, e->o.x), num_sub(robot->y, e->o.y));
            if ((best < 0 || dist < best_d) && sup_p2(robot, ref, e->o.x, e->o.y, e->d_act)) {
                best = i;
                best_d = dist;
            }
        }
        if (best >= 0) {
            const sup_entry_t *e = &s->obs[best];
            s->avoiding = 1;
            s->active = (uint8_t)best;
            s->side = avd_choose_side(robot, e->o.x, e->o.y); /* held until completion */
            emit(events, &n_ev, t_us, SUP_EVENT_ACTIVATE, e->o.id, s->side);
        }
    }

    d->n_events = n_ev;
    d->active = s->avoiding != 0 ? &s->obs[s->active] : NULL;
    d->side = s->side;
    if (sup_p3(v_r, w_r)) {
        d->mode = SUP_MODE_STOP;
    } else {
        d->mode = s->avoiding != 0 ? SUP_MODE_AVOID : SUP_MODE_TRACK;
    }
}
