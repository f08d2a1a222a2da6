/* SPDX-License-Identifier: MIT */
/*
 * libFuzzer harness: the slcan command parser of the board images' serial
 * transport (hal/stm32/slcan_codec.c, `make pil`, CAN=slcan), which reads
 * whatever arrives on the serial line.
 *
 * Input: the bytes from the host, as they are, with one exception: 0xFF is
 * taken as a receive error of the line (slcan_rx_error), the rest go through
 * slcan_rx_byte. The first byte also gives the S code at start-up.
 * After every command, otherwise abort() (a finding):
 *   - the reply fits its buffer, and is BEL alone or ends with CR;
 *   - a frame for the firmware comes only while the channel is open, has an
 *     11-bit identifier and a length of at most 8, with the bytes past it 0;
 *   - that frame, formatted as the firmware would send it
 *     (slcan_format_frame) and fed back into an open channel, gives the same
 *     frame and the reply "z" CR: what the codec reads and what it writes
 *     agree.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "slcan_codec.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check(bool ok)
{
    if (!ok) {
        abort();
    }
}

/* The frame read back from its own line, through an open channel. */
static void check_round_trip(const hal_can_frame_t *f)
{
    char line[SLCAN_FRAME_LINE_MAX];
    const size_t n = slcan_format_frame(f, line);
    check(n == 6u + 2u * f->dlc && line[n - 1u] == SLCAN_CR);
    slcan_t s;
    slcan_init(&s, 6u);
    slcan_result_t r;
    check(slcan_rx_byte(&s, 'O', &r) == false);
    check(slcan_rx_byte(&s, SLCAN_CR, &r) && !r.has_frame);
    for (size_t i = 0; i + 1u < n; i++) {
        check(!slcan_rx_byte(&s, (uint8_t)line[i], &r));
    }
    memset(&r, 0xA5, sizeof r);
    check(slcan_rx_byte(&s, SLCAN_CR, &r));
    check(r.has_frame && r.frame.id == f->id && r.frame.dlc == f->dlc);
    check(memcmp(r.frame.data, f->data, sizeof f->data) == 0);
    check(r.reply_len == 2u && r.reply[0] == 'z' && r.reply[1] == SLCAN_CR);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    slcan_t s;
    slcan_init(&s, size > 0u ? (uint8_t)(data[0] % 10u) : 6u);
    for (size_t i = 0; i < size; i++) {
        if (data[i] == 0xFFu) {
            slcan_rx_error(&s);
            continue;
        }
        const bool was_open = s.open;
        slcan_result_t r;
        memset(&r, 0x5A, sizeof r);
        if (!slcan_rx_byte(&s, data[i], &r)) {
            continue;
        }
        check(r.reply_len <= SLCAN_REPLY_MAX);
        if (r.reply_len > 0u) {
            check(r.reply[r.reply_len - 1u] == SLCAN_CR ||
                  (r.reply_len == 1u && r.reply[0] == SLCAN_BEL));
        }
        if (r.has_frame) {
            check(was_open && r.frame.id <= 0x7FFu && r.frame.dlc <= 8u);
            for (unsigned k = r.frame.dlc; k < 8u; k++) {
                check(r.frame.data[k] == 0u);
            }
            check_round_trip(&r.frame);
        }
    }
    return 0;
}
