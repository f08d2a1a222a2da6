/* SPDX-License-Identifier: MIT */
/* Odometry plausibility (odo.h). */
#include "app/odo.h"

void odo_reset(odo_t *o) { *o = (odo_t){ .have = false }; }

void odo_init(odo_t *o) { odo_reset(o); }

/* s = max(0, s + e − allowance). */
static num_t cusum(num_t s, num_t e, num_t allowance)
{
    return num_max(NUM_ZERO, num_sub(num_add(s, e), allowance));
}

bool odo_step(odo_t *o, const kin_params_t *p, const kin_wheels_t *w, num_t dt, const pose_t *odom,
              bool fresh_xy, bool fresh_theta)
{
    if (o->have) {
        num_t v;
        num_t om;
        kin_vw_from_wheels(p, w, &v, &om);
        const num_t turn = num_mul(om, dt);
        /* Midpoint heading: exact for a straight line, second order on an arc. */
        const num_t mid = num_add(o->pred.theta, num_mul(turn, NUM_C(0.5)));
        const num_t travel = num_mul(v, dt);
        o->pred.x = num_add(o->pred.x, num_mul(travel, num_cos(mid)));
        o->pred.y = num_add(o->pred.y, num_mul(travel, num_sin(mid)));
        o->pred.theta = num_wrap(num_add(o->pred.theta, turn));
        const num_t rel = NUM_C(ODO_TOL_REL);
        o->allow_xy =
            num_add(o->allow_xy, num_add(NUM_C(ODO_TOL_M), num_mul(rel, num_abs(travel))));
        o->allow_theta =
            num_add(o->allow_theta, num_add(NUM_C(ODO_TOL_RAD), num_mul(rel, num_abs(turn))));
    }
    if (fresh_xy) {
        if (o->have) {
            const num_t e = num_hypot(num_sub(odom->x, o->pred.x), num_sub(odom->y, o->pred.y));
            o->s_xy = cusum(o->s_xy, e, o->allow_xy);
        }
        o->pred.x = odom->x;
        o->pred.y = odom->y;
        o->allow_xy = NUM_ZERO;
    }
    if (fresh_theta) {
        if (o->have) {
            const num_t e = num_abs(num_wrap(num_sub(odom->theta, o->pred.theta)));
            o->s_theta = cusum(o->s_theta, e, o->allow_theta);
        }
        o->pred.theta = odom->theta;
        o->allow_theta = NUM_ZERO;
    }
    o->have = o->have || (fresh_xy && fresh_theta);
    return o->s_xy > NUM_C(ODO_LIMIT_M) || o->s_theta > NUM_C(ODO_LIMIT_RAD);
}
