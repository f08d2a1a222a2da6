/* SPDX-License-Identifier: MIT */
/* Last-line safety filter: closed-form barrier-function filter (cbf.h). */
#include "ctrl/cbf.h"

#include "ctrl/oset.h"
#include "ctrl/rol.h"

/* 2/α [s] and 2l [m]: the reach beyond which a constraint cannot bind (see
 * slack_sure). */
#define CBF_TWO_LOOKAHEADS NUM_C(2.0 * CBF_LOOKAHEAD_M)
#define CBF_TWO_OVER_ALPHA NUM_C(2.0 / CBF_ALPHA_PER_S)
/* Two constraints whose normals (g1, g2) are closer to parallel than this
 * have no vertex worth meeting [m²] (|a| is about 1 m near the barrier). */
#define CBF_MIN_DET        NUM_C(0.01)
/* l/κ² [1/m], l²/κ² and 1/l [1/m]. */
#define CBF_L_OVER_KAPPA2  NUM_C(CBF_LOOKAHEAD_M / (CBF_TURN_WEIGHT_M * CBF_TURN_WEIGHT_M))
#define CBF_L2_OVER_KAPPA2                                                                         \
    NUM_C(CBF_LOOKAHEAD_M *CBF_LOOKAHEAD_M / (CBF_TURN_WEIGHT_M * CBF_TURN_WEIGHT_M))
#define CBF_INV_LOOKAHEAD NUM_C(1.0 / CBF_LOOKAHEAD_M)
/* The largest gain on a moving obstacle's margin, dead ahead (brake_margin):
 * CBF_MOVING_GAIN + CBF_MOVING_RISE. */
#define CBF_MOVING_MOST   NUM_C(CBF_MOVING_GAIN_X + CBF_MOVING_RISE_X)
/* Inline whatever GCC's heuristics say: binding() and slack_sure() run for
 * every obstacle in every pass over them, and GCC -O2 keeps slack_sure() (or,
 * with it inline, binding()) out of line on a Cortex-M3, where the calls
 * cost some 190 instructions a step of the load-8 scene (docs/performance.md;
 * the same code, the same bits). Not when optimising nothing (the coverage
 * build, -O0): there each function stays one, and gcov counts its branches
 * once, not once per call site. */
#if defined(__GNUC__) && defined(__OPTIMIZE__)
#define CBF_INLINE static inline __attribute__((always_inline))
#else
#define CBF_INLINE static inline
#endif

void cbf_init(cbf_t *f) { cbf_reset(f); }

void cbf_reset(cbf_t *f)
{
    f->active = false;
    f->infeasible = false;
    f->cached = 0u;
    f->doomed = 0u;
}

/* One obstacle's constraint on (v, ω): a·u = g1 v + g2 l ω >= b, with
 * g1 = a·[cos θ, sin θ] and g2 = a·[−sin θ, cos θ] (l is kept out of g2, so
 * that Q16.16 holds it to the same relative precision as g1), b = a·w − α h. */
typedef cbf_constraint_t constraint_t;

/* The look-ahead point of one step (where the wheels carry it: shifted by
 * the prediction), the heading, and what the braking margin needs. */
typedef struct {
    num_t plx, ply;
    num_t c, s;
    num_t qx, qy;    /* look-ahead velocity of the command in force [m/s] */
    num_t brake_t;   /* T_b [s]; 0: no braking margin */
    num_t reach_add; /* |shift|_1 + |q|_1 T_b: what slack_sure adds [m] */
    num_t inv_accel; /* 1 / a_v [s²/m]: the look-ahead point's acceleration */
    num_t side;      /* across the heading: a_v side at most */
    num_t inv_side;  /* 1 / side */
    num_t gap;       /* D_s − R_m − R_ob: an obstacle's d_s less its contact distance */
    num_t q1;        /* |qx| + |qy| [m/s] */
    num_t horizon;   /* T_p [s]: a moving obstacle is taken at c + w T_p */
    cbf_t *f;        /* the step's constraint cache; NULL: none */
} lookahead_t;

