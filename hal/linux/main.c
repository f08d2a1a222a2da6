/* SPDX-License-Identifier: MIT */
/* mstc-fw: the firmware as a Linux process on a SocketCAN interface. */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/app.h"
#include "hal/hal_can.h"
#include "hal/hal_time.h"

static volatile sig_atomic_t stop;
static app_t app; /* static: no heap, as on a board */

static void on_signal(int sig)
{
    (void)sig;
    stop = 1;
}

static void usage(FILE *out)
{
    fprintf(out, "usage: mstc-fw --can IFACE [--realtime] [--period-ms MS]\n"
                 "\n"
                 "Run the mstc firmware on a SocketCAN interface (e.g. vcan0) until\n"
                 "SIGINT or SIGTERM. The protocol is firmware/comm/mstc.dbc.\n"
                 "\n"
                 "  --can IFACE     SocketCAN interface to use (required)\n"
                 "  --realtime      step on this process's own timer every --period-ms,\n"
                 "                  with the latest inputs, as on a board; without it the\n"
                 "                  firmware runs lock-step: one control step per STEP\n"
                 "                  frame, stamped with the frame's time\n"
                 "  --period-ms MS  control period in real-time mode, 1..1000 (default 20)\n"
                 "  --help          this text\n");
}

int main(int argc, char **argv)
{
    const char *iface = NULL;
    int realtime = 0;
    long period_ms = 20;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(argv[i], "--can") == 0 && i + 1 < argc) {
            iface = argv[++i];
        } else if (strcmp(argv[i], "--realtime") == 0) {
            realtime = 1;
        } else if (strcmp(argv[i], "--period-ms") == 0 && i + 1 < argc) {
            char *end = NULL;
            period_ms = strtol(argv[++i], &end, 10);
            if (end == NULL || *end != '\0' || period_ms < 1 || period_ms > 1000) {
                fprintf(stderr, "mstc-fw: --period-ms: expected an integer in 1..1000, got '%s'\n",
                        argv[i]);
                return 2;
            }
        } else {
            fprintf(stderr, "mstc-fw: unknown or incomplete option '%s' (see --help)\n", argv[i]);
            return 2;
        }
    }
    if (iface == NULL) {
        fprintf(stderr, "mstc-fw: --can IFACE is required (see --help)\n");
        return 2;
    }
    const int rc = hal_can_open(iface);
    if (rc != 0) {
        fprintf(stderr, "mstc-fw: cannot open CAN interface '%s': %s%s\n", iface, strerror(-rc),
                rc == -EAFNOSUPPORT ? " (this kernel has no SocketCAN; see docs/hil.md)" : "");
        return 1;
    }
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    app_init(&app, NULL);
    fprintf(stderr, "mstc-fw: %s mode on %s (%s)\n", realtime ? "real-time" : "lock-step", iface,
            NUM_MODE_NAME);

    const uint64_t period_us = (uint64_t)period_ms * 1000u;
    uint64_t next = hal_time_now_us() + period_us;
    while (!stop) {
        if (realtime) {
            const uint64_t now = hal_time_now_us();
            const uint32_t wait = now < next ? (uint32_t)(next - now) : 0u;
            app_poll(&app, wait);
            if (hal_time_now_us() >= next) {
                app_control_tick(&app, next);
                next += period_us;
            }
        } else {
            app_poll(&app, 100000u); /* wake up now and then to notice signals */
        }
    }
    hal_can_close();
    const comm_counters_t *d = &app.comm.drops;
    fprintf(stderr,
            "mstc-fw: %u steps; dropped frames: crc %u, sequence %u, length %u, unknown id %u\n",
            (unsigned)app.steps, d->crc, d->seq, d->len, d->unknown);
    return 0;
}
