/* SPDX-License-Identifier: MIT */
/*
 * Authenticated commands (auth.h): AES-128-CMAC and the SecOC-style
 * freshness check.
 *
 * CMAC is written here, over Mbed TLS's AES block function, rather than taken
 * from Mbed TLS's cmac.c: that one runs on its generic cipher layer
 * (cipher.c, cipher_wrap.c), which would link the cipher framework and AES
 * decryption into a 32 KB image for one mode of one cipher. Every message
 * the firmware authenticates is one block (16 and 13 bytes), so RFC 4493's
 * algorithm is two subkey doublings and one encryption (no CBC chain);
 * tests/unit/test_auth.c checks it against the RFC's examples of one block
 * and less, and tests/python/test_auth.py against `cryptography` on random
 * keys and messages of 0 to 16 bytes.
 */
#include "auth/auth.h"

#include <errno.h>
#include <string.h>

/* The configuration first, to check that it is ours and not Mbed TLS's
 * default (the include path decides: mk/auth.mk). */
#include "mbedtls/config.h"
#ifndef MSTC_MBEDTLS_CONFIG
#error "Mbed TLS's default configuration is in force, not firmware/auth/mbedtls-config (mk/auth.mk)"
#endif
#include "mbedtls/aes.h"

#define BLOCK   16u
/* RFC 4493: the constant of the subkey doubling in GF(2^128). */
#define CMAC_RB 0x87u

/* A key schedule on the caller's stack, wiped by schedule_wipe(). */
static void schedule(mbedtls_aes_context *ctx, const uint8_t key[AUTH_KEY_LEN])
{
    mbedtls_aes_init(ctx);
    /* Cannot fail: a 128-bit key is always a valid length. */
    (void)mbedtls_aes_setkey_enc(ctx, key, 128u);
}

static void schedule_wipe(mbedtls_aes_context *ctx) { mbedtls_aes_free(ctx); }

static void encrypt(mbedtls_aes_context *ctx, const uint8_t in[BLOCK], uint8_t out[BLOCK])
{
    /* Cannot fail without a hardware accelerator (none is configured). */
    (void)mbedtls_internal_aes_encrypt(ctx, in, out);
}

/* out = in · x in GF(2^128): one bit to the left, RB into the last byte when
 * the first bit fell out (RFC 4493, 2.3). */
static void dbl(const uint8_t in[BLOCK], uint8_t out[BLOCK])
{
    const uint8_t carry = (uint8_t)(in[0] >> 7);
    for (size_t i = 0; i + 1u < BLOCK; i++) {
        out[i] = (uint8_t)((unsigned)(in[i] << 1) | (unsigned)(in[i + 1u] >> 7));
    }
    out[BLOCK - 1u] = (uint8_t)((unsigned)(in[BLOCK - 1u] << 1) ^ (carry * CMAC_RB));
}

void auth_init(auth_t *s) { *s = (auth_t){ .keyed = false }; }

void auth_new_session(auth_t *s, uint32_t session)
{
    s->session = session;
    s->fv = 0u;
    s->outcome = (uint8_t)AUTH_OK;
}

void auth_set_key(auth_t *s, const uint8_t key[AUTH_KEY_LEN], uint32_t session)
{
    (void)memcpy(s->key, key, AUTH_KEY_LEN);
    mbedtls_aes_context ctx;
    schedule(&ctx, key);
    uint8_t zero[BLOCK];
    (void)memset(zero, 0, sizeof zero);
    uint8_t l[BLOCK];
    encrypt(&ctx, zero, l);
    schedule_wipe(&ctx);
    dbl(l, s->k1);
    dbl(s->k1, s->k2);
    s->keyed = true;
    auth_new_session(s, session);
}

int auth_cmac(const auth_t *s, const uint8_t *msg, size_t len, uint8_t mac[AUTH_CMAC_LEN])
{
    /* RFC 4493, 2.4, for a message of one block, all the firmware MACs
     * (commands: 16 bytes; the status: 13): a complete block XOR K1, else
     * padded with 10..0 and XOR K2, then one encryption. The empty message
     * is one incomplete block. */
    if (len > BLOCK) {
        return -EINVAL;
    }
    const uint8_t *k = len == BLOCK ? s->k1 : s->k2;
    uint8_t y[BLOCK];
    for (size_t i = 0; i < BLOCK; i++) {
        uint8_t m = 0u;
        if (i < len) {
            m = msg[i];
        } else if (i == len) {
            m = 0x80u;
        } else {
            /* the padding's zeros */
        }
        y[i] = (uint8_t)(m ^ k[i]);
    }
    mbedtls_aes_context ctx;
    schedule(&ctx, s->key);
    encrypt(&ctx, y, mac);
    schedule_wipe(&ctx);
    return 0;
}

