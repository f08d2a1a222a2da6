/* SPDX-License-Identifier: MIT */
/* The profile's program (profile.sh): one load scene recorded under one
 * strategy, then replayed once between two marker functions, so that a
 * trace of QEMU's translation blocks can be cut to the replay's steps. */
#include <stdio.h>

#include "bench.h"

#ifndef PROF_LOAD
#define PROF_LOAD 2 /* bench_loads[]: 0 load-1, 1 load-4, 2 load-8, 3 load-48 */
#endif
#ifndef PROF_STRATEGY
#define PROF_STRATEGY 1 /* CTL_STRATEGY_*: 0 paper, 1 mstc */
#endif

static bench_step_t steps[1100];

__attribute__((noinline, noipa)) void prof_begin(void);
__attribute__((noinline, noipa)) void prof_end(void);
int main(void);

__attribute__((noinline, noipa)) void prof_begin(void) { __asm volatile("nop"); }
__attribute__((noinline, noipa)) void prof_end(void) { __asm volatile("nop"); }

static uint64_t zero(void) { return 0; }

int main(void)
{
    bench_run_t run;
    bench_scenario_t sc = bench_loads[PROF_LOAD];
    sc.strategy = PROF_STRATEGY;
    bench_record(&sc, steps, &run);
    printf("checksum %08lx n %u\n", (unsigned long)bench_checksum(steps, run.n_steps),
           (unsigned)run.n_steps);
    prof_begin();
    (void)bench_replay(steps, run.n_steps, sc.strategy, bench_ctl_step, zero);
    prof_end();
    printf("done\n");
    return 0;
}
