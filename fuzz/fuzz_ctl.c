/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer harness: the control step fed arbitrary bit patterns (ctl.h,
 * docs/safety.md). In float mode every num_t is a raw IEEE single (NaN,
 * infinities, subnormals included); in fixed mode (-DNUM_FIXED) a raw
 * Q16.16. Covers the supervisor's input too: obstacle reports of any value.
 *
 * Input: 4-byte words, in order: robot x, y, θ; reference x, y, θ; v_r, ω_r;
 * a byte whose low bit says the wheels' speeds were measured, then (when it
 * is set) the left and right measured speeds as two words; a byte giving
 * the number of obstacles, then obstacles of 6 words each (id from the low
 * byte of the first, then x, y, radius, vx, vy), at most
 * SUP_MAX_OBSTACLES + 2; optionally, when the input starts with the byte
 * 'P', 13 parameter words, a strategy word (a raw num_t like the others: 0
 * paper, 1 mstc, anything else refused), then wheel_accel and wheel_tau
 * first (rejected ones leave the defaults, whose strategy is "mstc").
 * Several steps run on the same state. After each step: the wheel speeds are
 * finite and within ±max_wheel_speed, the mode is one of the four, the
 * events fit their buffer; otherwise abort().
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "ctrl/ctl.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static num_t word(const uint8_t **p, const uint8_t *end)
{
    num_t v;
    memset(&v, 0, sizeof v);
    if (end - *p >= (ptrdiff_t)sizeof v) {
        memcpy(&v, *p, sizeof v);
        *p += sizeof v;
    }
    return v;
}

static bool wheel_ok(num_t w, num_t max) { return num_is_finite(w) && num_abs(w) <= max; }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const uint8_t *p = data;
    const uint8_t *end = data + size;
    static ctl_t c;
    ctl_params_t params;
    ctl_params_default(&params);
    if (size > 0 && data[0] == 'P') {
        p++;
        num_t *all[] = { &params.r_m,
                         &params.r_ob,
                         &params.d_det,
                         &params.d_act,
                         &params.d_s,
                         &params.trk.k1,
                         &params.trk.k2,
                         &params.trk.k3,
                         &params.avd.k1,
                         &params.avd.k2,
                         &params.kin.wheel_radius,
                         &params.kin.track_width,
                         &params.kin.max_wheel_speed };
        for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) {
            *all[i] = word(&p, end);
        }
        params.strategy = word(&p, end);
        params.wheel_accel = word(&p, end);
        params.wheel_tau = word(&p, end);
    }
    (void)ctl_init(&c, &params);
    uint64_t t_us = 0;
    while (p < end) {
        ctl_input_t in = { .wheels_measured = false };
        in.robot = (pose_t){ word(&p, end), word(&p, end), word(&p, end) };
        in.ref = (pose_t){ word(&p, end), word(&p, end), word(&p, end) };
        in.v_r = word(&p, end);
        in.w_r = word(&p, end);
        if (p < end) {
            in.wheels_measured = (*p & 1u) != 0u;
            p++;
        }
        if (in.wheels_measured) {
            in.wheels.left = word(&p, end);
            in.wheels.right = word(&p, end);
        }
        sup_obstacle_t obs[SUP_MAX_OBSTACLES + 2u];
        size_t n = 0;
        size_t n_max = 0;
        if (p < end) {
            n_max = (size_t)(*p % (SUP_MAX_OBSTACLES + 3u));
            p++;
        }
        while (n < n_max && end - p >= 24) {
            const num_t id = word(&p, end);
            uint8_t id8;
            memcpy(&id8, &id, 1);
            obs[n] = (sup_obstacle_t){ .id = id8,
                                       .x = word(&p, end),
                                       .y = word(&p, end),
                                       .radius = word(&p, end),
                                       .vx = word(&p, end),
                                       .vy = word(&p, end) };
            n++;
        }
        in.obstacles = obs;
        in.n_obstacles = n;
        in.t_us = t_us;
        t_us += 20000u;
        ctl_output_t out;
        ctl_step(&c, &in, &out);
        const num_t max = c.p.kin.max_wheel_speed;
        if (!wheel_ok(out.wheels.left, max) || !wheel_ok(out.wheels.right, max) ||
            out.status.mode > SUP_MODE_BLOCKED || out.n_events > SUP_MAX_EVENTS) {
            abort();
        }
    }
    return 0;
}
