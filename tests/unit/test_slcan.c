/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the slcan line codec (hal/stm32/slcan_codec.c): the Lawicel
 * commands a host sends, the channel state they change, the replies, and the
 * lines of the frames the firmware sends.
 *
 * The codec is pure (no register access): the host build links it with this
 * test (TEST_SRCS_test_slcan). Expected lines and replies are written out by
 * hand from the Lawicel CAN232/CANUSB command list (slcan_codec.h);
 * tests/python/test_slcan_codec.py checks the same code against python-can's
 * own slcan encoder and decoder.
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "slcan_codec.h"
#include "unity.h"

void setUp(void) {}
void tearDown(void) {}

static slcan_t s;

/* Feed @p text; the result of its last CR into @p r. @return CRs seen. */
static unsigned feed(const char *text, slcan_result_t *r)
{
    unsigned lines = 0;
    for (const char *p = text; *p != '\0'; p++) {
        slcan_result_t one;
        if (slcan_rx_byte(&s, (uint8_t)*p, &one)) {
            *r = one;
            lines++;
        }
    }
    return lines;
}

/* One command; its reply must be @p reply (NULL: none) and it must or must
 * not carry a frame. */
static slcan_result_t cmd(const char *text, const char *reply, bool frame)
{
    slcan_result_t r;
    TEST_ASSERT_EQUAL_UINT_MESSAGE(1, feed(text, &r), text);
    if (reply == NULL) {
        TEST_ASSERT_EQUAL_UINT_MESSAGE(0, r.reply_len, text);
    } else {
        TEST_ASSERT_EQUAL_UINT_MESSAGE(strlen(reply), r.reply_len, text);
        TEST_ASSERT_EQUAL_MEMORY_MESSAGE(reply, r.reply, r.reply_len, text);
    }
    TEST_ASSERT_EQUAL_MESSAGE(frame, r.has_frame, text);
    return r;
}

static void open_channel(void)
{
    slcan_init(&s, 6);
    cmd("O\r", "\r", false);
}

static void test_slcan_starts_closed_and_o_c_follow_lawicel(void)
{
    slcan_init(&s, 6);
    TEST_ASSERT_FALSE(s.open);
    cmd("t1230\r", "\a", false); /* frames only while open */
    cmd("C\r", "\a", false);     /* closing a closed channel */
    cmd("O\r", "\r", false);
    TEST_ASSERT_TRUE(s.open);
    cmd("O\r", "\a", false);  /* already open */
    cmd("S6\r", "\a", false); /* the bit rate only while closed */
    cmd("C\r", "\r", false);
    TEST_ASSERT_FALSE(s.open);
}

static void test_slcan_bit_rate_commands(void)
{
    slcan_init(&s, 6);
    cmd("S0\r", "\r", false);
    TEST_ASSERT_EQUAL_UINT8(0, s.bitrate);
    cmd("S8\r", "\r", false);
    TEST_ASSERT_EQUAL_UINT8(8, s.bitrate);
    cmd("S9\r", "\a", false);
    cmd("S\r", "\a", false);
    cmd("S66\r", "\a", false);
    TEST_ASSERT_EQUAL_UINT8(8, s.bitrate);
    /* Lawicel's table: S0 10 k, S4 125 k, S6 500 k, S7 800 k, S8 1 M. */
    TEST_ASSERT_EQUAL_UINT32(10000, slcan_bitrate(0));
    TEST_ASSERT_EQUAL_UINT32(125000, slcan_bitrate(4));
    TEST_ASSERT_EQUAL_UINT32(500000, slcan_bitrate(6));
    TEST_ASSERT_EQUAL_UINT32(800000, slcan_bitrate(7));
    TEST_ASSERT_EQUAL_UINT32(1000000, slcan_bitrate(8));
    TEST_ASSERT_EQUAL_UINT32(0, slcan_bitrate(9));
    TEST_ASSERT_EQUAL_INT(6, slcan_bitrate_code(500000));
    TEST_ASSERT_EQUAL_INT(8, slcan_bitrate_code(1000000));
    TEST_ASSERT_EQUAL_INT(-1, slcan_bitrate_code(750000));
    slcan_init(&s, 200);
    TEST_ASSERT_EQUAL_UINT8(8, s.bitrate);
}

