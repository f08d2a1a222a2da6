/* SPDX-License-Identifier: MIT */
/**
 * @file kin.h
 * @brief Differential-drive kinematics: (v, ω) to wheel angular speeds and
 *        back, and saturation that keeps the curvature.
 */
#ifndef MSTC_KIN_H
#define MSTC_KIN_H

#include <stdbool.h>

#include "num/num.h"

/** @brief Wheel geometry and limit. */
typedef struct {
    num_t wheel_radius;    /**< r [m], > 0 */
    num_t track_width;     /**< L, distance between the wheels [m], > 0 */
    num_t max_wheel_speed; /**< largest |wheel angular speed| [rad/s], > 0 */
} kin_params_t;

/** @brief Wheel angular speeds [rad/s]; positive drives the robot forward. */
typedef struct {
    num_t left;
    num_t right;
} kin_wheels_t;

/**
 * @brief Wheel speeds for a body velocity:
 *        ω_R = (v + ω L/2) / r, ω_L = (v − ω L/2) / r.
 * @param p geometry.
 * @param v linear velocity [m/s].
 * @param w angular velocity [rad/s], positive counter-clockwise.
 * @param[out] out wheel speeds [rad/s], not saturated.
 */
void kin_wheels_from_vw(const kin_params_t *p, num_t v, num_t w, kin_wheels_t *out);

/**
 * @brief Body velocity for wheel speeds: v = r (ω_R + ω_L)/2, ω = r (ω_R − ω_L)/L.
 * @param p geometry.
 * @param wheels wheel speeds [rad/s].
 * @param[out] v linear velocity [m/s].
 * @param[out] w angular velocity [rad/s].
 */
void kin_vw_from_wheels(const kin_params_t *p, const kin_wheels_t *wheels, num_t *v, num_t *w);

/**
 * @brief Limit both wheels to ±max_wheel_speed by one common factor, so the
 *        ratio of the wheel speeds (and so the curvature ω/v) is kept.
 * @param p geometry and limit.
 * @param[in,out] wheels wheel speeds [rad/s].
 * @retval true  the speeds were scaled down.
 * @retval false they were within the limit and are unchanged.
 */
bool kin_saturate(const kin_params_t *p, kin_wheels_t *wheels);

#endif /* MSTC_KIN_H */
