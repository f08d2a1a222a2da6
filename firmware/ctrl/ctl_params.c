/* SPDX-License-Identifier: MIT */
/* The parameter set: its defaults and its check, both from the limits table
 * ctl_params.toml (ctl_limits.c, generated; docs/safety.md, "Parameters"). */
#include <errno.h>

#include "ctrl/ctl.h"

/* Every row of the table is held (tools/gen-limits refuses one that is not),
 * so ctl_param_slot() of an index below CTL_N_PARAMS is NULL only for an
 * index the table leaves out (reserved: ctl_limits[i].held is false). When
 * the table leaves none out (CTL_ALL_HELD), there is nothing to skip, and
 * the test is not compiled (it could never be false). */
void ctl_params_default(ctl_params_t *p)
{
    *p = (ctl_params_t){ 0 };
    for (unsigned i = 0; i < CTL_N_PARAMS; i++) {
#if !CTL_ALL_HELD
        if (!ctl_limits[i].held) {
            continue;
        }
#endif
        *ctl_param_slot(p, i) = ctl_limits[i].def;
    }
}

/* The value of parameter @p i in @p p (a copy: ctl_param_slot() wants it
 * writable). */
static num_t value_of(ctl_params_t *p, unsigned i) { return *ctl_param_slot(p, i); }

/* Finite and within [min, max]: num_is_finite() first, since an ordered
 * comparison with NaN raises FE_INVALID. */
/* A whole number, for an x already within an enumerated parameter's small
 * range (the cast cannot overflow). */
static bool whole(num_t x)
{
    const float f = num_to_float(x);
    return f == (float)(int32_t)f;
}

static bool in_range(num_t x, const ctl_limit_t *l)
{
    return num_is_finite(x) && x >= l->min && x <= l->max && (!l->integer || whole(x));
}

static bool holds(const ctl_relation_t *r, ctl_params_t *p)
{
    num_t total = value_of(p, r->rhs[0]);
    if (r->rhs[1] != CTL_P_NONE) {
        total = num_add(total, value_of(p, r->rhs[1]));
    }
    /* In range, every term is positive and small: no overflow, and the
     * rounding is the loader's (sim/mstc/limits.py emulates it). */
    const num_t rhs = num_mul(total, r->factor);
    const num_t lhs = value_of(p, r->lhs);
    bool ok;
    switch (r->op) {
    case CTL_REL_GE: ok = lhs >= rhs; break;
    case CTL_REL_LT: ok = lhs < rhs; break;
    default: ok = lhs <= rhs; break; /* CTL_REL_LE */
    }
    return ok;
}

ctl_params_verdict_t ctl_params_verdict(const ctl_params_t *p)
{
    ctl_params_t q = *p;
    for (unsigned i = 0; i < CTL_N_PARAMS; i++) {
#if !CTL_ALL_HELD
        if (!ctl_limits[i].held) {
            continue;
        }
#endif
        if (!in_range(value_of(&q, i), &ctl_limits[i])) {
            return CTL_PARAMS_RANGE;
        }
    }
    for (unsigned i = 0; i < CTL_N_RELATIONS; i++) {
        if (!holds(&ctl_relations[i], &q)) {
            return CTL_PARAMS_RELATION;
        }
    }
    return CTL_PARAMS_OK;
}

int ctl_params_check(const ctl_params_t *p)
{
    return ctl_params_verdict(p) == CTL_PARAMS_OK ? 0 : -EINVAL;
}
