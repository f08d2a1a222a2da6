/* SPDX-License-Identifier: MIT */
/* The "mstc" switch strategy (msw.h, docs/strategy.md). */
#include "ctrl/msw.h"

#include "ctrl/oset.h"
#include "ctrl/rol.h"

void msw_init(msw_t *m, num_t width)
{
    m->width = width;
    msw_reset(m);
}

void msw_reset(msw_t *m)
{
    m->state = (uint8_t)MSW_TRACK;
    m->trigger = 0u;
    m->followed = 0u;
    m->side = AVD_SIDE_NONE;
    m->cluster = 0u;
    m->revision = 0u;
    m->offset = MSW_FOLLOW_OFFSET;
    m->t_act_us = 0u;
    m->turned = NUM_ZERO;
    m->last_theta = NUM_ZERO;
    m->mark_x = NUM_ZERO;
    m->mark_y = NUM_ZERO;
    m->t_mark_us = 0u;
    m->ref_x = NUM_ZERO;
    m->ref_y = NUM_ZERO;
    m->held = false;
    m->ahead = false;
    m->aimed = false;
    m->reversed = false;
    for (size_t i = 0; i < SUP_MAX_OBSTACLES; i++) {
        m->acts[i] = 0u;
    }
    m->path = (rol_path_t){ .kind = ROL_TOO_LONG, .reach = NUM_MAX };
}

static void emit(sup_event_t *events, size_t *n, uint64_t t_us, sup_event_kind_t kind, uint8_t id,
                 avd_side_t side)
{
    events[*n] =
        (sup_event_t){ .t_us = t_us, .kind = (uint8_t)kind, .obstacle = id, .side = (int8_t)side };
    (*n)++;
}

bool msw_moving(const sup_entry_t *e)
{
    return num_add(num_abs(e->o.vx), num_abs(e->o.vy)) > MSW_MOVING_SPEED;
}

/* @p mask's indices within the table. */
static sup_mask_t in_table(sup_mask_t mask, const sup_t *s)
{
    return mask & sup_mask_first(s->n_obs);
}

/* Time since @p t0, 0 if the clock went backwards. */
static uint64_t since(uint64_t now, uint64_t t0) { return now >= t0 ? now - t0 : 0u; }

/* What one step looks at: its input, and the tracking command rolled out over
 * MSW_ROLLOUT (rol_path()) into *path (msw_t::path), computed once, when first
 * needed. */
typedef struct {
    const msw_input_t *in;
    bool rolled;
    bool aiming; /* the tracking command of this step goes to msw_t::aim */
    rol_path_t *path;
} look_t;

static const rol_path_t *rolled_out(look_t *lk)
{
    const msw_input_t *in = lk->in;
    if (!lk->rolled) {
        lk->rolled = true;
        rol_path(lk->path, in->robot, in->cos_th, in->sin_th, in->v_trk, in->w_trk, MSW_ROLLOUT);
    }
    return lk->path;
}

/* The robot's velocity under the tracking command, relative to entry @p e:
 * v_trk along the heading for a static entry; for a moving one, when the
 * roll-out is an arc, its chord per second: the velocity the tracking command
 * gives on average over MSW_ROLLOUT. In an avoidance the heading is the
 * avoidance's: a robot going round a moving obstacle's circle heads at it,
 * and tracking would turn it away at once; judged by its heading it would
 * never be released, and would follow the obstacle wherever it goes. On a
 * straight reference the two agree. */
static void relative_velocity(look_t *lk, const sup_entry_t *e, num_t *vx, num_t *vy)
{
    const msw_input_t *in = lk->in;
    num_t ux = num_mul(in->v_trk, in->cos_th);
    num_t uy = num_mul(in->v_trk, in->sin_th);
    if (msw_moving(e)) {
        const rol_path_t *path = rolled_out(lk);
        if (path->kind == ROL_ARC) {
            ux = num_mul(num_sub(path->s1x, path->s0x), MSW_ROLLOUT_INV);
            uy = num_mul(num_sub(path->s1y, path->s0y), MSW_ROLLOUT_INV);
        }
    }
    *vx = num_sub(ux, e->o.vx);
    *vy = num_sub(uy, e->o.vy);
}

