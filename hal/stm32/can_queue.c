/* SPDX-License-Identifier: MIT */
/* The task side of the STM32 CAN transports (see can_queue.h). */
#include "can_queue.h"

#include <errno.h>
#include <stddef.h>

#include "cortex_m.h"
#include "hal/hal_time.h"

int can_queue_send(can_ring_t *tx, unsigned tx_irq, const hal_can_frame_t *frame, int down,
                   volatile uint32_t *refused)
{
    if (frame == NULL || frame->id > HAL_CAN_MAX_STD_ID || frame->dlc > HAL_CAN_MAX_DLC) {
        return -EINVAL;
    }
    if (down != 0) {
        return down;
    }
    if (!can_ring_push(tx, frame)) {
        *refused = *refused + 1u;
        return -EAGAIN;
    }
    /* The interrupt is the queue's only consumer: wake it. */
    cm_nvic_set_pending(tx_irq);
    return 0;
}

int can_queue_recv(can_ring_t *rx, hal_can_frame_t *frame, uint32_t timeout_us,
                   bool (*failed)(void))
{
    if (frame == NULL) {
        return -EINVAL;
    }
    const uint64_t end = timeout_us != 0u ? hal_time_now_us() + timeout_us : 0u;
    for (;;) {
        if (can_ring_pop(rx, frame)) {
            return 0;
        }
        if (failed != NULL && failed()) {
            return -EIO;
        }
        if (timeout_us == 0u || hal_time_now_us() >= end) {
            return -EAGAIN;
        }
        /* Mask, check, sleep: a frame arriving in between still wakes us. */
        const uint32_t primask = cm_irq_save();
        if (can_ring_count(rx) == 0u) {
            cm_wfi();
        }
        cm_irq_restore(primask);
    }
}
