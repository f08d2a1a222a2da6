/* SPDX-License-Identifier: MIT */
/* The benchmark on a Cortex-M under QEMU (make bench): instructions of
 * ctl_step, counted with SysTick under `-icount shift=0`, where the counter
 * (processor clock, 25 MHz) advances once per 40 executed instructions, the
 * same every run. Prints `key value` lines for mstc.bench.ctl_step on the
 * semihosting console, then exits QEMU. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "auth/auth.h"
#include "bench.h"
#include "bench_wheel.h"
#include "scenarios.h"

#if defined(NUM_FIXED)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#include "fix16.h"
#pragma GCC diagnostic pop
#endif

#ifndef BENCH_CONFIG
#define BENCH_CONFIG "unknown"
#endif

#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)

static uint32_t systick_last;
static uint64_t systick_high;

/* SysTick as a 64-bit up counter; calls must come less than 2^24 ticks apart. */
static uint64_t ticks(void)
{
    const uint32_t cur = SYST_CVR & 0xFFFFFFu; /* counts down */
    if (cur > systick_last) {
        systick_high += UINT64_C(1) << 24;
    }
    systick_last = cur;
    return systick_high + (0xFFFFFFu - cur);
}

static void systick_start(void)
{
    SYST_RVR = 0xFFFFFFu;
    SYST_CVR = 0u;
    SYST_CSR = 0x5u; /* ENABLE, CLKSOURCE = processor clock, no interrupt */
    while ((SYST_CVR & 0xFFFFFFu) == 0u) {
    }
    systick_last = SYST_CVR & 0xFFFFFFu;
    systick_high = 0u;
}

/* 2·n instructions (+ a handful): the calibration of ticks to instructions. */
static void spin(uint32_t n)
{
    __asm volatile("1: subs %0, %0, #1\n\t"
                   "bne 1b"
                   : "+r"(n)
                   :
                   : "cc");
}

static bench_step_t steps[BENCH_TOTAL_STEPS];

/* ------------------------------------------------- primitive micro-benchmarks */

#define N_ARGS 256u
#define N_REPS 4u
static volatile num_t arg_a[N_ARGS];
static volatile num_t arg_b[N_ARGS];
static volatile num_t sink;
static double ips; /* instructions per tick */

static uint32_t lcg_state = 12345u;
static double lcg_uniform(double lo, double hi)
{
    lcg_state = lcg_state * 1664525u + 1013904223u;
    return lo + (hi - lo) * ((double)(lcg_state >> 8) / 16777216.0);
}

static void fill(double a_lo, double a_hi, double b_lo, double b_hi, int b_any_sign)
{
    lcg_state = 12345u;
    for (unsigned i = 0; i < N_ARGS; i++) {
        arg_a[i] = bench_num(lcg_uniform(a_lo, a_hi));
        double b = lcg_uniform(b_lo, b_hi);
        if (b_any_sign && lcg_uniform(0.0, 1.0) < 0.5) {
            b = -b;
        }
        arg_b[i] = bench_num(b);
    }
}

/* Instructions per evaluation of EXPR (over a and b), less the loop's own
 * (the same loop storing a). */
#define PRIM(NAME, DOMAIN, EXPR)                                                                   \
    do {                                                                                           \
        uint64_t t_op = 0;                                                                         \
        uint64_t t_base = 0;                                                                       \
        for (unsigned rep = 0; rep < N_REPS; rep++) {                                              \
            uint64_t t0 = ticks();                                                                 \
            for (unsigned i = 0; i < N_ARGS; i++) {                                                \
                const num_t a = arg_a[i];                                                          \
                const num_t b = arg_b[i];                                                          \
                (void)b;                                                                           \
                sink = (EXPR);                                                                     \
            }                                                                                      \
            t_op += ticks() - t0;                                                                  \
            t0 = ticks();                                                                          \
            for (unsigned i = 0; i < N_ARGS; i++) {                                                \
                const num_t a = arg_a[i];                                                          \
                const num_t b = arg_b[i];                                                          \
                (void)b;                                                                           \
                sink = a;                                                                          \
            }                                                                                      \
            t_base += ticks() - t0;                                                                \
        }                                                                                          \
        printf("prim %s %.1f %s\n", NAME,                                                          \
               ((double)t_op - (double)t_base) * ips / (double)(N_ARGS * N_REPS), DOMAIN);         \
    } while (0)

