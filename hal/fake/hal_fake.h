/* SPDX-License-Identifier: MIT */
/**
 * @file hal_fake.h
 * @brief Recording fakes of every HAL service, for the Unity tests. Each test's
 *        setUp() calls hal_fake_reset(); tests script received frames and the
 *        clock, and read back what was sent.
 */
#ifndef HAL_FAKE_H
#define HAL_FAKE_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_can.h"
#include "hal/hal_encoder.h"
#include "hal/hal_motor.h"
#include "hal/hal_sys.h"

#define HAL_FAKE_MAX_FRAMES 128u

/** @brief Everything the fakes record, and the values they return. */
typedef struct {
    hal_can_frame_t sent[HAL_FAKE_MAX_FRAMES]; /**< frames passed to hal_can_send() */
    unsigned n_sent;
    int send_rc;                             /**< returned by hal_can_send() (0) */
    hal_can_frame_t rx[HAL_FAKE_MAX_FRAMES]; /**< scripted frames for hal_can_recv() */
    unsigned rx_head;
    unsigned n_rx;
    unsigned n_recv_calls;
    uint32_t last_timeout_us; /**< timeout of the last hal_can_recv() */
    uint64_t now_us;          /**< returned by hal_time_now_us() */
    unsigned kicks;           /**< hal_sys_watchdog_kick() calls */
    hal_reset_cause_t reset_cause;
    hal_can_status_t can_status; /**< returned by hal_can_status() */
    int can_status_rc;           /**< its return value (0) */
    uint32_t boot_nonce;         /**< returned by hal_sys_boot_nonce(), then incremented */
    int boot_nonce_rc;           /**< its return value (0) */
    int32_t encoder[2];          /**< counts hal_encoder_read() returns, left and right
                                      (0 when encoder_rc is -ENODEV) */
    int encoder_rc;              /**< returned by hal_encoder_init() and _read() (0) */
    uint8_t encoder_overran;     /**< returned by hal_encoder_overran() (0) */
    unsigned encoder_reads;      /**< hal_encoder_read() calls */
    int16_t motor[2];            /**< commands of the last hal_motor_set() */
    bool motor_enabled;   /**< driver enabled: by hal_motor_set(), not since hal_motor_stop() */
    unsigned motor_sets;  /**< hal_motor_set() calls */
    unsigned motor_stops; /**< hal_motor_stop() calls */
} hal_fake_t;

extern hal_fake_t hal_fake;

/** @brief Forget everything recorded and scripted. */
void hal_fake_reset(void);

/** @brief Script a frame for a later hal_can_recv(). */
void hal_fake_push_rx(const hal_can_frame_t *f);

#endif /* HAL_FAKE_H */
