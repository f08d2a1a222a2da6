/* SPDX-License-Identifier: MIT */
/* 64-bit division by shifts and subtractions (div64.h). */
#include "div64.h"

#include <stddef.h>

uint64_t div64_u(uint64_t n, uint64_t d, uint64_t *rem)
{
    uint64_t q = 0u;
    uint64_t r = 0u;
    if (d == 0u || d > ((uint64_t)1u << 63)) {
        r = n; /* outside the contract (div64.h) */
    } else {
        /* Long division, one bit of n at a time, from the top: r < d <= 2^63,
         * so r << 1 never overflows. */
        for (unsigned i = 64u; i-- > 0u;) {
            r = (r << 1) | ((n >> i) & 1u);
            if (r >= d) {
                r -= d;
                q |= (uint64_t)1u << i;
            }
        }
    }
    if (rem != NULL) {
        *rem = r;
    }
    return q;
}

int64_t div64_nearest(int64_t num, uint64_t den)
{
    /* The magnitude of num, INT64_MIN included, as an unsigned value. */
    const uint64_t mag = num < 0 ? (uint64_t)0u - (uint64_t)num : (uint64_t)num;
    const uint64_t q = div64_u(mag + den / 2u, den, NULL);
    return num < 0 ? -(int64_t)q : (int64_t)q;
}
