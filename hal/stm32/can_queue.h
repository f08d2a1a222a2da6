/* SPDX-License-Identifier: MIT */
/**
 * @file can_queue.h
 * @brief The task side of the STM32 CAN transports (bxcan.c, slcan.c):
 *        hal_can_send() and hal_can_recv() over their lock-free queues
 *        (can_ring.h), whose other side is the transport's interrupt.
 */
#ifndef STM32_CAN_QUEUE_H
#define STM32_CAN_QUEUE_H

#include <stdbool.h>
#include <stdint.h>

#include "can_ring.h"
#include "hal/hal_can.h"

/**
 * @brief hal_can_send(): check @p frame, queue it into @p tx and pend
 *        interrupt @p tx_irq, the queue's only consumer.
 * @param down 0 when the transport can send; else the negative errno to
 *        return (not open, channel closed).
 * @param[in,out] refused counts the frames refused because @p tx was full.
 * @retval 0 queued. @retval -EINVAL bad frame. @retval -EAGAIN queue full.
 * @retval down the transport cannot send.
 */
int can_queue_send(can_ring_t *tx, unsigned tx_irq, const hal_can_frame_t *frame, int down,
                   volatile uint32_t *refused);

/**
 * @brief hal_can_recv(): take the next frame from @p rx, waiting (asleep) at
 *        most @p timeout_us for one.
 * @param failed the transport's failure check (bus-off: -EIO), or NULL.
 */
int can_queue_recv(can_ring_t *rx, hal_can_frame_t *frame, uint32_t timeout_us,
                   bool (*failed)(void));

#endif /* STM32_CAN_QUEUE_H */
