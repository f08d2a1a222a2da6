/* SPDX-License-Identifier: MIT */
/**
 * @file msw.h
 * @brief The "mstc" switch strategy (docs/strategy.md): switching on the
 *        robot's own motion, clusters gone around as one, moving obstacles
 *        met early and passed behind, release after a forward roll-out, and
 *        a blocked state instead of circling.
 *
 * It shares the supervisor's obstacle table (sup_take_reports(), Definition
 * 1) and decides, each step, what runs:
 *
 * - **Activation** (tracking): the nearest obstacle, by distance to its own
 *   safe circle, that the robot is within D_act of (the supervisor's per-
 *   obstacle threshold), closing on under the tracking command and, for a
 *   static one, that the tracking command's roll-out (rol.h) brings within
 *   its D_s + MSW_ACT_MARGIN (an obstacle beside a clear way does not
 *   activate); or, for a moving obstacle within D_act + MSW_CPA_REACH, whose
 *   closest approach within MSW_CPA_HORIZON comes inside D_s +
 *   MSW_CPA_MARGIN; whatever the reference does (no p1 here). Its cluster
 *   (oset_cluster(): obstacles whose followed circles overlap) is gone around
 *   on one side, chosen once (msw_choose_side()) and held. At most
 *   MSW_MAX_ACTIVATIONS activations per obstacle and encounter: the count
 *   starts again once the robot, tracking, is beyond D_act + MSW_CPA_REACH +
 *   reach of it (out of any activation's reach), and when its entry becomes
 *   another obstacle (a DETECT of its id: an id that came back elsewhere,
 *   sup.h).
 * - **Avoidance**: the avoidance law follows the member of the cluster
 *   nearest from the robot or just ahead of it, on a circle MSW_FOLLOW_OFFSET
 *   beyond its D_s (moving with it), or, when the cluster has gaps, half the
 *   cluster gap plus MSW_FILL_MARGIN beyond it, so that the circles overlap
 *   and close the gaps; the cluster is recomputed, from the member followed,
 *   whenever the table changes (obstacles detected later join it).
 * - **A reference that waits** (held): when the reference stands still while
 *   the robot avoids (a path reference that waits for the robot, as
 *   mstc.plant's does), the robot is on a boundary in the sense of the Bug
 *   algorithms, and the reference's line (the m-line) decides the leave:
 *   once the reference has moved on again (the robot came back to its path,
 *   further along: Bug2's leave point) and the roll-out clears the cluster;
 *   or, VisBug's shortcut, when a straight segment from the robot to the
 *   foot of its perpendicular on the reference's line, at least
 *   MSW_SHORTCUT_MIN past the reference and within what the sensor covers,
 *   clears every entry by D_s + MSW_SHORTCUT_MARGIN: tracking then aims at
 *   that line (msw_t::aim, MSW_AIM_LEAD ahead of the robot's foot on it)
 *   and the release needs only the roll-out clear. When the boundary has
 *   led the robot MSW_TURN_BACK behind the waiting reference along its
 *   line, it follows the boundary the other way (once an activation: the
 *   Bug family's reversal of direction). While held, circling does not
 *   count as blocked (a boundary is followed as long as it takes; standing
 *   still still does).
 * - **Release** (COMPLETE), with a reference on its schedule: after
 *   MSW_DWELL_US in avoidance, when p1 holds for every static member and the
 *   roll-out of the tracking command over MSW_ROLLOUT keeps every static
 *   obstacle beyond its D_s + MSW_CLEAR_MARGIN; a moving one is judged by
 *   its motion instead: no longer closing on it within reach of an
 *   activation, and its closest approach beyond what activates, by the
 *   margin. An obstacle outside the cluster does not end the avoidance:
 *   the safety filter keeps it beyond D_s, and the cluster takes it in when
 *   the circles meet.
 * - **Blocked**: in avoidance, when the robot has turned once around (the
 *   signed sum of its heading changes since the activation beyond MSW_LOOP:
 *   it circles the cluster; not while held) or has not moved MSW_PROGRESS
 *   for MSW_STILL_US (held in place), no progress is possible: it stops
 *   (BLOCKED, v = ω = 0) and waits, and resumes tracking (RESUME) when the
 *   roll-out tests of the release pass. Standing still while p3 stops the
 *   robot does not count.
 *
 * At most one change of mode per step, so with the detections and a filter
 * event a step emits at most SUP_MAX_EVENTS events.
 */
#ifndef MSTC_MSW_H
#define MSTC_MSW_H

#include <stddef.h>
#include <stdint.h>

