/* SPDX-License-Identifier: MIT */
/* Obstacle avoidance by boundary following, paper eq. (9)-(24), with eq. (15)
 * as corrected in docs/equations.md. */
#include "ctrl/avd.h"

/* Below this centre distance the direction to the obstacle is undefined. */
#define AVD_MIN_DIST NUM_C(0.001)

avd_side_t avd_choose_side(const pose_t *robot, num_t ox, num_t oy)
{
    /* eq. (11)-(12), compared on the wrapped difference (docs/equations.md erratum 2):
     * α = +π/2 (left) when wrap(θ − φ) >= 0. */
    const num_t phi = num_atan2(num_sub(oy, robot->y), num_sub(ox, robot->x));
    return num_wrap(num_sub(robot->theta, phi)) >= NUM_ZERO ? AVD_SIDE_LEFT : AVD_SIDE_RIGHT;
}

/* β, β̇ and |u| for the robot moving at (xd, yd) relative to the obstacle
 * (its velocity minus the obstacle's: u_mo changes at −(xd, yd)). */
static void direction(const pose_t *robot, num_t ox, num_t oy, num_t d_s, avd_side_t side, num_t xd,
                      num_t yd, avd_dir_t *dir)
{
    /* u_mo, eq. (5)/(9), and its length r = D_r. */
    const num_t mx = num_sub(ox, robot->x);
    const num_t my = num_sub(oy, robot->y);
    const num_t r = num_hypot(mx, my);
    if (r < AVD_MIN_DIST) {
        dir->beta = robot->theta;
        dir->beta_dot = NUM_ZERO;
        dir->u_norm = NUM_ZERO;
        return;
    }
    /* û = u_mo / r = [cos φ, sin φ], eq. (11). */
    const num_t cphi = num_div(mx, r);
    const num_t sphi = num_div(my, r);
    const num_t ds_r = num_div(d_s, r);
    const num_t k = num_sub(NUM_ONE, ds_r); /* u_p = (1 − D_s/r) u_mo, eq. (9) */
    /* u_f = R(α) u_mo, eq. (10): R(+π/2)[a, b] = [−b, a]; R(−π/2)[a, b] = [b, −a].
     * Blending vector u = u_p + u_f, eq. (13). */
    num_t ux;
    num_t uy;
    if (side == AVD_SIDE_LEFT) {
        ux = num_sub(num_mul(k, mx), my);
        uy = num_add(num_mul(k, my), mx);
    } else {
        ux = num_add(num_mul(k, mx), my);
        uy = num_sub(num_mul(k, my), mx);
    }
    const num_t u_norm = num_hypot(ux, uy); /* >= r > 0: u_f ⟂ u_p, |u_f| = r */
    /* cos β, sin β straight from u: eq. (14) without a trigonometric call. */
    const num_t cb = num_div(ux, u_norm);
    const num_t sb = num_div(uy, u_norm);

    /* Corrected eq. (15): u̇_p = (D_s/r − 1) q̇ − (D_s/r)(ẋ cos φ + ẏ sin φ) û. */
    const num_t radial = num_mul(ds_r, num_add(num_mul(xd, cphi), num_mul(yd, sphi)));
    num_t udx = num_sub(num_neg(num_mul(k, xd)), num_mul(radial, cphi));
    num_t udy = num_sub(num_neg(num_mul(k, yd)), num_mul(radial, sphi));
    /* eq. (16): u̇_f = −R q̇; eq. (17): u̇ = u̇_p + u̇_f. */
    if (side == AVD_SIDE_LEFT) {
        udx = num_add(udx, yd);
        udy = num_sub(udy, xd);
    } else {
        udx = num_sub(udx, yd);
        udy = num_add(udy, xd);
    }
    dir->beta = num_atan2(uy, ux);
    /* eq. (22): β̇ = (u̇_y cos β − u̇_x sin β) / |u|. */
    dir->beta_dot = num_div(num_sub(num_mul(udy, cb), num_mul(udx, sb)), u_norm);
    dir->u_norm = u_norm;
}

void avd_direction(const pose_t *robot, num_t ox, num_t oy, num_t d_s, avd_side_t side, num_t v,
                   avd_dir_t *dir)
{
    /* q̇ = v [cos θ, sin θ]. */
    num_t s;
    num_t c;
    num_sincos(robot->theta, &s, &c);
    const num_t xd = num_mul(v, c);
    const num_t yd = num_mul(v, s);
    direction(robot, ox, oy, d_s, side, xd, yd, dir);
}

void avd_control(const avd_gains_t *g, const pose_t *robot, const trk_err_t *err, num_t v_r,
                 num_t ox, num_t oy, num_t d_s, avd_side_t side, num_t *v, num_t *w, num_t *e)
{
    /* eq. (23): the same linear velocity as eq. (2). */
    *v = num_add(num_mul(v_r, num_cos(err->e3)), num_mul(g->k1, err->e1));
    /* β̇ is evaluated for the velocity the robot is about to be given. */
    avd_dir_t dir;
    avd_direction(robot, ox, oy, d_s, side, *v, &dir);
    /* eq. (21), wrapped (docs/equations.md erratum 2), and eq. (24). */
    *e = num_wrap(num_sub(dir.beta, robot->theta));
    *w = num_add(dir.beta_dot, num_mul(g->k2, *e));
}

void avd_turn(const avd_gains_t *g, const pose_t *robot, num_t cos_th, num_t sin_th,
              const avd_obstacle_t *o, avd_side_t side, num_t v, num_t *w, num_t *e)
{
    /* eq. (15)-(17) hold for u_mo = O − q whatever moves: u̇_mo = Ȯ − q̇, so
     * the robot's velocity enters relative to the obstacle's. */
    const num_t xd = num_sub(num_mul(v, cos_th), o->vx);
    const num_t yd = num_sub(num_mul(v, sin_th), o->vy);
    avd_dir_t dir;
    direction(robot, o->x, o->y, o->d_s, side, xd, yd, &dir);
    *e = num_wrap(num_sub(dir.beta, robot->theta));
    *w = num_add(dir.beta_dot, num_mul(g->k2, *e));
}
