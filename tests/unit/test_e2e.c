/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the E2E receiver of firmware/comm (comm.h, docs/safety.md):
 * - every 1-, 2- and 3-bit flip of every frame the firmware receives, over
 *   random payloads, is detected (exhaustively: CRC-8H2F's Hamming distance
 *   of 4 over the 80-bit codeword of data ID, payload and CRC), and some
 *   4-bit flip is not, so the bound is the real one;
 * - the per-frame status for every counter step 0..15;
 * - each transition of the window state machine.
 *
 * Expected values: the spec in docs/safety.md (AUTOSAR E2E profile statuses
 * and E2E_SMCheck), derived by hand for each sequence below; frames are built
 * with tests/unit/test_frames.h (its own CRC).
 */
#include <errno.h>
#include <string.h>

#include "comm/comm.h"
#include "test_frames.h"
#include "test_util.h"
#include "unity.h"

static comm_t c;

void setUp(void)
{
    comm_init(&c);
    memset(tf_counters, 0, sizeof tf_counters);
}
void tearDown(void) {}

/* Every identifier the firmware receives. */
static const uint32_t rx_ids[] = {
    COMM_ID_ODOM_XY, COMM_ID_ODOM_THETA, COMM_ID_REF_XY,    COMM_ID_REF_MOTION,
    COMM_ID_STEP,    COMM_ID_OBSTACLE,   COMM_ID_PARAM_SET, COMM_ID_PARAM_GET,
};
#define N_RX (sizeof rx_ids / sizeof rx_ids[0])

/* xorshift32: the test's own seeded generator. */
static uint32_t rng_state = 0x12345678u;
static uint32_t rng(void)
{
    uint32_t x = rng_state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    rng_state = x;
    return x;
}

static comm_e2e_status_t last_status(uint32_t id)
{
    return (comm_e2e_status_t)comm_rx(&c, id)->status;
}
static comm_sm_state_t sm_state(uint32_t id) { return (comm_sm_state_t)comm_rx(&c, id)->state; }

static const uint8_t zeros[8] = { 0 };

/* Decode a PARAM_GET with counter @p counter; return comm_decode's result. */
static int get_with(uint8_t counter)
{
    const hal_can_frame_t f = tf_seal_with(COMM_ID_PARAM_GET, zeros, counter);
    comm_msg_t m;
    return comm_decode(&c, &f, &m);
}

/* ------------------------------------------------------------- bit flips */

#define PAYLOADS_PER_FRAME 12u

/* Decode @p f with bits @p b[0..n-1] of its 64 flipped; true when dropped
 * for its CRC. */
static bool flip_detected(const hal_can_frame_t *f, const unsigned *b, unsigned n)
{
    hal_can_frame_t g = *f;
    for (unsigned k = 0; k < n; k++) {
        g.data[b[k] / 8u] ^= (uint8_t)(1u << (b[k] % 8u));
    }
    comm_msg_t m;
    return comm_decode(&c, &g, &m) == -EBADMSG;
}

static void test_e2e_every_1_2_and_3_bit_flip_of_every_received_frame_is_detected(void)
{
    unsigned long checked = 0;
    unsigned long missed = 0;
    for (size_t i = 0; i < N_RX; i++) {
        for (unsigned p = 0; p < PAYLOADS_PER_FRAME; p++) {
            uint8_t payload[8];
            for (unsigned k = 0; k < 8u; k++) {
                payload[k] = (uint8_t)rng();
            }
            const hal_can_frame_t f = tf_seal_with(rx_ids[i], payload, (uint8_t)(rng() & 0x0Fu));
            unsigned b[3];
            for (b[0] = 0; b[0] < 64u; b[0]++) {
                missed += flip_detected(&f, b, 1) ? 0u : 1u;
                for (b[1] = b[0] + 1u; b[1] < 64u; b[1]++) {
                    missed += flip_detected(&f, b, 2) ? 0u : 1u;
                    for (b[2] = b[1] + 1u; b[2] < 64u; b[2]++) {
                        missed += flip_detected(&f, b, 3) ? 0u : 1u;
                    }
                }
            }
            checked += 64u + 2016u + 41664u; /* C(64,1) + C(64,2) + C(64,3) */
        }
    }
    TEST_ASSERT_EQUAL_UINT32(N_RX * PAYLOADS_PER_FRAME * 43744u, checked);
    TEST_ASSERT_EQUAL_UINT32_MESSAGE(0, missed, "an undetected flip of at most 3 bits");
}

