/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer harness: authenticated commands (docs/safety.md, "Threat
 * model"): the PARAM_SET / PARAM_AUTH parser of comm.c, the gate of app.c and
 * the MAC and freshness check of auth.c, fed arbitrary keys, commands,
 * freshness values and MACs, with the E2E fields made right or not.
 *
 * Input: 20 bytes of set-up, [key 16, freshness 4 (little-endian)], then
 * records of 16 bytes, [op, b1..b15]:
 *   op % 4  0 auth_verify() on a private state: data ID b1..b2, data b3..b8,
 *             freshness low bits b9..b12, MAC b13..b15 and op >> 2;
 *           1 a PARAM_SET (bytes 2..7 from b1..b6) and, when b7 is odd, its
 *             PARAM_AUTH: with the right MAC for freshness (last + 1 + b8)
 *             when b9 is odd, else MAC and freshness from b10..b15; E2E
 *             counters and CRCs made right;
 *           2 a raw frame: identifier PARAM_SET, PARAM_AUTH or PARAM_GET by
 *             b1 % 3, DLC b2 & 15, bytes b3..b10, as they are;
 *           3 a real-time control tick b1 ms later (a waiting PARAM_SET
 *             expires).
 * After every record, otherwise abort() (a finding): the freshness never goes
 * back; it moves only with a command whose MAC, recomputed here, is right;
 * a PARAM_VALUE result ok answers only a command that was accepted; the
 * refusal count never goes back and stays within 12 bits.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "app/app.h"
#include "auth/auth.h"
#include "comm/mstc_dbc.h"
#include "hal_fake.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static app_t app;
static auth_t own;
static uint8_t counters[3];

static const uint32_t ids[3] = { COMM_ID_PARAM_SET, COMM_ID_PARAM_AUTH, COMM_ID_PARAM_GET };

static void check(bool ok)
{
    if (!ok) {
        abort();
    }
}

/* A frame with the next alive counter of its identifier and a right CRC. */
static hal_can_frame_t sealed(size_t k, const uint8_t payload[8])
{
    hal_can_frame_t f = { .id = ids[k], .dlc = 8u };
    memcpy(f.data, payload, 8);
    f.data[1] = (uint8_t)((f.data[1] & 0xF0u) | (counters[k]++ & 0x0Fu));
    uint16_t did = 0;
    (void)comm_data_id(f.id, &did);
    uint8_t buf[9] = { (uint8_t)(did & 0xFFu), (uint8_t)(did >> 8) };
    memcpy(&buf[2], &f.data[1], 7);
    f.data[0] = comm_crc8h2f(buf, sizeof buf);
    return f;
}

/* Whether the firmware answered a PARAM_VALUE with result ok since the fake
 * was cleared. */
static bool answered_ok(void)
{
    for (unsigned i = 0; i < hal_fake.n_sent; i++) {
        struct mstc_dbc_param_value_t v;
        if (hal_fake.sent[i].id == COMM_ID_PARAM_VALUE &&
            mstc_dbc_param_value_unpack(&v, hal_fake.sent[i].data, 8) == 0 &&
            v.param_value_result == COMM_PARAM_OK) {
            return true;
        }
    }
    return false;
}

static void verify_alone(const uint8_t *r)
{
    const uint32_t fv0 = own.fv;
    const uint16_t refused0 = own.refused;
    const uint16_t data_id = (uint16_t)(r[1] | r[2] << 8);
    const uint32_t low =
        (uint32_t)r[9] | (uint32_t)r[10] << 8 | (uint32_t)r[11] << 16 | (uint32_t)r[12] << 24;
    const uint8_t mac[AUTH_MAC_LEN] = { r[13], r[14], r[15], (uint8_t)(r[0] >> 2) };
    const auth_result_t res = auth_verify(&own, data_id, &r[3], low, mac);
    if (res == AUTH_OK) {
        uint8_t want[AUTH_MAC_LEN];
        auth_mac(&own, data_id, &r[3], own.fv, want);
        check(own.fv > fv0 && memcmp(want, mac, AUTH_MAC_LEN) == 0);
        check((own.fv & 0xFFFFFu) == (low & 0xFFFFFu) && own.refused == refused0);
    } else {
        check(own.fv == fv0 && own.refused >= refused0);
    }
}

static void command(const uint8_t *r)
{
    uint8_t p[8] = { 0 };
    memcpy(&p[2], &r[1], AUTH_DATA_LEN);
    (void)app_on_frame(&app, (hal_can_frame_t[]){ sealed(0, p) });
    if ((r[7] & 1u) == 0u) {
        return; /* MAC-less: refused later */
    }
    uint8_t a[8] = { 0 };
    uint32_t fv = app.auth.fv + 1u + r[8];
    uint8_t mac[AUTH_MAC_LEN];
    if ((r[9] & 1u) != 0u) {
        auth_mac(&app.auth, COMM_PARAM_SET_DATA_ID, &p[2], fv, mac);
    } else {
        fv = (uint32_t)r[10] | (uint32_t)r[11] << 8 | (uint32_t)r[12] << 16;
        memcpy(mac, &r[12], AUTH_MAC_LEN);
    }
    a[1] = (uint8_t)((fv & 0x0Fu) << 4);
    a[2] = (uint8_t)((fv >> 4) & 0xFFu);
    a[3] = (uint8_t)((fv >> 12) & 0xFFu);
    memcpy(&a[4], mac, AUTH_MAC_LEN);
    (void)app_on_frame(&app, (hal_can_frame_t[]){ sealed(1, a) });
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 20u) {
        return 0;
    }
    hal_fake_reset();
    hal_fake.can_status_rc = -95; /* -ENOTSUP: no controller */
    memset(counters, 0, sizeof counters);
    const uint32_t fv = (uint32_t)data[16] | (uint32_t)data[17] << 8 | (uint32_t)data[18] << 16 |
                        (uint32_t)data[19] << 24;
    (void)app_init(&app, NULL);
    app_set_key(&app, data, fv);
    auth_init(&own);
    auth_set_key(&own, data, fv);
    uint64_t now = 0;
    for (size_t at = 20u; at + 16u <= size; at += 16u) {
        const uint8_t *r = &data[at];
        const uint32_t fv0 = app.auth.fv;
        const uint16_t refused0 = app.auth.refused;
        hal_fake.n_sent = 0;
        switch (r[0] & 3u) {
        case 0: verify_alone(r); break;
        case 1: command(r); break;
        case 2: {
            hal_can_frame_t f = { .id = ids[r[1] % 3u], .dlc = (uint8_t)(r[2] & 15u) };
            memcpy(f.data, &r[3], 8);
            (void)app_on_frame(&app, &f);
            break;
        }
        default:
            now += (uint64_t)r[1] * 1000u;
            app_control_tick(&app, now);
            break;
        }
        check(app.auth.fv >= fv0 && app.auth.refused >= refused0);
        check(app.auth.refused <= AUTH_REFUSED_MAX);
        /* An ok answer only with a freshness that moved (every accepted
         * command moves it), or to a PARAM_GET (op 2, identifier 2). */
        check(!answered_ok() || app.auth.fv > fv0 || ((r[0] & 3u) == 2u && r[1] % 3u == 2u));
    }
    return 0;
}
