/* SPDX-License-Identifier: MIT */
/* Fixed mode of num.h: the Q16.16 primitives that are not inline (see
 * num_fixed.h for range, resolution and overflow of each). Every firmware
 * source is compiled in both modes, so in float mode this file is empty. */
#if defined(NUM_FIXED)

#include "num/num.h"

/* libfixmath's header is not clean under -Wconversion; including it here
 * lets the compiler check num_fixed.h's declarations of fix16_smul and
 * fix16_sdiv against the real ones. */
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#endif
#include "fix16.h"
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

/* ------------------------------------------------------------- integer help */

/* Leading zeros of a nonzero 32-bit value (CLZ on Cortex-M3/M4). */
static inline unsigned clz32(uint32_t x)
{
#if defined(__GNUC__)
    return (unsigned)__builtin_clz(x);
#else
    unsigned n = 0;
    while ((x & 0x80000000u) == 0u) {
        x <<= 1;
        n++;
    }
    return n;
#endif
}

/* |a| as an unsigned value, exact also for INT32_MIN. */
static inline uint32_t uabs32(int32_t a) { return a < 0 ? 0u - (uint32_t)a : (uint32_t)a; }

/* Signed product of two Q2.30 values, in Q2.30, truncated toward −inf
 * (an arithmetic shift; GCC defines >> on negative values so). */
static inline int32_t mul_q30(int32_t a, int32_t b) { return (int32_t)(((int64_t)a * b) >> 30); }

/* Q2.30 (or any Q.30 in int64) to Q16.16, rounded to nearest. */
static inline int32_t q30_to_q16(int32_t a) { return (int32_t)(((int64_t)a + (1 << 13)) >> 14); }

/* ----------------------------------------------------------- square roots */

/* floor(sqrt(n)) for n in [2^30, 2^32), in [2^15, 2^16): one integer Newton
 * step from a seed by the top 8 bits of n (the table: sqrt of the middle of
 * each of the 192 intervals [i·2^24, (i + 1)·2^24), i = 64 … 255, rounded),
 * at most 128.5 from the root; the step then lands on floor or floor + 1
 * (rarely + 2): from any start it is >= floor(sqrt(n)) (integer Newton from
 * above or below), the clamp keeps that (floor(sqrt(n)) <= 0xFFFF), and the
 * loop comes down to the floor exactly, whatever the seed. */
static const uint16_t SQRT_SEED[192] = {
    32896u, 33150u, 33402u, 33652u, 33900u, 34147u, 34392u, 34635u, 34876u, 35116u, 35354u, 35590u,
    35825u, 36059u, 36291u, 36521u, 36750u, 36978u, 37204u, 37429u, 37652u, 37874u, 38095u, 38315u,
    38533u, 38750u, 38966u, 39181u, 39394u, 39606u, 39818u, 40028u, 40237u, 40445u, 40652u, 40857u,
    41062u, 41266u, 41469u, 41671u, 41871u, 42071u, 42270u, 42468u, 42665u, 42861u, 43057u, 43251u,
    43445u, 43637u, 43829u, 44020u, 44210u, 44400u, 44588u, 44776u, 44963u, 45149u, 45334u, 45519u,
    45703u, 45886u, 46069u, 46250u, 46431u, 46612u, 46791u, 46970u, 47149u, 47326u, 47503u, 47679u,
    47855u, 48030u, 48204u, 48378u, 48551u, 48723u, 48895u, 49067u, 49237u, 49407u, 49577u, 49746u,
    49914u, 50082u, 50249u, 50416u, 50582u, 50747u, 50912u, 51077u, 51241u, 51404u, 51567u, 51730u,
    51892u, 52053u, 52214u, 52374u, 52534u, 52694u, 52853u, 53011u, 53169u, 53327u, 53484u, 53640u,
    53797u, 53952u, 54108u, 54262u, 54417u, 54571u, 54724u, 54877u, 55030u, 55182u, 55334u, 55485u,
    55636u, 55787u, 55937u, 56087u, 56236u, 56385u, 56534u, 56682u, 56830u, 56977u, 57124u, 57271u,
    57417u, 57563u, 57709u, 57854u, 57999u, 58143u, 58287u, 58431u, 58574u, 58717u, 58860u, 59002u,
    59144u, 59286u, 59427u, 59568u, 59709u, 59849u, 59989u, 60129u, 60268u, 60407u, 60546u, 60684u,
    60822u, 60960u, 61098u, 61235u, 61372u, 61508u, 61644u, 61780u, 61916u, 62051u, 62186u, 62321u,
    62456u, 62590u, 62724u, 62857u, 62991u, 63124u, 63256u, 63389u, 63521u, 63653u, 63785u, 63916u,
    64047u, 64178u, 64309u, 64439u, 64569u, 64699u, 64828u, 64957u, 65086u, 65215u, 65344u, 65472u
};

