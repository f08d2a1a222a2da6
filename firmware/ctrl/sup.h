/* SPDX-License-Identifier: MIT */
/**
 * @file sup.h
 * @brief Supervisor: the switch strategy of section 4 of the paper.
 *
 * Keeps the table of detected obstacles (Definition 1), decides each step
 * which controller runs (p1 completion, p2 activation, p3 stop), holds the
 * side of eq. (11)-(12) chosen at activation, and emits events stamped with
 * the step time. With several obstacles (docs/equations.md): completion of the active
 * obstacle is checked first; then, when tracking, the nearest obstacle that
 * satisfies p2 is activated, possibly in the same step.
 *
 * Obstacles are circles. Thresholds are centre to centre for the radius R_ob
 * of Table 1; for an obstacle of another radius R, D_s and D_act are moved out
 * by (R − R_ob), so the clearance to its surface is what it is for R_ob.
 */
#ifndef MSTC_SUP_H
#define MSTC_SUP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ctrl/avd.h"
#include "ctrl/pose.h"

/** @brief Obstacles the supervisor can remember at once. */
#define SUP_MAX_OBSTACLES 48u
/** @brief Most events one step can emit: a detect per new obstacle, and two
 *         more: a complete and an activate ("paper"), or one change of mode
 *         and a filter event ("mstc", msw.h). */
#define SUP_MAX_EVENTS    (SUP_MAX_OBSTACLES + 2u)

/**
 * @brief A set of table indices: bit i stands for sup_t::obs[i] ("mstc"'s
 *        clusters, msw.h; the safety filter's caches, cbf.h).
 *
 * 64 bits, read and written through the helpers below, which work on its
 * 32-bit halves: a Cortex-M has no 64-bit shift (a shift by a variable
 * amount is 7 instructions) and __builtin_ctzll is a call into libgcc
 * there (__ctzdi2), where a half is one RBIT and one CLZ (make bench).
 */
typedef uint64_t sup_mask_t;
_Static_assert(SUP_MAX_OBSTACLES <= 64u, "a bit of sup_mask_t per table entry");

/** @brief The half of @p m that holds bit @p i (i < 64). */
static inline uint32_t sup_mask_half(sup_mask_t m, unsigned i)
{
    return (uint32_t)(i < 32u ? m : m >> 32u);
}

/** @brief Whether index @p i (< 64) is in @p m. */
static inline bool sup_mask_has(sup_mask_t m, unsigned i)
{
    return ((sup_mask_half(m, i) >> (i & 31u)) & 1u) != 0u;
}

/** @brief The set of index @p i (< 64) alone. */
static inline sup_mask_t sup_mask_of(unsigned i)
{
    const uint32_t bit = 1u << (i & 31u); /* in its half */
    const sup_mask_t b = bit;
    return i < 32u ? b : b << 32u;
}

/** @brief The indices 0 .. @p n − 1 (n < 64). */
static inline sup_mask_t sup_mask_first(unsigned n)
{
    return n < 32u ? (sup_mask_t)((1u << n) - 1u)
                   : ((sup_mask_t)((1u << (n & 31u)) - 1u) << 32u) | UINT32_MAX;
}

/** @brief The lowest index in @p m, which is not empty: the loops over a set
 *         visit its members in the order of their indices. */
static inline unsigned sup_mask_lowest(sup_mask_t m)
{
    const uint32_t lo = (uint32_t)m;
    return lo != 0u ? (unsigned)__builtin_ctz(lo)
                    : 32u + (unsigned)__builtin_ctz((uint32_t)(m >> 32u));
}

/** @brief @p m without its lowest index. */
static inline sup_mask_t sup_mask_without_lowest(sup_mask_t m) { return m & (m - 1u); }