/* Closing on entry @p i under the tracking command. */
static bool closing(look_t *lk, const sup_entry_t *e)
{
    num_t vx;
    num_t vy;
    relative_velocity(lk, e, &vx, &vy);
    return oset_closing(num_sub(e->o.x, lk->in->robot->x), num_sub(e->o.y, lk->in->robot->y), vx,
                        vy);
}

/* A moving entry whose closest approach within the horizon, under the
 * tracking command, comes inside D_s + MSW_CPA_MARGIN. */
static bool cpa_inside(look_t *lk, const sup_entry_t *e, num_t horizon, num_t margin)
{
    const msw_input_t *in = lk->in;
    const num_t px = num_sub(e->o.x, in->robot->x);
    const num_t py = num_sub(e->o.y, in->robot->y);
    if (num_abs(px) >= NUM_C(32.0) || num_abs(py) >= NUM_C(32.0)) {
        return false; /* out of reach within any horizon used here */
    }
    num_t vx;
    num_t vy;
    relative_velocity(lk, e, &vx, &vy);
    if (num_abs(vx) >= NUM_C(32.0) || num_abs(vy) >= NUM_C(32.0)) {
        return true; /* beyond what the test can tell: assume the worst */
    }
    num_t t;
    num_t d2;
    oset_closest_approach(px, py, num_neg(vx), num_neg(vy), horizon, &t, &d2);
    const num_t r = num_add(e->d_s, margin);
    return d2 < num_sq(r);
}

/* The tracking command's roll-out keeps static entry @p e beyond @p clear. */
static bool clears(look_t *lk, const sup_entry_t *e, num_t clear, num_t d)
{
    const rol_path_t *path = rolled_out(lk);
    return d >= num_add(path->reach, clear) || rol_clears(path, e->o.x, e->o.y, clear);
}

/* Boundary distance of entry @p i: centre distance less its own D_s. */
static num_t boundary(const sup_t *s, const msw_input_t *in, unsigned i)
{
    return num_sub(in->dist[i], s->obs[i].d_s);
}

/* How far from static entry @p e the tracking command's roll-out must keep
 * for it not to activate: D_s + MSW_ACT_MARGIN, or + MSW_FILTERED_MARGIN when
 * the safety filter changed the previous step's command for it (the command
 * closes on it faster than the barrier allows: it is in the way, though the
 * roll-out passes it). */
static num_t act_clear(const sup_entry_t *e, const msw_input_t *in)
{
    return num_add(e->d_s, e->o.id == in->filtered ? MSW_FILTERED_MARGIN : MSW_ACT_MARGIN);
}

/* The activation candidate (table index), or -1. */
static int candidate(const msw_t *m, const sup_t *s, look_t *lk)
{
    const msw_input_t *in = lk->in;
    /* In locals, that the calls below leave in registers: the loop runs for
     * every entry, every step. */
    const num_t *const dist = in->dist;
    const num_t reach = in->reach;
    const unsigned n = s->n_obs;
    int best = -1;
    num_t best_b = NUM_ZERO;
    for (unsigned i = 0; i < n; i++) {
        const sup_entry_t *e = &s->obs[i];
        /* Beyond any trigger's reach first: the cheapest test, and most
         * entries fail it. */
        if (dist[i] >= num_add(num_add(e->d_act, MSW_CPA_REACH), reach) ||
            m->acts[i] >= MSW_MAX_ACTIVATIONS) {
            continue;
        }
        bool trig = dist[i] < num_add(e->d_act, reach) && closing(lk, e) &&
                    (msw_moving(e) || !clears(lk, e, act_clear(e, in), dist[i]));
        if (!trig && msw_moving(e)) {
            /* Within d_act + MSW_CPA_REACH + reach: the test above. */
            trig = cpa_inside(lk, e, MSW_CPA_HORIZON, num_add(MSW_CPA_MARGIN, reach));
        }
        if (trig) {
            const num_t b = boundary(s, in, i);
            if (best < 0 || b < best_b) {
                best = (int)i;
                best_b = b;
            }
        }
    }
    return best;
}

