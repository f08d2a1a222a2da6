/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/auth: AES-128-CMAC against RFC 4493's examples,
 * the SecOC-style authenticators of commands and of the status, the
 * challenge (every decision uses it up), sessions, the lock after failed
 * MAC checks and the refusal count (auth.h).
 *
 * Expected values: the CMACs are RFC 4493's (section 4) and, for 13 bytes,
 * `cryptography`'s; the authenticators
 * were computed with Python's `cryptography` (CMAC over AES-128) from the
 * layouts auth.h states, and written here; counts and times by hand from
 * auth.h's rules.
 */
#include <errno.h>
#include <string.h>

#include "auth/auth.h"
#include "test_util.h"
#include "unity.h"

static auth_t s;

/* RFC 4493's key (tests/data/test.key) and message M. */
static const uint8_t key[AUTH_KEY_LEN] = { 0x2b, 0x7e, 0x15, 0x16, 0x28, 0xae, 0xd2, 0xa6,
                                           0xab, 0xf7, 0x15, 0x88, 0x09, 0xcf, 0x4f, 0x3c };
static const uint8_t m[64] = {
    0x6b, 0xc1, 0xbe, 0xe2, 0x2e, 0x40, 0x9f, 0x96, 0xe9, 0x3d, 0x7e, 0x11, 0x73, 0x93, 0x17, 0x2a,
    0xae, 0x2d, 0x8a, 0x57, 0x1e, 0x03, 0xac, 0x9c, 0x9e, 0xb7, 0x6f, 0xac, 0x45, 0xaf, 0x8e, 0x51,
    0x30, 0xc8, 0x1c, 0x46, 0xa3, 0x5c, 0xe4, 0x11, 0xe5, 0xfb, 0xc1, 0x19, 0x1a, 0x0a, 0x52, 0xef,
    0xf6, 0x9f, 0x24, 0x45, 0xdf, 0x4f, 0x9b, 0x17, 0xad, 0x2b, 0x41, 0x7b, 0xe6, 0x6c, 0x37, 0x10,
};

/* PARAM_SET bytes 2..7 of the arm command (index 128, 1.0f, spare 0) and
 * their authenticators under key, data ID 0x1120, session SESSION
 * (cryptography's CMAC over 11 20 | data | session | freshness). */
#define SESSION 0x5EC0A1D1u
static const uint8_t arm_data[AUTH_DATA_LEN] = { 0x80, 0x00, 0x00, 0x80, 0x3F, 0x00 };
static const uint8_t arm_mac_fv1[AUTH_MAC_LEN] = { 0x3A, 0x4C, 0xB7, 0xE5 };
static const uint8_t arm_mac_fv2[AUTH_MAC_LEN] = { 0x33, 0x8C, 0x15, 0xC5 };
/* The same command, freshness 1, under the key 00 01 .. 0f; in session 0;
 * in session SESSION + 1. */
static const uint8_t arm_mac_other_key[AUTH_MAC_LEN] = { 0x52, 0x8D, 0x90, 0x4D };
static const uint8_t arm_mac_session_0[AUTH_MAC_LEN] = { 0x4E, 0xE5, 0xE0, 0x36 };
static const uint8_t arm_mac_next_session[AUTH_MAC_LEN] = { 0x9A, 0xD1, 0x6F, 0xF3 };
#define DATA_ID        0x1120u
#define STATUS_DATA_ID 0x1187u

void setUp(void)
{
    auth_init(&s);
    auth_set_key(&s, key, SESSION);
}
void tearDown(void) {}

/* ------------------------------------------------------------------- CMAC */

static void check_cmac(size_t len, const uint8_t want[16])
{
    uint8_t mac[AUTH_CMAC_LEN];
    TEST_ASSERT_EQUAL_INT(0, auth_cmac(&s, m, len, mac));
    TEST_ASSERT_EQUAL_HEX8_ARRAY(want, mac, 16);
}