#include "ctrl/avd.h"
#include "ctrl/rol.h"
#include "ctrl/sup.h"

/** @name Tunables of the strategy (docs/strategy.md says how each was chosen). @{ */
#define MSW_DWELL_US        500000u      /**< least time in avoidance [µs] */
#define MSW_ROLLOUT         NUM_C(1.0)   /**< roll-out horizon [s] */
#define MSW_ROLLOUT_INV     NUM_C(1.0)   /**< 1 / MSW_ROLLOUT [1/s] */
#define MSW_MARGIN          NUM_C(0.02)  /**< hysteresis margin of the release [m] */
#define MSW_ACT_MARGIN      NUM_C(0.03)  /**< activation: roll-out within D_s + this [m] */
#define MSW_FILTERED_MARGIN NUM_C(0.10)  /**< ... of an obstacle the filter acted on [m] */
#define MSW_CLEAR_MARGIN    NUM_C(0.045) /**< way clear: roll-out beyond D_s + this [m] */
#define MSW_TURN_BACK       NUM_C(1.0)   /**< held: side turned back this far behind [m] */
#define MSW_AIM_LEAD        NUM_C(0.3)   /**< aim: this far along the line past the robot [m] */
#define MSW_SHORTCUT_MIN    NUM_C(0.3)   /**< aim taken this far past the waiting reference [m] */
#define MSW_SHORTCUT_MARGIN NUM_C(0.08)  /**< aim's segment beyond D_s + this [m] */
#define MSW_FOLLOW_OFFSET   NUM_C(0.08)  /**< circle followed: D_s + this [m] */
#define MSW_FOLLOW_AHEAD    NUM_C(0.25)  /**< member chosen from this far ahead too [m] */
#define MSW_FILL_MARGIN     NUM_C(0.02)  /**< gapped cluster: circles overlap by [m] */
#define MSW_MAX_ACTIVATIONS 2u           /**< per obstacle and encounter */
#define MSW_CPA_HORIZON     NUM_C(3.0)   /**< closest-approach horizon [s] */
#define MSW_CPA_MARGIN      NUM_C(0.05)  /**< closest approach below D_s + this activates [m] */
#define MSW_CPA_REACH       NUM_C(1.0)   /**< ... when within D_act + this [m] */
#define MSW_RELEASE_REACH   NUM_C(1.0)   /**< no release while closing within D_act + this [m] */
#define MSW_LOOP            NUM_C(6.8)   /**< turned once around (2π + 0.5): blocked [rad] */
#define MSW_STILL_US        5000000u     /**< within MSW_PROGRESS this long: blocked [µs] */
#define MSW_PROGRESS        NUM_C(0.1)   /**< least motion that counts as progress [m] */
#define MSW_SIDE_DEADBAND   NUM_C(0.05)  /**< side ties below this [rad] */
#define MSW_TIE_OFFSET      NUM_C(0.05)  /**< reference-side ties below this [m] */
#define MSW_MOVING_SPEED    NUM_C(0.02)  /**< slower obstacles count as static [m/s] */
#define MSW_SPEED_MIN       NUM_C(0.5)   /**< least avoidance speed, times |v_r| */
#define MSW_CATCH_UP        NUM_C(1.0)   /**< largest speed: |v_r| + this [m/s] */
#define MSW_REGULATE        NUM_C(2.0)   /**< speed regulated within D_act + this [m] */
/** @} */

/** @brief State of the strategy. */
typedef enum {
    MSW_TRACK = 0,
    MSW_AVOID = 1,
    MSW_BLOCKED = 2,
} msw_state_t;

/** @brief Strategy state. */
typedef struct {
    num_t width;                     /**< cluster gap: circles closer form a cluster [m] */
    uint8_t state;                   /**< msw_state_t */
    uint8_t trigger;                 /**< table index that activated the cluster */
    uint8_t followed;                /**< table index followed now */
    avd_side_t side;                 /**< side held while avoiding */
    sup_mask_t cluster;              /**< members, a bit per table index */
    uint16_t revision;               /**< sup_t::revision the cluster was found at */
    num_t offset;                    /**< circles followed: D_s + this [m] */
    uint64_t t_act_us;               /**< time of the activation */
    num_t turned;                    /**< heading change since the activation [rad] */
    num_t last_theta;                /**< heading at the previous step [rad] */
    num_t mark_x, mark_y;            /**< where the robot last made progress [m] */
    uint64_t t_mark_us;              /**< when */
    num_t ref_x, ref_y;              /**< the reference's position at the last step */
    bool held;                       /**< the reference stood still since the activation */
    bool ahead;                      /**< and moved on after that */
    bool aimed;                      /**< tracking aims at aim, not the reference */
    bool reversed;                   /**< the side was turned back (turn_back()) */
    pose_t aim;                      /**< a point of the reference's line ahead of it */
    num_t aim_rx, aim_ry;            /**< the reference when the aim was taken */
    uint8_t acts[SUP_MAX_OBSTACLES]; /**< activations per table index, this encounter */
    /** Scratch of msw_step(): the tracking command's roll-out, written when a
     *  step first needs it (here rather than on the stack, where clearing
     *  it each step cost a memset). */
    rol_path_t path;
} msw_t;

