/* SPDX-License-Identifier: MIT */
/**
 * @file auth.h
 * @brief Authenticated commands in the manner of AUTOSAR SecOC: AES-128-CMAC
 *        (RFC 4493) truncated to 32 bits over a data ID, the payload and a
 *        32-bit freshness value that never repeats (docs/safety.md, "Threat
 *        model"; the frames are PARAM_SET, PARAM_AUTH and AUTH_STATUS of
 *        mstc.dbc).
 *
 * The authenticator is the first AUTH_MAC_LEN bytes of
 *
 *     CMAC(key, data_id[2] || data[AUTH_DATA_LEN] || freshness[4])
 *
 * with the data ID and the freshness value big-endian, as SecOC's
 * DataToAuthenticator. The sender sends the low AUTH_FV_LOW_BITS bits of the
 * freshness value; the receiver takes the smallest value above the last one
 * it accepted that has those low bits, and accepts the command when the MAC
 * verifies with it. So a value is accepted once: a recorded command played
 * again, with its alive counter and CRC made good, is refused as stale.
 *
 * The AES block cipher is Mbed TLS's (deps/mbedtls, fetched and checksummed
 * by tools/setup/fetch-source; configured by auth/mbedtls-config/: AES
 * encryption, tables in flash); CMAC is written here over it (auth.c says
 * why). The key schedule lives on the stack of each call and is wiped after
 * it, so only the 16-byte key and the two CMAC subkeys stay in RAM.
 */
#ifndef MSTC_AUTH_H
#define MSTC_AUTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** @brief AES-128 key length [bytes]. */
#define AUTH_KEY_LEN     16u
/** @brief CMAC length before truncation [bytes] (one AES block). */
#define AUTH_CMAC_LEN    16u
/** @brief Authenticated payload of a command: PARAM_SET bytes 2..7. */
#define AUTH_DATA_LEN    6u
/** @brief Bytes of the CMAC carried in PARAM_AUTH. */
#define AUTH_MAC_LEN     4u
/** @brief Bits of the freshness value carried in PARAM_AUTH. */
#define AUTH_FV_LOW_BITS 20u
/** @brief Refusals counted, at most (12 bits in AUTH_STATUS). */
#define AUTH_REFUSED_MAX 4095u

/** @brief Outcome of a check: AUTH_STATUS_last (mstc.dbc). */
typedef enum {
    AUTH_OK = 0,      /**< authentic and fresh (AUTH_STATUS_last "none") */
    AUTH_MISSING = 1, /**< a command without its PARAM_AUTH, or the reverse */
    AUTH_MAC = 2,     /**< the MAC does not verify: wrong key, forged, corrupted */
    AUTH_STALE = 3,   /**< authentic, but its freshness is not new: a replay */
    AUTH_NO_KEY = 4,  /**< no key was given: every command is refused */
} auth_result_t;

/** @brief Receiver state: key, CMAC subkeys, freshness, refusals. */
typedef struct {
    uint8_t key[AUTH_KEY_LEN];
    uint8_t k1[AUTH_CMAC_LEN]; /**< CMAC subkeys (RFC 4493, Generate_Subkey) */
    uint8_t k2[AUTH_CMAC_LEN];
    bool keyed;       /**< a key was given */
    uint32_t fv;      /**< last freshness value accepted */
    uint16_t refused; /**< refusals, saturating at AUTH_REFUSED_MAX */
    uint8_t last;     /**< auth_result_t of the last refusal, AUTH_OK before any */
} auth_t;

/** @brief No key (every command refused with AUTH_NO_KEY), freshness 0, no refusal. */
void auth_init(auth_t *s);

/**
 * @brief Take key @p key; the freshness restarts at @p fv (the next command
 *        must carry a larger value). Refusals are kept.
 */
void auth_set_key(auth_t *s, const uint8_t key[AUTH_KEY_LEN], uint32_t fv);

/**
 * @brief AES-128-CMAC (RFC 4493) of @p len bytes of @p msg under the key of
 *        @p s (all zeros when it has none) into @p mac.
 */
void auth_cmac(const auth_t *s, const uint8_t *msg, size_t len, uint8_t mac[AUTH_CMAC_LEN]);

/**
 * @brief The authenticator a sender puts in PARAM_AUTH bytes 4..7: the first
 *        AUTH_MAC_LEN bytes of the CMAC of @p data_id, @p data and @p fv.
 */
void auth_mac(const auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN], uint32_t fv,
              uint8_t mac[AUTH_MAC_LEN]);

/**
 * @brief Check a command: @p data under @p data_id, authenticated by the low
 *        freshness bits @p fv_low and the truncated MAC @p mac. Accepted (the
 *        freshness moves to the value used) or refused and counted.
 * @retval AUTH_OK accepted. @retval AUTH_NO_KEY, AUTH_MAC, AUTH_STALE refused.
 */
auth_result_t auth_verify(auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
                          uint32_t fv_low, const uint8_t mac[AUTH_MAC_LEN]);

/** @brief Count a refusal for @p why (a result other than AUTH_OK). */
void auth_refuse(auth_t *s, auth_result_t why);

#endif /* MSTC_AUTH_H */