static void test_auth_cmac_of_the_empty_message_is_rfc_4493_example_1(void)
{
    static const uint8_t t[16] = { 0xbb, 0x1d, 0x69, 0x29, 0xe9, 0x59, 0x37, 0x28,
                                   0x7f, 0xa3, 0x7d, 0x12, 0x9b, 0x75, 0x67, 0x46 };
    check_cmac(0, t);
}

static void test_auth_cmac_of_one_block_is_rfc_4493_example_2(void)
{
    static const uint8_t t[16] = { 0x07, 0x0a, 0x16, 0xb4, 0x6b, 0x4d, 0x41, 0x44,
                                   0xf7, 0x9b, 0xdd, 0x9d, 0xd0, 0x4a, 0x28, 0x7c };
    check_cmac(16, t);
}

static void test_auth_cmac_of_13_bytes_is_the_reference_s(void)
{
    /* The status's length: cryptography's CMAC of M's first 13 bytes. */
    static const uint8_t t[16] = { 0xed, 0x80, 0xb9, 0xa7, 0xa5, 0x41, 0x6c, 0xa0,
                                   0xea, 0xb5, 0x52, 0xa4, 0x13, 0x92, 0x3c, 0xc4 };
    check_cmac(13, t);
}

static void test_auth_cmac_refuses_more_than_one_block(void)
{
    /* RFC 4493's examples 3 and 4 (40 and 64 bytes) are beyond what the
     * firmware authenticates: refused, nothing written. */
    uint8_t mac[AUTH_CMAC_LEN];
    memset(mac, 0x5A, sizeof mac);
    TEST_ASSERT_EQUAL_INT(-EINVAL, auth_cmac(&s, m, 17, mac));
    TEST_ASSERT_EQUAL_INT(-EINVAL, auth_cmac(&s, m, 40, mac));
    TEST_ASSERT_EACH_EQUAL_HEX8(0x5A, mac, sizeof mac);
}

static void test_auth_cmac_subkeys_are_rfc_4493_s(void)
{
    /* RFC 4493, section 4, Subkey Generation. */
    static const uint8_t k1[16] = { 0xfb, 0xee, 0xd6, 0x18, 0x35, 0x71, 0x33, 0x66,
                                    0x7c, 0x85, 0xe0, 0x8f, 0x72, 0x36, 0xa8, 0xde };
    static const uint8_t k2[16] = { 0xf7, 0xdd, 0xac, 0x30, 0x6a, 0xe2, 0x66, 0xcc,
                                    0xf9, 0x0b, 0xc1, 0x1e, 0xe4, 0x6d, 0x51, 0x3b };
    TEST_ASSERT_EQUAL_HEX8_ARRAY(k1, s.k1, 16);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(k2, s.k2, 16);
}

/* --------------------------------------------------------- authenticator */

