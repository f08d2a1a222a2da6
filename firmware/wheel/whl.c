/* SPDX-License-Identifier: MIT */
/* The wheel-speed loop (whl.h; docs/wheel.md). */
#include "wheel/whl.h"

#include "hal/hal_motor.h"

/* Whole periods in @p x periods (x ≥ 0, small), rounded; at set-up only, so
 * through float in both modes. */
static uint32_t periods(num_t x) { return (uint32_t)(num_to_float(x) + 0.5f); }

uint32_t whl_period_us(const whl_params_t *p)
{
    return (uint32_t)(1.0e6f / num_to_float(p->rate) + 0.5f);
}

uint32_t whl_age_us(const whl_t *w) { return (whl_period_us(&w->p) * w->window + 1u) / 2u; }

void whl_set_params(whl_t *w, const whl_params_t *p, num_t accel)
{
    w->p = *p;
    w->accel = accel;
    uint32_t win = periods(num_mul(p->window, p->rate));
    win = win < 1u ? 1u : (win > WHL_MAX_WINDOW ? WHL_MAX_WINDOW : win);
    if (win != w->window) {
        /* The setpoints' sum over the new window, from the ring. */
        for (unsigned k = 0; k < WHL_N; k++) {
            whl_wheel_t *s = &w->w[k];
            s->sp_sum = NUM_ZERO;
            for (unsigned i = 0; i < win; i++) {
                s->sp_sum =
                    num_add(s->sp_sum, s->sp_hist[(w->head + WHL_MAX_WINDOW - i) % WHL_MAX_WINDOW]);
            }
        }
    }
    w->window = (uint8_t)win;
    w->inv_window = num_div(NUM_ONE, num_from_int((int32_t)win));
    /* 2π·rate/counts first: counts·W could exceed Q16.16's range. */
    w->speed_per_count =
        num_div(num_div(num_mul(NUM_TWO_PI, p->rate), p->counts), num_from_int((int32_t)win));
    w->inv_free_speed = num_div(NUM_ONE, p->free_speed);
    w->accel_ff = num_div(num_mul(p->rate, p->motor_tau), p->free_speed);
    w->ramp_step = num_div(accel, p->rate);
    w->ki_dt = num_div(p->ki, p->rate);
    const uint32_t stall = periods(num_mul(p->stall_time, p->rate));
    const uint32_t dead = periods(num_mul(WHL_DEAD_TIME, p->rate));
    w->stall_limit = (uint16_t)(stall < 1u ? 1u : (stall > UINT16_MAX ? UINT16_MAX : stall));
    w->dead_limit = (uint16_t)(dead < 1u ? 1u : (dead > UINT16_MAX ? UINT16_MAX : dead));
    /* Counts a period at WHL_MAX_SPEED_FACTOR times the free speed:
     * counts/(2π·rate) first, to stay within Q16.16. */
    const num_t per_period = num_div(num_div(p->counts, NUM_TWO_PI), p->rate);
    w->max_step =
        (int32_t)periods(num_mul(per_period, num_mul(WHL_MAX_SPEED_FACTOR, p->free_speed))) + 1;
}

void whl_init(whl_t *w, const whl_params_t *p, num_t accel)
{
    *w = (whl_t){ 0 };
    whl_set_params(w, p, accel);
}

void whl_clear_faults(whl_t *w)
{
    w->faults = 0u;
    for (unsigned k = 0; k < WHL_N; k++) {
        w->w[k].stall_periods = 0u;
        w->w[k].dead_periods = 0u;
    }
}

void whl_latch_faults(whl_t *w, uint8_t faults) { w->faults |= faults; }

int16_t whl_motor_cmd(num_t u)
{
    const num_t c = num_clamp(u, num_neg(NUM_ONE), NUM_ONE);
#if defined(NUM_FIXED)
    /* c·10000/2^16, rounded half away from zero: |c·10000| < 2^30. */
    const int32_t s = c * (int32_t)HAL_MOTOR_FULL_SCALE;
    return (int16_t)(s >= 0 ? (s + 32768) >> 16 : -((-s + 32768) >> 16));
#else
    const float s = c * (float)HAL_MOTOR_FULL_SCALE;
    return (int16_t)(s >= 0.0f ? s + 0.5f : s - 0.5f);
#endif
}

/* Stall and encoder checks of wheel @p k, on the drive applied over the
 * period that just ended and what the encoder saw of it (@p step counts
 * this period); returns the fault bits found. */
static uint8_t check_faults(whl_t *w, unsigned k, int32_t step)
{
    whl_wheel_t *s = &w->w[k];
    uint8_t found = 0u;
    const num_t u = s->drive;
    /* Faster than the wheel can turn: a broken, miswired or wrongly
     * configured encoder (ODrive's overspeed error). */
    if (step > w->max_step || step < -w->max_step) {
        found |= (uint8_t)(WHL_FAULT_ENCODER_LEFT << k);
    }
    /* Full drive, and no motion the way it drives: held, or an encoder that
     * died or counts the wrong way. */
    const num_t along = u > NUM_ZERO ? s->speed : num_neg(s->speed);
    if (num_abs(u) >= WHL_STALL_DRIVE && along < WHL_STALL_SPEED) {
        s->stall_periods = s->stall_periods < UINT16_MAX ? s->stall_periods + 1u : UINT16_MAX;
        if (s->stall_periods >= w->stall_limit) {
            found |= (uint8_t)(WHL_FAULT_STALL_LEFT << k);
        }
    } else {
        s->stall_periods = 0u;
    }
    /* Periods in a row driven at |u| >= WHL_DEAD_DRIVE in one direction
     * without a count: a healthy wheel so driven turns by many counts in
     * WHL_DEAD_TIME, whenever it is, so none is an encoder that is dead from
     * the start or died while turning (then the loop, seeing the wheel
     * stopped, drives it harder), or a wheel held so rigidly that it does not
     * turn at all (docs/wheel.md). */
    const bool fwd = u > NUM_ZERO;
    if (num_abs(u) < WHL_DEAD_DRIVE || step != 0 || fwd != s->dead_fwd) {
        s->dead_periods = 0u;
        s->dead_fwd = fwd;
    } else {
        s->dead_periods = s->dead_periods < UINT16_MAX ? s->dead_periods + 1u : UINT16_MAX;
        if (s->dead_periods >= w->dead_limit) {
            found |= (uint8_t)(WHL_FAULT_ENCODER_LEFT << k);
        }
    }
    return found;
}