/* The braking margin of an obstacle at Δ = p_l − c moving at w: with σ the
 * closing speed −Δ·(q − w)/|Δ| of the look-ahead point under the command in
 * force (0 when it does not close), σ T_b for a static obstacle (braking
 * along the path stops the closing in T_b), σ max(CBF_MOVING_BRAKE T_b,
 * G σ/a_β) for a moving one: nulling a closing speed the robot does not
 * cause takes σ/a_β, and G = CBF_MOVING_GAIN + CBF_MOVING_RISE cos β_b,
 * cos β_b = −Δ·[cos θ, sin θ]/|Δ|, is the most for an obstacle ahead, which
 * the robot meets head on or has to let cross its way, the least for one
 * behind, which it leaves by driving on. The root only for an obstacle that
 * closes. */
static num_t brake_margin(const lookahead_t *fr, const sup_entry_t *o, num_t dx, num_t dy, num_t d2,
                          bool *doomed)
{
    if (fr->brake_t <= NUM_ZERO) {
        return NUM_ZERO;
    }
    const num_t along =
        num_add(num_mul(dx, num_sub(fr->qx, o->o.vx)), num_mul(dy, num_sub(fr->qy, o->o.vy)));
    if (along >= NUM_ZERO) {
        return NUM_ZERO;
    }
    const num_t d = num_sqrt(d2);
    if (d <= NUM_ZERO) {
        return NUM_ZERO;
    }
    const num_t sigma = num_div(num_neg(along), d);
    num_t t = fr->brake_t;
    if (num_any_nonzero(o->o.vx, o->o.vy)) {
        /* Away from the obstacle (along Δ, at angle β to the heading) the
         * look-ahead point accelerates at a_v max(|cos β|, side |sin β|) at
         * most, a_v side at least. */
        const num_t behind = num_add(num_mul(dx, fr->c), num_mul(dy, fr->s));
        const num_t along_h = num_abs(behind);
        const num_t across = num_abs(num_sub(num_mul(dy, fr->c), num_mul(dx, fr->s)));
        const num_t share =
            num_max(num_div(num_max(along_h, num_mul(fr->side, across)), d), fr->side);
        const num_t shed = num_div(num_mul(sigma, fr->inv_accel), share);
        /* cos β_b = −Δ·heading/|Δ|. */
        const num_t gain = num_sub(CBF_MOVING_GAIN, num_mul(CBF_MOVING_RISE, num_div(behind, d)));
        t = num_max(num_mul(t, CBF_MOVING_BRAKE), num_mul(shed, gain));
        /* Closing faster than the robot can null before the bodies touch
         * (its centre l behind p_l): d − l − (R_m + r) < σ²/(2 a_β). */
        const num_t touch = num_sub(o->d_s, fr->gap);
        *doomed =
            num_sub(num_sub(d, CBF_LOOKAHEAD), touch) < num_mul(num_mul(sigma, shed), NUM_C(0.5));
    }
    return num_mul(sigma, t);
}

/* p_l − c, with a moving obstacle's centre where it will be at the end of
 * the prediction's horizon, c + w T_p: the look-ahead point is compared
 * where the lagging wheels carry it, so the obstacle is too. */
static void offset_of(const lookahead_t *fr, const sup_entry_t *o, num_t *dx, num_t *dy)
{
    *dx = num_sub(fr->plx, o->o.x);
    *dy = num_sub(fr->ply, o->o.y);
    if (num_any_nonzero(o->o.vx, o->o.vy)) {
        *dx = num_sub(*dx, num_mul(o->o.vx, fr->horizon));
        *dy = num_sub(*dy, num_mul(o->o.vy, fr->horizon));
    }
}