static void test_auth_mac_of_a_command_is_secoc_s(void)
{
    uint8_t mac[AUTH_MAC_LEN];
    auth_mac(&s, DATA_ID, arm_data, SESSION, 1u, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(arm_mac_fv1, mac, AUTH_MAC_LEN);
    auth_mac(&s, DATA_ID, arm_data, SESSION, 2u, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(arm_mac_fv2, mac, AUTH_MAC_LEN);
    auth_mac(&s, DATA_ID, arm_data, 0u, 1u, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(arm_mac_session_0, mac, AUTH_MAC_LEN);
}

static void test_auth_status_mac_covers_session_freshness_outcome_and_count(void)
{
    /* cryptography's CMAC over 11 87 | outcome | refused (bit 15:
     * saturated) | 00 00 00 | session | fv, first 4 bytes. */
    static const uint8_t start[AUTH_MAC_LEN] = { 0x9A, 0x8F, 0xD4, 0x0D };
    static const uint8_t after[AUTH_MAC_LEN] = { 0xB8, 0xF7, 0xDB, 0x06 };
    static const uint8_t saturated[AUTH_MAC_LEN] = { 0x60, 0xAE, 0x63, 0xEA };
    uint8_t mac[AUTH_MAC_LEN];
    auth_status_mac(&s, STATUS_DATA_ID, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(start, mac, AUTH_MAC_LEN);
    /* A command with a wrong MAC (fv 1, one refusal), then an expiry (fv 2,
     * outcome expired, not counted). */
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_other_key, 0u));
    auth_refuse(&s, AUTH_EXPIRED);
    auth_status_mac(&s, STATUS_DATA_ID, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(after, mac, AUTH_MAC_LEN);
    s.fv = 5u;
    s.outcome = (uint8_t)AUTH_STALE;
    s.refused = AUTH_REFUSED_MAX;
    s.refused_saturated = true;
    auth_status_mac(&s, STATUS_DATA_ID, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(saturated, mac, AUTH_MAC_LEN);
}

static void test_auth_accepts_the_challenge_once(void)
{
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
    TEST_ASSERT_EQUAL_UINT32(1u, s.fv);
    TEST_ASSERT_EQUAL_UINT8(AUTH_OK, s.outcome);
    /* The same again (a replay): stale, counted, and the challenge used up. */
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
    TEST_ASSERT_EQUAL_UINT32(2u, s.fv);
    TEST_ASSERT_EQUAL_UINT16(1u, s.refused);
    TEST_ASSERT_EQUAL_UINT8(AUTH_STALE, s.outcome);
    /* So fv 2 was decided too: a command signed for it is now stale. */
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 2u, arm_mac_fv2, 0u));
    TEST_ASSERT_EQUAL_UINT32(3u, s.fv);
}

static void test_auth_every_refusal_uses_the_challenge_up(void)
{
    /* A command for fv 1 under another key: refused, and the genuine one for
     * fv 1, kept back until then, is stale afterwards (issue 21, case 2). */
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_other_key, 0u));
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
    /* A refusal without a check (missing) and an expiry use it up as well. */
    auth_init(&s);
    auth_set_key(&s, key, SESSION);
    auth_refuse(&s, AUTH_MISSING);
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
    auth_init(&s);
    auth_set_key(&s, key, SESSION);
    auth_refuse(&s, AUTH_EXPIRED);
    TEST_ASSERT_EQUAL_UINT16(0u, s.refused); /* not a refusal */
    TEST_ASSERT_EQUAL_UINT8(AUTH_EXPIRED, s.outcome);
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
}

static void test_auth_a_command_of_another_session_is_refused(void)
{
    /* Signed in session 0 (an earlier start): the MAC covers the session. */
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_session_0, 0u));
    /* The next start: this session's command for fv 1 is refused there, and
     * that session's own is accepted. */
    auth_new_session(&s, SESSION + 1u);
    TEST_ASSERT_EQUAL_UINT32(0u, s.fv);
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
    auth_new_session(&s, SESSION + 1u);
    TEST_ASSERT_EQUAL_INT(AUTH_OK,
                          auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_next_session, 0u));
}

static void test_auth_refuses_another_key_a_changed_command_or_a_changed_mac(void)
{
    uint8_t data[AUTH_DATA_LEN];
    memcpy(data, arm_data, sizeof data);
    data[5] ^= 0x01u; /* the spare byte: covered too */
    /* Each try on a fresh receiver: the lock would refuse the fifth. */
    const struct {
        uint16_t id;
        const uint8_t *d;
        const uint8_t *mac;
    } bad[] = {
        { DATA_ID, arm_data, arm_mac_other_key },
        { DATA_ID, data, arm_mac_fv1 },
        { DATA_ID + 1u, arm_data, arm_mac_fv1 },
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; k++) {
        auth_set_key(&s, key, SESSION);
        s.fails = 0u;
        TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, bad[k].id, bad[k].d, 1u, bad[k].mac, 0u));
    }
    for (size_t i = 0; i < AUTH_MAC_LEN * 8u; i++) {
        uint8_t mac[AUTH_MAC_LEN];
        memcpy(mac, arm_mac_fv1, sizeof mac);
        mac[i / 8u] ^= (uint8_t)(1u << (i % 8u));
        auth_set_key(&s, key, SESSION);
        s.fails = 0u;
        TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, mac, 0u));
    }
    TEST_ASSERT_EQUAL_UINT16(3u + 32u, s.refused);
    TEST_ASSERT_EQUAL_UINT8(AUTH_MAC, s.outcome);
    auth_set_key(&s, key, SESSION);
    s.fails = 0u;
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
}

