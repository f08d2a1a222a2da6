/* SPDX-License-Identifier: MIT */
/* A brushed DC gearmotor with an encoder (dcm.h). */
#include "dcm.h"

#include <math.h>

#define TWO_PI 6.28318530717958647692

/* Datasheet of the Pololu 37D 12 V 30:1 gearmotor (items 4742/4752): no load
 * 330 rpm at 0.2 A, stall (extrapolated) 140 kg·mm at 5.5 A, 12 V; 64 CPR on
 * the motor shaft. docs/wheel.md, "The motor model", derives the rest. */
#define DS_VOLTS         12.0
#define DS_NO_LOAD_RPM   330.0
#define DS_NO_LOAD_AMPS  0.2
#define DS_STALL_KG_MM   140.0
#define DS_STALL_AMPS    5.5
#define DS_GEAR_RATIO    30.0
#define DS_MOTOR_CPR     64.0
/* Not in the datasheet (docs/wheel.md says why these values). */
#define COULOMB_SHARE    0.5                  /* of the no-load friction torque, at no-load speed */
#define ROTOR_INERTIA    1.0e-6               /* at the motor shaft [kg·m²] */
#define ROBOT_KG         1.0                  /* robot mass per wheel [kg] */
#define WHEEL_RADIUS_M   0.05                 /* [m] */
#define HOLD_DEFLECT_RAD 0.017453292519943295 /* 1° at stall torque */
#define HOLD_ZETA        0.7

void dcm_params_default(dcm_params_t *p)
{
    const double w_nl = DS_NO_LOAD_RPM * TWO_PI / 60.0;   /* 34.56 rad/s */
    const double tau_stall = DS_STALL_KG_MM * 9.80665e-3; /* 1.373 N·m */
    const double r = DS_VOLTS / DS_STALL_AMPS;            /* at stall ω = 0: V = R·I */
    const double ke = (DS_VOLTS - r * DS_NO_LOAD_AMPS) / w_nl;
    /* Stall: Kt·I_stall − τc = τ_stall, with τc = share·Kt·I_no_load. */
    const double kt = tau_stall / (DS_STALL_AMPS - COULOMB_SHARE * DS_NO_LOAD_AMPS);
    const double friction = kt * DS_NO_LOAD_AMPS; /* at no-load speed */
    const double j =
        ROBOT_KG * WHEEL_RADIUS_M * WHEEL_RADIUS_M + ROTOR_INERTIA * DS_GEAR_RATIO * DS_GEAR_RATIO;
    const double hold_k = tau_stall / HOLD_DEFLECT_RAD;
    *p = (dcm_params_t){
        .r_ohm = r,
        .kt = kt,
        .ke = ke,
        .j = j,
        .b = (1.0 - COULOMB_SHARE) * friction / w_nl,
        .tau_c = COULOMB_SHARE * friction,
        .v_supply = DS_VOLTS,
        .counts_per_rev = DS_MOTOR_CPR * DS_GEAR_RATIO,
        .hold_k = hold_k,
        .hold_c = 2.0 * HOLD_ZETA * sqrt(hold_k * j),
    };
}

void dcm_init(dcm_t *m) { *m = (dcm_t){ 0 }; }

void dcm_hold(dcm_t *m, bool held)
{
    if (held && !m->held) {
        m->hold_theta = m->theta;
    }
    m->held = held;
}

static int32_t raw_count(const dcm_t *m, const dcm_params_t *p)
{
    return (int32_t)floor(m->theta * p->counts_per_rev / TWO_PI);
}

void dcm_kill_encoder(dcm_t *m, const dcm_params_t *p)
{
    if (!m->encoder_dead) {
        m->dead_count = raw_count(m, p);
        m->encoder_dead = true;
    }
}

int32_t dcm_count(const dcm_t *m, const dcm_params_t *p)
{
    return m->encoder_dead ? m->dead_count : raw_count(m, p);
}

/* Electrical damping plus viscous friction: the B of J·ω' = A − B·ω. */
static double damping(const dcm_params_t *p) { return p->b + p->kt * p->ke / p->r_ohm; }

