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

void act_estimate_lag(act_t *a, num_t k, const kin_wheels_t *meas)
{
    if (meas != NULL) {
        a->est = *meas;
        return;
    }
    a->est.left = num_add(a->cmd.left, num_mul(num_sub(a->est.left, a->cmd.left), k));
    a->est.right = num_add(a->cmd.right, num_mul(num_sub(a->est.right, a->cmd.right), k));
}

bool act_limit(act_t *a, num_t step, kin_wheels_t *w)
{
    const num_t dl = num_sub(w->left, a->cmd.left);
    const num_t dr = num_sub(w->right, a->cmd.right);
    const num_t most = num_max(num_abs(dl), num_abs(dr));
    bool limited = false;
    if (most > step) {
        /* most > step >= 0: the factor lies in [0, 1). */
        const num_t k = num_div(step, most);
        w->left = num_add(a->cmd.left, num_mul(k, dl));
        w->right = num_add(a->cmd.right, num_mul(k, dr));
        limited = true;
    }
    a->cmd = *w;
    return limited;
}

num_t act_brake_time(const kin_wheels_t *u, num_t inv_accel, num_t dt)
{
    const num_t top = num_max(num_abs(u->left), num_abs(u->right));
    return num_mul(num_add(num_mul(top, inv_accel), dt), NUM_C(0.5));
}

num_t act_horizon(num_t tau, num_t dt, bool measured)
{
    return measured ? num_add(tau, num_mul(dt, NUM_C(0.5))) : tau;
}

/* The rotation of act_predict(): out->c, out->s; returns δ = ωt. */
static num_t rotate(num_t c0, num_t s0, num_t w, num_t t, act_pose_t *out)
{
    const num_t d = num_mul(w, t);
    const num_t d2 = num_mul(d, d);
    const num_t cd = num_sub(NUM_ONE, num_mul(d2, NUM_C(0.5)));
    const num_t sd = num_mul(d, num_sub(NUM_ONE, num_mul(d2, NUM_C(1.0 / 6.0))));
    out->c = num_sub(num_mul(c0, cd), num_mul(s0, sd));
    out->s = num_add(num_mul(s0, cd), num_mul(c0, sd));
    return d;
}

void act_predict(const pose_t *p0, num_t c0, num_t s0, num_t v, num_t w, num_t t, act_pose_t *out)
{
    const num_t d = rotate(c0, s0, w, t, out);
    const num_t hd = num_mul(d, NUM_C(0.5));
    const num_t l = num_mul(v, t);
    out->p.x = num_add(p0->x, num_mul(l, num_sub(c0, num_mul(s0, hd))));
    out->p.y = num_add(p0->y, num_mul(l, num_add(s0, num_mul(c0, hd))));
    out->p.theta = num_add(p0->theta, d);
}

void act_predict_heading(num_t theta, num_t c0, num_t s0, num_t w, num_t t, act_pose_t *out)
{
    out->p.theta = num_add(theta, rotate(c0, s0, w, t, out));
}
