/* SPDX-License-Identifier: MIT */
/* Differential-drive kinematics. */
#include "kin/kin.h"

void kin_wheels_from_vw(const kin_params_t *p, num_t v, num_t w, kin_wheels_t *out)
{
    /* ω L/2, halving last: L/2 rounded on its own (0.15 in Q16.16) would put
     * a 5e-5 relative error into every turn that kin_vw_from_wheels, which
     * divides by L, would not take back. */
    const num_t half_turn = num_mul(num_mul(w, p->track_width), NUM_C(0.5));
    out->right = num_div(num_add(v, half_turn), p->wheel_radius);
    out->left = num_div(num_sub(v, half_turn), p->wheel_radius);
}

void kin_vw_from_wheels(const kin_params_t *p, const kin_wheels_t *wheels, num_t *v, num_t *w)
{
    *v = num_mul(p->wheel_radius, num_mul(num_add(wheels->right, wheels->left), NUM_C(0.5)));
    *w = num_div(num_mul(p->wheel_radius, num_sub(wheels->right, wheels->left)), p->track_width);
}

static num_t limit_or_scale(num_t w, num_t peak, num_t f, num_t limit)
{
    if (num_abs(w) == peak) {
        return w > NUM_ZERO ? limit : num_neg(limit);
    }
    return num_mul(w, f);
}

bool kin_saturate(const kin_params_t *p, kin_wheels_t *wheels)
{
    const num_t peak = num_max(num_abs(wheels->left), num_abs(wheels->right));
    if (peak <= p->max_wheel_speed) {
        return false;
    }
    /* One factor for both wheels keeps their ratio, so ω/v is unchanged. The
     * faster wheel (both, when they are equally fast) is set to the limit
     * exactly rather than through the rounded factor. */
    const num_t f = num_div(p->max_wheel_speed, peak);
    wheels->left = limit_or_scale(wheels->left, peak, f, p->max_wheel_speed);
    wheels->right = limit_or_scale(wheels->right, peak, f, p->max_wheel_speed);
    return true;
}
