/* SPDX-License-Identifier: MIT */
/* What "mstc" knows of its wheels: rate limiter, estimate, braking time (act.h). */
#include "ctrl/act.h"

#include <stddef.h>

void act_init(act_t *a)
{
    a->cmd = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
    a->est = (kin_wheels_t){ NUM_ZERO, NUM_ZERO };
}

void act_configure(act_t *a, const kin_params_t *kin, num_t accel, num_t lever)
{
    const num_t ra = num_mul(kin->wheel_radius, accel);
    a->lim.inv_accel = num_div(NUM_ONE, accel);
    a->lim.inv_av = num_div(NUM_ONE, ra);
    a->lim.law_accel = num_mul(ra, ACT_LAW_SHARE);
    a->lim.gamma = num_div(num_add(a->lim.law_accel, a->lim.law_accel), kin->track_width);
    a->lim.sqrt_gamma = num_sqrt(a->lim.gamma);
    /* Wheel accelerations within ±a: the point's along-heading acceleration
     * r (a_L + a_R)/2 reaches r a, its across one l r (a_R − a_L)/L reaches
     * 2 l r a / L. */
    a->lim.side = num_min(NUM_ONE, num_div(num_add(lever, lever), kin->track_width));
    a->lim.inv_side = num_div(NUM_ONE, a->lim.side);
}

void act_sync(act_t *a, const kin_wheels_t *w)
{
    a->cmd = *w;
    a->est = *w;
}

num_t act_lag(num_t tau, num_t dt)
{
    /* (τ ω + dt u) / (τ + dt) = u + (ω − u) τ / (τ + dt); u when both are 0. */
    const num_t den = num_add(tau, dt);
    return den > NUM_ZERO ? num_div(tau, den) : NUM_ZERO;
}

void act_estimate(act_t *a, num_t tau, num_t dt, const kin_wheels_t *meas)
{
    act_estimate_lag(a, meas != NULL ? NUM_ZERO : act_lag(tau, dt), meas);
}