/* num_sincos(a) as one value for PRIM (the sum: one addition more). */
static num_t sincos_sum(num_t a)
{
    num_t s;
    num_t c;
    num_sincos(a, &s, &c);
    return num_add(s, c);
}

static void primitives(void)
{
    fill(-10.0, 10.0, -10.0, 10.0, 0);
    PRIM("num_add", "a, b in [-10, 10]", num_add(a, b));
    PRIM("num_mul", "a, b in [-10, 10]", num_mul(a, b));
    fill(-10.0, 10.0, 0.1, 10.0, 1);
    PRIM("num_div", "a in [-10, 10], |b| in [0.1, 10]", num_div(a, b));
    fill(0.0, 100.0, 0.0, 1.0, 0);
    PRIM("num_sqrt", "a in [0, 100]", num_sqrt(a));
#if defined(NUM_FIXED)
    PRIM("fix16_sqrt", "a in [0, 100]", fix16_sqrt(a));
#endif
    fill(-10.0, 10.0, -10.0, 10.0, 0);
    PRIM("num_hypot", "x, y in [-10, 10]", num_hypot(a, b));
    PRIM("num_atan2", "x, y in [-10, 10]", num_atan2(b, a));
#if defined(NUM_FIXED)
    PRIM("fix16_atan2", "x, y in [-10, 10]", fix16_atan2(b, a));
#endif
    fill(-4.0, 4.0, 0.0, 1.0, 0);
    PRIM("num_sin", "a in [-4, 4]", num_sin(a));
    PRIM("num_cos", "a in [-4, 4]", num_cos(a));
    PRIM("num_sincos", "a in [-4, 4] (both, and their sum)", sincos_sum(a));
#if defined(NUM_FIXED)
    PRIM("fix16_sin", "a in [-4, 4]", fix16_sin(a));
#endif
    fill(-8.0, 8.0, 0.0, 1.0, 0);
    PRIM("num_wrap", "a in [-8, 8] (60 % outside (-pi, pi])", num_wrap(a));
}

/* num_sincos() against num_sin() and num_cos() on the target's library (in
 * float mode with newlib it reduces the angle once for both, num_float.h):
 * how many of 400,001 angles over [−40, 40], and of the multiples of π/4
 * and the extremes, give other bits. Prints `sincos_differs N of M`. Then
 * num_sqrt() against sqrtf() (the FPU's instruction, in float mode on the
 * Cortex-M4F) on 400,001 values over [0, 400]: `sqrt_differs N of M`. */
static uint32_t bits_of(num_t a)
{
    uint32_t u;
    memcpy(&u, &a, sizeof u);
    return u;
}

static void sincos_check(void)
{
    const num_t edge[] = { NUM_ZERO,
                           NUM_PI,
                           num_neg(NUM_PI),
                           NUM_HALF_PI,
                           NUM_TWO_PI,
                           NUM_MAX,
                           num_neg(NUM_MAX),
                           bench_num(0.7853981633974483),
                           bench_num(-2.356194490192345) };
    const size_t n_edge = sizeof edge / sizeof edge[0];
    unsigned long differ = 0;
    unsigned long n = 0;
    for (int32_t i = -200000; i <= 200000 + (int32_t)n_edge; i++) {
        const num_t a = i <= 200000 ? bench_num((double)i * 2e-4) : edge[i - 200001];
        num_t s;
        num_t c;
        num_sincos(a, &s, &c);
        differ += bits_of(s) != bits_of(num_sin(a)) || bits_of(c) != bits_of(num_cos(a));
        n++;
    }
#if !defined(NUM_FIXED)
    /* And every float within 4096 steps of nπ/2, n = ±1 .. ±8 (where the
     * reduction's first approximation may not stand). */
    for (int32_t q = -8; q <= 8; q++) {
        const float centre = (float)q * 1.57079632679489662f;
        uint32_t u;
        memcpy(&u, &centre, sizeof u);
        for (uint32_t k = u - 4096u; q != 0 && k != u + 4096u; k++) {
            num_t a;
            memcpy(&a, &k, sizeof a);
            num_t s;
            num_t c;
            num_sincos(a, &s, &c);
            differ += bits_of(s) != bits_of(num_sin(a)) || bits_of(c) != bits_of(num_cos(a));
            n++;
        }
    }
#endif
    printf("sincos_differs %lu of %lu\n", differ, n);
#if !defined(NUM_FIXED)
    differ = 0;
    n = 0;
    for (int32_t i = 0; i <= 400000; i++) {
        const num_t a = bench_num((double)i * 1e-3);
        differ += bits_of(num_sqrt(a)) != bits_of(sqrtf(a));
        n++;
    }
    printf("sqrt_differs %lu of %lu\n", differ, n);
    /* num_hypot() against hypotf() (inline with newlib on the Cortex-M4F):
     * 2^20 pairs, each value of either sign with an exponent over
     * [2^-64, 2^64) and any significand (every branch of hypotf), then
     * the grid 0.01 .. 10 m of the scenes' distances. */
    differ = 0;
    n = 0;
    lcg_state = 12345u;
    for (uint32_t i = 0; i < (UINT32_C(1) << 20); i++) {
        const float x = ldexpf((float)lcg_uniform(1.0, 2.0), (int)lcg_uniform(-64.0, 64.0));
        const float y = ldexpf((float)lcg_uniform(1.0, 2.0), (int)lcg_uniform(-64.0, 64.0));
        const num_t a = (i & 1u) != 0u ? -x : x;
        const num_t b = (i & 2u) != 0u ? -y : y;
        differ += bits_of(num_hypot(a, b)) != bits_of(hypotf(a, b));
        n++;
    }
    for (int32_t i = 1; i <= 1000; i++) {
        for (int32_t j = 0; j <= 1000; j += 7) {
            const num_t a = (float)i * 0.01f;
            const num_t b = (float)j * 0.01f;
            differ += bits_of(num_hypot(a, b)) != bits_of(hypotf(a, b));
            n++;
        }
    }
    printf("hypot_differs %lu of %lu\n", differ, n);
#endif
}

