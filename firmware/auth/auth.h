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
 *     CMAC(key, data_id[2] || data[AUTH_DATA_LEN] || session[4] || freshness[4])
 *
 * with every number big-endian, as SecOC's DataToAuthenticator: 16 bytes,
 * one AES block. The freshness value is a **challenge**: the receiver
 * accepts exactly one value, the one after the last it decided (fv + 1), in
 * the current session, a value drawn at every start (hal_sys_entropy()).
 * Every decision uses the challenge up, accepted or refused (auth_verify(),
 * auth_refuse()): a command is accepted only for the moment
 * it was signed for, never after a later command, a refusal, an expiry or a
 * restart. The receiver publishes the challenge in an authenticated status
 * (auth_status_mac(): its own MAC, under another data ID), so that a sender
 * never signs for a value a node without the key made up.
 *
 * Brute force: AUTH_LOCK_TRIES MAC checks failed in a row lock the receiver
 * for AUTH_LOCK_US (every command refused unchecked), and every further
 * failure before an accepted command locks it again.
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
/** @brief Bytes of the CMAC carried in PARAM_AUTH and AUTH_CHALLENGE. */
#define AUTH_MAC_LEN     4u
/** @brief Bits of the freshness value: PARAM_AUTH and AUTH_CHALLENGE carry it whole. */
#define AUTH_FV_BITS     20u
/** @brief The last freshness value of a session: a new session must follow. */
#define AUTH_FV_MAX      ((UINT32_C(1) << AUTH_FV_BITS) - 1u)
/** @brief Refusals counted, at most (15 bits in AUTH_STATUS; a flag says when
 *         the count stopped there). */
#define AUTH_REFUSED_MAX 32767u
/** @brief MAC checks failed in a row that lock the receiver. */
#define AUTH_LOCK_TRIES  4u
/** @brief How long a lock lasts [µs of the receiver's time]. */
#define AUTH_LOCK_US     UINT64_C(10000000)

/** @brief Outcome of a decision: AUTH_STATUS_last (mstc.dbc). */
typedef enum {
    AUTH_OK = 0,      /**< accepted (AUTH_STATUS_last "ok"; also before any decision) */
    AUTH_MISSING = 1, /**< a command without its PARAM_AUTH, or the reverse */
    AUTH_MAC = 2,     /**< the MAC does not verify: wrong key, forged, corrupted */
    AUTH_STALE = 3,   /**< not the current challenge: a replay, or a sender out of step */
    AUTH_NO_KEY = 4,  /**< no key was given, or no new session could be drawn */
    AUTH_LOCKED = 5,  /**< refused unchecked: too many failed MAC checks */
    AUTH_EXPIRED = 6, /**< no command came for the challenge in time (not a refusal) */
} auth_result_t;

/** @brief Receiver state: key, CMAC subkeys, session, challenge, refusals, lock. */
typedef struct {
    uint8_t key[AUTH_KEY_LEN];
    uint8_t k1[AUTH_CMAC_LEN]; /**< CMAC subkeys (RFC 4493, Generate_Subkey) */
    uint8_t k2[AUTH_CMAC_LEN];
    bool keyed;               /**< a key was given */
    uint32_t session;         /**< drawn at start, and when a session's values are spent */
    uint32_t fv;              /**< last freshness value decided: the challenge is fv + 1 */
    uint8_t outcome;          /**< auth_result_t of the decision of fv */
    uint16_t refused;         /**< refusals, up to AUTH_REFUSED_MAX */
    bool refused_saturated;   /**< refused stopped at AUTH_REFUSED_MAX: more came */
    uint8_t fails;            /**< MAC checks failed in a row */
    uint64_t locked_until_us; /**< refusing everything unchecked before this time */
} auth_t;

/** @brief No key (every command refused with AUTH_NO_KEY), session 0, freshness 0. */
void auth_init(auth_t *s);

/**
 * @brief Take key @p key and start session @p session (freshness 0: the
 *        challenge is 1). Refusals are kept.
 */
void auth_set_key(auth_t *s, const uint8_t key[AUTH_KEY_LEN], uint32_t session);

/** @brief Start session @p session: freshness 0, every earlier challenge dead. */
void auth_new_session(auth_t *s, uint32_t session);

/**
 * @brief AES-128-CMAC (RFC 4493) of @p len bytes of @p msg under the key of
 *        @p s (all zeros when it has none) into @p mac: messages of one
 *        block, all the firmware authenticates.
 * @retval 0 done. @retval -EINVAL @p len is more than AUTH_CMAC_LEN.
 */
int auth_cmac(const auth_t *s, const uint8_t *msg, size_t len, uint8_t mac[AUTH_CMAC_LEN]);

/**
 * @brief The authenticator a sender puts in PARAM_AUTH bytes 4..7: the first
 *        AUTH_MAC_LEN bytes of the CMAC of @p data_id, @p data, @p session
 *        and @p fv.
 */
void auth_mac(const auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
              uint32_t session, uint32_t fv, uint8_t mac[AUTH_MAC_LEN]);

/**
 * @brief The authenticator of the receiver's status (AUTH_CHALLENGE bytes
 *        4..7): auth_mac() of @p data_id, the status (outcome; the refusal
 *        count with its saturation flag in bit 15, big-endian; three zero
 *        bytes), the session and fv.
 */
void auth_status_mac(const auth_t *s, uint16_t data_id, uint8_t mac[AUTH_MAC_LEN]);

/**
 * @brief Decide a command: @p data under @p data_id, with freshness @p fv
 *        (as sent: AUTH_FV_BITS bits) and the truncated MAC @p mac, at time
 *        @p now_us. Accepted only when @p fv is the challenge and the MAC
 *        verifies; either way the challenge is used up.
 * @retval AUTH_OK accepted.
 * @retval AUTH_NO_KEY, AUTH_LOCKED, AUTH_STALE, AUTH_MAC refused (and counted).
 */
auth_result_t auth_verify(auth_t *s, uint16_t data_id, const uint8_t data[AUTH_DATA_LEN],
                          uint32_t fv, const uint8_t mac[AUTH_MAC_LEN], uint64_t now_us);

/**
 * @brief Decide the challenge without a command for it, as @p why (not
 *        AUTH_OK): used up, and counted unless @p why is AUTH_EXPIRED (it
 *        expired unused: no command was refused).
 */
void auth_refuse(auth_t *s, auth_result_t why);

/** @brief Whether the session's freshness values are spent (a new session is due). */
static inline bool auth_spent(const auth_t *s) { return s->fv >= AUTH_FV_MAX; }

#endif /* MSTC_AUTH_H */
