/* SPDX-License-Identifier: MIT */
/**
 * @file mstc_sil_wheel.h
 * @brief C ABI of the firmware's wheel loop (firmware/wheel/whl.h) running
 *        against two DC motor models (sim/dcmotor/dcm.h) in the shared library
 *        (build/host/<numeric>/libmstc_sil.so), for the plant's "dc"
 *        actuator: the simulation drives the robot with the wheels the
 *        firmware's own inner loop turns (docs/wheel.md).
 *
 * The caller owns the memory (mstc_sil_wheels_size() bytes, 16-byte
 * aligned): both motors, their encoders and the wheel loop, which runs at
 * its parameters' rate on the motors' time. mstc_sil_wheels_advance() moves
 * that time on by any number of microseconds: the motors are integrated
 * exactly (dcm.h) between the wheel loop's periods, each period reading the
 * encoders and setting the drives the motors then keep until the next.
 *
 * Plain C types and doubles, whatever the firmware's numeric mode, as
 * mstc_sil.h; mstc_sil_wheels_layout() gives the structs' layout for the
 * bindings' check.
 */
#ifndef MSTC_SIL_WHEEL_H
#define MSTC_SIL_WHEEL_H

#include <stddef.h>
#include <stdint.h>

#include "mstc_sil.h"

/** @brief Constants of each motor (dcm_params_t), SI units, output shaft. */
typedef struct {
    double r_ohm, kt, ke, j, b, tau_c, v_supply, counts_per_rev, hold_k, hold_c;
} mstc_sil_motor_t;

/** @brief The wheel loop's parameters (whl_params_t; ctl_params.toml's
 *         wheel_* rows) and its setpoint ramp, wheel_accel, SI units. */
typedef struct {
    double kp, ki, free_speed, motor_tau, counts, rate, window, stall_time;
    double accel; /**< the setpoint ramp: wheel_accel [rad/s²] */
} mstc_sil_wheel_params_t;

/** @brief What the wheels are asked and what they meet. */
typedef struct {
    double setpoint[2]; /**< wheel speeds wanted [rad/s], left, right: the control step's */
    double load[2];     /**< torque against forward motion [N·m] */
} mstc_sil_wheels_input_t;

/** @brief Where the wheels are after an advance. */
typedef struct {
    double speed[2];    /**< true wheel speeds at the end [rad/s] */
    double angle[2];    /**< wheel angles [rad], running */
    double measured[2]; /**< the wheel loop's estimate of its last period [rad/s] */
    double drive[2];    /**< the drives in force, [−1, 1] */
    uint32_t faults;    /**< WHL_FAULT_* bits (whl.h): the drives are then 0 */
    uint32_t periods;   /**< wheel periods run since init */
    uint32_t age_us;    /**< the estimate's age now [µs]: half its window plus the
                             time since the last period (0 before the first) */
} mstc_sil_wheels_output_t;

/** @brief Bytes the caller must provide. */
size_t mstc_sil_wheels_size(void);

/** @brief The defaults: the limits table's wheel loop and wheel_accel, the
 *         default motor. */
void mstc_sil_wheels_defaults(mstc_sil_wheel_params_t *wp, mstc_sil_motor_t *mp);

/**
 * @brief Both wheels at rest, the loop started.
 * @retval 0 ready. @retval -EINVAL a NULL pointer, a motor constant not
 *         finite and positive (hold_k, hold_c, b and tau_c may be 0), or
 *         wheel parameters the firmware refuses (ctl_params_check() of the
 *         default set with them).
 */
int mstc_sil_wheels_init(void *mem, const mstc_sil_wheel_params_t *wp, const mstc_sil_motor_t *mp);

/**
 * @brief Move on by @p dt_us microseconds with @p in held.
 * @retval 0 done. @retval -EINVAL a NULL pointer.
 */
int mstc_sil_wheels_advance(void *mem, const mstc_sil_wheels_input_t *in, uint32_t dt_us,
                            mstc_sil_wheels_output_t *out);

/** @brief Hold a wheel (0 left, 1 right) where it is, or let it go; kill its
 *         encoder (it keeps its count). For tests of the faults.
 *  @retval 0 done. @retval -EINVAL a NULL pointer or wheel > 1. */
int mstc_sil_wheels_hold(void *mem, uint32_t wheel, uint32_t held);
int mstc_sil_wheels_kill_encoder(void *mem, uint32_t wheel);

/** @brief Forget the loop's faults (a re-arm). @retval 0, or -EINVAL. */
int mstc_sil_wheels_clear_faults(void *mem);

/** @brief The layout of the structs above, as mstc_sil_layout(). */
const mstc_sil_layout_t *mstc_sil_wheels_layout(size_t *n);

#endif /* MSTC_SIL_WHEEL_H */
