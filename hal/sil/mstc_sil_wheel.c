/* SPDX-License-Identifier: MIT */
/* The firmware's wheel loop against two DC motor models, for the plant
 * (mstc_sil_wheel.h). The motors and the loop share one clock in
 * microseconds; the loop runs at its period, as a board's millisecond tick
 * runs it (hal/stm32/main.c), and a fault stops the motors as
 * hal_motor_stop() does: the windings open, the wheels coast. */
#include "mstc_sil_wheel.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>

#include "ctrl/ctl.h"
#include "dcm.h"
#include "hal_sil.h"
#include "wheel/whl.h"

typedef struct {
    whl_t loop;
    dcm_params_t mp;
    dcm_t motor[2];
    whl_output_t out;   /* of the last period */
    uint64_t t_us;      /* the motors' time */
    uint64_t next_us;   /* the next period is due then */
    uint32_t period_us; /* whl_period_us() */
    uint32_t periods;   /* run since init */
} wheels_t;

_Static_assert(sizeof(mstc_sil_motor_t) == sizeof(dcm_params_t), "motor constants differ");

size_t mstc_sil_wheels_size(void) { return sizeof(wheels_t); }

static double to_d(num_t n) { return (double)num_to_float(n); }

void mstc_sil_wheels_defaults(mstc_sil_wheel_params_t *wp, mstc_sil_motor_t *mp)
{
    ctl_params_t c;
    ctl_params_default(&c);
    const whl_params_t *p = &c.wheel;
    *wp = (mstc_sil_wheel_params_t){
        .kp = to_d(p->kp),
        .ki = to_d(p->ki),
        .free_speed = to_d(p->free_speed),
        .motor_tau = to_d(p->motor_tau),
        .counts = to_d(p->counts),
        .rate = to_d(p->rate),
        .window = to_d(p->window),
        .stall_time = to_d(p->stall_time),
        .accel = to_d(c.wheel_accel),
    };
    dcm_params_t d;
    dcm_params_default(&d);
    *mp = (mstc_sil_motor_t){ d.r_ohm,          d.kt,     d.ke,    d.j, d.b, d.tau_c, d.v_supply,
                              d.counts_per_rev, d.hold_k, d.hold_c };
}

/* The wheel parameters as the firmware holds them, checked as a PARAM_SET
 * of each would be: within the default set, by ctl_params_check(). */
static int params_from(const mstc_sil_wheel_params_t *wp, whl_params_t *out, num_t *accel)
{
    const double v[] = { wp->kp,   wp->ki,     wp->free_speed, wp->motor_tau, wp->counts,
                         wp->rate, wp->window, wp->stall_time, wp->accel };
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++) {
        if (!isfinite(v[i])) {
            return -EINVAL; /* fixed mode has no NaN to refuse later */
        }
    }
    ctl_params_t c;
    ctl_params_default(&c);
    c.wheel = (whl_params_t){
        .kp = num_from_float((float)wp->kp),
        .ki = num_from_float((float)wp->ki),
        .free_speed = num_from_float((float)wp->free_speed),
        .motor_tau = num_from_float((float)wp->motor_tau),
        .counts = num_from_float((float)wp->counts),
        .rate = num_from_float((float)wp->rate),
        .window = num_from_float((float)wp->window),
        .stall_time = num_from_float((float)wp->stall_time),
    };
    c.wheel_accel = num_from_float((float)wp->accel);
    if (ctl_params_check(&c) != 0) {
        return -EINVAL;
    }
    *out = c.wheel;
    *accel = c.wheel_accel;
    return 0;
}

static bool motor_ok(const mstc_sil_motor_t *m)
{
    const double positive[] = { m->r_ohm, m->kt, m->ke, m->j, m->v_supply, m->counts_per_rev };
    const double zero_or_more[] = { m->b, m->tau_c, m->hold_k, m->hold_c };
    for (size_t i = 0; i < sizeof positive / sizeof positive[0]; i++) {
        if (!(isfinite(positive[i]) && positive[i] > 0.0)) {
            return false;
        }
    }
    for (size_t i = 0; i < sizeof zero_or_more / sizeof zero_or_more[0]; i++) {
        if (!(isfinite(zero_or_more[i]) && zero_or_more[i] >= 0.0)) {
            return false;
        }
    }
    return true;
}

int mstc_sil_wheels_init(void *mem, const mstc_sil_wheel_params_t *wp, const mstc_sil_motor_t *mp)
{
    if (mem == NULL || wp == NULL || mp == NULL || !motor_ok(mp)) {
        return -EINVAL;
    }
    whl_params_t p;
    num_t accel;
    if (params_from(wp, &p, &accel) != 0) {
        return -EINVAL;
    }
    wheels_t *w = mem;
    *w = (wheels_t){
        .mp = { mp->r_ohm, mp->kt, mp->ke, mp->j, mp->b, mp->tau_c, mp->v_supply,
                mp->counts_per_rev, mp->hold_k, mp->hold_c },
        .period_us = whl_period_us(&p),
    };
    whl_init(&w->loop, &p, accel);
    dcm_init(&w->motor[0]);
    dcm_init(&w->motor[1]);
    return 0;
}

