/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of firmware/auth: AES-128-CMAC against RFC 4493's examples,
 * the SecOC-style authenticator and the freshness check (auth.h).
 *
 * Expected values: the CMACs are RFC 4493's (section 4); the authenticators
 * of commands were computed with Python's `cryptography` (CMAC over AES-128)
 * and written here; the freshness values by hand from auth.h's rule.
 */
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
 * their authenticators under key, data ID 0x1120 (cryptography's CMAC). */
static const uint8_t arm_data[AUTH_DATA_LEN] = { 0x80, 0x00, 0x00, 0x80, 0x3F, 0x00 };
static const uint8_t arm_mac_fv1[AUTH_MAC_LEN] = { 0xDE, 0x2C, 0xBC, 0x55 };
static const uint8_t arm_mac_fv2[AUTH_MAC_LEN] = { 0x33, 0x04, 0xDE, 0xBD };
/* The same command under the key 00 01 .. 0f, freshness 1. */
static const uint8_t arm_mac_other_key[AUTH_MAC_LEN] = { 0xC5, 0xED, 0x37, 0x85 };
#define DATA_ID 0x1120u

void setUp(void)
{
    auth_init(&s);
    auth_set_key(&s, key, 0u);
}
void tearDown(void) {}

/* ------------------------------------------------------------------- CMAC */

static void check_cmac(size_t len, const uint8_t want[16])
{
    uint8_t mac[AUTH_CMAC_LEN];
    auth_cmac(&s, m, len, mac);
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

static void test_auth_cmac_of_40_bytes_is_rfc_4493_example_3(void)
{
    static const uint8_t t[16] = { 0xdf, 0xa6, 0x67, 0x47, 0xde, 0x9a, 0xe6, 0x30,
                                   0x30, 0xca, 0x32, 0x61, 0x14, 0x97, 0xc8, 0x27 };
    check_cmac(40, t);
}

static void test_auth_cmac_of_four_blocks_is_rfc_4493_example_4(void)
{
    static const uint8_t t[16] = { 0x51, 0xf0, 0xbe, 0xbf, 0x7e, 0x3b, 0x9d, 0x92,
                                   0xfc, 0x49, 0x74, 0x17, 0x79, 0x36, 0x3c, 0xfe };
    check_cmac(64, t);
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
    auth_mac(&s, DATA_ID, arm_data, 1u, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(arm_mac_fv1, mac, AUTH_MAC_LEN);
    auth_mac(&s, DATA_ID, arm_data, 2u, mac);
    TEST_ASSERT_EQUAL_HEX8_ARRAY(arm_mac_fv2, mac, AUTH_MAC_LEN);
}

static void test_auth_accepts_a_fresh_command_once(void)
{
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1));
    TEST_ASSERT_EQUAL_UINT32(1u, s.fv);
    /* The same again (a replay): stale, counted; the freshness stays. */
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1));
    TEST_ASSERT_EQUAL_UINT32(1u, s.fv);
    TEST_ASSERT_EQUAL_UINT16(1u, s.refused);
    TEST_ASSERT_EQUAL_UINT8(AUTH_STALE, s.last);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 2u, arm_mac_fv2));
    TEST_ASSERT_EQUAL_UINT32(2u, s.fv);
    /* An older one: stale too. */
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1));
    TEST_ASSERT_EQUAL_UINT16(2u, s.refused);
}

static void test_auth_refuses_another_key_a_changed_command_or_a_changed_mac(void)
{
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_other_key));
    uint8_t data[AUTH_DATA_LEN];
    memcpy(data, arm_data, sizeof data);
    data[5] ^= 0x01u; /* the spare byte: covered too */
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, data, 1u, arm_mac_fv1));
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID + 1u, arm_data, 1u, arm_mac_fv1));
    for (size_t i = 0; i < AUTH_MAC_LEN * 8u; i++) {
        uint8_t mac[AUTH_MAC_LEN];
        memcpy(mac, arm_mac_fv1, sizeof mac);
        mac[i / 8u] ^= (uint8_t)(1u << (i % 8u));
        TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, mac));
    }
    TEST_ASSERT_EQUAL_UINT16(3u + 32u, s.refused);
    TEST_ASSERT_EQUAL_UINT8(AUTH_MAC, s.last);
    TEST_ASSERT_EQUAL_UINT32(0u, s.fv); /* nothing accepted */
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1));
}

static void test_auth_without_a_key_refuses_everything(void)
{
    auth_init(&s);
    TEST_ASSERT_FALSE(s.keyed);
    TEST_ASSERT_EQUAL_INT(AUTH_NO_KEY, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1));
    TEST_ASSERT_EQUAL_UINT16(1u, s.refused);
    TEST_ASSERT_EQUAL_UINT8(AUTH_NO_KEY, s.last);
}

