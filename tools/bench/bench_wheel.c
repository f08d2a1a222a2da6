/* SPDX-License-Identifier: MIT */
/* The wheel loop's benchmark (make bench, bench_wheel.h): a closed loop of
 * whl_step against two DC motor models (sim/dcmotor/dcm.h), recorded, then
 * replayed through whl_step alone. */
#include "bench_wheel.h"

#include "dcm.h"

#define DT 1e-3

/* Setpoints [rad/s] of the recording at period @p k, left and right: a
 * start, a turn, a reversal, a stop; what a wheel loop meets. */
static void setpoints(size_t k, double sp[2])
{
    const double t = (double)k * DT;
    if (t < 0.1) {
        sp[0] = 0.0;
        sp[1] = 0.0;
    } else if (t < 0.8) {
        sp[0] = 20.0;
        sp[1] = 20.0;
    } else if (t < 1.4) {
        sp[0] = 25.0;
        sp[1] = 12.0;
    } else if (t < 2.2) {
        sp[0] = -15.0;
        sp[1] = -15.0;
    } else {
        sp[0] = 0.0;
        sp[1] = 0.0;
    }
}

num_t bench_wheel_params(whl_params_t *p)
{
    ctl_params_t c;
    ctl_params_default(&c);
    *p = c.wheel;
    return num_from_float(125.0f); /* docs/wheel.md's ramp (wheel_accel) for this motor */
}

size_t bench_wheel_record(bench_wheel_period_t *rec, size_t n)
{
    dcm_params_t mp;
    dcm_params_default(&mp);
    dcm_t m[2];
    dcm_init(&m[0]);
    dcm_init(&m[1]);
    whl_params_t p;
    const num_t accel = bench_wheel_params(&p);
    whl_t w;
    whl_init(&w, &p, accel);
    for (size_t k = 0; k < n; k++) {
        double sp[2];
        setpoints(k, sp);
        /* 30 % of stall torque on the left wheel for 0.3 s of the turn. */
        m[0].load = (k >= 1000u && k < 1300u) ? 0.41 : 0.0;
        whl_input_t *in = &rec[k].in;
        for (unsigned i = 0; i < 2u; i++) {
            in->setpoint[i] = num_from_float((float)sp[i]);
            in->count[i] = dcm_count(&m[i], &mp);
        }
        whl_output_t out;
        whl_step(&w, in, &out);
        rec[k].cmd[0] = out.cmd[0];
        rec[k].cmd[1] = out.cmd[1];
        for (unsigned i = 0; i < 2u; i++) {
            dcm_step(&m[i], &mp, (double)num_to_float(out.drive[i]), DT);
        }
    }
    return n;
}

size_t bench_wheel_verify(const bench_wheel_period_t *rec, size_t n)
{
    whl_params_t p;
    const num_t accel = bench_wheel_params(&p);
    whl_t w;
    whl_init(&w, &p, accel);
    size_t differ = 0;
    for (size_t k = 0; k < n; k++) {
        whl_output_t out;
        whl_step(&w, &rec[k].in, &out);
        differ += (out.cmd[0] != rec[k].cmd[0] || out.cmd[1] != rec[k].cmd[1]) ? 1u : 0u;
    }
    return differ;
}

/* The loop of a timed replay with no step in it: what the replay costs
 * beyond whl_step. */
static void empty_step(whl_t *w, const whl_input_t *in, whl_output_t *out)
{
    (void)w;
    out->cmd[0] = (int16_t)in->count[0];
    out->cmd[1] = (int16_t)in->count[1];
}

void bench_wheel_replay(const bench_wheel_period_t *rec, size_t n, bool empty,
                        uint64_t (*ticks)(void), uint64_t *total, uint64_t *largest)
{
    whl_params_t p;
    const num_t accel = bench_wheel_params(&p);
    whl_t w;
    whl_init(&w, &p, accel);
    void (*step)(whl_t *, const whl_input_t *, whl_output_t *) = empty ? empty_step : whl_step;
    volatile int16_t sink = 0;
    *total = 0u;
    *largest = 0u;
    for (size_t k = 0; k < n; k++) {
        whl_output_t out;
        const uint64_t t0 = ticks();
        step(&w, &rec[k].in, &out);
        const uint64_t t = ticks() - t0;
        sink = (int16_t)(sink + out.cmd[0]);
        *total += t;
        *largest = t > *largest ? t : *largest;
    }
}