static void constraint_of(const lookahead_t *fr, const sup_entry_t *o, constraint_t *k, num_t *h,
                          bool *doomed)
{
    num_t dx;
    num_t dy;
    offset_of(fr, o, &dx, &dy);
    const num_t d2 = num_sum_sq(dx, dy);
    *doomed = false;
    const num_t rho =
        num_add(num_add(o->d_s, CBF_LOOKAHEAD), brake_margin(fr, o, dx, dy, d2, doomed));
    *h = num_sub(d2, num_sq(rho));
    const num_t ax = num_add(dx, dx);
    const num_t ay = num_add(dy, dy);
    k->g1 = num_add(num_mul(ax, fr->c), num_mul(ay, fr->s));
    k->g2 = num_sub(num_mul(ay, fr->c), num_mul(ax, fr->s));
    k->b = num_sub(num_add(num_mul(ax, o->o.vx), num_mul(ay, o->o.vy)), num_mul(CBF_ALPHA, *h));
}

/* a·u for the command (v, ω), with @p lw = l ω (a pass over the obstacles
 * forms it once). */
static num_t rate_lw(const constraint_t *k, num_t v, num_t lw)
{
    return num_add(num_mul(k->g1, v), num_mul(k->g2, lw));
}

/* b − a·u: how far (v, ω) falls short of the constraint (> 0: violated). */
static num_t shortfall_lw(const constraint_t *k, num_t v, num_t lw)
{
    return num_sub(k->b, rate_lw(k, v, lw));
}

static num_t shortfall(const constraint_t *k, num_t v, num_t w)
{
    return shortfall_lw(k, v, num_mul(CBF_LOOKAHEAD, w));
}

/* slack_sure() of a moving obstacle, out of line: inline, GCC would start
 * its work (loads, absolute values, constants) before the test that sends
 * every static obstacle past it, some 9 instructions an obstacle a pass
 * (make bench). */
#if defined(__GNUC__)
__attribute__((noinline))
#endif
static bool
slack_sure_moving(const lookahead_t *fr, const sup_entry_t *o, num_t dist, num_t speed)
{
    const num_t ov = num_add(num_abs(o->o.vx), num_abs(o->o.vy));
    const num_t qw = num_add(fr->q1, ov);
    /* reach_add holds q1 T_b once: the gain's share of it added. */
    const num_t braked = num_add(num_mul(ov, fr->brake_t),
                                 num_mul(num_mul(num_mul(qw, qw), fr->inv_accel), fr->inv_side));
    const num_t extra =
        num_add(num_add(fr->reach_add, num_mul(ov, fr->horizon)),
                num_add(num_mul(braked, CBF_MOVING_MOST),
                        num_mul(num_mul(fr->q1, fr->brake_t), num_sub(CBF_MOVING_MOST, NUM_ONE))));
    const num_t term = num_mul(CBF_TWO_OVER_ALPHA, num_add(speed, ov));
    return dist >= num_add(num_add(num_add(o->d_s, CBF_TWO_LOOKAHEADS), extra), term);
}

/* The constraint of entry @p i, at centre distance @p dist from the robot,
 * cannot bind for the command (v, ω): with ḣ = a·(u − w) >= −2 |p_l − c| |u − w|
 * and h = (|p_l − c| − ρ)(|p_l − c| + ρ), ḣ + α h >= 0 whenever
 * |p_l − c| >= ρ + 2 |u − w| / α; |p_l − c| >= dist − l − |shift|, and
 * |u − w| <= |v| + l|ω| + |w_x| + |w_y|. Saves the products for every
 * obstacle not close. The reach is d_s + 2l + extra + (2/α)(|v| + l|ω| + ov),
 * extra what the prediction and the braking margin add: the prediction moves
 * p_l by at most |shift|_1 and a moving obstacle by at most ov T_p, and
 * since σ <= |q − w|_1 = q1 + ov the margin is at most q1 T_b for a static
 * obstacle (reach_add holds it with the shift), CBF_MOVING_MOST
 * (q1 + ov) (T_b + (q1 + ov)/(a_v side)) for a moving one (the largest
 * gain, CBF_MOVING_MOST > CBF_MOVING_BRAKE, on both terms). @p still is
 * (2/α)(|v| + l|ω|), the last term of every static obstacle (ov = 0):
 * computed once per command. */
