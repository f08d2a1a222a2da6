/* SPDX-License-Identifier: MIT */
/*
 * Measures the error of every fixed-point primitive of firmware/num against
 * libm in double precision, over the domain num_fixed.h documents, and prints
 * docs/numerics.md (Markdown) on stdout. `make numerics` runs it.
 *
 * Inputs are Q16.16 codes; the reference is the double-precision function of
 * the exact real values those codes hold, so the errors are the primitive's
 * own (its rounding to Q16.16 included: 0.5 LSB is the best possible).
 * Samples are either every code of a range (exhaustive) or drawn from a fixed
 * pseudo-random sequence (splitmix64), so the output is the same every run.
 *
 * For comparison, the same measurement is made of libfixmath's sqrt, sin, cos
 * and atan2 (with the build's libfixmath configuration), which the firmware
 * does not use, and of the float-mode (single precision, libm) primitives.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "num/num.h"

/* libfixmath's header is not clean under -Wconversion (see mk/numeric.mk). */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#include "fix16.h"
#pragma GCC diagnostic pop

#define LSB    (1.0 / 65536.0)
#define PI     3.14159265358979323846
#define TWO_PI 6.28318530717958647692

/* ------------------------------------------------------------- sampling */

static uint64_t rng_state;

static void rng_seed(uint64_t s) { rng_state = s; }

