/* SPDX-License-Identifier: MIT */
/**
 * @file pose.h
 * @brief Planar pose, shared by the controllers.
 */
#ifndef MSTC_POSE_H
#define MSTC_POSE_H

#include "num/num.h"

/** @brief Pose of a robot in the world frame. */
typedef struct {
    num_t x;     /**< [m] */
    num_t y;     /**< [m] */
    num_t theta; /**< heading [rad], any value (differences are wrapped) */
} pose_t;

#endif /* MSTC_POSE_H */
