/* SPDX-License-Identifier: MIT */
/*
 * A plain C ABI over the E2E receiver of comm.c, for
 * tests/python/test_e2e_model.py, which builds it as a shared library with
 * the project's warnings (float mode) and compares it, status by status,
 * with an independent Python model of docs/safety.md. Test code.
 */
#include <stdint.h>
#include <string.h>

#include "comm/comm.h"

/* The exported functions are this file's interface; they need no header. */
#pragma GCC diagnostic ignored "-Wmissing-prototypes"

static comm_t comm;

void e2e_init(void) { comm_init(&comm); }

/** Receive one frame; @return comm_decode()'s result. */
int e2e_decode(uint32_t id, uint8_t dlc, const uint8_t *data)
{
    hal_can_frame_t f = { .id = id, .dlc = dlc };
    memcpy(f.data, data, sizeof f.data);
    comm_msg_t m;
    return comm_decode(&comm, &f, &m);
}

/** Close a check cycle of @p id; @return 1 when a frame was accepted in it. */
int e2e_cycle(uint32_t id) { return comm_e2e_cycle(&comm, id) ? 1 : 0; }

/**
 * The receiver of @p id: out = {last status, state, ok_run, window length}.
 * @return 0, or -1 when the firmware does not receive @p id.
 */
int e2e_rx(uint32_t id, int *out)
{
    const comm_rx_t *r = comm_rx(&comm, id);
    if (r == NULL) {
        return -1;
    }
    out[0] = r->status;
    out[1] = r->state;
    out[2] = r->ok_run;
    out[3] = r->n;
    return 0;
}
