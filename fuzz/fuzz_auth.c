/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer harness: authenticated commands (docs/safety.md, "Threat
 * model"): the PARAM_SET / PARAM_AUTH parser of comm.c, the gate, the
 * challenge, its expiry and the sessions of app.c, and the MAC, challenge and
 * lock of auth.c, fed arbitrary keys, commands, freshness values, MACs,
 * times, replays of recorded commands and restarts.
 *
 * Input: 20 bytes of set-up, [key 16, session 4 (little-endian)], then
 * records of 16 bytes, [op, b1..b15]:
 *   op % 6  0 auth_verify() on a private state at time now + b1 ms: data ID
 *             b2..b3, data b4..b9, freshness b10..b12 (20 bits), MAC
 *             b12..b15;
 *           1 a command: PARAM_SET (bytes 2..7 from b1..b6), and its
 *             PARAM_AUTH at once when b7 is odd, else held back (op 6); by
 *             b8 % 3: the tool's, signed for the current challenge (it read
 *             the status); a tool out of step, signed for the challenge - 1 -
 *             b9; a forger's, for the challenge + b9 with a MAC wrong in the
 *             bits b10 | 1, b11..b13; E2E made right; recorded;
 *           2 a frame of another node: PARAM_SET, PARAM_AUTH or PARAM_GET by
 *             b1 % 3, DLC b2 & 15, bytes b3..b10, E2E made right when b11 is
 *             odd, else as they are;
 *           3 a real-time control tick b1 × 10 ms later (a waiting PARAM_SET
 *             expires, the challenge expires, a lock ends);
 *           4 a recorded command (record b1 % 8 of the last 8 whose
 *             PARAM_AUTH went out: one still held back is on nobody's
 *             recording) played again, E2E made right, after the command or
 *             refusal it came with;
 *           5 a restart: the firmware anew, same key, the next session;
 *           6 the PARAM_AUTH op 1 held back, now (after whatever came
 *             between: another node's PARAM_SET, ticks, a restart).
 * After every record, otherwise abort() (a finding): a command is accepted
 * only when the tool signed it for the challenge of that moment, with no
 * decision and no restart since it signed, and at most 0.6 s of the
 * firmware's time later (the expiry); a replayed one never; each decision moves the freshness on
 * by exactly one (or starts a new session); the private receiver's challenge,
 * lock and count behave as auth.h says; the refusal count never goes back,
 * stays within 15 bits, and says when it stopped.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
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

#define RECORDS 8u
static uint8_t recorded[RECORDS][2][8]; /* PARAM_SET and PARAM_AUTH payloads */
static unsigned n_recorded;

/* The tool's last command: its PARAM_AUTH, held back or not, and the moment
 * it was signed for. */
static struct {
    bool held;        /* its PARAM_AUTH not sent yet (op 6 sends it) */
    bool intended;    /* signed for the challenge, with the right MAC */
    uint8_t set[8];   /* PARAM_SET payload */
    uint8_t auth[8];  /* PARAM_AUTH payload */
    uint32_t session; /* the session and challenge it was signed for */
    uint32_t fv;
    unsigned restarts; /* restarts before it was signed */
    uint64_t t_us;     /* the firmware's time when it was signed */
} tool;
static unsigned restarts;

/* A finding: the invariant of line @p line did not hold. */
static void check_at(bool ok, int line)
{
    if (!ok) {
        (void)fprintf(stderr, "fuzz_auth.c:%d: invariant broken\n", line);
        abort();
    }
}
#define check(ok) check_at((ok), __LINE__)

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

/* Whether the firmware acted on a command since the fake was cleared: a
 * PARAM_VALUE with any result but unauthenticated (ok, unknown_index,
 * out_of_range, rejected, armed: each is an authenticated command's; a
 * PARAM_GET's answer too, which the caller tells apart). */
static bool acted(void)
{
    for (unsigned i = 0; i < hal_fake.n_sent; i++) {
        struct mstc_dbc_param_value_t v;
        if (hal_fake.sent[i].id == COMM_ID_PARAM_VALUE &&
            mstc_dbc_param_value_unpack(&v, hal_fake.sent[i].data, 8) == 0 &&
            v.param_value_result != COMM_PARAM_UNAUTHENTICATED) {
            return true;
        }
    }
    return false;
}

static void verify_alone(const uint8_t *r, uint64_t *own_now)
{
    *own_now += (uint64_t)r[1] * 1000u;
    const auth_t before = own;
    const uint16_t data_id = (uint16_t)(r[2] | r[3] << 8);
    const uint32_t fv =
        ((uint32_t)r[10] | (uint32_t)r[11] << 8 | (uint32_t)r[12] << 16) & AUTH_FV_MAX;
    const uint8_t mac[AUTH_MAC_LEN] = { r[12], r[13], r[14], r[15] };
    const auth_result_t res = auth_verify(&own, data_id, &r[4], fv, mac, *own_now);
    check(own.outcome == (uint8_t)res);
    /* Every decision uses the challenge up, except at the end of a session. */
    check(own.fv == (before.fv < AUTH_FV_MAX ? before.fv + 1u : AUTH_FV_MAX));
    if (res == AUTH_OK) {
        uint8_t want[AUTH_MAC_LEN];
        auth_mac(&before, data_id, &r[4], before.session, fv, want);
        check(fv == before.fv + 1u && memcmp(want, mac, AUTH_MAC_LEN) == 0);
        check(*own_now >= before.locked_until_us);
        check(own.refused == before.refused && own.fails == 0u);
    } else {
        check(own.refused == before.refused + 1u ||
              (before.refused == AUTH_REFUSED_MAX && own.refused_saturated));
    }
    if (res == AUTH_MAC) {
        check(fv == before.fv + 1u);
    }
    check(own.locked_until_us <= *own_now + AUTH_LOCK_US);
    check(own.fails <= AUTH_LOCK_TRIES);
}

/* The tool's PARAM_AUTH goes out, and from now on a listener has the
 * command: it is recorded for replays (op 4) only now. One held back (op 6)
 * was on nobody's recording before it went out. */
static void send_tools_auth(void)
{
    memcpy(recorded[n_recorded % RECORDS][0], tool.set, 8);
    memcpy(recorded[n_recorded % RECORDS][1], tool.auth, 8);
    n_recorded++;
    tool.held = false;
    (void)app_on_frame(&app, (hal_can_frame_t[]){ sealed(1, tool.auth) });
}

/* A command (op 1). */
static void command(const uint8_t *r)
{
    uint8_t p[8] = { 0 };
    memcpy(&p[2], &r[1], AUTH_DATA_LEN);
    const uint32_t challenge = (app.auth.fv + 1u) & AUTH_FV_MAX;
    uint32_t fv = challenge;
    uint8_t mac[AUTH_MAC_LEN];
    const unsigned kind = r[8] % 3u;
    if (kind == 1u) {
        /* A tool that missed a decision: an earlier challenge (0 is never
         * one), the right MAC. */
        fv = challenge > 1u + r[9] ? challenge - 1u - r[9] : 0u;
    } else if (kind == 2u) {
        fv = (fv + r[9]) & AUTH_FV_MAX; /* any value, a forged MAC */
    } else {
        /* what a tool that read the status sends */
    }
    auth_mac(&app.auth, COMM_PARAM_SET_DATA_ID, &p[2], app.auth.session, fv, mac);
    if (kind == 2u) {
        mac[0] ^= (uint8_t)(r[10] | 1u);
        mac[1] ^= r[11];
        mac[2] ^= r[12];
        mac[3] ^= r[13];
    }
    uint8_t a[8] = { 0 };
    a[1] = (uint8_t)((fv & 0x0Fu) << 4);
    a[2] = (uint8_t)((fv >> 4) & 0xFFu);
    a[3] = (uint8_t)((fv >> 12) & 0xFFu);
    memcpy(&a[4], mac, AUTH_MAC_LEN);
    tool.intended = kind == 0u;
    tool.session = app.auth.session;
    tool.fv = fv;
    tool.restarts = restarts;
    tool.t_us = app.now_us;
    memcpy(tool.set, p, 8);
    memcpy(tool.auth, a, 8);
    (void)app_on_frame(&app, (hal_can_frame_t[]){ sealed(0, p) });
    tool.held = (r[7] & 1u) == 0u;
    if (!tool.held) {
        send_tools_auth();
    }
}

static void start(const uint8_t key[AUTH_KEY_LEN], uint32_t session)
{
    (void)app_init(&app, NULL);
    app_set_key(&app, key, session);
    memset(counters, 0, sizeof counters);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 20u) {
        return 0;
    }
    hal_fake_reset();
    hal_fake.can_status_rc = -95; /* -ENOTSUP: no controller */
    uint32_t session = (uint32_t)data[16] | (uint32_t)data[17] << 8 | (uint32_t)data[18] << 16 |
                       (uint32_t)data[19] << 24;
    hal_fake.boot_nonce = session + 1u; /* the next session, when one is spent */
    start(data, session);
    auth_init(&own);
    auth_set_key(&own, data, session);
    n_recorded = 0;
    restarts = 0;
    tool.held = false;
    tool.intended = false;
    uint64_t now = 0;
    uint64_t own_now = 0;
    for (size_t at = 20u; at + 16u <= size; at += 16u) {
        const uint8_t *r = &data[at];
        const uint32_t session0 = app.auth.session;
        const uint32_t fv0 = app.auth.fv;
        const uint16_t refused0 = app.auth.refused;
        const bool saturated0 = app.auth.refused_saturated;
        bool restarted = false;
        bool tools = false; /* the tool's PARAM_AUTH went out in this record */
        hal_fake.n_sent = 0;
        switch (r[0] % 7u) {
        case 0: verify_alone(r, &own_now); break;
        case 1:
            command(r);
            tools = !tool.held;
            break;
        case 2: {
            hal_can_frame_t f = { .id = ids[r[1] % 3u], .dlc = (uint8_t)(r[2] & 15u) };
            memcpy(f.data, &r[3], 8);
            if ((r[11] & 1u) != 0u) {
                f = sealed(r[1] % 3u, f.data);
            }
            (void)app_on_frame(&app, &f);
            break;
        }
        case 3:
            now += (uint64_t)r[1] * 10000u;
            app_control_tick(&app, now);
            break;
        case 4:
            if (n_recorded > 0u) {
                const unsigned k = r[1] % (n_recorded < RECORDS ? n_recorded : RECORDS);
                (void)app_on_frame(&app, (hal_can_frame_t[]){ sealed(0, recorded[k][0]) });
                (void)app_on_frame(&app, (hal_can_frame_t[]){ sealed(1, recorded[k][1]) });
            }
            break;
        case 5:
            session++;
            start(data, session);
            hal_fake.boot_nonce = session + 1u;
            restarts++;
            restarted = true;
            break;
        default:
            if (tool.held) {
                send_tools_auth();
                tools = true;
            }
            break;
        }
        if (restarted) {
            check(app.auth.fv == 0u && app.auth.session != session0);
            continue;
        }
        /* Each decision moves the freshness on by one; several decisions
         * (a refused waiting PARAM_SET and then its successor's) by as many;
         * a spent session starts a new one. */
        check(app.auth.session != session0 || app.auth.fv >= fv0);
        check(app.auth.refused >= refused0 && app.auth.refused <= AUTH_REFUSED_MAX);
        check(!saturated0 || app.auth.refused_saturated);
        check(!app.auth.refused_saturated || app.auth.refused == AUTH_REFUSED_MAX);
        /* A command is accepted only when the tool signed it for the
         * challenge of that moment: its PARAM_AUTH went out in this record,
         * and no decision and no restart came since it signed (a PARAM_GET
         * is answered too: op 2, identifier 2). */
        const bool get = r[0] % 7u == 2u && r[1] % 3u == 2u;
        const bool moment =
            tool.intended && tool.restarts == restarts && tool.session == session0 &&
            tool.fv == fv0 + 1u &&
            app.now_us - tool.t_us <= APP_AUTH_CHALLENGE_US + APP_HOUSEKEEPING_PERIOD_US;
        check(!acted() || get || (tools && moment));
        check(!(r[0] % 7u == 4u && acted()));
    }
    return 0;
}