static void test_auth_without_a_key_refuses_everything(void)
{
    auth_init(&s);
    TEST_ASSERT_FALSE(s.keyed);
    TEST_ASSERT_EQUAL_INT(AUTH_NO_KEY, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1, 0u));
    TEST_ASSERT_EQUAL_UINT16(1u, s.refused);
    TEST_ASSERT_EQUAL_UINT8(AUTH_NO_KEY, s.outcome);
}

/* The authenticator of the arm command for freshness @p fv in this session,
 * by the code under test: auth_mac() is checked above against independent
 * values. */
static void mac_for(uint32_t fv, uint8_t mac[AUTH_MAC_LEN])
{
    auth_mac(&s, DATA_ID, arm_data, s.session, fv, mac);
}

static void test_auth_four_failed_checks_lock_for_ten_seconds(void)
{
    uint8_t mac[AUTH_MAC_LEN];
    const uint64_t t0 = 1000000u;
    for (unsigned k = 0; k < AUTH_LOCK_TRIES; k++) {
        TEST_ASSERT_EQUAL_UINT64(0u, s.locked_until_us);
        TEST_ASSERT_EQUAL_INT(AUTH_MAC,
                              auth_verify(&s, DATA_ID, arm_data, s.fv + 1u, arm_mac_other_key, t0));
    }
    TEST_ASSERT_EQUAL_UINT64(t0 + 10000000u, s.locked_until_us);
    /* Locked: even the genuine command is refused, unchecked, until 10 s on. */
    mac_for(s.fv + 1u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_LOCKED, auth_verify(&s, DATA_ID, arm_data, s.fv + 1u, mac, t0));
    mac_for(s.fv + 1u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_LOCKED,
                          auth_verify(&s, DATA_ID, arm_data, s.fv + 1u, mac, t0 + 9999999u));
    TEST_ASSERT_EQUAL_UINT8(AUTH_LOCKED, s.outcome);
    mac_for(s.fv + 1u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_OK,
                          auth_verify(&s, DATA_ID, arm_data, s.fv + 1u, mac, t0 + 10000000u));
    TEST_ASSERT_EQUAL_UINT8(0u, s.fails);
}

static void test_auth_after_a_lock_each_failure_locks_again(void)
{
    const uint64_t t0 = 0u;
    for (unsigned k = 0; k < AUTH_LOCK_TRIES; k++) {
        (void)auth_verify(&s, DATA_ID, arm_data, s.fv + 1u, arm_mac_other_key, t0);
    }
    /* Over at t0 + 10 s: one more failure locks again, until t0 + 20 s. */
    const uint64_t t1 = t0 + AUTH_LOCK_US;
    TEST_ASSERT_EQUAL_INT(AUTH_MAC,
                          auth_verify(&s, DATA_ID, arm_data, s.fv + 1u, arm_mac_other_key, t1));
    TEST_ASSERT_EQUAL_UINT64(t1 + AUTH_LOCK_US, s.locked_until_us);
    /* Stale or missing ones teach nothing: they do not lock. */
    auth_init(&s);
    auth_set_key(&s, key, SESSION);
    for (unsigned k = 0; k < 100u; k++) {
        TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 0u, arm_mac_fv1, t0));
        auth_refuse(&s, AUTH_MISSING);
    }
    TEST_ASSERT_EQUAL_UINT64(0u, s.locked_until_us);
    TEST_ASSERT_EQUAL_UINT8(0u, s.fails);
}

