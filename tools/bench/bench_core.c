/* SPDX-License-Identifier: MIT */
/* The benchmark's closed loop, recording and replay (bench.h). The same
 * source runs on the Cortex-M images and on the host. */
#include "bench.h"

#include <math.h>
#include <string.h>

num_t bench_num(double d)
{
#if defined(NUM_FIXED)
    /* As hal/sil/mstc_sil.c: round to nearest, saturate. */
    const double v = d * 65536.0;
    if (v >= 2147483647.5) {
        return NUM_MAX;
    }
    if (v <= -2147483648.5) {
        return NUM_MIN;
    }
    return (num_t)round(v);
#else
    return (num_t)d;
#endif
}

double bench_dbl(num_t a)
{
#if defined(NUM_FIXED)
    return (double)a / 65536.0;
#else
    return (double)a;
#endif
}

__attribute__((noinline, noipa)) void bench_empty_step(ctl_t *c, const ctl_input_t *in,
                                                       ctl_output_t *out)
{
    (void)c;
    (void)in;
    (void)out;
}

__attribute__((noinline, noipa)) void bench_ctl_step(ctl_t *c, const ctl_input_t *in,
                                                     ctl_output_t *out)
{
    ctl_step(c, in, out);
}

/* Load scenes: a circular reference of radius 1.8 m about the origin (0.5
 * m/s, 20 s: most of a lap), the robot starting on it; obstacles on the
 * circle (gone around, a cluster at 90°) and inside it. Every obstacle lies
 * within 1.8 m of the origin, so within 3.6 m of the robot, and in view
 * (D_det = 3.5 m) nearly all the time: `in_view` in the results says how
 * many were reported per step on average. */
#define LOAD(NAME, N, ...)                                                                         \
    {                                                                                              \
        .name = (NAME), .robot = { 0.05, -1.85, 0.0 }, .ref = { 0.0, -1.8, 0.0 }, .v_r = 0.5,      \
        .w_r = 0.5 / 1.8, .duration = 20.0, .dt = 0.02, .n_obs = (N), .obs = {                     \
            __VA_ARGS__                                                                            \
        }                                                                                          \
    }
const bench_scenario_t bench_loads[BENCH_N_LOADS] = {
    LOAD("load-1", 1, { 0.0, 1.8, 0.1 }),
    LOAD("load-4", 4, { 0.0, 1.8, 0.1 }, { -0.252, 1.428, 0.1 }, { -1.516, -0.875, 0.1 },
         { 0.0, 0.0, 0.1 }),
    LOAD("load-8", 8, { 0.0, 1.8, 0.1 }, { -0.252, 1.428, 0.1 }, { 0.414, 1.545, 0.1 },
         { 0.0, 0.0, 0.1 }, { 0.5, -0.5, 0.1 }, { -1.516, -0.875, 0.1 }, { 1.386, -0.8, 0.1 },
         { 1.2, 0.0, 0.1 }),
    /* A straight reference along y = 0 at 0.5 m/s for 14 s through the field
     * below: the table full every step. */
    { .name = "load-48",
      .robot = { 0.0, 0.0, 0.0 },
      .ref = { 0.1, 0.0, 0.0 },
      .v_r = 0.5,
      .w_r = 0.0,
      .duration = 14.0,
      .dt = 0.02,
      .n_obs = 0,
      .field = 1 },
};

/* ------------------------------------------------------------ the field */

/* load-48's field, BARN-like (Perille et al., SSRR 2020: cylinders of
 * radius 0.075 m on the cells of a 0.15 m grid): the cells at x = −4 +
 * 0.15 i (i < 100), y = 0.075 + 0.15 j (−27 <= j < 27), a quarter of them
 * occupied (a hash of i and j: the same field on every target), but for a
 * corridor |y| < 1.2 m along the reference, whose first rows are at
 * |y| = 1.275; in the corridor a pair at x = 2.9 and 3.05, y = 0.075, a
 * cluster of its own, which the robot goes around (0.385 m from its
 * centres). Within D_det (3.5 m) of the robot lie some 150 cylinders, so
 * the table stays full, and as the robot moves slots go to other cylinders
 * (ids that come back elsewhere, sup.h). */
#define FIELD_MAX    1200u
#define FIELD_RADIUS 0.075
static double field_xy[FIELD_MAX][2];
static unsigned field_n;

static void field_make(void);

unsigned bench_field_size(void)
{
    field_make();
    return field_n;
}

static void field_make(void)
{
    if (field_n != 0u) {
        return;
    }
    for (int i = 0; i < 100; i++) {
        for (int j = -27; j < 27; j++) {
            const double x = -4.0 + 0.15 * i;
            const double y = 0.075 + 0.15 * j;
            uint32_t h = (uint32_t)(i + 1) * 73856093u ^ (uint32_t)(j + 100) * 19349663u;
            h = h * 1664525u + 1013904223u;
            const int block = (i == 46 || i == 47) && j == 0; /* x 2.9, 3.05; y 0.075 */
            if ((fabs(y) > 1.2 && (h >> 24) < 64u) || block) {
                field_xy[field_n][0] = x;
                field_xy[field_n][1] = y;
                field_n++;
            }
        }
    }
}