static inline uint32_t isqrt32_floor(uint32_t n)
{
    uint32_t g = SQRT_SEED[(n >> 24) - 64u];
    g = (g + n / g) >> 1;
    if (g > 0xFFFFu) {
        g = 0xFFFFu;
    }
    while (g * g > n) {
        g--;
    }
    return g;
}

/*
 * round(sqrt(s)) for s <= 2^63, as uint32 (<= 3037000500); larger s are
 * outside its contract (the final check would overflow).
 *
 * s is normalised by an even shift 2k so that n = s·4^k has bit 63 or 62 set;
 * g = floor(sqrt(n >> 32)) comes from isqrt32_floor (a seed and a Newton
 * step in 32 bits, hardware division on a Cortex-M3), then one more Newton
 * step on the remainder gives sqrt(n) to within a few units, and shifting
 * back by k and a final check against s in exact 64-bit arithmetic give the
 * correctly rounded result. num_hypot's root (86 instructions a num_hypot
 * on a Cortex-M3); num_sqrt takes the same steps in 32 bits (46, where
 * libfixmath's bit-by-bit fix16_sqrt takes 178: docs/performance.md).
 */
static uint32_t isqrt64_round(uint64_t s)
{
    if (s == 0u) {
        return 0u;
    }
    const uint32_t s_hi = (uint32_t)(s >> 32);
    const unsigned lz = s_hi != 0u ? clz32(s_hi) : 32u + clz32((uint32_t)s);
    const unsigned k = lz >> 1;
    const uint64_t n = s << (2u * k);
    const uint32_t hi = (uint32_t)(n >> 32); /* in [2^30, 2^32) */
    const uint32_t lo = (uint32_t)n;

    const uint32_t g = isqrt32_floor(hi); /* floor(sqrt(hi)) in [2^15, 2^16) */
    const uint32_t rem = hi - g * g;      /* ≤ 2g < 2^17 */

    /* sqrt(n) ≈ g·2^16 + (rem·2^32 + lo) / (2·g·2^16); the numerator below is
     * that over 2^17 and fits in 32 bits (rem·2^15 ≤ 2^32 − 2^16). */
    const uint32_t num = (rem << 15) + (lo >> 17);
    uint64_t r = ((uint64_t)g << 16) + num / g; /* ≈ sqrt(n), within a few units */

    /* Back to sqrt(s) = sqrt(n) / 2^k, rounded; then make it exact:
     * round(sqrt(s)) is the r with r² − r < s ≤ r² + r. */
    if (k > 0u) {
        r = (r + ((uint64_t)1 << (k - 1u))) >> k;
    }
    /* sqrt(s) <= 3037000500 and r is within a few units of it: 32 bits, and
     * q² + q < 2^64 (a 32×32-bit product where r² took a 64-bit one). */
    uint32_t q = (uint32_t)r;
    while ((uint64_t)q * q + q < s) {
        q++;
    }
    while (q > 0u && (uint64_t)q * q - q >= s) {
        q--;
    }
    return q;
}

