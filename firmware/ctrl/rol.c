/* SPDX-License-Identifier: MIT */
/* Forward roll-out of a constant command in closed form (rol.h). */
#include "ctrl/rol.h"

#include "ctrl/oset.h"

void rol_path(rol_path_t *path, const pose_t *p, num_t cos_th, num_t sin_th, num_t v, num_t w,
              num_t horizon)
{
    /* Field by field: a compound literal costs a memset. What a kind does
     * not use stays zero. */
    path->kind = ROL_TOO_LONG;
    path->x = p->x;
    path->y = p->y;
    path->ex = NUM_ZERO;
    path->ey = NUM_ZERO;
    path->length = NUM_ZERO;
    path->widen = NUM_ZERO;
    path->cx = NUM_ZERO;
    path->cy = NUM_ZERO;
    path->radius = NUM_ZERO;
    path->s0x = NUM_ZERO;
    path->s0y = NUM_ZERO;
    path->s1x = NUM_ZERO;
    path->s1y = NUM_ZERO;
    path->ccw = false;
    path->whole = false;
    path->reach = NUM_MAX;
    const num_t length = num_mul(num_abs(v), horizon);
    if (length > ROL_MAX_LENGTH) {
        return;
    }
    const num_t turn = num_mul(w, horizon); /* Φ */
    if (num_abs(turn) <= ROL_STRAIGHT_TURN) {
        path->kind = ROL_SEGMENT;
        path->ex = v < NUM_ZERO ? num_neg(cos_th) : cos_th;
        path->ey = v < NUM_ZERO ? num_neg(sin_th) : sin_th;
        path->length = length;
        /* An arc of turn Φ and length L leaves its tangent by at most
         * ρ(1 − cos Φ) <= ρ Φ²/2 = L|Φ|/2. */
        path->widen = num_mul(length, num_mul(num_abs(turn), NUM_C(0.5)));
        path->reach = num_add(length, path->widen);
        return;
    }
    /* |v/ω| = L / |Φ| < 10 / 0.1 = 100 m: the circle's squares stay within
     * oset_within()'s reach. */
    const num_t k = num_div(v, w);
    path->kind = ROL_ARC;
    path->s0x = num_mul(k, sin_th);
    path->s0y = num_neg(num_mul(k, cos_th));
    path->cx = num_sub(p->x, path->s0x);
    path->cy = num_sub(p->y, path->s0y);
    path->radius = num_abs(k);
    const num_t th_end = num_add(p->theta, turn);
    num_t s_end;
    num_t c_end;
    num_sincos(th_end, &s_end, &c_end);
    path->s1x = num_mul(k, s_end);
    path->s1y = num_neg(num_mul(k, c_end));
    path->ccw = w > NUM_ZERO;
    path->whole = num_abs(turn) > NUM_PI;
    path->reach = length; /* an arc is no longer than |v| T, its chord shorter */
}

/* cross(a, b) = a_x b_y − a_y b_x. */
static num_t cross(num_t ax, num_t ay, num_t bx, num_t by)
{
    return num_sub(num_mul(ax, by), num_mul(ay, bx));
}

static bool segment_clears(const rol_path_t *path, num_t ox, num_t oy, num_t clear)
{
    const num_t c = num_add(clear, path->widen);
    const num_t wx = num_sub(ox, path->x);
    const num_t wy = num_sub(oy, path->y);
    if (!oset_within(wx, wy, num_add(c, path->length))) {
        return true; /* beyond the whole path's reach */
    }
    const num_t s = num_add(num_mul(wx, path->ex), num_mul(wy, path->ey));
    if (s <= NUM_ZERO) {
        return !oset_within(wx, wy, c); /* nearest to the start */
    }
    if (s >= path->length) {
        return !oset_within(num_sub(wx, num_mul(path->length, path->ex)),
                            num_sub(wy, num_mul(path->length, path->ey)), c);
    }
    return num_abs(cross(path->ex, path->ey, wx, wy)) >= c;
}

static bool arc_clears(const rol_path_t *path, num_t ox, num_t oy, num_t clear)
{
    const num_t rx = num_sub(ox, path->cx);
    const num_t ry = num_sub(oy, path->cy);
    /* The whole circle keeps the distance: | |r| − ρ | >= clear. */
    const bool in_annulus = oset_within(rx, ry, num_add(path->radius, clear)) &&
                            !oset_within(rx, ry, num_sub(path->radius, clear));
    if (!in_annulus) {
        return true;
    }
    if (path->whole) {
        return false;
    }
    /* The point faces the swept sector (|Φ| <= π): then the nearest point of
     * the circle is on the path. */
    const num_t c0 = cross(path->s0x, path->s0y, rx, ry);
    const num_t c1 = cross(rx, ry, path->s1x, path->s1y);
    const bool in_sector =
        path->ccw ? (c0 >= NUM_ZERO && c1 >= NUM_ZERO) : (c0 <= NUM_ZERO && c1 <= NUM_ZERO);
    if (in_sector) {
        return false;
    }
    /* Otherwise the distance grows along the arc away from the nearer end,
     * so the ends decide. */
    return !oset_within(num_sub(ox, path->x), num_sub(oy, path->y), clear) &&
           !oset_within(num_sub(rx, path->s1x), num_sub(ry, path->s1y), clear);
}

bool rol_clears(const rol_path_t *path, num_t ox, num_t oy, num_t clear)
{
    if (path->kind == ROL_SEGMENT) {
        return segment_clears(path, ox, oy, clear);
    }
    if (path->kind == ROL_ARC) {
        return arc_clears(path, ox, oy, clear);
    }
    return false;
}
