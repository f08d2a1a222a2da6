/* SPDX-License-Identifier: MIT */
/* HAL time and system services on Linux. */
#include <errno.h>
#include <time.h>

#include "hal/hal_sys.h"
#include "hal/hal_time.h"

uint64_t hal_time_now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

void hal_time_sleep_until_us(uint64_t t_us)
{
    const struct timespec ts = { .tv_sec = (time_t)(t_us / 1000000u),
                                 .tv_nsec = (long)(t_us % 1000000u) * 1000L };
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
    }
}

/* A host process has no hardware watchdog; a supervisor (systemd) would be
 * the equivalent. */
int hal_sys_watchdog_start(uint32_t timeout_ms)
{
    (void)timeout_ms;
    return -ENOTSUP;
}

void hal_sys_watchdog_kick(void) {}

hal_reset_cause_t hal_sys_reset_cause(void) { return HAL_RESET_POWER_ON; }