CBF_INLINE bool slack_sure(const lookahead_t *fr, const sup_entry_t *o, num_t dist, num_t speed,
                           num_t still)
{
    /* ov = |w_x| + |w_y| > 0 exactly when the obstacle moves (a sum of two
     * values >= 0 is 0 only when both are, in either mode): ov only then. */
    if (!num_any_nonzero(o->o.vx, o->o.vy)) {
        return dist >= num_add(num_add(num_add(o->d_s, CBF_TWO_LOOKAHEADS), fr->reach_add), still);
    }
    return slack_sure_moving(fr, o, dist, speed);
}

static num_t speed_of(num_t v, num_t w)
{
    return num_add(num_abs(v), num_mul(CBF_LOOKAHEAD, num_abs(w)));
}

static void frame_of(const pose_t *robot, num_t cos_th, num_t sin_th, const cbf_motion_t *m,
                     lookahead_t *fr)
{
    fr->plx = num_add(robot->x, num_mul(CBF_LOOKAHEAD, cos_th));
    fr->ply = num_add(robot->y, num_mul(CBF_LOOKAHEAD, sin_th));
    fr->c = cos_th;
    fr->s = sin_th;
    if (m == NULL) {
        /* Each field once (GCC stored these before the overwrite below). */
        fr->qx = NUM_ZERO;
        fr->qy = NUM_ZERO;
        fr->brake_t = NUM_ZERO;
        fr->reach_add = NUM_ZERO;
        fr->inv_accel = NUM_ZERO;
        fr->side = NUM_ONE;
        fr->inv_side = NUM_ONE;
        fr->gap = NUM_ZERO;
        fr->q1 = NUM_ZERO;
        fr->horizon = NUM_ZERO;
    } else {
        fr->plx = num_add(fr->plx, m->shift_x);
        fr->ply = num_add(fr->ply, m->shift_y);
        fr->qx = m->qx;
        fr->qy = m->qy;
        fr->brake_t = m->brake_t;
        fr->inv_accel = m->inv_accel;
        fr->side = m->side;
        fr->inv_side = m->inv_side;
        fr->gap = m->gap;
        fr->q1 = num_add(num_abs(m->qx), num_abs(m->qy));
        fr->horizon = m->horizon;
        fr->reach_add = num_add(num_add(num_abs(m->shift_x), num_abs(m->shift_y)),
                                num_mul(num_add(num_abs(m->qx), num_abs(m->qy)), m->brake_t));
    }
}

void cbf_barrier(const pose_t *robot, num_t cos_th, num_t sin_th, const cbf_motion_t *m,
                 const sup_entry_t *o, num_t *h, num_t *ax, num_t *ay)
{
    lookahead_t fr;
    frame_of(robot, cos_th, sin_th, m, &fr);
    constraint_t k;
    bool doomed;
    constraint_of(&fr, o, &k, h, &doomed);
    num_t dx;
    num_t dy;
    offset_of(&fr, o, &dx, &dy);
    *ax = num_add(dx, dx);
    *ay = num_add(dy, dy);
}

/* The constraint of entry @p i into *k, unless it surely cannot bind
 * (slack_sure): then false. Computed once a step (the cache in cbf_t). */
CBF_INLINE bool binding(const lookahead_t *fr, const sup_entry_t *e, uint8_t i, num_t dist,
                        num_t speed, num_t still, constraint_t *k)
{
    if (slack_sure(fr, &e[i], dist, speed, still)) {
        return false;
    }
    cbf_t *const f = fr->f;
    if (!sup_mask_has(f->cached, i)) {
        num_t h;
        bool doomed;
        constraint_of(fr, &e[i], &f->k[i], &h, &doomed);
        const sup_mask_t bit = sup_mask_of(i);
        f->cached |= bit;
        if (doomed) {
            f->doomed |= bit;
        }
    }
    *k = fr->f->k[i];
    return true;
}