/* ----------------------------------------------------------------- loads */

static const char *const mode_names[BENCH_N_MODES] = { "track", "avoid", "stop", "blocked" };

/* Per-mode mean and largest step, less the empty loop's mean @p base. */
static void print_by_mode(const char *key, const uint64_t *sum, const uint64_t *cnt,
                          const uint64_t *max, double base)
{
    for (unsigned m = 0; m < BENCH_N_MODES; m++) {
        if (cnt[m] != 0u) {
            printf("%s %s steps %u mean %.0f max %.0f\n", key, mode_names[m], (unsigned)cnt[m],
                   ((double)sum[m] / (double)cnt[m] - base) * ips, ((double)max[m] - base) * ips);
        }
    }
}

/* One load: record @p sc's closed loop under its strategy, check the replay,
 * count instructions (whole replay, and the largest single step). Prints
 * `load NAME strategy S obstacles N in_view X steps N replay_differs N
 * instr_per_step X max X min_clearance X events ...`. */
static void load(const bench_scenario_t *sc)
{
    bench_run_t run;
    bench_record(sc, steps, &run);
    const size_t n = run.n_steps;
    const size_t differ = bench_verify(steps, n, sc->strategy);
    const uint64_t t_step = bench_replay(steps, n, sc->strategy, bench_ctl_step, ticks);
    const uint64_t t_empty = bench_replay(steps, n, sc->strategy, bench_empty_step, ticks);
    uint64_t sum[BENCH_N_MODES] = { 0 }, cnt[BENCH_N_MODES] = { 0 }, max[BENCH_N_MODES] = { 0 };
    uint64_t esum[BENCH_N_MODES] = { 0 }, ecnt[BENCH_N_MODES] = { 0 }, emax[BENCH_N_MODES] = { 0 };
    bench_replay_each(steps, n, sc->strategy, bench_ctl_step, ticks, sum, cnt, max);
    bench_replay_each(steps, n, sc->strategy, bench_empty_step, ticks, esum, ecnt, emax);
    const double base = (double)(esum[0] + esum[1] + esum[2] + esum[3]) / (double)n;
    uint64_t largest = 0;
    for (unsigned m = 0; m < BENCH_N_MODES; m++) {
        largest = max[m] > largest ? max[m] : largest;
    }
    /* Smallest clearance to D_s (bench_record()). */
    const double clear = run.min_clearance;
    printf("load %s strategy %s obstacles %u in_view %.2f steps %u replay_differs %u "
           "instr_per_step %.1f max %.0f min_clearance %.4f events",
           sc->name, sc->strategy == (uint8_t)CTL_STRATEGY_MSTC ? "mstc" : "paper",
           sc->field != 0u ? bench_field_size() : sc->n_obs, run.in_view, (unsigned)n,
           (unsigned)differ, ((double)t_step - (double)t_empty) * ips / (double)n,
           ((double)largest - base) * ips, clear);
    for (size_t i = 0; i < run.n_events; i++) {
        const sup_event_t *e = &run.events[i];
        printf(" %.2f:%u:%u:%d", (double)e->t_us * 1e-6, e->kind, e->obstacle, e->side);
    }
    printf("\n");
    /* Every pose and wheel command of the load's closed loop, as `checksum`
     * for the paper's scenarios: a change that keeps these keeps the bits. */
    printf("load_checksum %s %s %08lx\n", sc->name,
           sc->strategy == (uint8_t)CTL_STRATEGY_MSTC ? "mstc" : "paper",
           (unsigned long)bench_checksum(steps, n));
    char key[48];
    snprintf(key, sizeof key, "load_mode %s %s", sc->name,
             sc->strategy == (uint8_t)CTL_STRATEGY_MSTC ? "mstc" : "paper");
    print_by_mode(key, sum, cnt, max, base);
}

