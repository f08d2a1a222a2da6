/* SPDX-License-Identifier: MIT */
/*
 * wheel_study: the measurements behind the wheel loop's design
 * (docs/wheel.md), in the numeric mode it is built in (make wheel-figures).
 *
 *   wheel_study estimator      the speed estimate's quantisation noise and
 *                              lag, window against tracking loop (a table)
 *   wheel_study response DIR   the closed loop against the motor model in
 *                              the acceptance's situations, and a small step
 *                              (10 -> 12 rad/s): DIR/<name>.csv (t, ramped
 *                              setpoint, true speed, estimate, drive)
 *
 * The window is the firmware's own (whl_step()'s speed); the tracking loop
 * is ODrive's encoder PLL (Firmware/MotorControl/encoder.cpp: predict the
 * position, correct it and the speed by the count error with gains 2·bw and
 * bw², snap to zero below half a step), in double: its best case.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ctrl/ctl.h"
#include "dcm.h"
#include "wheel/whl.h"

#define TWO_PI 6.28318530717958647692
#define RATE   1000.0
#define DT     (1.0 / RATE)
#define COUNTS 1920.0

/* The wheel loop's defaults: the limits table's (ctl_params.toml). */
static void whl_params_defaults(whl_params_t *p)
{
    ctl_params_t c;
    ctl_params_default(&c);
    *p = c.wheel;
}

/* The setpoint ramps (wheel_accel) of the runs: none of the loop's own
 * (wheel_accel's largest, wheels that follow at once), and docs/wheel.md's
 * for this motor. */
#define NO_RAMP    10000.0f
#define MOTOR_RAMP 125.0f

/* A shaft turning θ(t) = θ0 + ω0·t + α·t²/2, as the encoder counts it. */
static int32_t count_at(double theta0, double w0, double alpha, double t)
{
    return (int32_t)floor((theta0 + w0 * t + 0.5 * alpha * t * t) * COUNTS / TWO_PI);
}

/* The firmware's window estimate over a prescribed motion: the rms and the
 * largest error at constant speed @p w0 over many phases, and the lag on a
 * ramp of @p alpha. */
static void window_figures(double window_s, double w0, double alpha, double *rms, double *max,
                           double *lag)
{
    whl_params_t p;
    whl_params_defaults(&p);
    p.window = num_from_float((float)window_s);
    double sq = 0.0;
    double worst = 0.0;
    long n = 0;
    for (int ph = 0; ph < 64; ph++) {
        whl_t w;
        whl_init(&w, &p, num_from_float(NO_RAMP));
        const double theta0 = TWO_PI / COUNTS * ph / 64.0;
        for (int k = 0; k < 2000; k++) {
            const whl_input_t in = { { NUM_ZERO, NUM_ZERO },
                                     { count_at(theta0, w0, 0.0, k * DT), 0 } };
            whl_output_t out;
            whl_step(&w, &in, &out);
            w.faults = 0u; /* only the estimate is wanted here */
            if (k >= 100) {
                const double e = (double)num_to_float(out.speed[0]) - w0;
                sq += e * e;
                worst = fabs(e) > worst ? fabs(e) : worst;
                n++;
            }
        }
    }
    *rms = sqrt(sq / (double)n);
    *max = worst;
    whl_t w;
    whl_init(&w, &p, num_from_float(NO_RAMP));
    double lag_sum = 0.0;
    long m = 0;
    for (int k = 0; k < 400; k++) {
        const double t = k * DT;
        const whl_input_t in = { { NUM_ZERO, NUM_ZERO }, { count_at(0.0, 0.0, alpha, t), 0 } };
        whl_output_t out;
        whl_step(&w, &in, &out);
        w.faults = 0u;
        if (k >= 200) {
            lag_sum += (alpha * t - (double)num_to_float(out.speed[0])) / alpha;
            m++;
        }
    }
    *lag = lag_sum / (double)m;
}

/* ODrive's PLL (encoder.cpp), in counts. */
typedef struct {
    double pos, vel, kp, ki;
    int32_t count;
} pll_t;

static void pll_init(pll_t *s, double bw, double vel_counts, int32_t count)
{
    *s = (pll_t){ .pos = (double)count + 0.5, .vel = vel_counts, .kp = 2.0 * bw };
    s->ki = 0.25 * s->kp * s->kp;
    s->count = count;
}

static double pll_step(pll_t *s, int32_t count)
{
    s->pos += DT * s->vel;
    const double delta = (double)count - floor(s->pos);
    s->pos += DT * s->kp * delta;
    s->vel += DT * s->ki * delta;
    if (fabs(s->vel) < 0.5 * DT * s->ki) {
        s->vel = 0.0;
    }
    return s->vel * TWO_PI / COUNTS;
}

static void pll_figures(double bw, double w0, double alpha, double *rms, double *max, double *lag)
{
    double sq = 0.0;
    double worst = 0.0;
    long n = 0;
    for (int ph = 0; ph < 64; ph++) {
        const double theta0 = TWO_PI / COUNTS * ph / 64.0;
        pll_t s;
        pll_init(&s, bw, w0 * COUNTS / TWO_PI, count_at(theta0, w0, 0.0, 0.0));
        for (int k = 1; k < 2000; k++) {
            const double v = pll_step(&s, count_at(theta0, w0, 0.0, k * DT));
            if (k >= 500) {
                const double e = v - w0;
                sq += e * e;
                worst = fabs(e) > worst ? fabs(e) : worst;
                n++;
            }
        }
    }
    *rms = sqrt(sq / (double)n);
    *max = worst;
    pll_t s;
    pll_init(&s, bw, 0.0, 0);
    double lag_sum = 0.0;
    long m = 0;
    for (int k = 1; k < 400; k++) {
        const double t = k * DT;
        const double v = pll_step(&s, count_at(0.0, 0.0, alpha, t));
        if (k >= 200) {
            lag_sum += (alpha * t - v) / alpha;
            m++;
        }
    }
    *lag = lag_sum / (double)m;
}