/* The sensor's slots for the field: slot_of[k] the id of cylinder k, 0 when
 * not reported; owner[s] the cylinder of id s, or −1. */
static uint8_t slot_of[FIELD_MAX];
static int owner[BENCH_MAX_REPORTS + 1u];

static void slots_reset(void)
{
    for (unsigned k = 0; k < field_n; k++) {
        slot_of[k] = 0u;
    }
    for (unsigned s = 0; s <= BENCH_MAX_REPORTS; s++) {
        owner[s] = -1;
    }
}

/* What the sensor reports of the field from (x, y) into @p out, nearest
 * first: the BENCH_MAX_REPORTS nearest cylinders whose surface is within
 * @p d_det, each keeping its id while it stays reported, a new one taking
 * the lowest free id. Returns how many; *nearest the centre distance of the
 * nearest. */
static size_t field_sense(double x, double y, double d_det, sup_obstacle_t *out, double *nearest)
{
    const double range = d_det + FIELD_RADIUS;
    unsigned best[BENCH_MAX_REPORTS];
    double best_d2[BENCH_MAX_REPORTS];
    size_t m = 0;
    for (unsigned k = 0; k < field_n; k++) {
        const double dx = field_xy[k][0] - x;
        const double dy = field_xy[k][1] - y;
        if (fabs(dx) > range || fabs(dy) > range) {
            continue;
        }
        const double d2 = dx * dx + dy * dy;
        if (d2 > range * range || (m == BENCH_MAX_REPORTS && d2 >= best_d2[m - 1u])) {
            continue;
        }
        /* Insert in order; the farthest drops out of a full list. */
        size_t at = m < BENCH_MAX_REPORTS ? m++ : m - 1u;
        while (at > 0u && best_d2[at - 1u] > d2) {
            best[at] = best[at - 1u];
            best_d2[at] = best_d2[at - 1u];
            at--;
        }
        best[at] = k;
        best_d2[at] = d2;
    }
    /* Ids of cylinders no longer reported are free again... */
    for (unsigned s = 1; s <= BENCH_MAX_REPORTS; s++) {
        if (owner[s] < 0) {
            continue;
        }
        bool kept = false;
        for (size_t i = 0; i < m && !kept; i++) {
            kept = best[i] == (unsigned)owner[s];
        }
        if (!kept) {
            slot_of[owner[s]] = 0u;
            owner[s] = -1;
        }
    }
    /* ... for the new ones, nearest first. */
    for (size_t i = 0; i < m; i++) {
        const unsigned k = best[i];
        if (slot_of[k] == 0u) {
            unsigned s = 1;
            while (owner[s] >= 0) {
                s++;
            }
            owner[s] = (int)k;
            slot_of[k] = (uint8_t)s;
        }
        out[i] = (sup_obstacle_t){ .id = slot_of[k],
                                   .x = bench_num(field_xy[k][0]),
                                   .y = bench_num(field_xy[k][1]),
                                   .radius = bench_num(FIELD_RADIUS) };
    }
    *nearest = m > 0u ? sqrt(best_d2[0]) : (double)INFINITY;
    return m;
}

static void fresh(ctl_t *c, ctl_params_t *p, uint8_t strategy)
{
    ctl_params_default(p);
    p->strategy = num_from_int((int32_t)strategy);
    (void)ctl_init(c, p);
}

/* The recorded events against the scenario's expected ones: the same events,
 * in order, each at its expected time to within half a control period. */
static int events_match(const bench_scenario_t *s, const bench_run_t *r)
{
    if (r->n_events != s->n_expected) {
        return 0;
    }
    for (size_t i = 0; i < r->n_events; i++) {
        const sup_event_t *e = &r->events[i];
        const double t = (double)e->t_us * 1e-6;
        if (fabs(t - s->expected[i].t) > 0.5 * s->dt || e->kind != s->expected[i].kind ||
            e->obstacle != s->expected[i].obstacle || e->side != s->expected[i].side) {
            return 0;
        }
    }
    return 1;
}