/* The most violated constraint for (v, ω), by more than CBF_TOLERANCE: its
 * index, or -1. */
static int most_violated(const lookahead_t *fr, const sup_entry_t *e, const num_t *dist, uint8_t n,
                         num_t v, num_t w, constraint_t *worst)
{
    const num_t speed = speed_of(v, w);
    const num_t still = num_mul(CBF_TWO_OVER_ALPHA, speed);
    const num_t lw = num_mul(CBF_LOOKAHEAD, w);
    int found = -1;
    num_t worst_gap = CBF_TOLERANCE;
    for (uint8_t i = 0; i < n; i++) {
        constraint_t k;
        if (!binding(fr, e, i, dist[i], speed, still, &k)) {
            continue;
        }
        const num_t gap = shortfall_lw(&k, v, lw);
        if (gap > worst_gap) {
            worst_gap = gap;
            *worst = k;
            found = (int)i;
        }
    }
    return found;
}

/* The largest factor in [0, 1] by which (v, ω) can be scaled so that every
 * constraint with b <= 0 holds ((0, 0) meets them all); sets *infeasible when
 * a constraint with b > 0 is violated. */
static num_t brake_factor(const lookahead_t *fr, const sup_entry_t *e, const num_t *dist, uint8_t n,
                          num_t v, num_t w, bool *infeasible)
{
    const num_t speed = speed_of(v, w);
    const num_t still = num_mul(CBF_TWO_OVER_ALPHA, speed);
    const num_t lw = num_mul(CBF_LOOKAHEAD, w);
    num_t f = NUM_ONE;
    for (uint8_t i = 0; i < n; i++) {
        constraint_t k;
        if (!binding(fr, e, i, dist[i], speed, still, &k) ||
            shortfall_lw(&k, v, lw) <= CBF_TOLERANCE) {
            continue;
        }
        if (k.b > NUM_ZERO) {
            *infeasible = true;
        } else {
            /* b <= 0 and a·u < b <= 0: f a·u >= b for f <= b / a·u, in [0, 1). */
            f = num_min(f, num_div(k.b, rate_lw(&k, v, lw)));
        }
    }
    return num_max(f, NUM_ZERO);
}

/* The least change of (v, ω), in the norm Δv² + κ² Δω², that meets
 * constraint @p k exactly: with a·u = g1 v + g2 l ω, Δv = λ g1 and
 * Δω = λ g2 l/κ², λ = shortfall / (g1² + g2² l²/κ²). False when
 * g1 = g2 = 0 (p_l at the centre: no direction to leave by). */
static bool project(const constraint_t *k, num_t v, num_t w, num_t *vp, num_t *wp)
{
    const num_t den =
        num_add(num_mul(k->g1, k->g1), num_mul(num_mul(k->g2, k->g2), CBF_L2_OVER_KAPPA2));
    if (den <= NUM_ZERO) {
        return false;
    }
    const num_t lambda = num_div(shortfall(k, v, w), den);
    *vp = num_add(v, num_mul(lambda, k->g1));
    *wp = num_add(w, num_mul(lambda, num_mul(k->g2, CBF_L_OVER_KAPPA2)));
    return true;
}

/* (v, ω) meeting both constraints with equality, when they are not
 * parallel (|det| > CBF_MIN_DET, det = g1a g2b − g2a g1b; the system is
 * g1 v + g2 (l ω) = b, solved for v and l ω). */
static bool vertex(const constraint_t *a, const constraint_t *b, num_t *v, num_t *w)
{
    const num_t det = num_sub(num_mul(a->g1, b->g2), num_mul(a->g2, b->g1));
    if (num_abs(det) <= CBF_MIN_DET) {
        return false;
    }
    *v = num_div(num_sub(num_mul(a->b, b->g2), num_mul(a->g2, b->b)), det);
    const num_t lw = num_div(num_sub(num_mul(a->g1, b->b), num_mul(a->b, b->g1)), det);
    *w = num_mul(lw, CBF_INV_LOOKAHEAD);
    return true;
}

