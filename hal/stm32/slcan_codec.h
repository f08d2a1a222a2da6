/* SPDX-License-Identifier: MIT */
/**
 * @file slcan_codec.h
 * @brief The board-independent part of the slcan transport (hal/stm32/slcan.c):
 *        the Lawicel ASCII protocol that USB-CAN adapters speak on a serial
 *        line, seen from the adapter's side. Bytes from the host go in one at
 *        a time; each carriage return (CR, 0x0D) ends a command, which yields
 *        a frame for the firmware and/or the reply to send back. Frames the
 *        firmware sends are formatted as the lines an adapter forwards from its
 *        bus. Pure, no register access: unit-tested on the host
 *        (tests/unit/test_slcan.c) and against python-can's own slcan
 *        interface (tests/python/test_slcan_codec.py).
 *
 * Commands (Lawicel CAN232/CANUSB manuals; python-can's slcanBus is the
 * peer this is checked against):
 *
 *   command            when                 reply   firmware gets
 *   tiiildd..          channel open         z CR    the frame (11-bit id)
 *   Tiiiiiiiildd..     channel open         Z CR    nothing (29-bit id)
 *   riiil / Riiiiiiiil channel open         z / Z   nothing (remote frame)
 *   O                  channel closed       CR      (channel opens)
 *   C                  channel open         CR      (channel closes)
 *   S0 .. S8           channel closed       CR      (nominal bit rate)
 *   V                  always               Vhhss CR
 *   N                  always               Nxxxx CR
 *   (empty line)       always               nothing
 *   anything else, a command in the wrong channel state, a malformed or
 *   over-long line, a line that lost a byte:  BEL (0x07)
 *
 * i, d: hexadecimal digits (either case accepted, upper case sent); l: the
 * data length 0..8; exactly 2·l data digits. Like bxCAN's acceptance filters,
 * which only pass 11-bit data frames, extended and remote frames are
 * acknowledged but never reach the firmware. A line feed right after a CR
 * (a host ending lines with CR LF) is ignored.
 */
#ifndef STM32_SLCAN_CODEC_H
#define STM32_SLCAN_CODEC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal/hal_can.h"

/** @brief Longest command, CR excluded: 'T', 8 id digits, the length, 16
 *         data digits. */
#define SLCAN_LINE_MAX       26u
/** @brief Longest line the firmware sends, CR included: "tiiil" + 16 digits. */
#define SLCAN_FRAME_LINE_MAX 22u
/** @brief Longest reply, CR included ("Vhhss", "Nxxxx"). */
#define SLCAN_REPLY_MAX      6u

#define SLCAN_CR  '\r'
#define SLCAN_BEL '\a'

/** @brief Answer to V: hardware and software version, two decimal digits each. */
#define SLCAN_VERSION "V0101"
/** @brief Answer to N: a serial "number" of four characters. */
#define SLCAN_SERIAL  "NMSTC"

/** @brief Receive state of one serial line: the command being assembled and
 *         the channel as the host set it. Zero-initialised is not valid: use
 *         slcan_init(). */
typedef struct {
    char line[SLCAN_LINE_MAX]; /**< command so far, CR excluded */
    uint8_t len;               /**< characters in line[] */
    bool bad;                  /**< the command overflowed or lost a byte: BEL at its CR */
    bool open;                 /**< channel open (O) or closed (C, the start) */
    uint8_t bitrate;           /**< the S code in force, 0..8 */
} slcan_t;

/** @brief What one complete command asks for. */
typedef struct {
    bool has_frame;              /**< frame is a standard data frame for the firmware */
    hal_can_frame_t frame;       /**< bytes past dlc are 0 */
    uint8_t reply_len;           /**< bytes of reply[] to send back; 0: none */
    char reply[SLCAN_REPLY_MAX]; /**< the reply, ending with CR or being BEL */
} slcan_result_t;

/** @brief Channel closed, no command pending, bit rate S code @p bitrate
 *         (clamped to 8). */
void slcan_init(slcan_t *s, uint8_t bitrate);

/**
 * @brief One byte from the host.
 * @retval true the byte was a CR and ended a command: @p out says what it
 *         asks for (a frame, a reply, both or neither).
 * @retval false the command goes on (or the byte was a line feed after a CR);
 *         @p out is untouched.
 */
bool slcan_rx_byte(slcan_t *s, uint8_t byte, slcan_result_t *out);

/** @brief The serial line lost or garbled a byte (overrun, framing or noise
 *         error): the command being received is answered with BEL at its CR. */
void slcan_rx_error(slcan_t *s);

/**
 * @brief The line for a frame the firmware sends: "tiiil" and 2·dlc digits,
 *        upper case, then CR.
 * @param[out] out at least SLCAN_FRAME_LINE_MAX bytes.
 * @return its length (6 + 2·dlc), or 0 when the id or dlc is out of range.
 */
size_t slcan_format_frame(const hal_can_frame_t *f, char *out);

/** @brief Bit rate of S code @p code [bit/s]: 10 k .. 1 M; 0 for a code
 *         above 8. */
uint32_t slcan_bitrate(uint8_t code);

/** @brief S code of @p bitrate, or -1 when it has none. */
int slcan_bitrate_code(uint32_t bitrate);

/** @brief Whether @p id passes the acceptance filters (hal_can_set_filters()
 *         semantics: one of @p n matches, (id & mask) == (filter id & mask);
 *         n = 0 accepts every id). */
bool slcan_accepts(const hal_can_filter_t *filters, unsigned n, uint32_t id);

#endif /* STM32_SLCAN_CODEC_H */