static uint64_t rng_next(void)
{
    uint64_t z = (rng_state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* Uniform double in [lo, hi). */
static double rng_uniform(double lo, double hi)
{
    return lo + (hi - lo) * ((double)(rng_next() >> 11) * (1.0 / 9007199254740992.0));
}

/* A Q16.16 code uniform in [lo, hi] (reals). */
static num_t rng_code(double lo, double hi)
{
    const int64_t a = (int64_t)ceil(lo * 65536.0);
    const int64_t b = (int64_t)floor(hi * 65536.0);
    return (num_t)(a + (int64_t)(rng_next() % (uint64_t)(b - a + 1)));
}

/* A code whose magnitude is log-uniform over [2^-16, 2^lg_max], either sign:
 * exercises small and large operands alike. */
static num_t rng_code_log(double lg_max)
{
    const double mag = exp2(rng_uniform(-16.0, lg_max));
    double raw = floor(mag * 65536.0);
    if (raw > 2147483647.0) {
        raw = 2147483647.0;
    }
    const num_t c = (num_t)raw;
    return (rng_next() & 1u) ? c : -c;
}

static double val(num_t a) { return (double)a * LSB; }

/* ----------------------------------------------------------- statistics */

typedef struct {
    const char *name;   /* primitive */
    const char *impl;   /* implementation */
    const char *domain; /* inputs */
    const char *note;
    uint64_t n;
    double max_err;
    double sum_sq;
    double worst_in[2]; /* inputs of the largest error */
} stat_t;

static void stat_add(stat_t *s, double err, double in0, double in1)
{
    const double e = fabs(err);
    s->n++;
    s->sum_sq += e * e;
    if (e > s->max_err || s->n == 1u) {
        s->max_err = e;
        s->worst_in[0] = in0;
        s->worst_in[1] = in1;
    }
}

#define MAX_ROWS 64
static stat_t rows[MAX_ROWS];
static size_t n_rows;

static stat_t *row(const char *name, const char *impl, const char *domain, const char *note)
{
    if (n_rows == MAX_ROWS) {
        fprintf(stderr, "numerics: too many rows\n");
        exit(1);
    }
    stat_t *s = &rows[n_rows++];
    memset(s, 0, sizeof *s);
    s->name = name;
    s->impl = impl;
    s->domain = domain;
    s->note = note;
    return s;
}

/* Angle difference wrapped into [-π, π]: errors of angles modulo 2π. */
static double angle_diff(double a, double b) { return remainder(a - b, TWO_PI); }

/* --------------------------------------------------------- measurements */

#define N_RANDOM 2000000u

static void measure_mul(void)
{
    stat_t *s = row("num_mul", "fix16_smul's bits, inline", "a, b log-uniform, |a·b| < 32768",
                    "exact product, rounded");
    rng_seed(1);
    while (s->n < N_RANDOM) {
        const num_t a = rng_code_log(15.0);
        const num_t b = rng_code_log(15.0);
        const double ref = val(a) * val(b);
        if (fabs(ref) >= 32767.0) {
            continue;
        }
        stat_add(s, val(num_mul(a, b)) - ref, val(a), val(b));
    }
}

static void measure_div(void)
{
    stat_t *s = row("num_div", "fix16_sdiv's bits, num_fixed.c", "a, b log-uniform, |a/b| < 32768",
                    "rounded quotient");
    rng_seed(2);
    while (s->n < N_RANDOM) {
        const num_t a = rng_code_log(15.0);
        const num_t b = rng_code_log(15.0);
        const double ref = val(a) / val(b);
        if (fabs(ref) >= 32767.0) {
            continue;
        }
        stat_add(s, val(num_div(a, b)) - ref, val(a), val(b));
    }
}

static void measure_sqrt(void)
{
    stat_t *s = row("num_sqrt", "num_fixed.c (integer root)",
                    "every code in (0, 16]; every 61st code up to 32768", "");
    stat_t *l = row("sqrt", "libfixmath fix16_sqrt (not used)", "the same", "");
    stat_t *f = row("sqrt", "float mode: sqrtf (reference)", "the same", "");
    for (int64_t a = 1; a <= INT32_MAX; a += (a <= (16 << 16) ? 1 : 61)) {
        const double x = val((num_t)a);
        const double ref = sqrt(x);
        stat_add(s, val(num_sqrt((num_t)a)) - ref, x, 0.0);
        stat_add(l, val(fix16_sqrt((int32_t)a)) - ref, x, 0.0);
        stat_add(f, (double)sqrtf((float)x) - ref, x, 0.0);
    }
}

static void measure_hypot(void)
{
    stat_t *s = row("num_hypot", "num_fixed.c (64-bit sum of squares)",
                    "x, y uniform in [-100, 100] (a 100 m field)", "");
    stat_t *f = row("hypot", "float mode: hypotf (reference)", "the same", "");
    stat_t *t = row("num_hypot", "num_fixed.c", "x, y log-uniform, |x|, |y| < 23170",
                    "whole range where the result fits");
    rng_seed(3);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const num_t x = rng_code(-100.0, 100.0);
        const num_t y = rng_code(-100.0, 100.0);
        const double ref = hypot(val(x), val(y));
        stat_add(s, val(num_hypot(x, y)) - ref, val(x), val(y));
        stat_add(f, (double)hypotf((float)val(x), (float)val(y)) - ref, val(x), val(y));
    }
    rng_seed(4);
    while (t->n < N_RANDOM) {
        const num_t x = rng_code_log(14.49);
        const num_t y = rng_code_log(14.49);
        const double ref = hypot(val(x), val(y));
        if (ref >= 32767.0) {
            continue;
        }
        stat_add(t, val(num_hypot(x, y)) - ref, val(x), val(y));
    }
}

typedef num_t (*fn1_t)(num_t);
typedef int32_t (*fix1_t)(int32_t);

static num_t fix_sin(num_t a) { return fix16_sin(a); }
static num_t fix_cos(num_t a) { return fix16_cos(a); }

static void measure_trig(const char *name, fn1_t ours, fix1_t theirs, double (*ref_fn)(double),
                         float (*flt)(float))
{
    stat_t *s = row(name, "num_fixed.c (reduction mod π/2, polynomial in Q2.30)",
                    "every code in [-4π, 4π]", "");
    /* "sin" / "cos": the comparison rows are not num_sin / num_cos. */
    stat_t *l = row(name + 4,
                    theirs == fix_sin ? "libfixmath fix16_sin (not used)"
                                      : "libfixmath fix16_cos (not used)",
                    "the same", "");
    stat_t *f = row(name + 4, "float mode: sinf/cosf (reference)", "the same", "");
    stat_t *w = row(name, "num_fixed.c", "random codes over the whole range ±32768", "");
    const int32_t lim = (int32_t)(4.0 * PI * 65536.0);
    for (int32_t a = -lim; a <= lim; a++) {
        const double x = val(a);
        const double ref = ref_fn(x);
        stat_add(s, val(ours(a)) - ref, x, 0.0);
        stat_add(l, val(theirs(a)) - ref, x, 0.0);
        stat_add(f, (double)flt((float)x) - ref, x, 0.0);
    }
    rng_seed(5);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const num_t a = (num_t)(uint32_t)rng_next();
        stat_add(w, val(ours(a)) - ref_fn(val(a)), val(a), 0.0);
    }
}