/** @brief What the strategy sees in one step. */
typedef struct {
    const pose_t *robot;
    const pose_t *ref;
    const pose_t *host;   /**< the reference as received (ref may be the aim) */
    num_t range;          /**< obstacles are known within this of the robot [m] */
    num_t v_r, w_r;       /**< reference velocities */
    num_t cos_th, sin_th; /**< of the robot's heading */
    num_t v_trk, w_trk;   /**< the tracking command of this step, eq. (2)-(3) */
    const num_t *dist;    /**< centre distance to each table entry [m] */
    uint64_t t_us;        /**< step time [µs] */
    /** How much farther than D_act a closing obstacle activates [m]: the
     *  distance the wheels need to brake (0: at D_act, as the paper). */
    num_t reach;
    /** Id of the obstacle the safety filter changed the previous step's
     *  command for, or 0 (ctl_t::filtered). */
    uint8_t filtered;
} msw_input_t;

/** @brief What the strategy decided. */
typedef struct {
    sup_mode_t mode;
    const sup_entry_t *followed; /**< entry followed (AVOID), else NULL */
    avd_side_t side;             /**< side held (AVOID), else AVD_SIDE_NONE */
    avd_obstacle_t circle;       /**< circle followed (AVOID) */
} msw_decision_t;

/** @brief Initialise with the cluster gap @p width [m] (between D_s circles;
 *         ctl.c: 2 MSW_FOLLOW_OFFSET): tracking. */
void msw_init(msw_t *m, num_t width);

/** @brief Back to tracking, activation counts cleared; the width is kept. */
void msw_reset(msw_t *m);

/**
 * @brief One step of the strategy on the table @p s (already updated with
 *        this step's reports).
 * @param m      state.
 * @param s      the supervisor's table (sup_take_reports()).
 * @param in     robot, reference, tracking command, distances, time.
 * @param events where events go (SUP_MAX_EVENTS entries).
 * @param[in,out] n_events events already there: this step's detections
 *               (sup_take_reports()), each of which names an entry that is
 *               a new obstacle, whose activation count is forgotten (an id
 *               that came back elsewhere, sup.h); at most one is added.
 * @param[out] d the decision.
 */
void msw_step(msw_t *m, const sup_t *s, const msw_input_t *in, sup_event_t *events,
              size_t *n_events, msw_decision_t *d);

/** @brief The aim (msw_t::aim) moved to the foot of the perpendicular from
 *         @p robot onto the line of @p host (the reference as received),
 *         plus a lead along it. */
void msw_slide_aim(msw_t *m, const pose_t *robot, const pose_t *host);

/** @brief Whether the entry moves (faster than MSW_MOVING_SPEED, |vx| + |vy|). */
bool msw_moving(const sup_entry_t *e);

/**
 * @brief Side for going around cluster @p cluster, whose activation came
 *        from entry @p trigger, each member a disc of radius D_s + @p offset:
 *        1. a trigger moving across the robot's heading (faster than
 *           MSW_MOVING_SPEED) is passed behind: RIGHT when it moves to the
 *           robot's left, LEFT when to its right;
 *        2. else the side on which the cluster's edge lies nearer the
 *           reference's path (the line through the reference along its
 *           direction of motion): LEFT when its left edge is nearer;
 *        3. when the two are within MSW_TIE_OFFSET (an obstacle on the path),
 *           the side that needs the smaller turn of the robot's heading to
 *           clear the cluster's angular extent seen from the robot (for one
 *           obstacle: eq. (11)-(12) of the paper);
 *        4. when that is within MSW_SIDE_DEADBAND too (head-on): LEFT.
 * @param s       the table.
 * @param cluster members, a bit per table index.
 * @param trigger table index of the activating entry.
 * @param offset  circles followed: D_s + this [m].
 * @param in      robot, reference and distances.
 */
avd_side_t msw_choose_side(const sup_t *s, sup_mask_t cluster, uint8_t trigger, num_t offset,
                           const msw_input_t *in);

#endif /* MSTC_MSW_H */
