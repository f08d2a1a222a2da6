/**
 * @file hal_can_status.h
 * @brief PROPOSED addition to hal/include/hal/hal_can.h: the CAN controller's
 *        state and error counters, so that bus-off (and its automatic
 *        recovery) is visible to the application.
 *
 * Until the addition lands in hal_can.h, the STM32 ports declare it here.
 * When it lands, delete this file and its #include in hal/stm32/*.c; the
 * declarations below are meant to be copied verbatim (after hal_can_close()).
 *
 * Modelled on Zephyr's can_get_state() (enum can_state, struct
 * can_bus_err_cnt). Host ports would return their counters (SocketCAN:
 * CAN_ERR_BUSOFF error frames) or -ENOTSUP.
 */
#ifndef HAL_CAN_STATUS_H
#define HAL_CAN_STATUS_H

#include <stdint.h>

#include "hal/hal_can.h"

/** @brief Error state of the CAN controller (ISO 11898-1 fault confinement). */
typedef enum {
    HAL_CAN_STATE_STOPPED = 0,       /**< not open, or the controller did not start */
    HAL_CAN_STATE_ERROR_ACTIVE = 1,  /**< both error counters < 96 */
    HAL_CAN_STATE_ERROR_WARNING = 2, /**< a counter >= 96 */
    HAL_CAN_STATE_ERROR_PASSIVE = 3, /**< a counter >= 128 */
    HAL_CAN_STATE_BUS_OFF = 4,       /**< TEC > 255: off the bus; recovering if the port
                                          recovers automatically */
} hal_can_state_t;

/** @brief Counters since hal_can_open(); each wraps at 2^32. */
typedef struct {
    hal_can_state_t state; /**< state now */
    uint8_t tx_err;        /**< transmit error counter (TEC) now, saturated at 255 */
    uint8_t rx_err;        /**< receive error counter (REC) now */
    uint32_t bus_off;      /**< times the controller went bus-off (the event) */
    uint32_t rx_dropped;   /**< received frames lost: receive queue or controller FIFO full */
    uint32_t tx_dropped;   /**< frames hal_can_send() refused with -EAGAIN */
} hal_can_status_t;

/**
 * @brief Read the controller's state and counters.
 * @param[out] st filled on success.
 * @retval 0 filled. @retval -ENOTSUP this port keeps no such state.
 * Task or ISR context; never blocks.
 */
int hal_can_status(hal_can_status_t *st);

#endif /* HAL_CAN_STATUS_H */