/* The paper's scenarios under "mstc", and the load scenes under both. */
static void loads(void)
{
    for (unsigned s = 0; s < BENCH_N_SCENARIOS; s++) {
        bench_scenario_t sc = bench_scenarios[s];
        sc.strategy = (uint8_t)CTL_STRATEGY_MSTC;
        load(&sc);
    }
    for (unsigned i = 0; i < BENCH_N_LOADS; i++) {
        for (uint8_t st = 0; st <= (uint8_t)CTL_STRATEGY_MSTC; st++) {
            bench_scenario_t sc = bench_loads[i];
            sc.strategy = st;
            load(&sc);
        }
    }
}

/* ---------------------------------------------- authenticated commands */

/* Instructions of the firmware's work per authenticated command (issue 21,
 * docs/safety.md "Cost"): auth_verify() of a genuine command for the
 * challenge (one CMAC), the status MAC that follows every decision and every
 * housekeeping (one CMAC), and auth_set_key() at start (the subkeys). The
 * sender's MAC is computed outside the timed part. Means of AUTH_RUNS calls,
 * ±40 instructions each (one tick). */
#define AUTH_RUNS 200u

static void authenticated_commands(void)
{
    static const uint8_t key[AUTH_KEY_LEN] = { 0x2b, 0x7e, 0x15, 0x16, 0x28, 0xae, 0xd2, 0xa6,
                                               0xab, 0xf7, 0x15, 0x88, 0x09, 0xcf, 0x4f, 0x3c };
    static const uint8_t data[AUTH_DATA_LEN] = { 0x80, 0x00, 0x00, 0x80, 0x3F, 0x00 };
    auth_t s;
    auth_init(&s);
    uint64_t t_key = 0;
    uint64_t t_verify = 0;
    uint64_t t_status = 0;
    unsigned accepted = 0;
    for (unsigned i = 0; i < AUTH_RUNS; i++) {
        uint64_t t0 = ticks();
        auth_set_key(&s, key, 0x5EC0A1D1u + i);
        t_key += ticks() - t0;
        uint8_t mac[AUTH_MAC_LEN];
        auth_mac(&s, 0x1120u, data, s.session, s.fv + 1u, mac);
        t0 = ticks();
        accepted += auth_verify(&s, 0x1120u, data, s.fv + 1u, mac, 0u) == AUTH_OK ? 1u : 0u;
        t_verify += ticks() - t0;
        t0 = ticks();
        auth_status_mac(&s, 0x1187u, mac);
        t_status += ticks() - t0;
    }
    printf("auth_accepted %u of %u\n", accepted, AUTH_RUNS);
    printf("auth_set_key_instr %.0f\n", (double)t_key * ips / AUTH_RUNS);
    printf("auth_verify_instr %.0f\n", (double)t_verify * ips / AUTH_RUNS);
    printf("auth_status_instr %.0f\n", (double)t_status * ips / AUTH_RUNS);
}

/* ------------------------------------------------------------ wheel loop */

static bench_wheel_period_t wheel_periods[BENCH_WHEEL_PERIODS];

/* The wheel loop's closed loop recorded, its replay checked, then timed
 * period by period, less the empty loop's. Prints `wheel periods N
 * replay_differs N instr_per_period X max X`. */
