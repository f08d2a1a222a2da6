/* SPDX-License-Identifier: MIT */
/**
 * @file bench.h
 * @brief The benchmark of the control step (make bench): the paper's
 *        scenarios in closed loop, recorded once, then replayed through
 *        ctl_step and timed. Shared by the Cortex-M images (bench_target.c,
 *        instructions counted with SysTick under qemu -icount) and the host
 *        program (bench_host.c, nanoseconds).
 *
 * The closed loop is the one of `make sim`: a forward-Euler unicycle plant in
 * double, a range sensor reporting obstacles within D_det, Table 1 parameters,
 * and the scenarios of sim/scenarios/ (python -m mstc.bench.scenarios), each
 * with its strategy ("paper" unless its [params] say otherwise). The load
 * scenes (bench_loads) add runs with 1, 4 and 8 obstacles in view, and a
 * full table of SUP_MAX_OBSTACLES reported from a BARN-like field of
 * cylinders, under both strategies.
 */
#ifndef MSTC_BENCH_H
#define MSTC_BENCH_H

#include <stddef.h>
#include <stdint.h>

#include "ctrl/ctl.h"

#define BENCH_MAX_OBS      8u                /**< obstacles a scenario lists */
#define BENCH_MAX_REPORTS  SUP_MAX_OBSTACLES /**< obstacles reported in a step */
#define BENCH_MAX_EXPECTED 8u
#define BENCH_MAX_EVENTS   16u

/** @brief A scenario (sim/scenarios/<name>.toml). */
typedef struct {
    const char *name;
    double robot[3]; /**< x [m], y [m], θ [rad] */
    double ref[3];
    double v_r, w_r;
    double duration, dt; /**< [s] */
    unsigned n_obs;
    double obs[BENCH_MAX_OBS][3]; /**< x, y, radius [m] */
    uint8_t strategy;             /**< CTL_STRATEGY_* */
    /** Not 0: the obstacles are the BARN-like field of bench_core.c
     *  (n_obs 0), reported as a sensor with slots reports them: the
     *  nearest within D_det of their surface, at most BENCH_MAX_REPORTS,
     *  each under an id (1..BENCH_MAX_REPORTS) it keeps while it stays
     *  reported. */
    unsigned field;
    unsigned n_expected;
    struct {
        double t;
        int kind, obstacle, side;
    } expected[BENCH_MAX_EXPECTED];
} bench_scenario_t;

/** @brief One recorded control step. */
typedef struct {
    ctl_input_t in; /**< in.obstacles points into obs */
    sup_obstacle_t obs[BENCH_MAX_REPORTS];
    kin_wheels_t wheels; /**< what ctl_step answered when recorded */
    uint8_t mode;        /**< sup_mode_t it ran in */
} bench_step_t;

/** @brief What a closed-loop run produced. */
typedef struct {
    size_t n_steps;
    size_t n_events;
    sup_event_t events[BENCH_MAX_EVENTS];
    int events_match; /**< 1 when the events are the scenario's expected ones, to the step */
    double min_distance[BENCH_MAX_OBS]; /**< [m], centre to centre (a scenario's obstacles) */
    double min_clearance; /**< smallest centre distance less the obstacle's D_s (Table 1's
                               0.35 m moved out by its radius less 0.1 m), over the run [m] */
    double in_view;       /**< obstacles reported per step, on average */
} bench_run_t;

/** @brief Modes a step can run in (sup_mode_t), for the per-mode figures. */
#define BENCH_N_MODES 4u

/** @brief Load scenes: a circular reference past 1, 4 and 8 obstacles, all
 *         within D_det for most of the run; and load-48, a straight one
 *         through a BARN-like field, a full table reported every step
 *         (bench_core.c). */
#define BENCH_N_LOADS 4u
extern const bench_scenario_t bench_loads[BENCH_N_LOADS];

/** @brief Cylinders in load-48's field. */
unsigned bench_field_size(void);

/** @brief A step function with ctl_step's signature. */
typedef void (*bench_step_fn)(ctl_t *c, const ctl_input_t *in, ctl_output_t *out);

/** @brief A monotonic counter (instructions/40 on the target, ns on the host). */
typedef uint64_t (*bench_clock_fn)(void);

/**
 * @brief Run scenario @p s in closed loop, recording every step's inputs and
 *        outputs into @p steps (at least duration/dt + 1 entries).
 */
void bench_record(const bench_scenario_t *s, bench_step_t *steps, bench_run_t *run);

/**
 * @brief Replay @p n recorded steps of one scenario through @p step from a
 *        fresh controller with @p strategy.
 * @retval the counter difference of @p clk over the loop.
 */
uint64_t bench_replay(const bench_step_t *steps, size_t n, uint8_t strategy, bench_step_fn step,
                      bench_clock_fn clk);

/**
 * @brief Replay as bench_replay(), timing each step on its own: adds each
 *        step's counter difference to @p sum[mode] and counts it in
 *        @p count[mode] (mode = the recorded sup_mode_t), and keeps the
 *        largest in @p max[mode].
 */
void bench_replay_each(const bench_step_t *steps, size_t n, uint8_t strategy, bench_step_fn step,
                       bench_clock_fn clk, uint64_t sum[BENCH_N_MODES],
                       uint64_t count[BENCH_N_MODES], uint64_t max[BENCH_N_MODES]);

/**
 * @brief Replay and compare with the recorded outputs.
 * @retval number of steps whose wheel speeds differ (0: the replay is the
 *         closed loop).
 */
size_t bench_verify(const bench_step_t *steps, size_t n, uint8_t strategy);

/**
 * @brief FNV-1a hash of the bits of every recorded pose and wheel command:
 *        equal hashes mean the closed loops ran bit for bit alike (fixed
 *        mode: host and Cortex-M3 compute the same numbers).
 */
uint32_t bench_checksum(const bench_step_t *steps, size_t n);

/** @brief A step that does nothing, not inlined nor analysed away: the
 *         baseline subtracted from ctl_step's figures. */
void bench_empty_step(ctl_t *c, const ctl_input_t *in, ctl_output_t *out);

/** @brief ctl_step through a pointer, like the baseline. */
void bench_ctl_step(ctl_t *c, const ctl_input_t *in, ctl_output_t *out);

/** @brief double to num_t as the SIL converts (round to nearest, saturate). */
num_t bench_num(double d);

/** @brief num_t to double. */
double bench_dbl(num_t a);

#endif /* MSTC_BENCH_H */