/* Meet the most violated constraint @p ka and the one most violated after
 * it, B, in closed form: the projection of the command onto A if it meets
 * B, else onto B if that meets A, else the vertex where both hold with
 * equality (the three candidates of a two-constraint least-change problem). */
static void meet_two(const lookahead_t *fr, const sup_entry_t *e, const num_t *dist, uint8_t n,
                     const constraint_t *ka, num_t *v, num_t *w)
{
    constraint_t kb;
    num_t va;
    num_t wa;
    if (!project(ka, *v, *w, &va, &wa)) {
        *v = NUM_ZERO; /* p_l at a centre: stop */
        *w = NUM_ZERO;
        return;
    }
    if (most_violated(fr, e, dist, n, va, wa, &kb) < 0) {
        *v = va;
        *w = wa;
        return;
    }
    num_t vb;
    num_t wb;
    if (project(&kb, *v, *w, &vb, &wb) && shortfall(ka, vb, wb) <= CBF_TOLERANCE) {
        *v = vb;
        *w = wb;
    } else if (vertex(ka, &kb, &vb, &wb)) {
        *v = vb;
        *w = wb;
    } else {
        /* Parallel: they ask for the same direction, or for opposite ones
         * that nothing meets; the second projection, then the brake. */
        *v = va;
        *w = wa;
        (void)project(&kb, va, wa, v, w);
    }
}

void cbf_step(cbf_t *f, const pose_t *robot, num_t cos_th, num_t sin_th, const cbf_motion_t *m,
              const sup_entry_t *e, const num_t *dist, uint8_t n, num_t *v, num_t *w,
              cbf_result_t *r)
{
    *r = (cbf_result_t){ .changed = false };
    lookahead_t fr;
    frame_of(robot, cos_th, sin_th, m, &fr);
    fr.f = f;
    f->cached = 0u;
    f->doomed = 0u;
    constraint_t k;
    const int first = most_violated(&fr, e, dist, n, *v, *w, &k);
    if (first >= 0) {
        r->changed = true;
        r->obstacle = e[first].o.id;
        num_t vf = *v;
        num_t wf = *w;
        meet_two(&fr, e, dist, n, &k, &vf, &wf);
        const num_t scale = brake_factor(&fr, e, dist, n, vf, wf, &r->infeasible);
        *v = num_mul(vf, scale);
        *w = num_mul(wf, scale);
    }
    r->new_episode = r->changed && !f->active;
    f->active = r->changed;
    r->new_infeasible = r->infeasible && !f->infeasible;
    f->infeasible = r->infeasible;
}

bool cbf_brake_clear(const cbf_brake_t *b, const sup_entry_t *e, const num_t *dist, uint8_t n)
{
    const num_t reach = num_add(num_mul(num_abs(b->v), b->travel_t), b->lead);
    /* Every point of the path is within reach of the robot: a segment's
     * widening is at most 5 % of its length (|Φ| <= 0.1, rol.h). */
    const num_t widened = num_add(reach, num_mul(reach, NUM_C(0.0625)));
    bool built = false;
    rol_path_t path;
    for (uint8_t i = 0; i < n; i++) {
        const sup_entry_t *o = &e[i];
        if (num_any_nonzero(o->o.vx, o->o.vy)) {
            continue; /* moving: stopping in its way does not help (cbf.h) */
        }
        num_t clear = num_add(o->d_s, CBF_GUARD_MARGIN);
        if (dist[i] >= num_add(clear, widened)) {
            continue;
        }
        /* Inside the margin already: no closer than now. */
        clear = num_min(clear, num_sub(dist[i], CBF_GUARD_SLACK));
        if (!built) {
            rol_path(&path, &b->start, b->c, b->s, b->v, b->w, b->travel_t);
            built = true;
        }
        if (!rol_clears(&path, o->o.x, o->o.y, clear)) {
            return false;
        }
    }
    return true;
}