static void measure_atan2(void)
{
    stat_t *s = row("num_atan2", "num_fixed.c (octant, 32-bit ratio, degree-13 polynomial)",
                    "x, y uniform in [-100, 100]", "");
    stat_t *l = row("atan2", "libfixmath fix16_atan2 (not used)", "the same", "");
    stat_t *f = row("atan2", "float mode: atan2f (reference)", "the same", "");
    stat_t *t = row("num_atan2", "num_fixed.c", "x, y log-uniform over the whole range", "");
    stat_t *u = row("num_atan2", "num_fixed.c", "x, y uniform in [-0.01, 0.01]",
                    "small vectors: few significant bits");
    rng_seed(6);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const num_t x = rng_code(-100.0, 100.0);
        const num_t y = rng_code(-100.0, 100.0);
        const double ref = atan2(val(y), val(x));
        stat_add(s, val(num_atan2(y, x)) - ref, val(y), val(x));
        stat_add(l, val(fix16_atan2(y, x)) - ref, val(y), val(x));
        stat_add(f, (double)atan2f((float)val(y), (float)val(x)) - ref, val(y), val(x));
    }
    rng_seed(7);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const num_t x = rng_code_log(15.0);
        const num_t y = rng_code_log(15.0);
        stat_add(t, val(num_atan2(y, x)) - atan2(val(y), val(x)), val(y), val(x));
    }
    rng_seed(8);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const num_t x = rng_code(-0.01, 0.01);
        const num_t y = rng_code(-0.01, 0.01);
        if (x == 0 && y == 0) {
            continue;
        }
        stat_add(u, val(num_atan2(y, x)) - atan2(val(y), val(x)), val(y), val(x));
    }
}

static void measure_wrap(void)
{
    stat_t *s = row("num_wrap", "num_fixed.c", "every code in [-64, 64]",
                    "error modulo 2π against the exact value; checked: every result in "
                    "(−NUM_PI, NUM_PI], identity there; the largest errors are at the seam, "
                    "where −NUM_PI is returned as NUM_PI");
    stat_t *v =
        row("num_wrap", "num_fixed.c", "the same, results other than NUM_PI", "away from the seam");
    stat_t *w = row("num_wrap", "num_fixed.c", "random codes over the whole range ±32768",
                    "error modulo 2π");
    unsigned bad_range = 0;
    unsigned bad_identity = 0;
    const int32_t lim = 64 << 16;
    for (int32_t a = -lim; a <= lim; a++) {
        const num_t r = num_wrap(a);
        if (r <= -NUM_PI || r > NUM_PI) {
            bad_range++;
        }
        if (a > -NUM_PI && a <= NUM_PI && r != a) {
            bad_identity++;
        }
        stat_add(s, angle_diff(val(r), val(a)), val(a), 0.0);
        if (r != NUM_PI) {
            stat_add(v, angle_diff(val(r), val(a)), val(a), 0.0);
        }
    }
    rng_seed(9);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const num_t a = (num_t)(uint32_t)rng_next();
        const num_t r = num_wrap(a);
        if (r <= -NUM_PI || r > NUM_PI) {
            bad_range++;
        }
        stat_add(w, angle_diff(val(r), val(a)), val(a), 0.0);
    }
    if (bad_range != 0u || bad_identity != 0u) {
        fprintf(stderr,
                "numerics: num_wrap: %u results out of (-NUM_PI, NUM_PI], %u not identity\n",
                bad_range, bad_identity);
        exit(1);
    }
}

static void measure_conversions(void)
{
    stat_t *s = row("num_from_float", "num_fixed.h", "floats uniform in [-32768, 32767]",
                    "round to nearest");
    stat_t *t = row("num_to_float", "num_fixed.h", "every code in [-256, 256]", "exact below 256");
    stat_t *u = row("num_to_float", "num_fixed.h", "random codes over the whole range",
                    "rounded to float's 24 bits");
    stat_t *v = row("num_from_int", "num_fixed.h", "every integer in [-32768, 32767]", "exact");
    rng_seed(10);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const float x = (float)rng_uniform(-32768.0, 32767.0);
        stat_add(s, val(num_from_float(x)) - (double)x, (double)x, 0.0);
    }
    for (int32_t a = -(256 << 16); a <= (256 << 16); a++) {
        stat_add(t, (double)num_to_float(a) - val(a), val(a), 0.0);
    }
    rng_seed(11);
    for (uint32_t i = 0; i < N_RANDOM; i++) {
        const num_t a = (num_t)(uint32_t)rng_next();
        stat_add(u, (double)num_to_float(a) - val(a), val(a), 0.0);
    }
    for (int32_t i = -32768; i <= 32767; i++) {
        stat_add(v, val(num_from_int(i)) - (double)i, (double)i, 0.0);
    }
}

