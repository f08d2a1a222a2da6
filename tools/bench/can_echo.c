/* SPDX-License-Identifier: MIT */
/* can_echo: the smallest possible peer for the CAN benchmark. It answers
 * every frame it receives with N frames at once (copies of the received
 * payload under IDs 0x180, 0x181, ...), so that a python-can round trip to it
 * measures the bus and Python alone, without the firmware. Built on the HAL's
 * Linux port, so <linux/can.h> stays in hal/linux. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hal/hal_can.h"

static volatile sig_atomic_t stop;

static void on_signal(int sig)
{
    (void)sig;
    stop = 1;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: can_echo IFACE ANSWERS (1..8)\n");
        return 2;
    }
    const long answers = strtol(argv[2], NULL, 10);
    if (answers < 1 || answers > 8) {
        fprintf(stderr, "can_echo: ANSWERS must be 1..8, got '%s'\n", argv[2]);
        return 2;
    }
    const int rc = hal_can_open(argv[1]);
    if (rc != 0) {
        fprintf(stderr, "can_echo: cannot open %s: %s\n", argv[1], strerror(-rc));
        return 1;
    }
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    fprintf(stderr, "can_echo: echo mode on %s\n", argv[1]);
    hal_can_frame_t f;
    while (!stop) {
        if (hal_can_recv(&f, 100000u) != 0) {
            continue;
        }
        for (long i = 0; i < answers; i++) {
            f.id = 0x180u + (uint32_t)i;
            (void)hal_can_send(&f);
        }
    }
    hal_can_close();
    return 0;
}