num_t num_sqrt(num_t a)
{
    if (a <= 0) {
        return NUM_ZERO;
    }
    /* round(sqrt(s)) for s = a·2^16 < 2^47 (sqrt(a/2^16)·2^16 = sqrt(a·2^16):
     * at most 181.02·2^16, in range), in 32-bit arithmetic but for the final
     * check: isqrt64_round's steps for an s whose low 16 bits are zero.
     * n = a·4^k lies in [2^30, 2^32); g = floor(sqrt(n)) (isqrt32_floor);
     * then sqrt(n)·2^8 ≈ g·2^8 + rem·2^7/g to
     * within one unit (the tangent is above the root by at most
     * 2^8 rem²/(8 g³) <= 2^7/g < 2^-8, and the quotient is truncated), and
     * sqrt(s) = sqrt(n)·2^8 / 2^k, rounded. That is within one of
     * round(sqrt(s)), and one check each way against s, exact in 64 bits,
     * makes it the r with r² − r < s <= r² + r: the same value as
     * isqrt64_round(s) for every a (checked against it over all 2^31
     * non-negative inputs when it was written). On a Cortex-M3 it takes
     * half the instructions it took through isqrt64_round (92 -> 46). */
    const uint32_t u = (uint32_t)a;
    const unsigned k = clz32(u) >> 1; /* 0 … 15 */
    const uint32_t n = u << (2u * k);
    const uint32_t g = isqrt32_floor(n);
    const uint32_t rem = n - g * g; /* <= 2g < 2^17 */
    uint32_t r = (g << 8) + (rem << 7) / g;
    if (k > 0u) {
        r = (r + (1u << (k - 1u))) >> k;
    }
    const uint64_t s = (uint64_t)u << 16;
    const uint64_t r2 = (uint64_t)r * r;
    if (r2 + r < s) {
        r++;
    } else if (r2 - r >= s) {
        r--;
    } else {
        /* r is the root */
    }
    return (num_t)r;
}

num_t num_hypot(num_t x, num_t y)
{
    /* Exact sum of squares in Q32.32: each square ≤ 2^62, so the sum < 2^63. */
    const uint64_t ax = uabs32(x);
    const uint64_t ay = uabs32(y);
    const uint32_t r = isqrt64_round(ax * ax + ay * ay);
    return r > (uint32_t)INT32_MAX ? NUM_MAX : (num_t)r;
}

/* ------------------------------------------------------------ trigonometry */

/* π/2 in Q32.32 (6746518852.26…), 2/π in Q0.32 (2734261102.37…). */
#define HALF_PI_Q32     INT64_C(6746518852)
#define TWO_OVER_PI_Q32 INT64_C(2734261102)

/* Taylor coefficients in Q2.30 for |r| ≤ π/4 (+ a little): the first omitted
 * terms are r⁹/9! ≤ 3.1e-7 and r¹⁰/10! ≤ 2.5e-8, below 0.02 LSB. */
#define SIN_C3  (-178956971) /* −1/6 */
#define SIN_C5  8947849      /* 1/120 */
#define SIN_C7  (-213045)    /* −1/5040 */
#define COS_C2  (-536870912) /* −1/2 */
#define COS_C4  44739243     /* 1/24 */
#define COS_C6  (-1491308)   /* −1/720 */
#define COS_C8  26631        /* 1/40320 */
#define ONE_Q30 (1 << 30)

/*
 * a = q·π/2 + r with q = round(a·2/π) and |r| ≲ π/4, r in Q2.30; then
 * sin(a) = ±sin r or ±cos r by quadrant q mod 4, cos(a) by (q + 1) mod 4.
 */
typedef struct {
    int32_t q; /* the multiple of π/2 */
    int32_t r; /* the remainder, Q2.30 */
    int32_t z; /* r², Q2.30 */
} reduced_t;

static inline reduced_t reduce_half_pi(num_t a)
{
    reduced_t d;
    /* q from a·(2/π): |a·2^16·(2/π)·2^32| < 2^63. The rounding of q may be
     * off by one at a boundary; r is then just past π/4, still accurate. */
    d.q = (int32_t)(((int64_t)a * TWO_OVER_PI_Q32 + (INT64_C(1) << 47)) >> 48);
    /* r = a − q·π/2 in Q32.32, exact but for π/2's 2^-33 rounding times q. */
    const int64_t r32 = ((int64_t)a * 65536) - (int64_t)d.q * HALF_PI_Q32;
    d.r = (int32_t)((r32 + 2) >> 2); /* Q2.30, |r| < 0.8 */
    d.z = mul_q30(d.r, d.r);
    return d;
}

/* sin r = r + r·z·(C3 + z·(C5 + z·C7)), Q2.30. */
static inline int32_t sin_poly(const reduced_t *d)
{
    int32_t p = SIN_C5 + mul_q30(d->z, SIN_C7);
    p = SIN_C3 + mul_q30(d->z, p);
    return d->r + mul_q30(d->r, mul_q30(d->z, p));
}

