/* SPDX-License-Identifier: MIT */
/*
 * A plain C ABI over the slcan line codec (hal/stm32/slcan_codec.c), for
 * tests/python/test_slcan_codec.py, which builds it as a shared library with
 * the project's warnings and loads it with ctypes. One codec state, as the
 * board's USART interrupt has.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "../../hal/stm32/slcan_codec.h"

/* The exported functions are this file's interface; they need no header. */
#pragma GCC diagnostic ignored "-Wmissing-prototypes"

static slcan_t state;

void slcan_shim_init(uint8_t bitrate) { slcan_init(&state, bitrate); }

int slcan_shim_open(void) { return state.open ? 1 : 0; }

/* Feed @p n bytes. @return the commands they completed; the last one's frame
 * (has_frame, id, dlc, data[8]) and reply (reply[SLCAN_REPLY_MAX],
 * reply_len) go to the outputs. */
int slcan_shim_feed(const uint8_t *bytes, size_t n, int *has_frame, uint32_t *id, uint8_t *dlc,
                    uint8_t *data, char *reply, uint8_t *reply_len)
{
    int lines = 0;
    for (size_t i = 0; i < n; i++) {
        slcan_result_t r;
        if (slcan_rx_byte(&state, bytes[i], &r)) {
            lines++;
            *has_frame = r.has_frame ? 1 : 0;
            *id = r.frame.id;
            *dlc = r.frame.dlc;
            memcpy(data, r.frame.data, HAL_CAN_MAX_DLC);
            memcpy(reply, r.reply, SLCAN_REPLY_MAX);
            *reply_len = r.reply_len;
        }
    }
    return lines;
}

/* The line of a frame the firmware sends into @p out (SLCAN_FRAME_LINE_MAX
 * bytes); its length, 0 when out of range. */
size_t slcan_shim_format(uint32_t id, uint8_t dlc, const uint8_t *data, char *out)
{
    hal_can_frame_t f = { .id = id, .dlc = dlc };
    memcpy(f.data, data, HAL_CAN_MAX_DLC);
    return slcan_format_frame(&f, out);
}