/* The member of the cluster to follow: the nearest by boundary distance
 * (centre distance less D_s) from the robot or from the point
 * MSW_FOLLOW_AHEAD ahead of it, whichever is smaller. Looking ahead hands the
 * robot over to the next member before it reaches a concave corner of the
 * cluster, where the tangent of the member it leaves points into the next. */
static uint8_t nearest_member(const sup_t *s, const msw_input_t *in, sup_mask_t cluster,
                              uint8_t fallback)
{
    const num_t qx = num_add(in->robot->x, num_mul(MSW_FOLLOW_AHEAD, in->cos_th));
    const num_t qy = num_add(in->robot->y, num_mul(MSW_FOLLOW_AHEAD, in->sin_th));
    const num_t *const dist = in->dist;
    uint8_t best = fallback;
    num_t best_b = NUM_MAX;
    for (sup_mask_t rest = in_table(cluster, s); rest != 0u; rest = sup_mask_without_lowest(rest)) {
        const unsigned i = sup_mask_lowest(rest);
        const sup_entry_t *e = &s->obs[i];
        const num_t ahead = oset_distance(num_sub(e->o.x, qx), num_sub(e->o.y, qy));
        const num_t b = num_sub(num_min(dist[i], ahead), e->d_s);
        if (b < best_b) {
            best = (uint8_t)i;
            best_b = b;
        }
    }
    return best;
}

/* asin(x) for x in [0, 1], from atan2 (num.h has no asin). */
static num_t asin01(num_t x) { return num_atan2(x, num_sqrt(num_sub(NUM_ONE, num_mul(x, x)))); }

/* Side from the cluster's extent across the reference's path: the line
 * through the reference along its direction of motion. Passing on the left
 * (side LEFT, cluster on the robot's right) takes the robot to the cluster's
 * left edge, max(offset + ρ); passing on the right to its right edge,
 * min(offset − ρ). The side whose edge lies nearer the path wins; NONE when
 * they are within MSW_TIE_OFFSET. */
static avd_side_t side_by_reference(const sup_t *s, sup_mask_t cluster, num_t offset,
                                    const msw_input_t *in)
{
    num_t ey;
    num_t ex;
    num_sincos(in->ref->theta, &ey, &ex);
    if (in->v_r < NUM_ZERO) {
        ex = num_neg(ex);
        ey = num_neg(ey);
    }
    num_t left = num_neg(NUM_MAX);
    num_t right = NUM_MAX;
    for (sup_mask_t rest = in_table(cluster, s); rest != 0u; rest = sup_mask_without_lowest(rest)) {
        const sup_entry_t *e = &s->obs[sup_mask_lowest(rest)];
        /* Signed offset of the centre to the left of the path. */
        const num_t off = num_sub(num_mul(ex, num_sub(e->o.y, in->ref->y)),
                                  num_mul(ey, num_sub(e->o.x, in->ref->x)));
        const num_t rho = num_add(e->d_s, offset);
        left = num_max(left, num_add(off, rho));
        right = num_min(right, num_sub(off, rho));
    }
    /* Deviation to pass left: left (if > 0); to pass right: −right. */
    const num_t lean = num_add(num_max(left, NUM_ZERO), num_min(right, NUM_ZERO));
    if (lean < num_neg(MSW_TIE_OFFSET)) {
        return AVD_SIDE_LEFT;
    }
    if (lean > MSW_TIE_OFFSET) {
        return AVD_SIDE_RIGHT;
    }
    return AVD_SIDE_NONE;
}

/* Side from the cluster's angular extent seen from the robot, relative to
 * its heading (each member a disc of radius D_s + offset): with
 * L and R its left and right edges, LEFT when L + R < 0, i.e. the smaller
 * turn; for one obstacle this is eq. (11)-(12). NONE when |L + R| is within
 * 2 MSW_SIDE_DEADBAND. */