static int estimator(void)
{
    const double w0 = 10.0;
    const double alpha = 250.0;
    printf("# Speed estimate at 1,920 counts/rev, 1 kHz (%s): noise at a constant %.0f rad/s "
           "(64 phases of the count, 1.9 s each), lag on a %.0f rad/s² ramp\n",
           NUM_MODE_NAME, w0, alpha);
    printf("estimator | setting | rms noise [rad/s] | largest error [rad/s] | lag [ms]\n");
    const double windows[] = { 0.002, 0.005, 0.010, 0.020 };
    for (size_t i = 0; i < sizeof windows / sizeof windows[0]; i++) {
        double rms, max, lag;
        window_figures(windows[i], w0, alpha, &rms, &max, &lag);
        printf("window | %.0f ms | %.3f | %.3f | %.2f\n", windows[i] * 1e3, rms, max, lag * 1e3);
    }
    const double bws[] = { 100.0, 200.0, 300.0, 400.0 };
    for (size_t i = 0; i < sizeof bws / sizeof bws[0]; i++) {
        double rms, max, lag;
        pll_figures(bws[i], w0, alpha, &rms, &max, &lag);
        printf("PLL | bandwidth %.0f rad/s | %.3f | %.3f | %.2f\n", bws[i], rms, max, lag * 1e3);
    }
    return 0;
}

/* ------------------------------------------------------- closed-loop runs */

typedef enum { RUN_STEP, RUN_SMALL, RUN_RAMP, RUN_STALL, RUN_LOAD } run_kind_t;

static int response(const char *dir)
{
    static const struct {
        const char *name;
        run_kind_t kind;
    } runs[] = {
        { "step", RUN_STEP },   { "small", RUN_SMALL }, { "ramp", RUN_RAMP },
        { "stall", RUN_STALL }, { "load", RUN_LOAD },
    };
    dcm_params_t mp;
    dcm_params_default(&mp);
    const double tau_stall = mp.kt * mp.v_supply / mp.r_ohm - mp.tau_c;
    /* The hold: a load full drive turns the wheel against at 2 rad/s only
     * (dcm.h's ω∞ with u = 1), the drive saturated: the windup's situation.
     * A wheel held rigidly gives no count and is stopped within 0.1 s
     * (docs/wheel.md, "Faults"). */
    const double hold_load = tau_stall - 2.0 * (mp.b + mp.kt * mp.ke / mp.r_ohm);
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; r++) {
        char path[512];
        snprintf(path, sizeof path, "%s/%s.csv", dir, runs[r].name);
        FILE *f = fopen(path, "w");
        if (f == NULL) {
            fprintf(stderr, "wheel_study: cannot write %s\n", path);
            return 1;
        }
        fprintf(f, "t,setpoint,speed,estimate,drive\n");
        whl_params_t p;
        whl_params_defaults(&p);
        const bool ramped = runs[r].kind == RUN_RAMP || runs[r].kind == RUN_STALL;
        const float ramp = ramped ? MOTOR_RAMP : NO_RAMP;
        if (runs[r].kind == RUN_STALL) {
            p.stall_time = num_from_float(5.0f); /* the windup, not the fault */
        }
        whl_t w;
        whl_init(&w, &p, num_from_float(ramp));
        dcm_t m;
        dcm_init(&m);
        for (int k = 0; k < 1500; k++) {
            const double t = k * DT;
            double sp = 20.0;
            if (runs[r].kind == RUN_SMALL) {
                sp = t < 0.5 ? 10.0 : 12.0; /* a step the drive need not saturate for */
            }
            if (runs[r].kind == RUN_RAMP) {
                sp = t < 0.1 ? 0.0 : (t < 0.5 ? 20.0 : (t < 1.0 ? -20.0 : 0.0));
            }
            if (runs[r].kind == RUN_STALL) {
                m.load = t >= 0.3 && t < 1.3 ? hold_load : 0.0;
            }
            if (runs[r].kind == RUN_LOAD) {
                m.load = t >= 0.5 ? 0.3 * tau_stall : 0.0;
            }
            const whl_input_t in = { { num_from_float((float)sp), NUM_ZERO },
                                     { dcm_count(&m, &mp), 0 } };
            whl_output_t out;
            whl_step(&w, &in, &out);
            fprintf(f, "%.3f,%.4f,%.4f,%.4f,%.4f\n", t, (double)num_to_float(w.w[0].setpoint),
                    m.omega, (double)num_to_float(out.speed[0]),
                    (double)num_to_float(out.drive[0]));
            dcm_step(&m, &mp, (double)num_to_float(out.drive[0]), DT);
        }
        fclose(f);
    }
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "estimator") == 0) {
        return estimator();
    }
    if (argc == 3 && strcmp(argv[1], "response") == 0) {
        return response(argv[2]);
    }
    fprintf(stderr, "usage: wheel_study estimator | wheel_study response DIR\n");
    return 2;
}