static void test_slcan_version_serial_and_unknown(void)
{
    slcan_init(&s, 6);
    cmd("V\r", "V0101\r", false);
    cmd("N\r", "NMSTC\r", false);
    cmd("VV\r", "\a", false);
    cmd("X\r", "\a", false);
    cmd("L\r", "\a", false);     /* listen-only: not offered */
    cmd("s011C\r", "\a", false); /* bit timing registers: not offered */
    cmd("\r", NULL, false);      /* an empty line: nothing */
}

static void test_slcan_standard_frames_reach_the_firmware(void)
{
    open_channel();
    slcan_result_t r = cmd("t1230\r", "z\r", true);
    TEST_ASSERT_EQUAL_UINT32(0x123, r.frame.id);
    TEST_ASSERT_EQUAL_UINT8(0, r.frame.dlc);
    const uint8_t zero[8] = { 0 };
    TEST_ASSERT_EQUAL_MEMORY(zero, r.frame.data, 8);

    r = cmd("t7FF80102030405060708\r", "z\r", true);
    const uint8_t full[8] = { 1, 2, 3, 4, 5, 6, 7, 8 };
    TEST_ASSERT_EQUAL_UINT32(0x7FF, r.frame.id);
    TEST_ASSERT_EQUAL_UINT8(8, r.frame.dlc);
    TEST_ASSERT_EQUAL_MEMORY(full, r.frame.data, 8);

    /* Either case; bytes past the length are zero. */
    r = cmd("t0002aBfe\r", "z\r", true);
    const uint8_t two[8] = { 0xAB, 0xFE };
    TEST_ASSERT_EQUAL_UINT32(0x000, r.frame.id);
    TEST_ASSERT_EQUAL_UINT8(2, r.frame.dlc);
    TEST_ASSERT_EQUAL_MEMORY(two, r.frame.data, 8);
}

static void test_slcan_extended_and_remote_frames_are_acknowledged_only(void)
{
    open_channel();
    cmd("T1FFFFFFF0\r", "Z\r", false);
    cmd("T0000012320102\r", "Z\r", false);
    cmd("r1238\r", "z\r", false);
    cmd("R123456780\r", "Z\r", false);
}

static void test_slcan_malformed_frames_get_bel(void)
{
    open_channel();
    const char *bad[] = {
        "t8000\r",       /* id beyond 11 bits */
        "t1239\r",       /* length 9 */
        "t123A\r",       /* length not a digit */
        "t1232AB\r",     /* one byte short */
        "t1231ABCD\r",   /* one byte long */
        "t12G0\r",       /* not hexadecimal */
        "t1G30\r",       /* ... in the first digit */
        "t1231 A\r",     /* a space */
        "t12\r",         /* truncated id */
        "t\r",           /* nothing */
        "T200000000\r",  /* id beyond 29 bits */
        "T1234567\r",    /* truncated extended id */
        "r12380\r",      /* a remote frame carries no data */
        "R1234567890\r", /* length 9 */
        "t1231\n00\r",   /* a line feed inside */
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        cmd(bad[i], "\a", false);
    }
    /* And the channel still works. */
    cmd("t1231FF\r", "z\r", true);
}

static void test_slcan_line_limits_and_errors(void)
{
    open_channel();
    /* The longest command fits: T, 8 + 1 + 16 characters. */
    cmd("T1FFFFFFF81122334455667788\r", "Z\r", false);
    /* One more character: BEL, and the next line is fine. */
    cmd("T1FFFFFFF811223344556677889\r", "\a", false);
    char flood[200];
    memset(flood, '7', sizeof flood - 2u);
    flood[sizeof flood - 2u] = '\r';
    flood[sizeof flood - 1u] = '\0';
    cmd(flood, "\a", false);
    cmd("V\r", "V0101\r", false);
    /* A byte lost on the line: the command is rejected at its CR. */
    slcan_result_t r;
    TEST_ASSERT_EQUAL_UINT(0, feed("t12", &r));
    slcan_rx_error(&s);
    cmd("31AA\r", "\a", false);
    cmd("t1231AA\r", "z\r", true);
}

static void test_slcan_crlf_line_ends_are_accepted(void)
{
    slcan_init(&s, 6);
    slcan_result_t r;
    TEST_ASSERT_EQUAL_UINT(2, feed("O\r\nV\r\n", &r));
    TEST_ASSERT_TRUE(s.open);
    TEST_ASSERT_EQUAL_UINT(6, r.reply_len);
    TEST_ASSERT_EQUAL_MEMORY("V0101\r", r.reply, 6);
    /* Several CRs in a row (hosts flush with them): no replies. */
    TEST_ASSERT_EQUAL_UINT(3, feed("\r\r\r", &r));
    TEST_ASSERT_EQUAL_UINT(0, r.reply_len);
}