static avd_side_t side_by_heading(const sup_t *s, sup_mask_t cluster, num_t offset,
                                  const msw_input_t *in)
{
    const pose_t *p = in->robot;
    num_t left = num_neg(NUM_MAX);
    num_t right = NUM_MAX;
    for (sup_mask_t rest = in_table(cluster, s); rest != 0u; rest = sup_mask_without_lowest(rest)) {
        const unsigned i = sup_mask_lowest(rest);
        const sup_entry_t *e = &s->obs[i];
        const num_t psi =
            num_wrap(num_sub(num_atan2(num_sub(e->o.y, p->y), num_sub(e->o.x, p->x)), p->theta));
        const num_t rho = num_add(e->d_s, offset);
        const num_t half = in->dist[i] > rho ? asin01(num_div(rho, in->dist[i])) : NUM_HALF_PI;
        left = num_max(left, num_add(psi, half));
        right = num_min(right, num_sub(psi, half));
    }
    const num_t lean = num_add(left, right);
    const num_t band = num_add(MSW_SIDE_DEADBAND, MSW_SIDE_DEADBAND);
    if (lean < num_neg(band)) {
        return AVD_SIDE_LEFT;
    }
    if (lean > band) {
        return AVD_SIDE_RIGHT;
    }
    return AVD_SIDE_NONE;
}

avd_side_t msw_choose_side(const sup_t *s, sup_mask_t cluster, uint8_t trigger, num_t offset,
                           const msw_input_t *in)
{
    const sup_entry_t *t = &s->obs[trigger];
    if (msw_moving(t)) {
        /* Obstacle velocity across the heading: [−sin θ, cos θ]·v_o. */
        const num_t across =
            num_add(num_mul(num_neg(in->sin_th), t->o.vx), num_mul(in->cos_th, t->o.vy));
        if (across > MSW_MOVING_SPEED) {
            return AVD_SIDE_RIGHT;
        }
        if (across < num_neg(MSW_MOVING_SPEED)) {
            return AVD_SIDE_LEFT;
        }
    }
    avd_side_t side = side_by_reference(s, cluster, offset, in);
    if (side == AVD_SIDE_NONE) {
        side = side_by_heading(s, cluster, offset, in);
    }
    return side == AVD_SIDE_NONE ? AVD_SIDE_LEFT : side;
}

/* The tracking command's roll-out keeps every static entry of @p mask beyond
 * its D_s + MSW_CLEAR_MARGIN (that it turns away from an entry it passes
 * close to is not asked: the release's p1 and the safety filter see to
 * that); a moving one is judged by its motion. */
static bool way_clear_of(const sup_t *s, look_t *lk, sup_mask_t mask)
{
    const msw_input_t *in = lk->in;
    const rol_path_t *path = rolled_out(lk);
    const num_t *const dist = in->dist; /* locals, as in candidate() */
    const unsigned n = s->n_obs;
    for (unsigned i = 0; i < n; i++) {
        if (!sup_mask_has(mask, i)) {
            continue;
        }
        const sup_entry_t *e = &s->obs[i];
        const num_t clear = num_add(e->d_s, MSW_CLEAR_MARGIN);
        /* A moving entry: the robot no longer closes on it within reach of an
         * activation, and its closest approach over the activation's horizon
         * stays beyond what activates by the margin (hysteresis). */
        bool ok;
        if (msw_moving(e)) {
            ok = !(closing(lk, e) && dist[i] < num_add(e->d_act, MSW_RELEASE_REACH)) &&
                 !cpa_inside(lk, e, MSW_CPA_HORIZON,
                             num_max(num_sub(clear, e->d_s), num_add(MSW_CPA_MARGIN, MSW_MARGIN)));
        } else {
            /* Beyond the path's reach by the distance: clear without a look. */
            ok = dist[i] >= num_add(path->reach, clear) || rol_clears(path, e->o.x, e->o.y, clear);
        }
        if (!ok) {
            return false;
        }
    }
    return true;
}

static bool way_clear(const sup_t *s, look_t *lk) { return way_clear_of(s, lk, ~(sup_mask_t)0); }

/* p1, eq. (19)-(20), as sup_p1() but on squares (no root): u1·u2 > 0 and
 * |u2| >= D_act (the paper's |u2| > D_act but for the equality). */