/* A sender's authenticator for freshness @p fv, by the code under test:
 * auth_mac() itself is checked above against independent values. */
static void mac_for(uint32_t fv, uint8_t mac[AUTH_MAC_LEN])
{
    auth_mac(&s, DATA_ID, arm_data, fv, mac);
}

static void test_auth_freshness_is_the_next_value_with_the_low_bits_sent(void)
{
    uint8_t mac[AUTH_MAC_LEN];
    /* Last accepted 0x000FFFFE; low bits 0xFFFFF: 0x000FFFFF. */
    auth_set_key(&s, key, 0x000FFFFEu);
    mac_for(0x000FFFFFu, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 0xFFFFFu, mac));
    TEST_ASSERT_EQUAL_UINT32(0x000FFFFFu, s.fv);
    /* Low bits 0x00000 now: across the carry, 0x00100000. */
    mac_for(0x00100000u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 0x00000u, mac));
    TEST_ASSERT_EQUAL_UINT32(0x00100000u, s.fv);
    /* A jump ahead within 2^20: low bits 0x12345 give 0x00112345. */
    mac_for(0x00112345u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 0x12345u, mac));
    TEST_ASSERT_EQUAL_UINT32(0x00112345u, s.fv);
    /* Only the low 20 bits of what is received count. */
    mac_for(0x00112346u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 0xFFF12346u, mac));
    /* A value 2^20 or more ahead cannot be told from one behind: its MAC
     * does not verify with the value reconstructed. */
    mac_for(0x00212347u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 0x12347u, mac));
}

static void test_auth_freshness_stops_at_its_end(void)
{
    uint8_t mac[AUTH_MAC_LEN];
    auth_set_key(&s, key, 0xFFFFFFFEu);
    mac_for(0xFFFFFFFFu, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 0xFFFFFu, mac));
    /* Spent: every value is at or below the last; the same command again is
     * stale, a wrapped one (0 after 2^32 - 1) does not verify. */
    TEST_ASSERT_EQUAL_INT(AUTH_STALE, auth_verify(&s, DATA_ID, arm_data, 0xFFFFFu, mac));
    mac_for(0u, mac);
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 0u, mac));
    TEST_ASSERT_EQUAL_UINT32(0xFFFFFFFFu, s.fv);
}

static void test_auth_refusals_saturate_at_4095(void)
{
    for (unsigned k = 0; k < AUTH_REFUSED_MAX + 10u; k++) {
        auth_refuse(&s, AUTH_MISSING);
    }
    TEST_ASSERT_EQUAL_UINT16(AUTH_REFUSED_MAX, s.refused);
    TEST_ASSERT_EQUAL_UINT8(AUTH_MISSING, s.last);
}

static void test_auth_a_new_key_restarts_the_freshness_and_keeps_the_count(void)
{
    TEST_ASSERT_EQUAL_INT(AUTH_MAC, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_other_key));
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_fv1));
    static const uint8_t other[AUTH_KEY_LEN] = { 0, 1, 2,  3,  4,  5,  6,  7,
                                                 8, 9, 10, 11, 12, 13, 14, 15 };
    auth_set_key(&s, other, 0u);
    TEST_ASSERT_EQUAL_UINT32(0u, s.fv);
    TEST_ASSERT_EQUAL_UINT16(1u, s.refused);
    TEST_ASSERT_EQUAL_INT(AUTH_OK, auth_verify(&s, DATA_ID, arm_data, 1u, arm_mac_other_key));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_auth_cmac_of_the_empty_message_is_rfc_4493_example_1);
    RUN_TEST(test_auth_cmac_of_one_block_is_rfc_4493_example_2);
    RUN_TEST(test_auth_cmac_of_40_bytes_is_rfc_4493_example_3);
    RUN_TEST(test_auth_cmac_of_four_blocks_is_rfc_4493_example_4);
    RUN_TEST(test_auth_cmac_subkeys_are_rfc_4493_s);
    RUN_TEST(test_auth_mac_of_a_command_is_secoc_s);
    RUN_TEST(test_auth_accepts_a_fresh_command_once);
    RUN_TEST(test_auth_refuses_another_key_a_changed_command_or_a_changed_mac);
    RUN_TEST(test_auth_without_a_key_refuses_everything);
    RUN_TEST(test_auth_freshness_is_the_next_value_with_the_low_bits_sent);
    RUN_TEST(test_auth_freshness_stops_at_its_end);
    RUN_TEST(test_auth_refusals_saturate_at_4095);
    RUN_TEST(test_auth_a_new_key_restarts_the_freshness_and_keeps_the_count);
    return UNITY_END();
}