/* Saturation: a few exact checks, reported as a list. */
static void saturation_checks(void)
{
    struct {
        const char *what;
        num_t got, want;
    } c[] = {
        { "num_add(NUM_MAX, 1 LSB)", num_add(NUM_MAX, 1), NUM_MAX },
        { "num_add(NUM_MIN, −1 LSB)", num_add(NUM_MIN, -1), NUM_MIN },
        { "num_sub(NUM_MIN, 1 LSB)", num_sub(NUM_MIN, 1), NUM_MIN },
        { "num_sub(NUM_MAX, −1 LSB)", num_sub(NUM_MAX, -1), NUM_MAX },
        { "num_neg(NUM_MIN)", num_neg(NUM_MIN), NUM_MAX },
        { "num_abs(NUM_MIN)", num_abs(NUM_MIN), NUM_MAX },
        { "num_mul(200, 200)", num_mul(NUM_C(200), NUM_C(200)), NUM_MAX },
        { "num_mul(−200, 200)", num_mul(NUM_C(-200), NUM_C(200)), NUM_MIN },
        { "num_div(1000, 0.001)", num_div(NUM_C(1000), NUM_C(0.001)), NUM_MAX },
        { "num_div(1, 0)", num_div(NUM_ONE, NUM_ZERO), NUM_MAX },
        { "num_div(−1, 0)", num_div(-NUM_ONE, NUM_ZERO), NUM_MIN },
        { "num_hypot(NUM_MIN, NUM_MIN)", num_hypot(NUM_MIN, NUM_MIN), NUM_MAX },
        { "num_hypot(30000, 30000)", num_hypot(NUM_C(30000), NUM_C(30000)), NUM_MAX },
        { "num_sqrt(−1)", num_sqrt(-NUM_ONE), NUM_ZERO },
        { "num_from_float(1e9)", num_from_float(1e9f), NUM_MAX },
        { "num_from_float(−1e9)", num_from_float(-1e9f), NUM_MIN },
        { "num_from_int(40000)", num_from_int(40000), NUM_MAX },
        { "num_wrap(NUM_PI)", num_wrap(NUM_PI), NUM_PI },
        { "num_wrap(−NUM_PI)", num_wrap(-NUM_PI), NUM_PI },
        { "num_wrap(NUM_PI + 1 LSB)", num_wrap(NUM_PI + 1), NUM_PI },
        { "num_wrap(NUM_PI + 2 LSB)", num_wrap(NUM_PI + 2), -NUM_PI + 1 },
        { "num_wrap(NUM_TWO_PI)", num_wrap(NUM_TWO_PI), NUM_ZERO },
        { "num_wrap(NUM_MIN)", num_wrap(NUM_MIN),
          NUM_C(-32768.0 + 5215.0 * 6.28318530717958647692) },
        { "num_atan2(0, −1)", num_atan2(NUM_ZERO, -NUM_ONE), NUM_PI },
        { "num_atan2(0, 0)", num_atan2(NUM_ZERO, NUM_ZERO), NUM_ZERO },
    };
    unsigned failed = 0;
    printf("## Saturation and edge cases (exact)\n\n");
    printf("| expression | result | expected |\n|---|---|---|\n");
    for (size_t i = 0; i < sizeof c / sizeof c[0]; i++) {
        printf("| `%s` | %.8g | %.8g%s |\n", c[i].what, val(c[i].got), val(c[i].want),
               c[i].got == c[i].want ? "" : " **differs**");
        failed += c[i].got != c[i].want;
    }
    printf("\n");
    if (failed != 0u) {
        fprintf(stderr, "numerics: %u edge cases differ\n", failed);
        exit(1);
    }
}

/* ------------------------------------------------------------------ report */

static const stat_t *find_row(const char *name, const char *impl_prefix)
{
    for (size_t i = 0; i < n_rows; i++) {
        if (strcmp(rows[i].name, name) == 0 &&
            strncmp(rows[i].impl, impl_prefix, strlen(impl_prefix)) == 0) {
            return &rows[i];
        }
    }
    fprintf(stderr, "numerics: no row %s/%s\n", name, impl_prefix);
    exit(1);
}

/* Markdown table cell text: a '|' would end the cell. */
static void cell(const char *text)
{
    for (const char *c = text; *c != '\0'; c++) {
        if (*c == '|') {
            putchar('\\');
        }
        putchar(*c);
    }
}