static bool p1(const msw_input_t *in, const sup_entry_t *e)
{
    const num_t u2x = num_sub(in->ref->x, e->o.x);
    const num_t u2y = num_sub(in->ref->y, e->o.y);
    const num_t dot = num_add(num_mul(num_sub(in->robot->x, e->o.x), u2x),
                              num_mul(num_sub(in->robot->y, e->o.y), u2y));
    return dot > NUM_ZERO && !oset_within(u2x, u2y, e->d_act);
}

static bool release_ok(const msw_t *m, const sup_t *s, look_t *lk)
{
    const msw_input_t *in = lk->in;
    if (since(in->t_us, m->t_act_us) < MSW_DWELL_US) {
        return false;
    }
    /* p1 for every static member (a moving one may never let the reference
     * pass it: way_clear() judges it by its motion). */
    if (m->held) {
        /* Bug2: back on the path further along than before, or VisBug: the
         * tracking command of this step goes to the aim (a point of the
         * reference's line ahead, shortcut()) and its way is clear. */
        return (m->ahead && way_clear_of(s, lk, m->cluster)) || (lk->aiming && way_clear(s, lk));
    }
    for (sup_mask_t rest = in_table(m->cluster, s); rest != 0u;
         rest = sup_mask_without_lowest(rest)) {
        const sup_entry_t *e = &s->obs[sup_mask_lowest(rest)];
        if (!msw_moving(e) && !p1(in, e)) {
            return false;
        }
    }
    return way_clear(s, lk);
}

/* The robot's position along the line of @p host (the reference as
 * received: its position and heading) [m], and the line's direction. */
static num_t along_line(const pose_t *robot, const pose_t *host, num_t *ux, num_t *uy)
{
    num_sincos(host->theta, uy, ux);
    return num_add(num_mul(num_sub(robot->x, host->x), *ux),
                   num_mul(num_sub(robot->y, host->y), *uy));
}

/* The reference waits (held): a point P of its line ahead of it, the foot of
 * the perpendicular from the robot, that the robot sees a clear straight way
 * to (VisBug's shortcut to the m-line). */
static bool shortcut(msw_t *m, const sup_t *s, const msw_input_t *in)
{
    num_t uy;
    num_t ux;
    const num_t a = along_line(in->robot, in->host, &ux, &uy);
    if (a < MSW_SHORTCUT_MIN) {
        return false;
    }
    const num_t px = num_add(in->host->x, num_mul(a, ux));
    const num_t py = num_add(in->host->y, num_mul(a, uy));
    const num_t sx = num_sub(px, in->robot->x);
    const num_t sy = num_sub(py, in->robot->y);
    const num_t len = oset_distance(sx, sy);
    for (unsigned i = 0; i < s->n_obs; i++) {
        const sup_entry_t *e = &s->obs[i];
        const num_t clear = num_add(e->d_s, MSW_SHORTCUT_MARGIN);
        if (num_add(len, clear) > in->range) {
            return false; /* beyond what the sensor tells */
        }
        if (in->dist[i] >= num_add(len, clear)) {
            continue;
        }
        const num_t cx = num_sub(e->o.x, in->robot->x);
        const num_t cy = num_sub(e->o.y, in->robot->y);
        num_t t = len > NUM_C(0.001)
                      ? num_div(num_add(num_mul(cx, sx), num_mul(cy, sy)), num_mul(len, len))
                      : NUM_ZERO;
        t = num_clamp(t, NUM_ZERO, NUM_ONE);
        const num_t dx = num_sub(cx, num_mul(t, sx));
        const num_t dy = num_sub(cy, num_mul(t, sy));
        if (oset_within(dx, dy, clear)) {
            return false;
        }
    }
    m->aim_rx = in->host->x;
    m->aim_ry = in->host->y;
    msw_slide_aim(m, in->robot, in->host);
    return true;
}

/* Held, the boundary has led the robot MSW_TURN_BACK behind the waiting
 * reference along its line: it follows the boundary the other way (once an
 * activation; the Bug family's reversal of direction). */
static void turn_back(msw_t *m, const msw_input_t *in)
{
    num_t ux;
    num_t uy;
    if (!m->reversed && along_line(in->robot, in->host, &ux, &uy) < num_neg(MSW_TURN_BACK)) {
        m->side = m->side == AVD_SIDE_LEFT ? AVD_SIDE_RIGHT : AVD_SIDE_LEFT;
        m->reversed = true;
    }
}

