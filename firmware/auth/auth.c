/* SPDX-License-Identifier: MIT */
/*
 * Authenticated commands (auth.h): AES-128-CMAC and the SecOC-style
 * freshness check.
 *
 * CMAC is written here, over Mbed TLS's AES block function, rather than taken
 * from Mbed TLS's cmac.c: that one runs on its generic cipher layer
 * (cipher.c, cipher_wrap.c), which would link the cipher framework and AES
 * decryption into a 32 KB image for one mode of one cipher. RFC 4493's
 * algorithm is two subkey doublings and a CBC chain; tests/unit/test_auth.c
 * checks it against the RFC's four examples, and tests/python/test_auth.py
 * against `cryptography` on random keys and messages.
 */
#include "auth/auth.h"

#include <string.h>

/* The configuration first, to check that it is ours and not Mbed TLS's
 * default (the include path decides: mk/auth.mk). */
#include "mbedtls/config.h"
#ifndef MSTC_MBEDTLS_CONFIG
#error "Mbed TLS's default configuration is in force, not firmware/auth/mbedtls-config (mk/auth.mk)"
#endif
#include "mbedtls/aes.h"

#define BLOCK       16u
#define FV_LOW_MASK ((UINT32_C(1) << AUTH_FV_LOW_BITS) - 1u)
#define FV_SPAN     (UINT64_C(1) << AUTH_FV_LOW_BITS)
/* RFC 4493: the constant of the subkey doubling in GF(2^128). */
#define CMAC_RB     0x87u

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

void auth_set_key(auth_t *s, const uint8_t key[AUTH_KEY_LEN], uint32_t fv)
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
    s->fv = fv;
}

void auth_cmac(const auth_t *s, const uint8_t *msg, size_t len, uint8_t mac[AUTH_CMAC_LEN])
{
    /* RFC 4493, 2.4: every block but the last through the CBC chain; the last
     * XOR K1 when complete, else padded with 10..0 and XOR K2. The empty
     * message is one incomplete block. */
    const size_t n = len == 0u ? 1u : (len + BLOCK - 1u) / BLOCK;
    const bool complete = len != 0u && len % BLOCK == 0u;
    mbedtls_aes_context ctx;
    schedule(&ctx, s->key);
    uint8_t x[BLOCK];
    (void)memset(x, 0, sizeof x);
    uint8_t y[BLOCK];
    for (size_t b = 0; b + 1u < n; b++) {
        for (size_t i = 0; i < BLOCK; i++) {
            y[i] = (uint8_t)(x[i] ^ msg[b * BLOCK + i]);
        }
        encrypt(&ctx, y, x);
    }
    const size_t base = (n - 1u) * BLOCK;
    const size_t rest = len - base;
    for (size_t i = 0; i < BLOCK; i++) {
        uint8_t m;
        if (i < rest) {
            m = msg[base + i];
        } else {
            m = i == rest ? 0x80u : 0u;
        }
        y[i] = (uint8_t)(x[i] ^ m ^ (complete ? s->k1[i] : s->k2[i]));
    }
    encrypt(&ctx, y, mac);
    schedule_wipe(&ctx);
}

/* Bytes 0..1 data ID, 2..7 the data, 8..11 the freshness, both big-endian. */
#define MAC_INPUT_LEN (2u + AUTH_DATA_LEN + 4u)

void auth_mac(const auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN], uint32_t fv,
              uint8_t mac[AUTH_MAC_LEN])
{
    uint8_t in[MAC_INPUT_LEN];
    in[0] = (uint8_t)(data_id >> 8);
    in[1] = (uint8_t)(data_id & 0xFFu);
    (void)memcpy(&in[2], data, AUTH_DATA_LEN);
    for (size_t i = 0; i < 4u; i++) {
        in[2u + AUTH_DATA_LEN + i] = (uint8_t)((fv >> (24u - 8u * i)) & 0xFFu);
    }
    uint8_t full[AUTH_CMAC_LEN];
    auth_cmac(s, in, sizeof in, full);
    (void)memcpy(mac, full, AUTH_MAC_LEN);
}

/* Whether @p mac is the authenticator of the command with freshness @p fv.
 * Every byte is compared whatever the first difference, so the time taken
 * says nothing about how much of a forged MAC was right. */
static bool mac_ok(const auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
                   uint32_t fv, const uint8_t mac[AUTH_MAC_LEN])
{
    uint8_t want[AUTH_MAC_LEN];
    auth_mac(s, data_id, data, fv, want);
    unsigned diff = 0u;
    for (size_t i = 0; i < AUTH_MAC_LEN; i++) {
        diff |= (unsigned)(want[i] ^ mac[i]);
    }
    return diff == 0u;
}

void auth_refuse(auth_t *s, auth_result_t why)
{
    s->last = (uint8_t)why;
    if (s->refused < AUTH_REFUSED_MAX) {
        s->refused++;
    }
}

auth_result_t auth_verify(auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
                          uint32_t fv_low, const uint8_t mac[AUTH_MAC_LEN])
{
    auth_result_t r;
    /* The smallest value above the last accepted one with these low bits
     * (SecOC's freshness reconstruction), in 64 bits: it can pass 2^32 - 1
     * when the counter is spent, and is then not accepted. */
    uint64_t fv = ((uint64_t)s->fv & ~(uint64_t)FV_LOW_MASK) | (uint64_t)(fv_low & FV_LOW_MASK);
    if (fv <= (uint64_t)s->fv) {
        fv += FV_SPAN;
    }
    if (!s->keyed) {
        r = AUTH_NO_KEY;
    } else if (fv <= (uint64_t)UINT32_MAX && mac_ok(s, data_id, data, (uint32_t)fv, mac)) {
        s->fv = (uint32_t)fv;
        r = AUTH_OK;
    } else if (fv >= FV_SPAN && mac_ok(s, data_id, data, (uint32_t)(fv - FV_SPAN), mac)) {
        /* Authentic with the value at or below the last accepted one that
         * has these low bits: played again. Told apart only to say why. */
        r = AUTH_STALE;
    } else {
        r = AUTH_MAC;
    }
    if (r != AUTH_OK) {
        auth_refuse(s, r);
    }
    return r;
}