/* Whether the rate-limited command @p u (from @p base) passes
 * cbf_brake_clear(); *u is then what the rate limiter made of it, and *body
 * its body velocity. @p body holds that of *u before the limiter, if known:
 * a command the limiter leaves alone keeps it. */
static bool guard_passes(act_t *a, const cbf_guard_t *g, const sup_entry_t *e, const num_t *dist,
                         uint8_t n, const kin_wheels_t *base, kin_wheels_t *u, cbf_body_t *body)
{
    a->cmd = *base;
    const bool limited = act_limit(a, g->step, u);
    cbf_brake_t b = { .start = g->start, .c = g->c, .s = g->s, .lead = g->lead };
    if (body->known && !limited) {
        b.v = body->v;
        b.w = body->w;
    } else {
        kin_vw_from_wheels(g->kin, u, &b.v, &b.w);
    }
    *body = (cbf_body_t){ .v = b.v, .w = b.w, .known = true };
    const num_t top = num_max(num_abs(u->left), num_abs(u->right));
    b.travel_t = num_add(g->dt, num_mul(num_mul(top, g->inv_accel), NUM_C(0.5)));
    return cbf_brake_clear(&b, e, dist, n);
}

bool cbf_guard(act_t *a, const cbf_guard_t *g, const sup_entry_t *e, const num_t *dist, uint8_t n,
               kin_wheels_t *wheels, cbf_body_t *body)
{
    const kin_wheels_t base = a->cmd;
    kin_wheels_t u = *wheels;
    cbf_body_t tried = *body;
    if (guard_passes(a, g, e, dist, n, &base, &u, &tried)) {
        *wheels = u;
        *body = tried;
        return false;
    }
    /* Brake the speed, keep the turn: (0, ω) of the command. */
    num_t v;
    num_t w;
    if (body->known) {
        w = body->w;
    } else {
        kin_vw_from_wheels(g->kin, wheels, &v, &w);
    }
    kin_wheels_from_vw(g->kin, NUM_ZERO, w, &u);
    tried.known = false;
    if (!kin_saturate(g->kin, &u) && guard_passes(a, g, e, dist, n, &base, &u, &tried)) {
        *wheels = u;
        *body = tried;
        return true;
    }
    *wheels = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
    a->cmd = base;
    (void)act_limit(a, g->step, wheels);
    body->known = false;
    return true;
}

uint8_t cbf_unreachable(const cbf_t *f, const sup_entry_t *e, uint8_t n, const kin_params_t *kin,
                        const kin_wheels_t *base, num_t step)
{
    /* a·u = g1 v + g2 l ω with v = r (u_L + u_R)/2, ω = r (u_R − u_L)/L:
     * c_L = r (g1/2 − g2 l/L), c_R = r (g1/2 + g2 l/L). */
    if (f->doomed == 0u) {
        return 0u; /* nearly always: no division */
    }
    const num_t lever = num_div(CBF_LOOKAHEAD, kin->track_width);
    for (uint8_t i = 0; i < n; i++) {
        const sup_entry_t *o = &e[i];
        /* Only a moving obstacle is ever doomed (brake_margin). */
        if (!sup_mask_has(f->doomed, i)) {
            continue;
        }
        const cbf_constraint_t *k = &f->k[i];
        const num_t half = num_mul(k->g1, NUM_C(0.5));
        const num_t turn = num_mul(k->g2, lever);
        const num_t cl = num_mul(kin->wheel_radius, num_sub(half, turn));
        const num_t cr = num_mul(kin->wheel_radius, num_add(half, turn));
        const num_t best = num_add(num_add(num_mul(cl, base->left), num_mul(cr, base->right)),
                                   num_mul(step, num_add(num_abs(cl), num_abs(cr))));
        if (num_sub(k->b, best) > CBF_TOLERANCE) {
            return o->o.id;
        }
    }
    return 0u;
}
