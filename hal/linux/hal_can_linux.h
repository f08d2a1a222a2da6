/* SPDX-License-Identifier: MIT */
/**
 * @file hal_can_linux.h
 * @brief What the Linux port offers beyond hal_can.h, for Linux programs that
 *        wait on the bus together with other files (tools/vm/can-bridge.c).
 *        Firmware never includes it.
 */
#ifndef HAL_CAN_LINUX_H
#define HAL_CAN_LINUX_H

/**
 * @brief The file descriptor of the socket hal_can_open() opened, for poll():
 *        readable when hal_can_recv() has a frame. Task context, never blocks.
 * @return the descriptor, or -1 before hal_can_open() and after hal_can_close().
 */
int hal_can_linux_fd(void);

#endif /* HAL_CAN_LINUX_H */
