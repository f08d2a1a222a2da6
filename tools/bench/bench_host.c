/* SPDX-License-Identifier: MIT */
/* The benchmark on the host (make bench): nanoseconds per ctl_step over the
 * same closed-loop sequence as the Cortex-M images. Each replay of the whole
 * sequence is timed with the thread's CPU clock (time spent descheduled on a
 * busy machine does not count), less the same loop with an empty step; the
 * figure is the median of N_RUNS replays. Prints `key value` lines for
 * mstc.bench.ctl_step. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "bench.h"
#include "scenarios.h"

#define N_RUNS 301u

static bench_step_t steps[BENCH_TOTAL_STEPS];

static uint64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (uint64_t)ts.tv_sec * UINT64_C(1000000000) + (uint64_t)ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a;
    const double y = *(const double *)b;
    return (x > y) - (x < y);
}

/* ns per step of one whole replay of every scenario through @p fn. */
static double replay_all(const size_t *offset, const size_t *count, bench_step_fn fn)
{
    uint64_t t = 0;
    size_t total = 0;
    for (unsigned s = 0; s < BENCH_N_SCENARIOS; s++) {
        t += bench_replay(&steps[offset[s]], count[s], bench_scenarios[s].strategy, fn, now_ns);
        total += count[s];
    }
    return (double)t / (double)total;
}

int main(void)
{
    size_t offset[BENCH_N_SCENARIOS];
    size_t count[BENCH_N_SCENARIOS];
    size_t total = 0;
    int ok = 1;
    for (unsigned s = 0; s < BENCH_N_SCENARIOS; s++) {
        bench_run_t run;
        offset[s] = total;
        bench_record(&bench_scenarios[s], &steps[total], &run);
        count[s] = run.n_steps;
        total += run.n_steps;
        ok = ok && run.events_match &&
             bench_verify(&steps[offset[s]], count[s], bench_scenarios[s].strategy) == 0u;
    }
    printf("checksum %08lx\n", (unsigned long)bench_checksum(steps, total));
    static double step_ns[N_RUNS];
    static double empty_ns[N_RUNS];
    for (unsigned r = 0; r < N_RUNS; r++) {
        step_ns[r] = replay_all(offset, count, bench_ctl_step);
        empty_ns[r] = replay_all(offset, count, bench_empty_step);
    }
    qsort(step_ns, N_RUNS, sizeof step_ns[0], cmp_double);
    qsort(empty_ns, N_RUNS, sizeof empty_ns[0], cmp_double);
    printf("config host-%s\nmode %s\nsteps %u\nevents_match %d\n", NUM_MODE_NAME, NUM_MODE_NAME,
           (unsigned)total, ok);
    printf("host_runs %u\nhost_ns_per_step %.1f\nhost_ns_per_step_min %.1f\n", N_RUNS,
           step_ns[N_RUNS / 2u] - empty_ns[N_RUNS / 2u], step_ns[0] - empty_ns[0]);
    return ok ? 0 : 1;
}