/** @brief Which controller runs. */
typedef enum {
    SUP_MODE_TRACK = 0,   /**< trajectory tracking, eq. (1)-(3) */
    SUP_MODE_AVOID = 1,   /**< obstacle avoidance, eq. (9)-(24) */
    SUP_MODE_STOP = 2,    /**< p3: v_r = ω_r = 0, so v = ω = 0 */
    SUP_MODE_BLOCKED = 3, /**< "mstc" only: no progress possible; v = ω = 0 until the way
                               clears (msw.h) */
} sup_mode_t;

/** @brief Kinds of event. */
typedef enum {
    SUP_EVENT_DETECT = 1,     /**< first step with D_r <= D_det (Definition 1) */
    SUP_EVENT_ACTIVATE = 2,   /**< p2 held: avoidance starts, with its side */
    SUP_EVENT_COMPLETE = 3,   /**< p1 held for the active obstacle: tracking resumes ("mstc":
                                   the release test of msw.h held) */
    SUP_EVENT_BLOCKED = 4,    /**< "mstc": the robot stops, no progress is possible (msw.h) */
    SUP_EVENT_RESUME = 5,     /**< "mstc": the way is clear again, tracking resumes; obstacle 0 */
    SUP_EVENT_INFEASIBLE = 7, /**< "mstc": first step at which the safety filter finds a
                                   moving obstacle it cannot keep away (cbf.h) */
    SUP_EVENT_FILTER = 6,     /**< "mstc": first step of a safety-filter intervention episode;
                                   obstacle = the constraining one (cbf.h) */
} sup_event_kind_t;

/** @brief An event, stamped with the time of the step that emitted it. */
typedef struct {
    uint64_t t_us;    /**< step time [µs] */
    uint8_t kind;     /**< sup_event_kind_t */
    uint8_t obstacle; /**< obstacle id (0: none, RESUME) */
    int8_t side;      /**< avd_side_t on ACTIVATE, AVD_SIDE_NONE otherwise */
} sup_event_t;

/** @brief An obstacle as the range sensor reports it. */
typedef struct {
    uint8_t id;   /**< identifier, 1..255, stable over time (0 is invalid) */
    num_t x;      /**< centre [m] */
    num_t y;      /**< centre [m] */
    num_t radius; /**< [m], > 0 */
    num_t vx;     /**< velocity [m/s], 0 for a static obstacle ("mstc" uses it; "paper"
                       ignores it) */
    num_t vy;     /**< velocity [m/s] */
} sup_obstacle_t;

/** @brief Thresholds of Definitions 1-4 (Table 1), centre to centre. */
typedef struct {
    num_t r_ob;  /**< obstacle radius the thresholds are set for [m] */
    num_t d_det; /**< sensor range D_det [m]: centre distance at which an obstacle of radius
                      R_ob is detected; one of radius r at D_det + r - R_ob */
    num_t d_act; /**< activation distance D_act [m], > d_s */
    num_t d_s;   /**< safe distance D_s [m], >= R_m */
} sup_params_t;

/** @brief A remembered obstacle and its own thresholds. */
typedef struct {
    sup_obstacle_t o;
    num_t d_s;   /**< D_s + (radius − R_ob) [m] */
    num_t d_act; /**< D_act + (radius − R_ob) [m] */
} sup_entry_t;

/** @brief Most reports a static obstacle's centre is averaged over: a
 *         running mean of the first SUP_AVG_MAX, then an exponential one
 *         with weight 1 / SUP_AVG_MAX (sup_take_averaged_reports()). */
#define SUP_AVG_MAX          8u
/** @brief A report of a known id farther than this from its entry's centre
 *         (in x or in y), both static, names another obstacle: "an id that
 *         comes back elsewhere" (sup_take_reports()) [m]. Below it a static
 *         obstacle's reports are averaged ("mstc"). */
#define SUP_AVG_GATE         NUM_C(0.1)
/** @brief When the entry or the report moves, the gate is SUP_AVG_GATE plus
 *         the distance the faster of the two velocities (along each axis)
 *         covers in this time [s]: a moving obstacle missing from the
 *         reports for up to half a second (25 periods of 20 ms) is still
 *         itself when it comes back. */
