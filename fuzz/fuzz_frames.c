/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer harness: arbitrary traffic into the application (docs/safety.md):
 * frames through comm_decode() and app_on_frame() (the E2E receiver and the
 * safety supervisor), control ticks in real-time mode, STEP frames in
 * lock-step, and the CAN controller's state, in any order.
 *
 * Input: records of 12 bytes, [op, id, dlc, b0..b7, arg].
 *   op & 3  0 raw frame: identifier by id % (n + 1), n the number of frames
 *           of the DBC: the (id % (n + 1))-th of them, in the DBC's order,
 *           or for n 0x100 + id (any identifier, mostly unknown); DLC
 *           dlc & 15, bytes b0..b7 as given;
 *           1 the same with alive counter and CRC made right (so the fuzzer
 *           reaches past the E2E checks), and for PARAM_AUTH the right
 *           freshness and MAC for the last PARAM_SET sent (so it reaches
 *           the armed application: the key is fixed here);
 *           2 a real-time control tick, arg·1 ms after the previous time;
 *           3 the bus: state (arg % 5) and bus-off count += (b0 & 1), or
 *             hal_can_status() -ENOTSUP when arg is 0xFF.
 * After every record: the wheel speeds are finite and within
 * ±max_wheel_speed or, while halted, no faster than after the record before
 * (a halt ramps down from where the wheels were, at the deceleration in force
 * when it began, whatever max_wheel_speed is set to meanwhile: docs/safety.md),
 * and the application is either running or halted with a reason STATUS_halt
 * documents; otherwise abort() (a finding).
 *
 * With MSTC_FUZZ_TRACE set in the environment it also writes, on stderr, the
 * identifier of every frame it hands to the application (`frame 0x105`) and
 * every change of the halt reason (`halt 7`): tests/python/test_fuzz_frames.py
 * runs it on inputs of its own and reads them.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/app.h"
#include "comm/mstc_dbc.h"
#include "hal_fake.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Every frame of the DBC, and every halt reason of its STATUS_halt table
 * (docs/safety.md): mk/quality.mk writes both lists at build time from the
 * codec's header, generated from firmware/comm/mstc.dbc, so that a frame or a
 * halt added to the DBC is fuzzed from the first build that has it. */
static const uint32_t ids[] = {
#include "fuzz_dbc_ids.h"
};
#define N_IDS (sizeof ids / sizeof ids[0])
static const unsigned halts[] = {
#include "fuzz_dbc_halts.h"
};

/* @p halt is a reason STATUS_halt documents. */
static bool halt_documented(uint8_t halt)
{
    for (size_t i = 0; i < sizeof halts / sizeof halts[0]; i++) {
        if (halts[i] == halt) {
            return true;
        }
    }
    return false;
}

/* The harness's device key (any will do: it authenticates its own commands). */
static const uint8_t key[AUTH_KEY_LEN] = { 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16 };
static uint8_t last_set[AUTH_DATA_LEN]; /* bytes 2..7 of the last PARAM_SET sent */

static app_t app;
static uint8_t counters[N_IDS]; /* alive counter of each frame, for op 1 */

/* Wheel speed @p w within ±@p max or, while @p halted, no faster than @p before. */
static bool wheel_ok(num_t w, num_t max, bool halted, num_t before)
{
    return num_is_finite(w) && (num_abs(w) <= max || (halted && num_abs(w) <= num_abs(before)));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int trace = -1;
    if (trace < 0) {
        trace = getenv("MSTC_FUZZ_TRACE") != NULL ? 1 : 0;
    }
    hal_fake_reset();
    memset(counters, 0, sizeof counters);
    (void)app_init(&app, NULL);
    app_set_key(&app, key, 0x5EC0A1D1u);
    memset(last_set, 0, sizeof last_set);
    uint64_t now = 0;
    kin_wheels_t before = *app_last_wheels(&app);
    uint8_t halt_before = app.halt;
    for (size_t at = 0; at + 12u <= size; at += 12u) {
        const uint8_t *r = &data[at];
        const uint8_t op = r[0] & 3u;
        hal_fake.n_sent = 0; /* the fake keeps the first 128 only */
        if (op <= 1u) {
            const size_t k = r[1] % (N_IDS + 1u);
            hal_can_frame_t f = { .id = k < N_IDS ? ids[k] : 0x100u + r[1],
                                  .dlc = (uint8_t)(r[2] & 15u) };
            memcpy(f.data, &r[3], 8);
            uint16_t did;
            if (op == 1u && f.id == COMM_ID_PARAM_AUTH) {
                const uint32_t fv = (app.auth.fv + 1u) & AUTH_FV_MAX;
                f.data[1] = (uint8_t)((fv & 0x0Fu) << 4);
                f.data[2] = (uint8_t)((fv >> 4) & 0xFFu);
                f.data[3] = (uint8_t)((fv >> 12) & 0xFFu);
                auth_mac(&app.auth, COMM_PARAM_SET_DATA_ID, last_set, app.auth.session, fv,
                         &f.data[4]);
            }
            if (op == 1u && f.id == COMM_ID_PARAM_SET) {
                memcpy(last_set, &f.data[2], sizeof last_set);
            }
            if (op == 1u && k < N_IDS && comm_data_id(f.id, &did) == 0) {
                f.data[1] = (uint8_t)((f.data[1] & 0xF0u) | (counters[k]++ & 0x0Fu));
                uint8_t buf[9] = { (uint8_t)(did & 0xFFu), (uint8_t)(did >> 8) };
                memcpy(&buf[2], &f.data[1], 7);
                f.data[0] = comm_crc8h2f(buf, sizeof buf);
            }
            if (trace != 0) {
                (void)fprintf(stderr, "frame 0x%03x\n", (unsigned)f.id);
            }
            (void)app_on_frame(&app, &f);
        } else if (op == 2u) {
            now += (uint64_t)r[11] * 1000u;
            app_control_tick(&app, now);
        } else {
            hal_fake.can_status_rc = r[11] == 0xFFu ? -95 /* -ENOTSUP */ : 0;
            hal_fake.can_status.state = (hal_can_state_t)(r[11] % 5u);
            hal_fake.can_status.bus_off += r[3] & 1u;
        }
        if (trace != 0 && app.halt != halt_before) {
            (void)fprintf(stderr, "halt %u\n", (unsigned)app.halt);
        }
        halt_before = app.halt;
        const kin_wheels_t *w = app_last_wheels(&app);
        const num_t max = app.ctl.p.kin.max_wheel_speed;
        const bool halted = app.halt != (uint8_t)COMM_HALT_NONE;
        if (!wheel_ok(w->left, max, halted, before.left) ||
            !wheel_ok(w->right, max, halted, before.right) || !halt_documented(app.halt)) {
            abort();
        }
        before = *w;
    }
    return 0;
}