/* The motors over @p dt_us with the drives of the last period, or coasting
 * while the loop has a fault (hal_motor_stop(): the driver disabled). */
static void run_motors(wheels_t *w, uint64_t dt_us)
{
    if (dt_us == 0u) {
        return;
    }
    const double dt = (double)dt_us * 1e-6;
    for (unsigned i = 0; i < 2u; i++) {
        if (w->out.faults != 0u) {
            dcm_coast(&w->motor[i], &w->mp, dt);
        } else {
            dcm_step(&w->motor[i], &w->mp, (double)num_to_float(w->out.drive[i]), dt);
        }
    }
}

int mstc_sil_wheels_advance(void *mem, const mstc_sil_wheels_input_t *in, uint32_t dt_us,
                            mstc_sil_wheels_output_t *out)
{
    if (mem == NULL || in == NULL || out == NULL) {
        return -EINVAL;
    }
    wheels_t *w = mem;
    w->motor[0].load = in->load[0];
    w->motor[1].load = in->load[1];
    const uint64_t end = w->t_us + dt_us;
    while (w->next_us <= end) {
        run_motors(w, w->next_us - w->t_us);
        w->t_us = w->next_us;
        const whl_input_t wi = {
            { num_from_float((float)in->setpoint[0]), num_from_float((float)in->setpoint[1]) },
            { dcm_count(&w->motor[0], &w->mp), dcm_count(&w->motor[1], &w->mp) },
        };
        whl_step(&w->loop, &wi, &w->out);
        w->periods++;
        w->next_us += w->period_us;
    }
    run_motors(w, end - w->t_us);
    w->t_us = end;
    for (unsigned i = 0; i < 2u; i++) {
        out->speed[i] = w->motor[i].omega;
        out->angle[i] = w->motor[i].theta;
        out->measured[i] = (double)num_to_float(w->out.speed[i]);
        out->drive[i] = w->out.faults != 0u ? 0.0 : (double)num_to_float(w->out.drive[i]);
    }
    out->faults = w->out.faults;
    out->periods = w->periods;
    kin_wheels_t speed;
    uint8_t faults;
    uint32_t age_us;
    out->age_us = hal_sil_wheels_measurement(w, &speed, &faults, &age_us) ? age_us : 0u;
    return 0;
}

bool hal_sil_wheels_measurement(const void *mem, kin_wheels_t *speed, uint8_t *faults,
                                uint32_t *age_us)
{
    const wheels_t *w = mem;
    if (w->periods == 0u) {
        return false;
    }
    *speed = (kin_wheels_t){ w->out.speed[0], w->out.speed[1] };
    *faults = w->out.faults;
    /* The last period ran at next_us − period_us, at or before t_us. */
    const uint64_t since = w->t_us - (w->next_us - w->period_us);
    *age_us = whl_age_us(&w->loop) + (uint32_t)since;
    return true;
}

int mstc_sil_wheels_hold(void *mem, uint32_t wheel, uint32_t held)
{
    if (mem == NULL || wheel > 1u) {
        return -EINVAL;
    }
    dcm_hold(&((wheels_t *)mem)->motor[wheel], held != 0u);
    return 0;
}

int mstc_sil_wheels_kill_encoder(void *mem, uint32_t wheel)
{
    if (mem == NULL || wheel > 1u) {
        return -EINVAL;
    }
    wheels_t *w = mem;
    dcm_kill_encoder(&w->motor[wheel], &w->mp);
    return 0;
}

int mstc_sil_wheels_clear_faults(void *mem)
{
    if (mem == NULL) {
        return -EINVAL;
    }
    wheels_t *w = mem;
    whl_clear_faults(&w->loop);
    w->out.faults = 0u;
    return 0;
}

static const mstc_sil_layout_t layout[] = {
    MSTC_SIL_LAYOUT_STRUCT(mstc_sil_motor_t),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, r_ohm),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, kt),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, ke),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, j),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, b),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, tau_c),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, v_supply),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, counts_per_rev),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, hold_k),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_motor_t, hold_c),

    MSTC_SIL_LAYOUT_STRUCT(mstc_sil_wheel_params_t),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, kp),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, ki),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, free_speed),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, motor_tau),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, counts),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, rate),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, window),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, stall_time),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheel_params_t, accel),

    MSTC_SIL_LAYOUT_STRUCT(mstc_sil_wheels_input_t),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_input_t, setpoint),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_input_t, load),

    MSTC_SIL_LAYOUT_STRUCT(mstc_sil_wheels_output_t),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_output_t, speed),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_output_t, angle),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_output_t, measured),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_output_t, drive),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_output_t, faults),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_output_t, periods),
    MSTC_SIL_LAYOUT_FIELD(mstc_sil_wheels_output_t, age_us),
};

const mstc_sil_layout_t *mstc_sil_wheels_layout(size_t *n)
{
    if (n != NULL) {
        *n = sizeof layout / sizeof layout[0];
    }
    return layout;
}