static void test_e2e_some_4_bit_flip_goes_undetected_so_the_bound_is_tight(void)
{
    /* Hamming distance exactly 4: the test above could fail if the CRC were
     * weaker, and this one shows that its claim is no stronger than true. */
    const hal_can_frame_t f = tf_seal_with(COMM_ID_ODOM_XY, zeros, 0);
    unsigned b[4];
    for (b[0] = 0; b[0] < 64u; b[0]++) {
        for (b[1] = b[0] + 1u; b[1] < 64u; b[1]++) {
            for (b[2] = b[1] + 1u; b[2] < 64u; b[2]++) {
                for (b[3] = b[2] + 1u; b[3] < 64u; b[3]++) {
                    if (!flip_detected(&f, b, 4)) {
                        return; /* found one */
                    }
                }
            }
        }
    }
    TEST_FAIL_MESSAGE("every 4-bit flip detected: the Hamming distance would be more than 4");
}

/* ------------------------------------------------------- per-frame status */

static void test_e2e_status_of_every_counter_step(void)
{
    /* From counter 5: delta 1 OK, 2..3 OK_SOME_LOST, 0 REPEATED, 4..15
     * WRONG_SEQUENCE (docs/safety.md). Each case starts from a fresh state. */
    for (uint8_t delta = 0; delta < 16u; delta++) {
        comm_init(&c);
        TEST_ASSERT_EQUAL_INT(0, get_with(5));
        TEST_ASSERT_EQUAL_INT(COMM_E2E_OK, last_status(COMM_ID_PARAM_GET)); /* the first */
        const int rc = get_with((uint8_t)((5u + delta) & 0x0Fu));
        comm_e2e_status_t want;
        int want_rc;
        if (delta == 1u) {
            want = COMM_E2E_OK, want_rc = 0;
        } else if (delta == 0u) {
            want = COMM_E2E_REPEATED, want_rc = -EALREADY;
        } else if (delta <= 3u) {
            want = COMM_E2E_OK_SOME_LOST, want_rc = 0;
        } else {
            want = COMM_E2E_WRONG_SEQUENCE, want_rc = -ERANGE;
        }
        TEST_ASSERT_EQUAL_INT_MESSAGE(want_rc, rc, "return");
        TEST_ASSERT_EQUAL_INT_MESSAGE(want, last_status(COMM_ID_PARAM_GET), "status");
    }
}

static void test_e2e_status_of_a_bad_crc_and_a_bad_length(void)
{
    hal_can_frame_t f = tf_seal_with(COMM_ID_STEP, zeros, 0);
    f.data[3] ^= 0x01u;
    comm_msg_t m;
    TEST_ASSERT_EQUAL_INT(-EBADMSG, comm_decode(&c, &f, &m));
    TEST_ASSERT_EQUAL_INT(COMM_E2E_ERROR, last_status(COMM_ID_STEP));
    f = tf_seal_with(COMM_ID_STEP, zeros, 0);
    f.dlc = 7;
    TEST_ASSERT_EQUAL_INT(-EMSGSIZE, comm_decode(&c, &f, &m));
    TEST_ASSERT_EQUAL_INT(COMM_E2E_LENGTH, last_status(COMM_ID_STEP));
}