/* The ramped setpoint of wheel @p s into the ring and the window's sum. */
static void push_setpoint(whl_wheel_t *s, unsigned back, unsigned next)
{
    s->sp_sum = num_add(num_sub(s->sp_sum, s->sp_hist[back]), s->setpoint);
    s->sp_hist[next] = s->setpoint;
}

/* The PI with feed-forward of wheel @p s towards its ramped setpoint. */
static num_t drive(const whl_t *w, whl_wheel_t *s, num_t target, int32_t delta, unsigned back,
                   unsigned next)
{
    const num_t step = w->ramp_step;
    const num_t moved = num_clamp(num_sub(target, s->setpoint), num_neg(step), step);
    s->setpoint = num_add(s->setpoint, moved);
    push_setpoint(s, back, next);
    if (s->setpoint == NUM_ZERO && target == NUM_ZERO && delta >= -1 && delta <= 1) {
        s->integ = NUM_ZERO; /* release at standstill (whl.h, 4.) */
        return NUM_ZERO;
    }
    /* The error against the setpoint's mean over the speed window: ω̂ is the
     * wheel's mean speed over it, so on a ramp both lag alike and the
     * feedback sees the wheel's error, not the window's delay. */
    const num_t e = num_sub(num_mul(s->sp_sum, w->inv_window), s->speed);
    /* Feed-forward: the drive that holds the setpoint without load, plus
     * the drive that gives its acceleration (ODrive's vel_ramp: torque =
     * step/dt · inertia; here in drive units, moved·rate·τm/free_speed). */
    const num_t ff = num_add(num_mul(s->setpoint, w->inv_free_speed), num_mul(moved, w->accel_ff));
    const num_t u = num_add(num_add(ff, num_mul(w->p.kp, e)), s->integ);
    /* Conditional integration (ODrive controller.cpp: no integration while
     * the output is limited, then vel_integrator_limit): the integral moves
     * unless the output is saturated and e would push it further. */
    const bool held_high = u >= NUM_ONE && e > NUM_ZERO;
    const bool held_low = u <= num_neg(NUM_ONE) && e < NUM_ZERO;
    if (!held_high && !held_low) {
        s->integ = num_clamp(num_add(s->integ, num_mul(w->ki_dt, e)), num_neg(NUM_ONE), NUM_ONE);
    }
    return num_clamp(u, num_neg(NUM_ONE), NUM_ONE);
}

void whl_step(whl_t *w, const whl_input_t *in, whl_output_t *out)
{
    /* The ring holds the counts of the last WHL_MAX_WINDOW periods,
     * hist[head] the latest. This period's goes to head + 1; the count W
     * periods before it is at head + 1 − W, read before the write (W may be
     * the ring's whole length). */
    const unsigned n = WHL_MAX_WINDOW;
    const unsigned next = (w->head + 1u) % n;
    const unsigned back = (w->head + 1u + n - w->window) % n;
    uint8_t found = 0u;
    int32_t delta[WHL_N];
    for (unsigned k = 0; k < WHL_N; k++) {
        whl_wheel_t *s = &w->w[k];
        const int32_t c = in->count[k];
        if (!w->primed) {
            for (unsigned i = 0; i < n; i++) {
                s->hist[i] = c;
            }
        }
        /* Modulo 2^32: a running count that wraps still gives the right
         * difference. */
        delta[k] = (int32_t)((uint32_t)c - (uint32_t)s->hist[back]);
        const int32_t step = (int32_t)((uint32_t)c - (uint32_t)s->hist[w->head]);
        s->hist[next] = c;
        s->speed = num_mul(num_from_int(delta[k]), w->speed_per_count);
        found |= check_faults(w, k, step);
    }
    w->head = (uint8_t)next;
    w->primed = true;
    w->faults |= found;

    for (unsigned k = 0; k < WHL_N; k++) {
        whl_wheel_t *s = &w->w[k];
        num_t u = NUM_ZERO;
        if (w->faults != 0u) {
            /* Stopped: a later resume (whl_clear_faults) starts its ramp
             * from the wheel's speed, without a jump. */
            s->setpoint = s->speed;
            s->integ = NUM_ZERO;
            push_setpoint(s, back, next);
        } else {
            const num_t target = num_is_finite(in->setpoint[k]) ? in->setpoint[k] : NUM_ZERO;
            u = drive(w, s, target, delta[k], back, next);
        }
        s->drive = u;
        out->drive[k] = u;
        out->cmd[k] = whl_motor_cmd(u);
        out->speed[k] = s->speed;
    }
    out->faults = w->faults;
}