void msw_slide_aim(msw_t *m, const pose_t *robot, const pose_t *host)
{
    num_t uy;
    num_t ux;
    const num_t a = along_line(robot, host, &ux, &uy);
    const num_t along = num_add(num_max(a, NUM_ZERO), MSW_AIM_LEAD);
    m->aim.x = num_add(host->x, num_mul(along, ux));
    m->aim.y = num_add(host->y, num_mul(along, uy));
    m->aim.theta = host->theta;
}

/* Progress watchdog while avoiding: true when no progress is possible, that
 * is when the robot has turned once around (the signed sum of its heading
 * changes since the activation exceeds MSW_LOOP: it circles the cluster),
 * or has stayed within MSW_PROGRESS of one point for MSW_STILL_US (stuck,
 * the filter holding it). While p3 stops the robot, standing still is no
 * sign of anything: the mark follows it (@p p3: sup_p3() of the step). */
static bool no_progress(msw_t *m, const msw_input_t *in, bool p3)
{
    m->turned = num_add(m->turned, num_wrap(num_sub(in->robot->theta, m->last_theta)));
    m->last_theta = in->robot->theta;
    if (p3 || !oset_within(num_sub(in->robot->x, m->mark_x), num_sub(in->robot->y, m->mark_y),
                           MSW_PROGRESS)) {
        m->mark_x = in->robot->x;
        m->mark_y = in->robot->y;
        m->t_mark_us = in->t_us;
    }
    return (!m->held && num_abs(m->turned) > MSW_LOOP) ||
           since(in->t_us, m->t_mark_us) >= MSW_STILL_US;
}

/* The cluster of the trigger, and the offset of the circles followed round
 * it: with gaps, half the width (the widest a gap in a cluster can be) plus
 * MSW_FILL_MARGIN, so that neighbouring circles overlap. */
static void find_cluster(msw_t *m, const sup_t *s)
{
    bool gapped;
    m->cluster = oset_cluster(s->obs, s->n_obs, m->followed, m->width, &gapped);
    m->revision = s->revision;
    m->offset =
        gapped ? num_add(num_mul(m->width, NUM_C(0.5)), MSW_FILL_MARGIN) : MSW_FOLLOW_OFFSET;
    m->offset = num_max(m->offset, MSW_FOLLOW_OFFSET);
}

/* An obstacle the robot is beyond any activation's reach of (candidate())
 * has been left: its count of activations starts again, so that a robot on a
 * circular reference meets it afresh on its next lap. */
static void forget_left(msw_t *m, const sup_t *s, const msw_input_t *in)
{
    const num_t *const dist = in->dist; /* locals, as in candidate() */
    const num_t reach = in->reach;
    const unsigned n = s->n_obs;
    for (unsigned i = 0; i < n; i++) {
        if (m->acts[i] != 0u &&
            dist[i] >= num_add(num_add(s->obs[i].d_act, MSW_CPA_REACH), reach)) {
            m->acts[i] = 0u;
        }
    }
}

/* Each DETECT among the events of this step so far (sup_take_reports())
 * names an entry that is a new obstacle, in a place that may have held
 * another (an id that came back elsewhere, sup.h): what the strategy kept
 * for that index, its count of activations, starts again. */
static void forget_new(msw_t *m, const sup_t *s, const sup_event_t *events, size_t n_events)
{
    for (size_t k = 0; k < n_events; k++) {
        const uint8_t slot = s->slot[events[k].obstacle]; /* index + 1, 0: not in the table */
        if (events[k].kind == (uint8_t)SUP_EVENT_DETECT && slot != 0u) {
            m->acts[slot - 1u] = 0u;
        }
    }
}

