/* SPDX-License-Identifier: MIT */
/* HAL time and system services on Linux. */
#include <errno.h>
#include <sys/random.h>
#include <time.h>

#include "hal/hal_sys.h"
#include "hal/hal_time.h"

static uint64_t monotonic_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* CLOCK_MONOTONIC at the first reading: hal_time.h's clock starts with the
 * process, as a board's starts at reset, so that the step and event times a
 * real-time mstc-fw sends count from its start, not from the machine's boot. */
static uint64_t start_us;
static int started;

uint64_t hal_time_now_us(void)
{
    const uint64_t t = monotonic_us();
    if (!started) {
        start_us = t;
        started = 1;
    }
    return t - start_us;
}

void hal_time_sleep_until_us(uint64_t t_us)
{
    (void)hal_time_now_us(); /* fixes the start if this is the first reading */
    const uint64_t abs_us = start_us + t_us;
    const struct timespec ts = { .tv_sec = (time_t)(abs_us / 1000000u),
                                 .tv_nsec = (long)(abs_us % 1000000u) * 1000L };
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

/* The kernel's random source: unpredictable, every start and every call. */
int hal_sys_boot_nonce(uint32_t *nonce)
{
    return getrandom(nonce, sizeof *nonce, 0) == (ssize_t)sizeof *nonce ? 0 : -EIO;
}
