/* SPDX-License-Identifier: MIT */
/**
 * @file dcm.h
 * @brief A brushed DC gearmotor driving one wheel, with its quadrature
 *        encoder: the plant the wheel loop (firmware/wheel) is tested
 *        against, in the Unity tests and in the simulation (libmstc_sil.so,
 *        hal/sil/mstc_sil_wheel.c). Not firmware: double precision, host only.
 *
 * Per wheel, everything referred to the output shaft (the wheel):
 *
 *     i = (u·V − Ke·ω) / R                                  armature, L neglected
 *     J·dω/dt = Kt·i − b·ω − τc·sgn(ω) − τ_load             shaft
 *
 * u ∈ [−1, 1] is the drive (the PWM duty with its sign, hal_motor.h), V the
 * supply, R the armature resistance, Ke and Kt the back-EMF and torque
 * constants at the output (Kt < Ke: the gearbox's loss), J the rotor's
 * inertia reflected through the gearbox plus the robot's share, b and τc
 * viscous and Coulomb friction, τ_load an external torque opposing forward
 * motion. The armature inductance is left out: its time constant (L/R, about
 * a millisecond for motors of this size) is below the 1 ms the drive is held
 * for, so the model is first order and its step response is exactly
 *
 *     ω(t) = ω∞ + (ω0 − ω∞)·exp(−t/τm),  τm = J / (b + Kt·Ke/R),
 *     ω∞ = (Kt·u·V/R − τc·sgn(ω) − τ_load) / (b + Kt·Ke/R),
 *
 * which dcm_step() integrates exactly (the drive and load held over each
 * call), stopping at ω = 0 when friction would reverse the motion and staying
 * there while |Kt·u·V/R − τ_load| ≤ τc (static friction).
 *
 * The encoder is ideal: dcm_count() is ⌊θ·counts_per_rev / 2π⌋, the ×4
 * quadrature count of a shaft at angle θ. A dead encoder (dcm_t::encoder_dead)
 * keeps the count it had when it died.
 *
 * A held wheel (dcm_t::held) is tied to the angle where it was caught by a
 * damped torsional spring, the compliance of the gearbox and tyre (params
 * hold_k, hold_c): held against the floor or a hand, a wheel under torque
 * gives a few counts, as a real one does.
 *
 * docs/wheel.md derives the defaults (dcm_params_default()) from the
 * datasheet of a Pololu 37D 12 V 30:1 gearmotor.
 */
#ifndef MSTC_DCM_H
#define MSTC_DCM_H

#include <stdbool.h>
#include <stdint.h>

/** @brief Constants of one motor, at the output shaft, SI units. */
typedef struct {
    double r_ohm;          /**< armature resistance R [Ω] */
    double kt;             /**< torque constant Kt [N·m/A] */
    double ke;             /**< back-EMF constant Ke [V·s/rad] */
    double j;              /**< inertia J: rotor reflected plus load [kg·m²] */
    double b;              /**< viscous friction b [N·m·s/rad] */
    double tau_c;          /**< Coulomb friction τc [N·m] */
    double v_supply;       /**< supply V [V]: the voltage at drive 1 */
    double counts_per_rev; /**< encoder counts per output revolution (×4 quadrature) */
    double hold_k;         /**< stiffness of a hold [N·m/rad] */
    double hold_c;         /**< damping of a hold [N·m·s/rad] */
} dcm_params_t;

/** @brief State of one motor. */
typedef struct {
    double omega;      /**< output shaft speed ω [rad/s] */
    double theta;      /**< output shaft angle θ [rad] */
    double current;    /**< armature current over the last step's end [A] */
    double load;       /**< external torque τ_load opposing forward motion [N·m] */
    bool held;         /**< the wheel is held (see the file's doc) */
    double hold_theta; /**< angle where it was caught [rad] */
    bool encoder_dead; /**< the encoder gives no more counts */
    int32_t dead_count;
} dcm_t;

/**
 * @brief The defaults: a Pololu 37D 12 V 30:1 gearmotor with its 64 CPR
 *        encoder (1,920 counts per output revolution), 1 kg of robot per wheel
 *        on a 0.05 m wheel (docs/wheel.md derives each constant).
 */
void dcm_params_default(dcm_params_t *p);

/** @brief At rest, angle 0, no load, not held, encoder working. */
void dcm_init(dcm_t *m);

/** @brief Hold the wheel where it is (true) or let it go (false). */
void dcm_hold(dcm_t *m, bool held);

/** @brief The encoder stops counting (keeps its last count). */
void dcm_kill_encoder(dcm_t *m, const dcm_params_t *p);

/**
 * @brief Advance by @p dt seconds with drive @p drive (clamped to [−1, 1])
 *        and the load in m->load held over the step.
 */
void dcm_step(dcm_t *m, const dcm_params_t *p, double drive, double dt);

/**
 * @brief Advance by @p dt seconds with the windings open (a disabled
 *        driver, hal_motor_stop()): no current, no electrical torque or
 *        braking; the shaft coasts against friction and the load.
 */
void dcm_coast(dcm_t *m, const dcm_params_t *p, double dt);

/** @brief The encoder's count: a signed running total. */
int32_t dcm_count(const dcm_t *m, const dcm_params_t *p);

/** @brief Mechanical time constant τm = J / (b + Kt·Ke/R) [s]. */
double dcm_tau(const dcm_params_t *p);

/**
 * @brief Steady-state speed under constant @p drive and @p load, moving
 *        forward (ω∞ of the file's doc with sgn(ω) = +1) [rad/s]; negative
 *        when the motor cannot turn forward.
 */
double dcm_speed_steady(const dcm_params_t *p, double drive, double load);

/**
 * @brief The drive that holds speed @p omega > 0 against @p load in steady
 *        state: (R/(Kt·V))·(b·ω + τc + τ_load) + Ke·ω/V.
 */
double dcm_drive_steady(const dcm_params_t *p, double omega, double load);

#endif /* MSTC_DCM_H */
