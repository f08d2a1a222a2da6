/* SPDX-License-Identifier: MIT */
/* slcan (Lawicel) line protocol: the board-independent part (see slcan_codec.h). */
#include "slcan_codec.h"

#define STD_ID_DIGITS 3u
#define EXT_ID_DIGITS 8u
#define MAX_EXT_ID    0x1FFFFFFFu
#define MAX_S_CODE    8u
#define LF            '\n'

static const char hex_upper[] = "0123456789ABCDEF";

/* Lawicel's S0..S8 [bit/s]. */
static const uint32_t s_rates[MAX_S_CODE + 1u] = {
    10000u, 20000u, 50000u, 100000u, 125000u, 250000u, 500000u, 800000u, 1000000u,
};

void slcan_init(slcan_t *s, uint8_t bitrate)
{
    *s = (slcan_t){ .bitrate = bitrate <= MAX_S_CODE ? bitrate : (uint8_t)MAX_S_CODE };
}

uint32_t slcan_bitrate(uint8_t code) { return code <= MAX_S_CODE ? s_rates[code] : 0u; }

int slcan_bitrate_code(uint32_t bitrate)
{
    for (unsigned i = 0; i <= MAX_S_CODE; i++) {
        if (s_rates[i] == bitrate) {
            return (int)i;
        }
    }
    return -1;
}

bool slcan_accepts(const hal_can_filter_t *filters, unsigned n, uint32_t id)
{
    if (n == 0u) {
        return true;
    }
    for (unsigned i = 0; i < n; i++) {
        if ((id & filters[i].mask) == (filters[i].id & filters[i].mask)) {
            return true;
        }
    }
    return false;
}

/* Value of a hexadecimal digit, or -1. */
static int hex_value(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    return -1;
}

/* @p n hexadecimal digits at @p p into @p out. */
static bool hex_number(const char *p, size_t n, uint32_t *out)
{
    uint32_t v = 0u;
    for (size_t i = 0; i < n; i++) {
        const int d = hex_value(p[i]);
        if (d < 0) {
            return false;
        }
        v = (v << 4) | (uint32_t)d;
    }
    *out = v;
    return true;
}

static void reply(slcan_result_t *out, const char *text)
{
    /* A loop, not strlen and memcpy: the answers are a few characters, and
     * newlib's memcpy would cost 300 B of a 32 KB image for them (the build
     * keeps such loops loops: mk/firmware.mk). */
    size_t n = 0u;
    for (; text[n] != '\0'; n++) {
        out->reply[n] = text[n];
    }
    out->reply[n] = SLCAN_CR;
    out->reply_len = (uint8_t)(n + 1u);
}

static void reply_bel(slcan_result_t *out)
{
    out->reply[0] = SLCAN_BEL;
    out->reply_len = 1u;
}

/* A frame command (t, T, r, R) of @p len characters: its id, length and (for
 * a data frame) payload are well formed, and for t the frame goes to @p f. */
static bool parse_frame(const char *line, size_t len, bool ext, bool remote, hal_can_frame_t *f)
{
    const size_t id_digits = ext ? EXT_ID_DIGITS : STD_ID_DIGITS;
    if (len < id_digits + 2u) {
        return false;
    }
    uint32_t id;
    if (!hex_number(&line[1], id_digits, &id) || id > (ext ? MAX_EXT_ID : HAL_CAN_MAX_STD_ID)) {
        return false;
    }
    const char l = line[1u + id_digits];
    if (l < '0' || l > (char)('0' + HAL_CAN_MAX_DLC)) {
        return false;
    }
    const uint8_t dlc = (uint8_t)(l - '0');
    const size_t data_at = id_digits + 2u;
    if (len != data_at + (remote ? 0u : 2u * (size_t)dlc)) {
        return false;
    }
    hal_can_frame_t fr = { .id = id, .dlc = dlc };
    for (size_t i = 0; !remote && i < dlc; i++) {
        uint32_t byte;
        if (!hex_number(&line[data_at + 2u * i], 2u, &byte)) {
            return false;
        }
        fr.data[i] = (uint8_t)byte;
    }
    *f = fr;
    return true;
}

/* One complete command (CR excluded). */
static void command(slcan_t *s, const char *line, size_t len, slcan_result_t *out)
{
    const char c = line[0];
    if (c == 't' || c == 'T' || c == 'r' || c == 'R') {
        const bool ext = c == 'T' || c == 'R';
        const bool remote = c == 'r' || c == 'R';
        hal_can_frame_t f;
        if (!s->open || !parse_frame(line, len, ext, remote, &f)) {
            reply_bel(out);
            return;
        }
        out->has_frame = !ext && !remote;
        out->frame = f;
        reply(out, ext ? "Z" : "z");
    } else if (len == 1u && c == 'O' && !s->open) {
        s->open = true;
        reply(out, "");
    } else if (len == 1u && c == 'C' && s->open) {
        s->open = false;
        reply(out, "");
    } else if (len == 2u && c == 'S' && !s->open && line[1] >= '0' &&
               line[1] <= (char)('0' + MAX_S_CODE)) {
        s->bitrate = (uint8_t)(line[1] - '0');
        reply(out, "");
    } else if (len == 1u && c == 'V') {
        reply(out, SLCAN_VERSION);
    } else if (len == 1u && c == 'N') {
        reply(out, SLCAN_SERIAL);
    } else {
        reply_bel(out);
    }
}

bool slcan_rx_byte(slcan_t *s, uint8_t byte, slcan_result_t *out)
{
    const char c = (char)byte;
    if (c != SLCAN_CR) {
        if (c == LF && s->len == 0u && !s->bad) {
            return false; /* CR LF line ends */
        }
        if (s->len < SLCAN_LINE_MAX) {
            s->line[s->len] = c;
            s->len++;
        } else {
            s->bad = true; /* too long: no command is */
        }
        return false;
    }
    *out = (slcan_result_t){ .has_frame = false };
    if (s->bad) {
        reply_bel(out);
    } else if (s->len > 0u) {
        command(s, s->line, s->len, out);
    } else {
        /* an empty line (hosts send CRs to flush a half-sent command): no reply */
    }
    s->len = 0u;
    s->bad = false;
    return true;
}

void slcan_rx_error(slcan_t *s) { s->bad = true; }

size_t slcan_format_frame(const hal_can_frame_t *f, char *out)
{
    if (f->id > HAL_CAN_MAX_STD_ID || f->dlc > HAL_CAN_MAX_DLC) {
        return 0u;
    }
    out[0] = 't';
    for (size_t k = 0; k < STD_ID_DIGITS; k++) {
        out[1u + k] = hex_upper[(f->id >> (4u * (STD_ID_DIGITS - 1u - k))) & 0xFu];
    }
    out[1u + STD_ID_DIGITS] = hex_upper[f->dlc]; /* 0..8: its own digit */
    size_t n = STD_ID_DIGITS + 2u;
    for (size_t i = 0; i < f->dlc; i++) {
        out[n] = hex_upper[f->data[i] >> 4u];
        out[n + 1u] = hex_upper[f->data[i] & 0xFu];
        n += 2u;
    }
    out[n] = SLCAN_CR;
    return n + 1u;
}