/* cos r = 1 + z·(C2 + z·(C4 + z·(C6 + z·C8))), Q2.30. */
static inline int32_t cos_poly(const reduced_t *d)
{
    int32_t p = COS_C6 + mul_q30(d->z, COS_C8);
    p = COS_C4 + mul_q30(d->z, p);
    p = COS_C2 + mul_q30(d->z, p);
    return ONE_Q30 + mul_q30(d->z, p);
}

/* sin(a) (cos_shift = 0) or cos(a) (cos_shift = 1) in Q2.30. */
static int32_t sincos_q30(num_t a, unsigned cos_shift)
{
    const reduced_t d = reduce_half_pi(a);
    const unsigned quadrant = ((unsigned)d.q + cos_shift) & 3u;
    const int32_t v = (quadrant & 1u) == 0u ? sin_poly(&d) : cos_poly(&d);
    return (quadrant & 2u) != 0u ? -v : v;
}

num_t num_sin(num_t a) { return q30_to_q16(sincos_q30(a, 0u)); }

num_t num_cos(num_t a) { return q30_to_q16(sincos_q30(a, 1u)); }

void num_sincos(num_t a, num_t *s, num_t *c)
{
    /* sincos_q30 twice, with the reduction and each polynomial once. */
    const reduced_t d = reduce_half_pi(a);
    const int32_t sp = sin_poly(&d);
    const int32_t cp = cos_poly(&d);
    const unsigned qs = (unsigned)d.q & 3u;
    const unsigned qc = ((unsigned)d.q + 1u) & 3u;
    const int32_t vs = (qs & 1u) == 0u ? sp : cp;
    const int32_t vc = (qc & 1u) == 0u ? sp : cp;
    *s = q30_to_q16((qs & 2u) != 0u ? -vs : vs);
    *c = q30_to_q16((qc & 2u) != 0u ? -vc : vc);
}

/*
 * floor((u1·2^32 + u0) / v) for u1 < v and v normalised (bit 31 set): the
 * quotient fits in 32 bits. Two 16-bit digits of schoolbook division, each
 * from a 32/16 hardware division and at most two corrections (Knuth's
 * algorithm D; Hacker's Delight, divlu).
 */
static inline uint32_t udiv64_32(uint32_t u1, uint32_t u0, uint32_t v)
{
    const uint32_t b = 65536u;
    const uint32_t vn1 = v >> 16;
    const uint32_t vn0 = v & 0xFFFFu;
    const uint32_t un1 = u0 >> 16;
    const uint32_t un0 = u0 & 0xFFFFu;

    uint32_t q1 = u1 / vn1;
    uint32_t rhat = u1 - q1 * vn1;
    while (q1 >= b || q1 * vn0 > b * rhat + un1) {
        q1--;
        rhat += vn1;
        if (rhat >= b) {
            break;
        }
    }
    const uint32_t un21 = u1 * b + un1 - q1 * v; /* mod 2^32: the true value < v */
    uint32_t q0 = un21 / vn1;
    rhat = un21 - q0 * vn1;
    while (q0 >= b || q0 * vn0 > b * rhat + un0) {
        q0--;
        rhat += vn1;
        if (rhat >= b) {
            break;
        }
    }
    return q1 * b + q0;
}

