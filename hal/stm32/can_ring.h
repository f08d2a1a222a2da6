/* SPDX-License-Identifier: MIT */
/**
 * @file can_ring.h
 * @brief Lock-free single-producer / single-consumer queue of CAN frames,
 *        between an interrupt handler and the main loop.
 *
 * Board-independent and header-only, so the host tests use it as it is.
 *
 * The producer only writes `head`, the consumer only writes `tail`; both are
 * free-running counters (their difference is the fill level, valid across
 * the 2^32 wrap because CAN_RING_SIZE divides 2^32). C11 atomics order the
 * slot's contents before the index that publishes it (release) and after the
 * index that announces it (acquire): on a Cortex-M3/M4 these are plain loads
 * and stores with a DMB, no lock and no interrupt masking. Each side must be
 * one context only: RX is ISR -> task, TX is task -> ISR.
 *
 * A full queue refuses the new frame (can_ring_push() returns false) and the
 * producer counts it in `dropped`: oldest data is kept, as bxCAN's FIFO does
 * with RFLM set.
 */
#ifndef STM32_CAN_RING_H
#define STM32_CAN_RING_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_can.h"

/** @brief Capacity in frames; a power of two. */
#ifndef CAN_RING_SIZE
#define CAN_RING_SIZE 32u
#endif
_Static_assert((CAN_RING_SIZE & (CAN_RING_SIZE - 1u)) == 0u, "CAN_RING_SIZE: power of two");

/** @brief The queue. Zero-initialised (static storage) is empty. */
typedef struct {
    hal_can_frame_t slot[CAN_RING_SIZE];
    atomic_uint head; /**< frames pushed; written by the producer only */
    atomic_uint tail; /**< frames popped; written by the consumer only */
    uint32_t dropped; /**< frames refused because full; producer only */
} can_ring_t;

/** @brief Empty the queue. Only while neither side runs (before enabling the
 *         interrupt). */
static inline void can_ring_init(can_ring_t *r)
{
    atomic_store_explicit(&r->head, 0u, memory_order_relaxed);
    atomic_store_explicit(&r->tail, 0u, memory_order_relaxed);
    r->dropped = 0u;
}

/** @brief Producer: append @p f. @return false (and counts it) when full. */
static inline bool can_ring_push(can_ring_t *r, const hal_can_frame_t *f)
{
    const unsigned head = atomic_load_explicit(&r->head, memory_order_relaxed);
    const unsigned tail = atomic_load_explicit(&r->tail, memory_order_acquire);
    if (head - tail >= CAN_RING_SIZE) {
        r->dropped++;
        return false;
    }
    r->slot[head & (CAN_RING_SIZE - 1u)] = *f;
    atomic_store_explicit(&r->head, head + 1u, memory_order_release);
    return true;
}

/** @brief Consumer: take the oldest frame into @p f. @return false when empty. */
static inline bool can_ring_pop(can_ring_t *r, hal_can_frame_t *f)
{
    const unsigned tail = atomic_load_explicit(&r->tail, memory_order_relaxed);
    const unsigned head = atomic_load_explicit(&r->head, memory_order_acquire);
    if (head == tail) {
        return false;
    }
    *f = r->slot[tail & (CAN_RING_SIZE - 1u)];
    atomic_store_explicit(&r->tail, tail + 1u, memory_order_release);
    return true;
}

/** @brief Frames queued now. Either side; exact on the consumer's side, a
 *         lower bound of the free room on the producer's. */
static inline unsigned can_ring_count(can_ring_t *r)
{
    const unsigned tail = atomic_load_explicit(&r->tail, memory_order_acquire);
    const unsigned head = atomic_load_explicit(&r->head, memory_order_acquire);
    return head - tail;
}

#endif /* STM32_CAN_RING_H */
