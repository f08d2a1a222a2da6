/* SPDX-License-Identifier: MIT */
/* Geometry of the obstacle set for the "mstc" strategy (oset.h). */
#include "ctrl/oset.h"

/* Relative speeds below this are "no relative motion" [m/s]: t* is then 0.
 * Its square, 1e-4, is 6.6 Q16.16 steps: |v|² is never divided by 0. */
#define OSET_MIN_SPEED NUM_C(0.01)

oset_link_t oset_link(const sup_entry_t *a, const sup_entry_t *b, num_t width)
{
    const num_t dx = num_sub(b->o.x, a->o.x);
    const num_t dy = num_sub(b->o.y, a->o.y);
    const num_t touch = num_add(a->d_s, b->d_s);
    if (!oset_within(dx, dy, num_add(touch, width))) {
        return OSET_APART;
    }
    return oset_within(dx, dy, touch) ? OSET_OVERLAP : OSET_GAP;
}

sup_mask_t oset_cluster(const sup_entry_t *e, uint8_t n, uint8_t seed, num_t width, bool *gapped)
{
    /* Breadth first over bit masks: each member is expanded once, against
     * every other entry: the ones not yet in the cluster may join it, the
     * ones in it already may leave a gap with it. The entries each member
     * is tested against are walked as a mask too (those not yet expanded,
     * in the order of their indices). */
    const sup_mask_t table = sup_mask_first(n);
    sup_mask_t members = sup_mask_of(seed);
    sup_mask_t todo = members;
    sup_mask_t done = 0u;
    *gapped = false;
    while (todo != 0u) {
        const unsigned i = sup_mask_lowest(todo);
        todo = sup_mask_without_lowest(todo);
        done |= sup_mask_of(i);
        /* Not itself, nor a pair tested from the other end. */
        for (sup_mask_t rest = table & ~done; rest != 0u; rest = sup_mask_without_lowest(rest)) {
            const unsigned j = sup_mask_lowest(rest);
            const oset_link_t link = oset_link(&e[i], &e[j], width);
            if (link != OSET_APART) {
                *gapped = *gapped || link == OSET_GAP;
                const sup_mask_t bit = sup_mask_of(j);
                if ((members & bit) == 0u) {
                    members |= bit;
                    todo |= bit;
                }
            }
        }
    }
    return members;
}

bool oset_closing(num_t dx, num_t dy, num_t vx, num_t vy)
{
    return num_add(num_mul(dx, vx), num_mul(dy, vy)) > NUM_ZERO;
}

void oset_closest_approach(num_t px, num_t py, num_t vx, num_t vy, num_t horizon, num_t *t,
                           num_t *d2)
{
    const num_t v2 = num_sum_sq(vx, vy);
    num_t ts = NUM_ZERO;
    if (v2 >= num_mul(OSET_MIN_SPEED, OSET_MIN_SPEED)) {
        /* t* = −p·v / |v|², in the past (< 0: receding) or beyond the horizon
         * clamped to the ends. */
        const num_t pv = num_add(num_mul(px, vx), num_mul(py, vy));
        if (pv < NUM_ZERO) {
            ts = num_min(num_div(num_neg(pv), v2), horizon);
        }
    }
    const num_t cx = num_add(px, num_mul(vx, ts));
    const num_t cy = num_add(py, num_mul(vy, ts));
    *t = ts;
    *d2 = num_sum_sq(cx, cy);
}