/*
 * num_div: fix16_sdiv's result (deps/libfixmath/fix16.c, its fix16_div for
 * processors with a 32-bit hardware division, rounding and overflow
 * detection on) in closed form. With A = |a|, B = |b| as unsigned values
 * (|INT32_MIN| = 2^31, as fix_abs gives it):
 *
 * - fix16_div forms the quotient Q in units of 2^-17 and returns
 *   (Q + 1) >> 1 with the sign of a·b. For B >= 2^20 it first takes the
 *   estimate q0 = floor(A / (floor(B/2^17) + 1)) and the remainder
 *   A − floor(q0 B / 2^17), whose floor dropped e = (q0 B) mod 2^17; its
 *   loop of 32-bit divisions then divides the remainder exactly (long
 *   division, the divisor's factors of 16 shifted out alike), so
 *   Q = q0 + floor((A 2^17 − q0 B + e) / B) = floor((A 2^17 + e) / B).
 *   For B < 2^20 there is no estimate: e = 0.
 * - Its overflow test fires on a digit whose place puts the quotient at
 *   2^32 or beyond: for B >= 2^20, Q < 2^29 and it never does; for B < 2^20
 *   exactly when Q >= 2^32 (the first digit, taken from the remainder
 *   shifted left as far as it goes, is the one). Q = 2^32 − 1 passes the
 *   test and (Q + 1) >> 1 = 2^31 becomes INT32_MIN, which fix16_div and then
 *   fix16_sdiv read as an overflow too. fix16_sdiv saturates an overflow, and
 *   b == 0, by the signs: NUM_MAX when a and b have the same sign (b = 0
 *   counting as positive), NUM_MIN otherwise.
 *
 * So: saturate when b == 0 or Q >= 2^32 − 1, else ±((Q + 1) >> 1). Q by
 * long division with 32-bit hardware divisions: the integer part
 * q = floor(A / B) and its remainder r < B, then floor(r 2^17 / B) in one
 * digit when B < 2^15, in two (12 and 5 bits) when B < 2^20, each digit's
 * dividend below 2^32; for B >= 2^20, with e, from one 64/32 division
 * (udiv64_32, the divisor normalised; there Q < 2^29). Checked against
 * fix16_sdiv in tests/unit/test_num.c (edges and 10^6 pairs at every
 * magnitude) and on 4·10^9 pairs when it was written.
 */
num_t num_div(num_t a, num_t b)
{
    const num_t saturated = (a ^ b) < 0 ? NUM_MIN : NUM_MAX;
    if (b == 0) {
        return saturated;
    }
    const uint32_t ua = uabs32(a);
    const uint32_t ub = uabs32(b);
    uint32_t q;
    if (ub < (1u << 20)) {
        const uint32_t q_int = ua / ub;
        if (q_int >= (1u << 15)) {
            return saturated; /* Q >= 2^32 */
        }
        const uint32_t r = ua - q_int * ub;
        uint32_t low;
        if (ub < (1u << 15)) {
            low = (r << 17) / ub;
        } else {
            const uint32_t r12 = r << 12; /* < 2^32 */
            const uint32_t d12 = r12 / ub;
            low = (d12 << 5) + ((r12 - d12 * ub) << 5) / ub;
        }
        q = (q_int << 17) + low;
        if (q == UINT32_MAX) {
            return saturated; /* (Q + 1) >> 1 = 2^31 */
        }
    } else {
        const uint32_t q0 = ua / ((ub >> 17) + 1u);
        const uint32_t e = (q0 * ub) & 0x1FFFFu; /* the low 17 bits of the 64-bit product */
        const unsigned sh = clz32(ub);           /* <= 11 */
        /* (A 2^17 + e) 2^sh < 2^(49 + 11): its high word is below ub 2^sh. */
        const uint64_t nn = (((uint64_t)ua << 17) + e) << sh;
        q = udiv64_32((uint32_t)(nn >> 32), (uint32_t)nn, ub << sh);
    }
    const num_t m = (num_t)((q + 1u) >> 1); /* q < 2^32 − 1: m < 2^31 */
    return (a ^ b) < 0 ? -m : m;
}

/*
 * num_mul_period: the period in Q0.32, D = floor(us 2^32 / 10^6)
 * = floor(us 2^26 / 15625) (< 2^32 for us < 10^6), by long division in
 * two 32-bit digits: q1 = floor(us 2^10 / 15625) with remainder r1, then
 * floor(r1 2^16 / 15625) (us 2^10 < 2^30 and r1 2^16 < 2^30: no overflow,
 * no 64-bit division). D is below the period by less than 2^-32 s, so a·D
 * by less than |a| 2^-32; rounding a·D / 2^32 to the nearest code adds
 * 0.5 LSB at most (|a·D| < 2^63).
 */
num_t num_mul_period(num_t a, num_t dt, uint32_t us)
{
    (void)dt;
    const uint32_t u = us << 10;
    const uint32_t q1 = u / 15625u;
    const uint32_t r1 = u - q1 * 15625u;
    const uint32_t d = (q1 << 16) + (r1 << 16) / 15625u;
    const int64_t p = (int64_t)a * (int64_t)d;
    return (num_t)((p + (INT64_C(1) << 31)) >> 32);
}

