/* SPDX-License-Identifier: MIT */
/**
 * @file hal_can.h
 * @brief CAN service of the HAL: classic CAN, 11-bit identifiers.
 *
 * One implementation per port (hal/linux: SocketCAN; hal/sil: in-process
 * queues; hal/fake: recording fakes; boards: bxCAN). Plain types only.
 */
#ifndef HAL_CAN_H
#define HAL_CAN_H

#include <stdbool.h>
#include <stdint.h>

/** @brief Largest classic CAN payload. */
#define HAL_CAN_MAX_DLC    8u
/** @brief Largest 11-bit identifier. */
#define HAL_CAN_MAX_STD_ID 0x7FFu

/** @brief A classic CAN data frame. */
typedef struct {
    uint32_t id;                   /**< 11-bit identifier */
    uint8_t dlc;                   /**< payload length, 0..8 */
    uint8_t data[HAL_CAN_MAX_DLC]; /**< payload; bytes past dlc are 0 */
} hal_can_frame_t;

/** @brief An acceptance filter: a frame passes when (id & mask) == (filter_id & mask). */
typedef struct {
    uint32_t id;
    uint32_t mask;
} hal_can_filter_t;

/**
 * @brief Open the CAN interface.
 * @param iface port-specific name (e.g. "vcan0" on Linux; ignored on boards).
 * @retval 0 ready.
 * @retval -ENODEV no such interface; other negative errno on failure.
 * Task context; may block briefly.
 */
int hal_can_open(const char *iface);

/**
 * @brief Accept only frames matching one of @p filters (at most 16).
 * @param filters array of filters; NULL with @p n 0 accepts everything.
 * @retval 0 set. @retval -EINVAL too many filters.
 * Task context.
 */
int hal_can_set_filters(const hal_can_filter_t *filters, unsigned n);

/**
 * @brief Queue a frame for transmission.
 * @retval 0 queued. @retval -EAGAIN no room (the frame is not sent).
 * @retval -EINVAL bad id or dlc. Task context; does not block.
 */
int hal_can_send(const hal_can_frame_t *frame);

/**
 * @brief Take the next received frame.
 * @param[out] frame the frame.
 * @param timeout_us 0 to poll; otherwise wait at most this long.
 * @retval 0 a frame was taken. @retval -EAGAIN none arrived in time.
 * @retval -EIO the interface failed (bus-off, link down).
 * Task context; blocks up to @p timeout_us.
 */
int hal_can_recv(hal_can_frame_t *frame, uint32_t timeout_us);

/** @brief Close the interface. Task context. */
void hal_can_close(void);

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
 * @brief Read the controller's state and counters, so that bus-off (and its
 *        automatic recovery) is visible to the application (after Zephyr's
 *        can_get_state()).
 * @param[out] st filled on success.
 * @retval 0 filled. @retval -ENOTSUP this port keeps no such state.
 * Task or ISR context; never blocks.
 */
int hal_can_status(hal_can_status_t *st);

#endif /* HAL_CAN_H */