#define SUP_MOVING_GATE_TIME NUM_C(0.5)

/** @brief Supervisor state. */
typedef struct {
    sup_params_t p;
    sup_entry_t obs[SUP_MAX_OBSTACLES]; /**< detected obstacles, one per id, in the order
                                             their ids were first detected */
    uint8_t n_obs;                      /**< entries used in obs[] */
    uint8_t avoiding;                   /**< 1 while the avoidance controller runs */
    uint8_t active;                     /**< index into obs[] while avoiding */
    avd_side_t side;                    /**< side held while avoiding */
    uint16_t dropped;                   /**< reports rejected (bad value or table full) */
    uint16_t revision; /**< changes whenever an entry is added, replaced or moves (position or
                            radius), or the thresholds change: "mstc" recomputes its cluster
                            only then (msw.h) */
    uint8_t n_avg[SUP_MAX_OBSTACLES]; /**< reports averaged into each entry's centre
                                           (sup_take_averaged_reports()); 1 for one
                                           taken as it came */
    uint8_t slot[256]; /**< index + 1 in obs[] of each id, 0 when unknown: a report finds its
                            entry without a search */
} sup_t;

/** @brief What the supervisor decided for one step. */
typedef struct {
    sup_mode_t mode;
    const sup_entry_t *active; /**< the obstacle being avoided, or NULL */
    avd_side_t side;           /**< its side, or AVD_SIDE_NONE */
    size_t n_events;           /**< events written */
} sup_decision_t;

/**
 * @brief Completion condition p1, eq. (19)-(20): |u2| > D_act and u1·u2 > 0,
 *        with u1 = robot − obstacle and u2 = reference − obstacle.
 */
bool sup_p1(const pose_t *robot, const pose_t *ref, num_t ox, num_t oy, num_t d_act);

/** @brief Activation condition p2: |u1| < D_act and not p1. */
bool sup_p2(const pose_t *robot, const pose_t *ref, num_t ox, num_t oy, num_t d_act);

/** @brief Stop condition p3: v_r = 0 and ω_r = 0. */
bool sup_p3(num_t v_r, num_t w_r);

/**
 * @brief Initialise with thresholds @p p (not checked here: see ctl_init) and
 *        forget every obstacle.
 */
void sup_init(sup_t *s, const sup_params_t *p);

/** @brief New thresholds; the obstacles' own thresholds are recomputed, the
 *         rest of the state is kept. */
void sup_set_params(sup_t *s, const sup_params_t *p);

/** @brief Forget every obstacle and return to tracking; keep the thresholds. */
void sup_reset(sup_t *s);

/**
 * @brief Step 1 of sup_step() alone (Definition 1): reports of unknown ids
 *        within D_det enter the table (DETECT), reports of known ids update
 *        their position and velocity; bad reports are counted in `dropped`.
 *        The "mstc" strategy keeps its table with it (msw.h).
 *
 * An id that comes back elsewhere is a new obstacle. A range sensor numbers
 * what it reports in slots: an id stays with an obstacle while it stays
 * reported, and may then be given to another (docs/protocol.md, OBSTACLE).
 * So a report of a known id farther from its entry's centre than
 * SUP_AVG_GATE in x or in y (both static; with a velocity, the gate widened
 * by SUP_MOVING_GATE_TIME, sup.c's elsewhere()) replaces the entry, in its
 * place in the table, as a new obstacle: DETECT, the revision changes, its
 * averaging starts again (n_avg 1), and the strategy forgets what it kept
 * for that index (msw_step(): a DETECT names an entry that is new). Like
 * the first report of an unknown id it needs to be within D_det; until it
 * is, the entry stays the obstacle it was. The "paper" supervisor's own
 * state is its active index: an entry replaced while it is avoided stays
 * the one avoided (the paper assumes ids that never change obstacle).
 * @param s        state.
 * @param robot    robot pose.
 * @param reports  obstacles reported this step (may be NULL when @p n_reports is 0).
 * @param n_reports number of reports.
 * @param t_us     step time [µs], stamped on the events.
 * @param events   where events go; at least SUP_MAX_EVENTS entries.
 * @param[in,out] n_events events already in @p events; incremented per DETECT.
 */