static void print_table(void)
{
    printf("| primitive | implementation | domain | samples | max abs error | RMS error | max "
           "error (LSB) | worst input |\n");
    printf("|---|---|---|---:|---:|---:|---:|---|\n");
    for (size_t i = 0; i < n_rows; i++) {
        const stat_t *s = &rows[i];
        const double rms = s->n != 0u ? sqrt(s->sum_sq / (double)s->n) : 0.0;
        char worst[64];
        if (s->worst_in[1] != 0.0 || strstr(s->name, "mul") || strstr(s->name, "div") ||
            strstr(s->name, "hypot") || strstr(s->name, "atan2")) {
            snprintf(worst, sizeof worst, "%.6g, %.6g", s->worst_in[0], s->worst_in[1]);
        } else {
            snprintf(worst, sizeof worst, "%.6g", s->worst_in[0]);
        }
        printf("| `%s` | %s | ", s->name, s->impl);
        cell(s->domain);
        printf(" | %llu | %.3g | %.3g | %.3f | %s |\n", (unsigned long long)s->n, s->max_err, rms,
               s->max_err / LSB, worst);
    }
    printf("\n");
    for (size_t i = 0; i < n_rows; i++) {
        if (rows[i].note[0] != '\0') {
            printf("- `%s`, %s: %s.\n", rows[i].name, rows[i].domain, rows[i].note);
        }
    }
    printf("\n");
}

int main(void)
{
    measure_mul();
    measure_div();
    measure_sqrt();
    measure_hypot();
    measure_trig("num_sin", num_sin, fix_sin, sin, sinf);
    measure_trig("num_cos", num_cos, fix_cos, cos, cosf);
    measure_atan2();
    measure_wrap();
    measure_conversions();

    printf("<!-- Generated by tools/numerics (make numerics). Do not edit by hand. -->\n");
    printf("# Numerics of the fixed-point mode\n\n");
    printf("`NUMERIC=fixed` builds every controller with `num_t` = Q16.16 (firmware/num/"
           "num_fixed.h): range [-32768, 32768 − 2^-16], resolution 1 LSB = 2^-16 = "
           "1.53e-5 (15.3 µm, 15.3 µrad); every operation saturates, none wraps. This file "
           "is written by `tools/numerics/numerics.c`: each primitive is run over the domain "
           "below and compared with libm in double precision, evaluated on the exact real "
           "values of the Q16.16 inputs. 0.5 LSB (7.6e-6) is the error of rounding an exact "
           "result to Q16.16, the least any primitive can have.\n\n");
    printf("libfixmath (Debian source package, `tools/setup/sources.lock`) is built with "
           "`FIXMATH_NO_CACHE`, rounding and overflow detection on, 64-bit multiply, for the "
           "host and the cross builds alike (mk/numeric.mk). The firmware uses its saturating "
           "div, and its saturating mul written inline in firmware/num (the same bits, "
           "checked by tests/unit/test_num.c); its sqrt, sin, cos and atan2 are measured here for "
           "comparison only "
           "(rows marked *not used*), as are the float mode's single-precision primitives "
           "(*reference*).\n\n");
    printf("## Errors against libm (double)\n\n");
    print_table();
    saturation_checks();
    const stat_t *fs = find_row("sin", "libfixmath");
    const stat_t *fa = find_row("atan2", "libfixmath");
    printf("## Why not libfixmath's sqrt, sin, cos, atan2\n\n");
    printf("- sin, cos: its Taylor series to x^11 overflows Q16.16 for |x| > 2.57 (x^11 > "
           "32768), so near ±π it is off by up to %.2g (%.0f LSB, at x = %.6g).\n",
           fs->max_err, fs->max_err / LSB, fs->worst_in[0]);
    printf("- atan2: a cubic in (x − |y|)/(x + |y|), off by up to %.2g rad (%.0f LSB); "
           "x + |y| overflows for large vectors.\n",
           fa->max_err, fa->max_err / LSB);
    printf("- sqrt: correctly rounded, but bit by bit, which takes more instructions than "
           "num_sqrt's seed and Newton step on a Cortex-M3 (docs/performance.md); and there is no "
           "hypot, while squaring in Q16.16 overflows beyond 181.\n\n");
    printf("The polynomial of num_atan2 comes from `tools/numerics/fit-atan`.\n");
    return 0;
}