static void test_e2e_cycle_without_a_frame_is_no_new_data(void)
{
    TEST_ASSERT_EQUAL_INT(0, get_with(0));
    TEST_ASSERT_TRUE(comm_e2e_cycle(&c, COMM_ID_PARAM_GET)); /* accepted in this cycle */
    TEST_ASSERT_FALSE(comm_e2e_cycle(&c, COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(COMM_E2E_NO_NEW_DATA, last_status(COMM_ID_PARAM_GET));
    /* A cycle with only a dropped frame: not accepted, and no NO_NEW_DATA
     * on top of the frame's own status. */
    TEST_ASSERT_EQUAL_INT(-EALREADY, get_with(0));
    TEST_ASSERT_FALSE(comm_e2e_cycle(&c, COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(COMM_E2E_REPEATED, last_status(COMM_ID_PARAM_GET));
}

static void test_e2e_identifiers_not_received_have_no_receiver(void)
{
    TEST_ASSERT_NULL(comm_rx(&c, COMM_ID_WHEEL_CMD));
    TEST_ASSERT_NULL(comm_rx(&c, 0x7FFu));
    TEST_ASSERT_FALSE(comm_e2e_cycle(&c, COMM_ID_STATUS));
    TEST_ASSERT_FALSE(comm_e2e_cycle(&c, 0x7FFu));
    TEST_ASSERT_NOT_NULL(comm_rx(&c, COMM_ID_ODOM_XY));
}

static void test_e2e_each_identifier_has_its_own_receiver(void)
{
    TEST_ASSERT_EQUAL_INT(0, get_with(3));
    TEST_ASSERT_EQUAL_INT(0, get_with(4));
    TEST_ASSERT_EQUAL_INT(COMM_SM_VALID, sm_state(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(COMM_SM_NODATA, sm_state(COMM_ID_PARAM_SET));
    TEST_ASSERT_EQUAL_UINT8(0, comm_rx(&c, COMM_ID_PARAM_SET)->ok_run);
}

/* ----------------------------------------------------- window state machine */

static void test_e2e_sm_starts_in_nodata_and_ignores_errors_there(void)
{
    TEST_ASSERT_EQUAL_INT(COMM_SM_NODATA, sm_state(COMM_ID_PARAM_GET));
    hal_can_frame_t f = tf_seal_with(COMM_ID_PARAM_GET, zeros, 0);
    f.data[0] ^= 0xFFu;
    comm_msg_t m;
    (void)comm_decode(&c, &f, &m); /* ERROR */
    f.dlc = 3;
    (void)comm_decode(&c, &f, &m);               /* LENGTH */
    (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* no NO_NEW_DATA: frames came */
    (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* NO_NEW_DATA */
    TEST_ASSERT_EQUAL_INT(COMM_E2E_NO_NEW_DATA, last_status(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(COMM_SM_NODATA, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_sm_first_good_frame_inits_and_the_second_validates(void)
{
    TEST_ASSERT_EQUAL_INT(0, get_with(7));
    TEST_ASSERT_EQUAL_INT(COMM_SM_INIT, sm_state(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(0, get_with(8));
    TEST_ASSERT_EQUAL_INT(COMM_SM_VALID, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_sm_init_waits_on_repeats_and_falls_on_an_error(void)
{
    TEST_ASSERT_EQUAL_INT(0, get_with(7));
    TEST_ASSERT_EQUAL_INT(-EALREADY, get_with(7)); /* window [REPEATED]: ok 0, err 0 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INIT, sm_state(COMM_ID_PARAM_GET));
    hal_can_frame_t f = tf_seal_with(COMM_ID_PARAM_GET, zeros, 8);
    f.data[5] ^= 0x40u;
    comm_msg_t m;
    TEST_ASSERT_EQUAL_INT(-EBADMSG, comm_decode(&c, &f, &m)); /* err 1 > 0 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
}

static void corrupt_get(uint8_t counter)
{
    hal_can_frame_t f = tf_seal_with(COMM_ID_PARAM_GET, zeros, counter);
    f.data[2] ^= 0x01u;
    comm_msg_t m;
    TEST_ASSERT_EQUAL_INT(-EBADMSG, comm_decode(&c, &f, &m));
}

static void test_e2e_sm_valid_tolerates_one_error_in_the_window_not_two(void)
{
    for (uint8_t k = 0; k < 5u; k++) {
        TEST_ASSERT_EQUAL_INT(0, get_with(k)); /* INIT, then VALID: [OK OK OK OK] */
    }
    corrupt_get(5); /* [OK OK OK ERR]: err 1, ok 3 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_VALID, sm_state(COMM_ID_PARAM_GET));
    corrupt_get(5); /* [OK OK ERR ERR]: err 2 > 1 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_sm_a_wrong_length_counts_as_an_error(void)
{
    for (uint8_t k = 0; k < 5u; k++) {
        TEST_ASSERT_EQUAL_INT(0, get_with(k));
    }
    hal_can_frame_t f = tf_seal_with(COMM_ID_PARAM_GET, zeros, 5);
    f.dlc = 6;
    comm_msg_t m;
    TEST_ASSERT_EQUAL_INT(-EMSGSIZE, comm_decode(&c, &f, &m)); /* [OK OK OK LEN] */
    TEST_ASSERT_EQUAL_INT(COMM_SM_VALID, sm_state(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(-EMSGSIZE, comm_decode(&c, &f, &m)); /* [OK OK LEN LEN] */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_sm_valid_falls_when_good_frames_stop(void)
{
    for (uint8_t k = 0; k < 5u; k++) {
        TEST_ASSERT_EQUAL_INT(0, get_with(k));
        (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET);
    }
    (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* [OK OK OK NND] */
    (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* [OK OK NND NND]: ok 2 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_VALID, sm_state(COMM_ID_PARAM_GET));
    (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* [OK NND NND NND]: ok 1 < 2 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_sm_invalid_needs_three_good_and_no_error_in_the_window(void)
{
    TEST_ASSERT_EQUAL_INT(0, get_with(0));
    corrupt_get(1);                        /* INIT → INVALID: [ERR] */
    TEST_ASSERT_EQUAL_INT(0, get_with(1)); /* [ERR OK] */
    TEST_ASSERT_EQUAL_INT(0, get_with(2)); /* [ERR OK OK] */
    TEST_ASSERT_EQUAL_INT(0, get_with(3)); /* [ERR OK OK OK]: ok 3 but err 1 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(0, get_with(4)); /* [OK OK OK OK] */
    TEST_ASSERT_EQUAL_INT(COMM_SM_VALID, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_sm_invalid_stays_when_too_few_good_frames(void)
{
    TEST_ASSERT_EQUAL_INT(0, get_with(0));
    corrupt_get(1);
    for (unsigned k = 0; k < 4u; k++) {
        (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* NND: err leaves, ok does not come */
    }
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(0, get_with(1)); /* [NND NND NND OK]: err 0, ok 1 < 3 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_sm_repeats_and_wrong_sequences_starve_valid(void)
{
    for (uint8_t k = 0; k < 4u; k++) {
        TEST_ASSERT_EQUAL_INT(0, get_with(k)); /* VALID [OK OK OK] */
    }
    TEST_ASSERT_EQUAL_INT(-EALREADY, get_with(3)); /* [OK OK OK REP] */
    TEST_ASSERT_EQUAL_INT(-ERANGE, get_with(10));  /* [OK OK REP WS] */
    TEST_ASSERT_EQUAL_INT(COMM_SM_VALID, sm_state(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(-EALREADY, get_with(10)); /* [OK REP WS REP]: ok 1 */
    TEST_ASSERT_EQUAL_INT(COMM_SM_INVALID, sm_state(COMM_ID_PARAM_GET));
}

static void test_e2e_ok_run_counts_good_frames_in_a_row_and_saturates(void)
{
    for (unsigned k = 0; k < 300u; k++) {
        TEST_ASSERT_EQUAL_INT(0, get_with((uint8_t)(k & 0x0Fu)));
    }
    TEST_ASSERT_EQUAL_UINT8(255, comm_rx(&c, COMM_ID_PARAM_GET)->ok_run);
    TEST_ASSERT_EQUAL_INT(0, get_with(14)); /* OK_SOME_LOST counts too (300 % 16 = 12) */
    TEST_ASSERT_EQUAL_UINT8(255, comm_rx(&c, COMM_ID_PARAM_GET)->ok_run);
    (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* frames in the cycle: no NND */
    TEST_ASSERT_EQUAL_UINT8(255, comm_rx(&c, COMM_ID_PARAM_GET)->ok_run);
    (void)comm_e2e_cycle(&c, COMM_ID_PARAM_GET); /* NND breaks the run */
    TEST_ASSERT_EQUAL_UINT8(0, comm_rx(&c, COMM_ID_PARAM_GET)->ok_run);
    TEST_ASSERT_EQUAL_INT(0, get_with(15));
    TEST_ASSERT_EQUAL_UINT8(1, comm_rx(&c, COMM_ID_PARAM_GET)->ok_run);
}

static void test_e2e_init_forgets_every_receiver(void)
{
    TEST_ASSERT_EQUAL_INT(0, get_with(0));
    TEST_ASSERT_EQUAL_INT(0, get_with(1));
    comm_init(&c);
    TEST_ASSERT_EQUAL_INT(COMM_SM_NODATA, sm_state(COMM_ID_PARAM_GET));
    TEST_ASSERT_EQUAL_INT(0, get_with(1)); /* a repeat of the last, but first after init */
    TEST_ASSERT_EQUAL_INT(COMM_E2E_OK, last_status(COMM_ID_PARAM_GET));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_e2e_every_1_2_and_3_bit_flip_of_every_received_frame_is_detected);
    RUN_TEST(test_e2e_some_4_bit_flip_goes_undetected_so_the_bound_is_tight);
    RUN_TEST(test_e2e_status_of_every_counter_step);
    RUN_TEST(test_e2e_status_of_a_bad_crc_and_a_bad_length);
    RUN_TEST(test_e2e_cycle_without_a_frame_is_no_new_data);
    RUN_TEST(test_e2e_identifiers_not_received_have_no_receiver);
    RUN_TEST(test_e2e_each_identifier_has_its_own_receiver);
    RUN_TEST(test_e2e_sm_starts_in_nodata_and_ignores_errors_there);
    RUN_TEST(test_e2e_sm_first_good_frame_inits_and_the_second_validates);
    RUN_TEST(test_e2e_sm_init_waits_on_repeats_and_falls_on_an_error);
    RUN_TEST(test_e2e_sm_valid_tolerates_one_error_in_the_window_not_two);
    RUN_TEST(test_e2e_sm_a_wrong_length_counts_as_an_error);
    RUN_TEST(test_e2e_sm_valid_falls_when_good_frames_stop);
    RUN_TEST(test_e2e_sm_invalid_needs_three_good_and_no_error_in_the_window);
    RUN_TEST(test_e2e_sm_invalid_stays_when_too_few_good_frames);
    RUN_TEST(test_e2e_sm_repeats_and_wrong_sequences_starve_valid);
    RUN_TEST(test_e2e_ok_run_counts_good_frames_in_a_row_and_saturates);
    RUN_TEST(test_e2e_init_forgets_every_receiver);
    return UNITY_END();
}