void bench_record(const bench_scenario_t *s, bench_step_t *steps, bench_run_t *run)
{
    ctl_t c;
    ctl_params_t p;
    fresh(&c, &p, s->strategy);
    const double r = bench_dbl(p.kin.wheel_radius);
    const double track = bench_dbl(p.kin.track_width);
    const double d_det = bench_dbl(p.d_det);
    const double dt = s->dt;
    const size_t n = (size_t)(s->duration / dt + 0.5);
    double x = s->robot[0], y = s->robot[1], th = s->robot[2];
    double xr = s->ref[0], yr = s->ref[1], thr = s->ref[2];

    run->n_steps = n + 1u;
    run->n_events = 0;
    run->min_clearance = INFINITY;
    size_t seen = 0;
    for (unsigned i = 0; i < s->n_obs; i++) {
        run->min_distance[i] = INFINITY;
    }
    if (s->field != 0u) {
        field_make();
        slots_reset();
    }
    for (size_t k = 0; k <= n; k++) {
        bench_step_t *st = &steps[k];
        size_t m = 0;
        if (s->field != 0u) {
            double nearest;
            m = field_sense(x, y, d_det, st->obs, &nearest);
            run->min_clearance = fmin(run->min_clearance, nearest - (0.35 + FIELD_RADIUS - 0.1));
        }
        /* Sensor: every obstacle whose centre is within D_det. */
        for (unsigned i = 0; i < s->n_obs; i++) {
            const double d = hypot(s->obs[i][0] - x, s->obs[i][1] - y);
            run->min_distance[i] = fmin(run->min_distance[i], d);
            run->min_clearance = fmin(run->min_clearance, d - (0.35 + s->obs[i][2] - 0.1));
            if (d <= d_det) {
                st->obs[m++] = (sup_obstacle_t){ .id = (uint8_t)(i + 1u),
                                                 .x = bench_num(s->obs[i][0]),
                                                 .y = bench_num(s->obs[i][1]),
                                                 .radius = bench_num(s->obs[i][2]) };
            }
        }
        seen += m;
        st->in = (ctl_input_t){
            .robot = { bench_num(x), bench_num(y), bench_num(th) },
            .ref = { bench_num(xr), bench_num(yr), bench_num(thr) },
            .v_r = bench_num(s->v_r),
            .w_r = bench_num(s->w_r),
            .obstacles = st->obs,
            .n_obstacles = m,
            .t_us = (uint64_t)llround((double)k * dt * 1e6),
        };
        ctl_output_t out;
        ctl_step(&c, &st->in, &out);
        st->wheels = out.wheels;
        st->mode = (uint8_t)out.status.mode;
        for (size_t j = 0; j < out.n_events && run->n_events < BENCH_MAX_EVENTS; j++) {
            run->events[run->n_events++] = out.events[j];
        }
        /* Plant: differential drive, forward Euler (as sim/mstc/plant/plant.py). */
        const double wl = bench_dbl(out.wheels.left);
        const double wr = bench_dbl(out.wheels.right);
        const double v = r * (wr + wl) / 2.0;
        const double w = r * (wr - wl) / track;
        x += v * cos(th) * dt;
        y += v * sin(th) * dt;
        th += w * dt;
        xr += s->v_r * cos(thr) * dt;
        yr += s->v_r * sin(thr) * dt;
        thr += s->w_r * dt;
    }
    run->events_match = events_match(s, run);
    run->in_view = (double)seen / (double)run->n_steps;
}

uint64_t bench_replay(const bench_step_t *steps, size_t n, uint8_t strategy, bench_step_fn step,
                      bench_clock_fn clk)
{
    ctl_t c;
    ctl_params_t p;
    ctl_output_t out;
    fresh(&c, &p, strategy);
    const uint64_t t0 = clk();
    for (size_t k = 0; k < n; k++) {
        step(&c, &steps[k].in, &out);
    }
    return clk() - t0;
}

void bench_replay_each(const bench_step_t *steps, size_t n, uint8_t strategy, bench_step_fn step,
                       bench_clock_fn clk, uint64_t sum[BENCH_N_MODES],
                       uint64_t count[BENCH_N_MODES], uint64_t max[BENCH_N_MODES])
{
    ctl_t c;
    ctl_params_t p;
    ctl_output_t out;
    fresh(&c, &p, strategy);
    for (size_t k = 0; k < n; k++) {
        const uint64_t t0 = clk();
        step(&c, &steps[k].in, &out);
        const uint64_t d = clk() - t0;
        const unsigned m = steps[k].mode < BENCH_N_MODES ? steps[k].mode : 2u;
        sum[m] += d;
        count[m]++;
        if (d > max[m]) {
            max[m] = d;
        }
    }
}

size_t bench_verify(const bench_step_t *steps, size_t n, uint8_t strategy)
{
    ctl_t c;
    ctl_params_t p;
    ctl_output_t out;
    fresh(&c, &p, strategy);
    size_t differ = 0;
    for (size_t k = 0; k < n; k++) {
        ctl_step(&c, &steps[k].in, &out);
        differ +=
            out.wheels.left != steps[k].wheels.left || out.wheels.right != steps[k].wheels.right;
    }
    return differ;
}

static uint32_t fnv1a(uint32_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++) {
        h = (h ^ p[i]) * 16777619u;
    }
    return h;
}

uint32_t bench_checksum(const bench_step_t *steps, size_t n)
{
    uint32_t h = 2166136261u;
    for (size_t k = 0; k < n; k++) {
        const num_t v[5] = { steps[k].in.robot.x, steps[k].in.robot.y, steps[k].in.robot.theta,
                             steps[k].wheels.left, steps[k].wheels.right };
        uint32_t bits[5];
        _Static_assert(sizeof v == sizeof bits, "num_t is 32 bits in both modes");
        memcpy(bits, v, sizeof bits);
        h = fnv1a(h, bits, sizeof bits);
    }
    return h;
}
