/* SPDX-License-Identifier: MIT */
/**
 * @file hal_sil.h
 * @brief The plant's side of the SIL HAL's CAN queues (used by mstc_sil.c).
 */
#ifndef HAL_SIL_H
#define HAL_SIL_H

#include "hal/hal_can.h"

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

#endif /* HAL_SIL_H */