static void activate(msw_t *m, const sup_t *s, const msw_input_t *in, uint8_t i,
                     sup_event_t *events, size_t *n_ev)
{
    m->state = (uint8_t)MSW_AVOID;
    m->trigger = i;
    m->followed = i;
    find_cluster(m, s);
    m->side = msw_choose_side(s, m->cluster, i, m->offset, in);
    m->acts[i]++;
    m->t_act_us = in->t_us;
    m->held = false;
    m->ahead = false;
    m->aimed = false;
    m->reversed = false;
    m->turned = NUM_ZERO;
    m->last_theta = in->robot->theta;
    m->mark_x = in->robot->x;
    m->mark_y = in->robot->y;
    m->t_mark_us = in->t_us;
    emit(events, n_ev, in->t_us, SUP_EVENT_ACTIVATE, s->obs[i].o.id, m->side);
}

void msw_step(msw_t *m, const sup_t *s, const msw_input_t *in, sup_event_t *events,
              size_t *n_events, msw_decision_t *d)
{
    forget_new(m, s, events, *n_events);
    /* The path is written when first needed (rolled_out()). */
    look_t lk = { .in = in, .rolled = false, .aiming = m->aimed, .path = &m->path };
    const bool p3 = sup_p3(in->v_r, in->w_r); /* once a step: a call to sup.c */
    /* The reference waits for the robot: it stands still though its
     * velocity says it moves (a reference at rest, v_r = 0, does not). */
    const bool still = in->v_r != NUM_ZERO && in->host->x == m->ref_x && in->host->y == m->ref_y;
    if (m->state == (uint8_t)MSW_AVOID) {
        if (still) {
            m->held = true;
        } else if (m->held) {
            m->ahead = true;
        } else {
            /* moving as scheduled */
        }
    }
    m->ref_x = in->host->x;
    m->ref_y = in->host->y;
    if (m->state == (uint8_t)MSW_BLOCKED) {
        if (way_clear(s, &lk)) {
            m->state = (uint8_t)MSW_TRACK;
            emit(events, n_events, in->t_us, SUP_EVENT_RESUME, 0u, AVD_SIDE_NONE);
        }
    } else if (m->state == (uint8_t)MSW_AVOID) {
        if (s->revision != m->revision) {
            find_cluster(m, s); /* obstacles joined or moved */
        }
        m->followed = nearest_member(s, in, m->cluster, m->followed);
        if (m->held) {
            turn_back(m, in);
            m->aimed = shortcut(m, s, in); /* the aim of the next step's tracking */
        }
        if (release_ok(m, s, &lk)) {
            m->state = (uint8_t)MSW_TRACK;
            emit(events, n_events, in->t_us, SUP_EVENT_COMPLETE, s->obs[m->followed].o.id,
                 AVD_SIDE_NONE);
        } else if (no_progress(m, in, p3)) {
            m->state = (uint8_t)MSW_BLOCKED;
            emit(events, n_events, in->t_us, SUP_EVENT_BLOCKED, s->obs[m->followed].o.id,
                 AVD_SIDE_NONE);
        } else {
            /* keep avoiding */
        }
    } else {
        forget_left(m, s, in);
        const int i = candidate(m, s, &lk);
        if (i >= 0) {
            activate(m, s, in, (uint8_t)i, events, n_events);
            m->followed = nearest_member(s, in, m->cluster, (uint8_t)i);
        }
    }

    d->mode = SUP_MODE_TRACK;
    d->followed = NULL;
    d->side = AVD_SIDE_NONE;
    if (m->state == (uint8_t)MSW_AVOID) {
        const sup_entry_t *f = &s->obs[m->followed];
        d->mode = SUP_MODE_AVOID;
        d->followed = f;
        d->side = m->side;
        d->circle.x = f->o.x;
        d->circle.y = f->o.y;
        d->circle.vx = f->o.vx;
        d->circle.vy = f->o.vy;
        d->circle.d_s = num_add(f->d_s, m->offset);
    } else {
        /* No circle: zero, field by field (a compound literal costs a
         * memset). */
        d->circle.x = NUM_ZERO;
        d->circle.y = NUM_ZERO;
        d->circle.vx = NUM_ZERO;
        d->circle.vy = NUM_ZERO;
        d->circle.d_s = NUM_ZERO;
        if (m->state == (uint8_t)MSW_BLOCKED) {
            d->mode = SUP_MODE_BLOCKED;
        }
    }
    if (p3) {
        d->mode = SUP_MODE_STOP;
    }
}