double dcm_tau(const dcm_params_t *p) { return p->j / damping(p); }

/* Torque of the drive less the load: the A of J·ω' = A − B·ω − τc·s. */
static double drive_torque(const dcm_params_t *p, double drive, double load)
{
    return p->kt * drive * p->v_supply / p->r_ohm - load;
}

double dcm_speed_steady(const dcm_params_t *p, double drive, double load)
{
    return (drive_torque(p, drive, load) - p->tau_c) / damping(p);
}

double dcm_drive_steady(const dcm_params_t *p, double omega, double load)
{
    return p->r_ohm / (p->kt * p->v_supply) * (p->b * omega + p->tau_c + load) +
           p->ke * omega / p->v_supply;
}

static double sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

/* Free shaft over @p dt: exact solution of J·ω' = a − B·ω − τc·sgn(ω),
 * segment by segment, stopping at ω = 0 where friction would reverse the
 * motion (dcm.h). */
static void step_free(dcm_t *m, const dcm_params_t *p, double a, double bb, double dt)
{
    const double tau = p->j / bb;
    double left = dt;
    for (int seg = 0; seg < 4 && left > 0.0; seg++) {
        double s = sign(m->omega);
        if (s == 0.0) {
            if (fabs(a) <= p->tau_c) {
                return; /* static friction holds it */
            }
            s = sign(a);
        }
        const double w_inf = (a - p->tau_c * s) / bb;
        /* Does ω reach 0 before the end (ω∞ on the other side of 0)? */
        double h = left;
        bool stops = false;
        if (w_inf * s < 0.0 && m->omega != 0.0) {
            const double t0 = tau * log((m->omega - w_inf) / -w_inf);
            if (t0 < left) {
                h = t0;
                stops = true;
            }
        }
        const double decay = exp(-h / tau);
        m->theta += w_inf * h + (m->omega - w_inf) * tau * (1.0 - decay);
        m->omega = stops ? 0.0 : w_inf + (m->omega - w_inf) * decay;
        left -= h;
    }
}

/* Held: the shaft on a damped spring to hold_theta; integrated in small
 * steps (semi-implicit Euler, 10 µs, far below the spring's period of about
 * 40 ms), Coulomb friction as a smoothed sign below 1 mrad/s. */
static void step_held(dcm_t *m, const dcm_params_t *p, double a, double bb, double dt)
{
    const int n = (int)ceil(dt / 1e-5);
    if (n < 1) {
        return;
    }
    const double h = dt / n;
    for (int k = 0; k < n; k++) {
        const double s = fabs(m->omega) > 1e-3 ? sign(m->omega) : m->omega / 1e-3;
        const double spring = p->hold_k * (m->theta - m->hold_theta) + p->hold_c * m->omega;
        m->omega += h * (a - bb * m->omega - p->tau_c * s - spring) / p->j;
        m->theta += h * m->omega;
    }
}

void dcm_step(dcm_t *m, const dcm_params_t *p, double drive, double dt)
{
    const double u = drive > 1.0 ? 1.0 : (drive < -1.0 ? -1.0 : drive);
    const double a = drive_torque(p, u, m->load);
    if (m->held) {
        step_held(m, p, a, damping(p), dt);
    } else {
        step_free(m, p, a, damping(p), dt);
    }
    m->current = (u * p->v_supply - p->ke * m->omega) / p->r_ohm;
}

/* The smallest damping a coasting shaft is given: without viscous friction
 * the solution would divide by zero; 1e-9 N·m·s/rad changes nothing else. */
#define MIN_DAMPING 1e-9

void dcm_coast(dcm_t *m, const dcm_params_t *p, double dt)
{
    if (m->held) {
        step_held(m, p, -m->load, p->b, dt); /* no current, no electrical torque */
    } else {
        step_free(m, p, -m->load, p->b > MIN_DAMPING ? p->b : MIN_DAMPING, dt);
    }
    m->current = 0.0;
}