/* Coefficients of atan(t) ≈ t·(A1 + A3·t² + … + A13·t¹²) on [0, 1], in
 * Q2.30: a minimax fit (tools/numerics/fit-atan), max error 2.48e-7 rad
 * (0.016 LSB) with the coefficients rounded as here. */
#define ATAN_A1        1073737649
#define ATAN_A3        (-357742515)
#define ATAN_A5        212684800
#define ATAN_A7        (-142091928)
#define ATAN_A9        85495265
#define ATAN_A11       (-36082255)
#define ATAN_A13       7314107
/* π/4, π/2 and π in Q2.30 as unsigned (π·2^30 needs 32 bits). */
#define QUARTER_PI_U30 843314857u
#define HALF_PI_U30    1686629713u
#define PI_U30         3373259426u

num_t num_atan2(num_t y, num_t x)
{
    const uint32_t ax = uabs32(x);
    const uint32_t ay = uabs32(y);
    if (ax == 0u && ay == 0u) {
        return NUM_ZERO;
    }
    /* Octant: t = min/max in [0, 1]. */
    const bool steep = ay > ax;
    const uint32_t n = steep ? ax : ay;
    const uint32_t m = steep ? ay : ax;
    uint32_t angle; /* atan(n/m) in Q2.30, then the full angle in [0, π] */
    if (n == m) {
        angle = QUARTER_PI_U30;
    } else {
        /* t = n/m in Q0.32 from the normalised pair (n < m so t < 1). */
        const unsigned sh = clz32(m);
        const uint32_t t32 = udiv64_32(n << sh, 0u, m << sh);
        const int32_t t = (int32_t)(t32 >> 2); /* Q2.30 */
        const int32_t z = mul_q30(t, t);
        int32_t p = ATAN_A11 + mul_q30(z, ATAN_A13);
        p = ATAN_A9 + mul_q30(z, p);
        p = ATAN_A7 + mul_q30(z, p);
        p = ATAN_A5 + mul_q30(z, p);
        p = ATAN_A3 + mul_q30(z, p);
        p = ATAN_A1 + mul_q30(z, p);
        angle = (uint32_t)mul_q30(t, p);
    }
    if (steep) {
        angle = HALF_PI_U30 - angle;
    }
    if (x < 0) {
        angle = PI_U30 - angle;
    }
    const num_t r = (num_t)((angle + (1u << 13)) >> 14);
    return y < 0 ? -r : r;
}

/* ------------------------------------------------------------- angle wrap */

/* 2π and π in Q32.32; 1/(2π) in Q0.32 (683565275.58…). */
#define TWO_PI_Q32     INT64_C(26986075409)
#define PI_Q32         INT64_C(13493037705)
#define INV_TWO_PI_Q32 INT64_C(683565276)

num_t num_wrap(num_t a)
{
    if (a > -NUM_PI && a <= NUM_PI) {
        return a;
    }
    /* k = round(a/2π) from a multiplication (|a·2^16·2^32/2π| < 2^61); then
     * w = a − k·2π in Q32.32, exact but for 2π's rounding (2^-33) times
     * |k| ≤ 5216, i.e. ≤ 6e-7 = 0.04 LSB. */
    const int64_t k = ((int64_t)a * INV_TWO_PI_Q32 + (INT64_C(1) << 47)) >> 48;
    int64_t w = ((int64_t)a * 65536) - k * TWO_PI_Q32;
    /* k may be off by one at the seam: bring w into (−π, π]. */
    if (w > PI_Q32) {
        w -= TWO_PI_Q32;
    } else if (w <= -PI_Q32) {
        w += TWO_PI_Q32;
    }
    /* π·2^16 = 205887.42, so w rounds to a code in [−NUM_PI, NUM_PI]; the
     * seam code −NUM_PI becomes NUM_PI, as in float mode. */
    const num_t r = (num_t)((w + (INT64_C(1) << 15)) >> 16);
    return r == -NUM_PI ? NUM_PI : r;
}

#endif /* NUM_FIXED */