static void wheel(void)
{
    const size_t n = bench_wheel_record(wheel_periods, BENCH_WHEEL_PERIODS);
    const size_t differ = bench_wheel_verify(wheel_periods, n);
    uint64_t t_step = 0;
    uint64_t t_max = 0;
    uint64_t t_empty = 0;
    uint64_t t_empty_max = 0;
    bench_wheel_replay(wheel_periods, n, false, ticks, &t_step, &t_max);
    bench_wheel_replay(wheel_periods, n, true, ticks, &t_empty, &t_empty_max);
    const double base = (double)t_empty / (double)n;
    printf("wheel periods %u replay_differs %u instr_per_period %.1f max %.0f\n", (unsigned)n,
           (unsigned)differ, ((double)t_step - (double)t_empty) * ips / (double)n,
           ((double)t_max - base) * ips);
}

/* ------------------------------------------------------------------ main */

int main(void)
{
    systick_start();
    const uint32_t spins = 1000000u;
    const uint64_t t0 = ticks();
    spin(spins);
    const uint64_t cal = ticks() - t0;
    ips = 2.0 * (double)spins / (double)cal;
    printf("config %s\nmode %s\nips %.3f\n", BENCH_CONFIG, NUM_MODE_NAME, ips);

    /* Record the closed loop of every scenario, then check the replay
     * reproduces it. */
    size_t offset[BENCH_N_SCENARIOS];
    size_t count[BENCH_N_SCENARIOS];
    size_t total = 0;
    for (unsigned s = 0; s < BENCH_N_SCENARIOS; s++) {
        bench_run_t run;
        offset[s] = total;
        bench_record(&bench_scenarios[s], &steps[total], &run);
        count[s] = run.n_steps;
        total += run.n_steps;
        const size_t differ =
            bench_verify(&steps[offset[s]], count[s], bench_scenarios[s].strategy);
        printf("scenario %s steps %u events_match %d replay_differs %u min_distance",
               bench_scenarios[s].name, (unsigned)run.n_steps, run.events_match, (unsigned)differ);
        for (unsigned i = 0; i < bench_scenarios[s].n_obs; i++) {
            printf(" %.4f", run.min_distance[i]);
        }
        printf("\nevents %s", bench_scenarios[s].name);
        for (size_t i = 0; i < run.n_events; i++) {
            const sup_event_t *e = &run.events[i];
            printf(" %.2f:%u:%u:%d", (double)e->t_us * 1e-6, e->kind, e->obstacle, e->side);
        }
        printf("\n");
    }

    printf("checksum %08lx\n", (unsigned long)bench_checksum(steps, total));

    /* Whole replays: ctl_step, and the same loop calling an empty step. */
    uint64_t t_step = 0;
    uint64_t t_empty = 0;
    for (unsigned s = 0; s < BENCH_N_SCENARIOS; s++) {
        const uint8_t st = bench_scenarios[s].strategy;
        t_step += bench_replay(&steps[offset[s]], count[s], st, bench_ctl_step, ticks);
        t_empty += bench_replay(&steps[offset[s]], count[s], st, bench_empty_step, ticks);
    }
    printf("steps %u\n", (unsigned)total);
    printf("instr_per_step %.1f\n", ((double)t_step - (double)t_empty) * ips / (double)total);

    /* Step by step, by mode (each figure ±1 tick = ±40 instructions). */
    uint64_t sum[BENCH_N_MODES] = { 0 }, cnt[BENCH_N_MODES] = { 0 }, max[BENCH_N_MODES] = { 0 };
    uint64_t esum[BENCH_N_MODES] = { 0 }, ecnt[BENCH_N_MODES] = { 0 }, emax[BENCH_N_MODES] = { 0 };
    for (unsigned s = 0; s < BENCH_N_SCENARIOS; s++) {
        const uint8_t st = bench_scenarios[s].strategy;
        bench_replay_each(&steps[offset[s]], count[s], st, bench_ctl_step, ticks, sum, cnt, max);
        bench_replay_each(&steps[offset[s]], count[s], st, bench_empty_step, ticks, esum, ecnt,
                          emax);
    }
    const double base = (double)(esum[0] + esum[1] + esum[2] + esum[3]) / (double)total;
    print_by_mode("by_mode", sum, cnt, max, base);

    loads();

    wheel();

    primitives();
    sincos_check();
    authenticated_commands();
    printf("done\n");
    return 0;
}