static void expect_line(uint32_t id, uint8_t dlc, const uint8_t *data, const char *want)
{
    hal_can_frame_t f = { .id = id, .dlc = dlc };
    memcpy(f.data, data, dlc);
    char out[SLCAN_FRAME_LINE_MAX];
    const size_t n = slcan_format_frame(&f, out);
    TEST_ASSERT_EQUAL_size_t(strlen(want), n);
    TEST_ASSERT_EQUAL_MEMORY(want, out, n);
}

static void test_slcan_format_frames(void)
{
    const uint8_t d[8] = { 0xAB, 0x01, 0xFF, 0x00, 0x10, 0x9C, 0x7E, 0xE7 };
    expect_line(0x000, 0, d, "t0000\r");
    expect_line(0x123, 3, d, "t1233AB01FF\r");
    expect_line(0x7FF, 8, d, "t7FF8AB01FF00109C7EE7\r");
    expect_line(0x00A, 1, d, "t00A1AB\r");
    hal_can_frame_t f = { .id = 0x800, .dlc = 0 };
    char out[SLCAN_FRAME_LINE_MAX];
    TEST_ASSERT_EQUAL_size_t(0, slcan_format_frame(&f, out));
    f = (hal_can_frame_t){ .id = 0x100, .dlc = 9 };
    TEST_ASSERT_EQUAL_size_t(0, slcan_format_frame(&f, out));
}

/* Property: a formatted frame parses back to itself, for every length and a
 * spread of ids. */
static void test_slcan_format_then_parse_round_trips(void)
{
    open_channel();
    for (uint32_t id = 0; id <= HAL_CAN_MAX_STD_ID; id += 0x49) {
        for (uint8_t dlc = 0; dlc <= 8; dlc++) {
            hal_can_frame_t f = { .id = id, .dlc = dlc };
            for (uint8_t i = 0; i < dlc; i++) {
                f.data[i] = (uint8_t)(id * 7u + i * 37u);
            }
            char line[SLCAN_FRAME_LINE_MAX + 1];
            const size_t n = slcan_format_frame(&f, line);
            line[n] = '\0';
            const slcan_result_t r = cmd(line, "z\r", true);
            TEST_ASSERT_EQUAL_UINT32(f.id, r.frame.id);
            TEST_ASSERT_EQUAL_UINT8(f.dlc, r.frame.dlc);
            TEST_ASSERT_EQUAL_MEMORY(f.data, r.frame.data, 8);
        }
    }
}

static void test_slcan_acceptance_filters(void)
{
    const hal_can_filter_t f[] = { { 0x100, 0x7FF }, { 0x120, 0x7F0 } };
    TEST_ASSERT_TRUE(slcan_accepts(f, 0, 0x555)); /* none: everything */
    TEST_ASSERT_TRUE(slcan_accepts(f, 2, 0x100));
    TEST_ASSERT_FALSE(slcan_accepts(f, 2, 0x101));
    TEST_ASSERT_TRUE(slcan_accepts(f, 2, 0x120));
    TEST_ASSERT_TRUE(slcan_accepts(f, 2, 0x12F));
    TEST_ASSERT_FALSE(slcan_accepts(f, 2, 0x130));
    TEST_ASSERT_FALSE(slcan_accepts(f, 1, 0x120));
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_slcan_starts_closed_and_o_c_follow_lawicel);
    RUN_TEST(test_slcan_bit_rate_commands);
    RUN_TEST(test_slcan_version_serial_and_unknown);
    RUN_TEST(test_slcan_standard_frames_reach_the_firmware);
    RUN_TEST(test_slcan_extended_and_remote_frames_are_acknowledged_only);
    RUN_TEST(test_slcan_malformed_frames_get_bel);
    RUN_TEST(test_slcan_line_limits_and_errors);
    RUN_TEST(test_slcan_crlf_line_ends_are_accepted);
    RUN_TEST(test_slcan_format_frames);
    RUN_TEST(test_slcan_format_then_parse_round_trips);
    RUN_TEST(test_slcan_acceptance_filters);
    return UNITY_END();
}
