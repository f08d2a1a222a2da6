/* SPDX-License-Identifier: MIT */
/* Trajectory tracking, paper eq. (1)-(3) (Kanayama et al. 1990). */
#include "ctrl/trk.h"

void trk_errors(const pose_t *robot, const pose_t *ref, trk_err_t *err)
{
    num_t s;
    num_t c;
    num_sincos(robot->theta, &s, &c);
    trk_errors_cs(robot, c, s, ref, err);
}

void trk_control(const trk_gains_t *g, const trk_err_t *err, num_t v_r, num_t w_r, num_t *v,
                 num_t *w)
{
    num_t s3;
    num_t c3;
    num_sincos(err->e3, &s3, &c3);
    /* eq. (2) */
    *v = num_add(num_mul(v_r, c3), num_mul(g->k1, err->e1));
    /* eq. (3) */
    const num_t turn = num_add(num_mul(g->k2, err->e2), num_mul(g->k3, s3));
    *w = num_add(w_r, num_mul(v_r, turn));
}
