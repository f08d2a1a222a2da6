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
};

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
    size_t seen = 0;
    for (unsigned i = 0; i < s->n_obs; i++) {
        run->min_distance[i] = INFINITY;
    }
    for (size_t k = 0; k <= n; k++) {
        bench_step_t *st = &steps[k];
        /* Sensor: every obstacle whose centre is within D_det. */
        size_t m = 0;
        for (unsigned i = 0; i < s->n_obs; i++) {
            const double d = hypot(s->obs[i][0] - x, s->obs[i][1] - y);
            run->min_distance[i] = fmin(run->min_distance[i], d);
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
