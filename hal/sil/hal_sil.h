/* SPDX-License-Identifier: MIT */
/**
 * @file hal_sil.h
 * @brief The plant's side of the SIL HAL's CAN queues (used by mstc_sil.c).
 */
#ifndef HAL_SIL_H
#define HAL_SIL_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_can.h"
#include "kin/kin.h"

/** @brief Empty both queues and clear the filters. */
void hal_sil_reset(void);

/**
 * @brief Put a frame on the firmware's receive queue (dropped silently when
 *        the firmware's filters reject it, as a CAN controller would).
 * @retval 0 queued or filtered. @retval -EAGAIN queue full. @retval -EINVAL bad id/dlc.
 */
int hal_sil_to_fw(const hal_can_frame_t *f);

/**
 * @brief Take the next frame the firmware sent.
 * @retval 0 taken. @retval -EAGAIN none.
 */
int hal_sil_from_fw(hal_can_frame_t *f);

/**
 * @brief The measurement of the wheels at @p mem (mstc_sil_wheel.h) as a
 *        board's main loop hands it to the application before a control step
 *        (app_wheels_measured()): the loop's last estimate @p speed, its
 *        fault bits @p faults, and its age @p age_us now (half its speed
 *        window plus the time since its last period).
 * @return false before the loop's first period (nothing measured yet).
 */
bool hal_sil_wheels_measurement(const void *mem, kin_wheels_t *speed, uint8_t *faults,
                                uint32_t *age_us);

#endif /* HAL_SIL_H */