static void test_auth_a_spent_session_accepts_nothing(void)
{
    uint8_t mac[AUTH_MAC_LEN];
    s.fv = AUTH_FV_MAX - 1u;
    mac_for(AUTH_FV_MAX, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, AUTH_FV_MAX, mac, 0u));
    TEST_ASSERT_TRUE(auth_spent(&s));
    /* 2^20 would be the next value, which PARAM_AUTH cannot carry: nothing,
     * not even a wrapped 0, is accepted until a new session starts. */
    mac_for(0u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_NO_KEY, auth_verify(&s, DATA_ID, arm_data, 0u, mac, 0u));
    TEST_ASSERT_EQUAL_UINT32(AUTH_FV_MAX, s.fv);
    auth_new_session(&s, SESSION + 1u);
    TEST_ASSERT_FALSE(auth_spent(&s));
    TEST_ASSERT_EQUAL_INT(AUTH_OK,
                          auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_next_session, 0u));
}

static void test_auth_the_refusal_count_says_when_it_stops(void)
{
    for (unsigned k = 0; k < AUTH_REFUSED_MAX; k++) {
        auth_refuse(&s, AUTH_MISSING);
    }
    TEST_ASSERT_EQUAL_UINT16(AUTH_REFUSED_MAX, s.refused);
    TEST_ASSERT_FALSE(s.refused_saturated);
    auth_refuse(&s, AUTH_MISSING);
    TEST_ASSERT_EQUAL_UINT16(AUTH_REFUSED_MAX, s.refused);
    TEST_ASSERT_TRUE(s.refused_saturated);
    TEST_ASSERT_EQUAL_UINT8(AUTH_MISSING, s.outcome);
}

static void test_auth_a_new_key_restarts_the_session_and_keeps_the_count(void)
{
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_other_key, 0u));
    static const uint8_t other[AUTH_KEY_LEN] = { 0, 1, 2,  3,  4,  5,  6,  7,
                                                 8, 9, 10, 11, 12, 13, 14, 15 };
    auth_set_key(&s, other, SESSION);
    TEST_ASSERT_EQUAL_UINT32(0u, s.fv);
    TEST_ASSERT_EQUAL_UINT16(1u, s.refused);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_other_key, 0u));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_auth_cmac_of_the_empty_message_is_rfc_4493_example_1);
    RUN_TEST(test_auth_cmac_of_one_block_is_rfc_4493_example_2);
    RUN_TEST(test_auth_cmac_of_13_bytes_is_the_reference_s);
    RUN_TEST(test_auth_cmac_refuses_more_than_one_block);
    RUN_TEST(test_auth_cmac_subkeys_are_rfc_4493_s);
    RUN_TEST(test_auth_mac_of_a_command_is_secoc_s);
    RUN_TEST(test_auth_status_mac_covers_session_freshness_outcome_and_count);
    RUN_TEST(test_auth_accepts_the_challenge_once);
    RUN_TEST(test_auth_every_refusal_uses_the_challenge_up);
    RUN_TEST(test_auth_a_command_of_another_session_is_refused);
    RUN_TEST(test_auth_refuses_another_key_a_changed_command_or_a_changed_mac);
    RUN_TEST(test_auth_without_a_key_refuses_everything);
    RUN_TEST(test_auth_four_failed_checks_lock_for_ten_seconds);
    RUN_TEST(test_auth_after_a_lock_each_failure_locks_again);
    RUN_TEST(test_auth_a_spent_session_accepts_nothing);
    RUN_TEST(test_auth_the_refusal_count_says_when_it_stops);
    RUN_TEST(test_auth_a_new_key_restarts_the_session_and_keeps_the_count);
    return UNITY_END();
}
