/* SPDX-License-Identifier: MIT */
/* HAL CAN on Linux SocketCAN (raw sockets). The only file of the project that
 * includes <linux/can.h>: everything else sees hal_can.h's plain types. */
/* ppoll(): a wait to the microsecond. poll()'s whole milliseconds would make
 * every control tick of the real-time loop up to 1 ms late. */
#define _GNU_SOURCE
#include <errno.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "hal/hal_can.h"
#include "hal_can_linux.h"

static int sock = -1;

int hal_can_open(const char *iface)
{
    if (iface == NULL || strlen(iface) >= IFNAMSIZ) {
        return -EINVAL;
    }
    const int s = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (s < 0) {
        return -errno; /* EAFNOSUPPORT: the kernel has no CAN */
    }
    const unsigned idx = if_nametoindex(iface);
    if (idx == 0) {
        close(s);
        return -ENODEV;
    }
    struct sockaddr_can addr = { .can_family = AF_CAN, .can_ifindex = (int)idx };
    if (bind(s, (struct sockaddr *)&addr, sizeof addr) != 0) {
        const int e = errno;
        close(s);
        return -e;
    }
    sock = s;
    return 0;
}

int hal_can_set_filters(const hal_can_filter_t *filters, unsigned n)
{
    struct can_filter f[16];
    if (n > 16u || (n > 0 && filters == NULL)) {
        return -EINVAL;
    }
    for (unsigned i = 0; i < n; i++) {
        /* Standard frames only: the EFF flag is part of the compare. */
        f[i].can_id = filters[i].id & CAN_SFF_MASK;
        f[i].can_mask = (filters[i].mask & CAN_SFF_MASK) | CAN_EFF_FLAG | CAN_RTR_FLAG;
    }
    if (setsockopt(sock, SOL_CAN_RAW, CAN_RAW_FILTER, n > 0 ? f : NULL,
                   (socklen_t)(n * sizeof f[0])) != 0) {
        return -errno;
    }
    return 0;
}

int hal_can_send(const hal_can_frame_t *frame)
{
    if (frame->id > HAL_CAN_MAX_STD_ID || frame->dlc > HAL_CAN_MAX_DLC) {
        return -EINVAL;
    }
    struct can_frame cf;
    memset(&cf, 0, sizeof cf);
    cf.can_id = frame->id;
    cf.can_dlc = frame->dlc;
    memcpy(cf.data, frame->data, frame->dlc);
    const ssize_t n = write(sock, &cf, sizeof cf);
    if (n != (ssize_t)sizeof cf) {
        return n < 0 && (errno == ENOBUFS || errno == EAGAIN) ? -EAGAIN : -EIO;
    }
    return 0;
}

int hal_can_recv(hal_can_frame_t *frame, uint32_t timeout_us)
{
    struct pollfd p = { .fd = sock, .events = POLLIN };
    const struct timespec wait = { .tv_sec = (time_t)(timeout_us / 1000000u),
                                   .tv_nsec = (long)(timeout_us % 1000000u) * 1000L };
    const int r = ppoll(&p, 1, &wait, NULL);
    if (r == 0) {
        return -EAGAIN;
    }
    if (r < 0) {
        return errno == EINTR ? -EAGAIN : -EIO;
    }
    struct can_frame cf;
    const ssize_t n = read(sock, &cf, sizeof cf);
    if (n != (ssize_t)sizeof cf) {
        return -EIO;
    }
    if ((cf.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) != 0) {
        return -EAGAIN; /* not a standard data frame: not ours */
    }
    frame->id = cf.can_id & CAN_SFF_MASK;
    /* A classic frame's DLC can claim up to 15; only 8 bytes exist. */
    frame->dlc = cf.can_dlc > HAL_CAN_MAX_DLC ? HAL_CAN_MAX_DLC : cf.can_dlc;
    memset(frame->data, 0, sizeof frame->data);
    memcpy(frame->data, cf.data, frame->dlc);
    return 0;
}

/* SocketCAN reports controller state as error frames, which a raw socket
 * receives only with CAN_RAW_ERR_FILTER set; vcan has no controller at all.
 * Not kept here yet. */
int hal_can_status(hal_can_status_t *st)
{
    (void)st;
    return -ENOTSUP;
}

int hal_can_linux_fd(void) { return sock; }

void hal_can_close(void)
{
    if (sock >= 0) {
        close(sock);
        sock = -1;
    }
}