static void put32(uint8_t *out, uint32_t v)
{
    for (size_t i = 0; i < 4u; i++) {
        out[i] = (uint8_t)((v >> (24u - 8u * i)) & 0xFFu);
    }
}

/* Bytes 0..1 data ID, 2..7 the data, 8..11 the session, 12..15 the
 * freshness, all big-endian: one complete block. */
#define MAC_INPUT_LEN (2u + AUTH_DATA_LEN + 4u + 4u)

void auth_mac(const auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
              uint32_t session, uint32_t fv, uint8_t mac[AUTH_MAC_LEN])
{
    uint8_t in[MAC_INPUT_LEN];
    in[0] = (uint8_t)(data_id >> 8);
    in[1] = (uint8_t)(data_id & 0xFFu);
    (void)memcpy(&in[2], data, AUTH_DATA_LEN);
    put32(&in[2u + AUTH_DATA_LEN], session);
    put32(&in[6u + AUTH_DATA_LEN], fv);
    uint8_t full[AUTH_CMAC_LEN];
    (void)auth_cmac(s, in, sizeof in, full); /* one block: cannot fail */
    (void)memcpy(mac, full, AUTH_MAC_LEN);
}

void auth_status_mac(const auth_t *s, uint16_t data_id, uint8_t mac[AUTH_MAC_LEN])
{
    /* A command's layout, with the status in place of the command's data:
     * the data ID tells the two apart. */
    const unsigned refused = (unsigned)s->refused | (s->refused_saturated ? 0x8000u : 0u);
    const uint8_t status[AUTH_DATA_LEN] = {
        s->outcome, (uint8_t)(refused >> 8), (uint8_t)(refused & 0xFFu), 0u, 0u, 0u
    };
    auth_mac(s, data_id, status, s->session, s->fv, mac);
}

/* Whether @p mac is the authenticator of the command with freshness @p fv.
 * Every byte is compared whatever the first difference, so the time taken
 * says nothing about how much of a forged MAC was right. */
static bool mac_ok(const auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
                   uint32_t fv, const uint8_t mac[AUTH_MAC_LEN])
{
    uint8_t want[AUTH_MAC_LEN];
    auth_mac(s, data_id, data, s->session, fv, want);
    unsigned diff = 0u;
    for (size_t i = 0; i < AUTH_MAC_LEN; i++) {
        diff |= (unsigned)(want[i] ^ mac[i]);
    }
    return diff == 0u;
}

/* The challenge is decided: the next one is fv + 1. A spent session stays
 * at AUTH_FV_MAX, where nothing is accepted, until a new one starts. */
static void use_up(auth_t *s, auth_result_t outcome)
{
    if (s->fv < AUTH_FV_MAX) {
        s->fv++;
    }
    s->outcome = (uint8_t)outcome;
}

void auth_refuse(auth_t *s, auth_result_t why)
{
    if (why == AUTH_EXPIRED) {
        /* no command came: not a refusal */
    } else if (s->refused < AUTH_REFUSED_MAX) {
        s->refused++;
    } else {
        s->refused_saturated = true;
    }
    use_up(s, why);
}

auth_result_t auth_verify(auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
                          uint32_t fv, const uint8_t mac[AUTH_MAC_LEN], uint64_t now_us)
{
    auth_result_t r;
    if (!s->keyed || auth_spent(s)) {
        r = AUTH_NO_KEY;
    } else if (now_us < s->locked_until_us) {
        r = AUTH_LOCKED;
    } else if (fv != s->fv + 1u) {
        /* Signed for another moment: a recorded command, or a sender that
         * did not see the last decision. No MAC is checked, so nothing is
         * learnt: it does not count towards the lock. */
        r = AUTH_STALE;
    } else if (mac_ok(s, data_id, data, fv, mac)) {
        r = AUTH_OK;
    } else {
        r = AUTH_MAC;
        /* After a lock, fails stays at the limit: each further failure before
         * an accepted command locks again at once. */
        if (s->fails < AUTH_LOCK_TRIES) {
            s->fails++;
        }
        if (s->fails >= AUTH_LOCK_TRIES) {
            s->locked_until_us = now_us + AUTH_LOCK_US;
        }
    }
    if (r == AUTH_OK) {
        s->fails = 0u;
        use_up(s, AUTH_OK);
    } else {
        auth_refuse(s, r);
    }
    return r;
}