void sup_take_reports(sup_t *s, const pose_t *robot, const sup_obstacle_t *reports,
                      size_t n_reports, uint64_t t_us, sup_event_t *events, size_t *n_events);

/** @brief sup_take_reports() for reports every value of which the caller
 *         has found finite (ctl.c screens them): the same table and events,
 *         without testing that again (id 0 and a radius <= 0 are still
 *         dropped). */
void sup_take_finite_reports(sup_t *s, const pose_t *robot, const sup_obstacle_t *reports,
                             size_t n_reports, uint64_t t_us, sup_event_t *events,
                             size_t *n_events);

/**
 * @brief sup_take_finite_reports() with the centres of static obstacles
 *        averaged ("mstc"): a report with zero velocity of an entry whose
 *        velocity is zero too, of the same radius, within SUP_AVG_GATE of
 *        its centre in x and y (beyond it: a new obstacle,
 *        sup_take_reports()), moves the centre by (report − centre) / n,
 *        n the reports averaged so far, this one included, at most
 *        SUP_AVG_MAX: the mean of the first SUP_AVG_MAX reports, then an
 *        exponential mean. Any other report that moves a known obstacle is
 *        taken as it comes (n = 1). A report equal to the centre leaves it
 *        as it is and is not counted (it costs no more than in
 *        sup_take_finite_reports(), whose table noiseless reports give).
 */
void sup_take_averaged_reports(sup_t *s, const pose_t *robot, const sup_obstacle_t *reports,
                               size_t n_reports, uint64_t t_us, sup_event_t *events,
                               size_t *n_events);

/**
 * @brief One step of the switch strategy, on the state at the start of the
 *        control period.
 *
 * 1. Reports of unknown ids within D_det enter the table (DETECT); reports of
 *    known ids update their position, or replace the entry as a new obstacle
 *    (DETECT) when they come back elsewhere (sup_take_reports()). Reports
 *    with id 0, a non-finite value or a radius <= 0, and new ones when the
 *    table is full, are counted in `dropped` and ignored.
 * 2. While avoiding, p1 of the active obstacle ends the avoidance (COMPLETE).
 * 3. While tracking, the nearest obstacle satisfying p2 is activated, its side
 *    chosen by avd_choose_side() and held (ACTIVATE).
 * 4. p3 overrides the output mode with STOP (the avoidance state is kept).
 *
 * @param s        state.
 * @param robot    robot pose.
 * @param ref      reference pose.
 * @param v_r,w_r  reference velocities [m/s], [rad/s].
 * @param reports  obstacles reported this step (may be NULL when @p n_reports is 0).
 * @param n_reports number of reports.
 * @param t_us     step time [µs], stamped on the events.
 * @param events   where events go; at least SUP_MAX_EVENTS entries.
 * @param[out] d   the decision.
 */
void sup_step(sup_t *s, const pose_t *robot, const pose_t *ref, num_t v_r, num_t w_r,
              const sup_obstacle_t *reports, size_t n_reports, uint64_t t_us, sup_event_t *events,
              sup_decision_t *d);

/**
 * @brief Steps 2 to 4 of sup_step() alone, on the table as
 *        sup_take_reports() left it: sup_step() is sup_take_reports() then
 *        this.
 * @param s, robot, ref, v_r, w_r, t_us, events, d as sup_step().
 * @param n_events events already in @p events this step (the detections);
 *                 d->n_events counts them with the ones added here.
 */
void sup_decide(sup_t *s, const pose_t *robot, const pose_t *ref, num_t v_r, num_t w_r,
                uint64_t t_us, sup_event_t *events, size_t n_events, sup_decision_t *d);

#endif /* MSTC_SUP_H */
