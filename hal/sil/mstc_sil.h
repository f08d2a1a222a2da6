/* SPDX-License-Identifier: MIT */
/**
 * @file mstc_sil.h
 * @brief C ABI of the firmware as a shared library
 *        (build/host/<numeric>/libmstc_sil.so), for the Python plant.
 *
 * Two entries into the same firmware:
 * - the whole application behind CAN frames (mstc_sil_fw_*): the frames go
 *   through the SIL HAL's queues to the same app code that runs in mstc-fw and
 *   on boards; this is what the python-can interface "mstc-sil" wraps, in
 *   lock-step; mstc_sil_fw_tick() is the real-time mode's timer tick;
 * - the control step alone, in memory (mstc_sil_init/step), the reference
 *   the frame path is compared against, and the same step over many
 *   controllers in one call (mstc_sil_step_batch), for sweeps.
 *
 * Plain C types and doubles only, whatever the firmware's numeric mode: the
 * library converts at this boundary. For the in-memory step the caller owns
 * the controller's memory (mstc_sil_size() bytes, 16-byte aligned); the frame
 * path has one firmware instance per loaded library, like a board.
 */
#ifndef MSTC_SIL_H
#define MSTC_SIL_H

#include <stddef.h>
#include <stdint.h>

#define MSTC_SIL_MAX_OBSTACLES 48
#define MSTC_SIL_MAX_EVENTS    50

/** @brief Parameters, SI units (see ctl_params_t). */
typedef struct {
    double r_m, r_ob, d_det, d_act, d_s;
    double trk_k[3]; /**< tracking gains k1, k2, k3 */
    double avd_k[2]; /**< avoidance gains k1, k2 */
    double wheel_radius, track_width, max_wheel_speed;
    uint32_t strategy;  /**< 0 paper, 1 mstc (the DBC's value table Strategy) */
    double wheel_accel; /**< what the wheels can do [rad/s²] */
    double wheel_tau;   /**< their lag, delays included [s] */
} mstc_sil_params_t;

/** @brief A reported obstacle. */
typedef struct {
    uint32_t id; /**< 1..255 */
    double x, y, radius;
    double vx, vy; /**< velocity [m/s], 0 for a static obstacle */
} mstc_sil_obstacle_t;

/** @brief Inputs of one step. */
typedef struct {
    double robot[3]; /**< x [m], y [m], θ [rad] */
    double ref[3];   /**< x_r, y_r, θ_r */
    double v_r, w_r; /**< [m/s], [rad/s] */
    uint64_t t_us;   /**< step time [µs] */
    uint32_t n_obstacles;
    const mstc_sil_obstacle_t *obstacles;
    /** Measured wheel speeds, left and right [rad/s], used when
     *  wheel_measured is not 0; otherwise the firmware predicts them from its
     *  own commands. From external drives (WHEEL_SPEED: each wheel's mean
     *  over the period that just ended) or a board's own wheel loop
     *  (mstc_sil_wheel.h's measured, of age wheel_age_us). */
    double wheel_speed[2];
    uint32_t wheel_measured;
    /** Their age [µs] (ctl_input_t::wheels_age): from the middle of the time
     *  they average to t_us; 0: half the period (WHEEL_SPEED's). */
    uint32_t wheel_age_us;
} mstc_sil_input_t;

/** @brief An event (see sup_event_t). */
typedef struct {
    uint64_t t_us;
    int32_t kind;     /**< 1 detect, 2 activate, 3 complete */
    int32_t obstacle; /**< obstacle id */
    int32_t side;     /**< 1 left, -1 right, 0 none */
} mstc_sil_event_t;

/** @brief Outputs of one step (see ctl_output_t). */
typedef struct {
    double wheel_left, wheel_right; /**< [rad/s] */
    int32_t mode;                   /**< 0 track, 1 avoid, 2 stop */
    int32_t active_obstacle;        /**< id, 0 when none */
    int32_t side;                   /**< 1 left, -1 right, 0 none */
    uint32_t faults;                /**< CTL_FAULT_* bits */
    double e1, e2, e3, e;
    double v, w; /**< commanded body velocity after saturation */
    uint32_t n_obstacles;
    uint32_t obstacle_id[MSTC_SIL_MAX_OBSTACLES];
    double distance[MSTC_SIL_MAX_OBSTACLES];
    uint32_t n_events;
    mstc_sil_event_t events[MSTC_SIL_MAX_EVENTS];
} mstc_sil_output_t;

/** @brief Bytes the caller must provide for one controller. */
size_t mstc_sil_size(void);

/** @brief "float" or "fixed". */
const char *mstc_sil_numeric(void);

/** @brief Table 1 defaults into @p p. */
void mstc_sil_defaults(mstc_sil_params_t *p);

/**
 * @brief Initialise the controller in @p mem.
 * @retval 0 ready; -EINVAL parameters rejected (ctl_params_check).
 */
int mstc_sil_init(void *mem, const mstc_sil_params_t *p);

/**
 * @brief One control step.
 * @retval 0 done; -EINVAL more than MSTC_SIL_MAX_OBSTACLES obstacles or a
 *         NULL pointer (nothing is done).
 */
int mstc_sil_step(void *mem, const mstc_sil_input_t *in, mstc_sil_output_t *out);

/**
 * @brief One scene of a batched step (mstc_sil_step_batch()): the inputs of
 *        mstc_sil_step() with the scene's obstacle table inline and what the
 *        range sensor reports of it as a mask, so that an array of them is a
 *        plain numpy structured array (no pointers to fill in).
 */
typedef struct {
    /** The step's inputs; in.n_obstacles is the number of entries of
     *  @ref table (at most MSTC_SIL_MAX_OBSTACLES), in.obstacles is ignored. */
    mstc_sil_input_t in;
    /** Not 0: table[i] is reported this step (a byte per entry, so that a
     *  numpy bool mask is copied in as it is). The step gets the reported
     *  entries in table order, as mstc_sil_step() would get that list. */
    uint8_t reported[MSTC_SIL_MAX_OBSTACLES];
    mstc_sil_obstacle_t table[MSTC_SIL_MAX_OBSTACLES];
} mstc_sil_batch_input_t;

/**
 * @brief Bytes from one controller to the next in a batch's memory:
 *        mstc_sil_size() rounded up to 16, so that each stays 16-byte aligned.
 */
size_t mstc_sil_batch_stride(void);

/**
 * @brief One control step of @p n controllers: controller i (at
 *        mem + i·mstc_sil_batch_stride(), initialised with mstc_sil_init())
 *        steps on in[i] into out[i], exactly as mstc_sil_step() would with
 *        the reported entries of in[i].table as its obstacle list.
 * @param mem the controllers, 16-byte aligned.
 * @param n the number of controllers, inputs and outputs.
 * @param active NULL: every controller steps; else only those whose byte is
 *        not 0 (the others, and their outputs, are left as they are).
 * @retval 0 done. @retval -EINVAL a NULL pointer, or an input with more than
 *         MSTC_SIL_MAX_OBSTACLES table entries or an entry reported beyond
 *         its table: then no controller has stepped.
 */
int mstc_sil_step_batch(void *mem, size_t n, const mstc_sil_batch_input_t *in,
                        const uint8_t *active, mstc_sil_output_t *out);

/** @brief A classic CAN frame (same layout as hal_can_frame_t). */
typedef struct {
    uint32_t id; /**< 11-bit identifier */
    uint8_t dlc; /**< 0..8 */
    uint8_t data[8];
} mstc_sil_frame_t;

/**
 * @brief (Re)start the library's firmware instance: empty bus queues, fresh
 *        application state.
 * @param p parameters, or NULL for the defaults.
 * @retval 0 ready; -EINVAL parameters rejected (the defaults are then used).
 */
int mstc_sil_fw_init(const mstc_sil_params_t *p);

/** @brief Length of a key [bytes] (AES-128). */
#define MSTC_SIL_KEY_LEN 16

/**
 * @brief Give the firmware instance its key for authenticated commands
 *        (app_set_key()), with a session drawn from the OS
 *        (hal_sys_boot_nonce()), as a board's start draws one. Without a
 *        key, every PARAM_SET is refused. mstc_sil_fw_init() forgets it.
 * @retval 0 done. @retval -EINVAL NULL or @p len is not MSTC_SIL_KEY_LEN.
 * @retval -EIO the OS gave no random value.
 */
int mstc_sil_fw_set_key(const uint8_t *key, size_t len);

/**
 * @brief Set the firmware's node id (app_set_node()): its identifiers are
 *        mstc.dbc's plus 0x100 times @p node. After mstc_sil_fw_init(),
 *        which sets the build's (NODE= of make, 0).
 * @retval 0 done. @retval -EINVAL @p node above 6.
 */
int mstc_sil_fw_set_node(uint8_t node);

/**
 * @brief Start session @p session instead (freshness 0): for the replay of a
 *        log recorded in that session (mstc replay), never for a run.
 * @retval 0 done. @retval -EINVAL no key was given.
 */
int mstc_sil_fw_set_session(uint32_t session);

/**
 * @brief AES-128-CMAC (RFC 4493) of @p len bytes of @p msg under @p key, by
 *        the firmware's own code (auth_cmac()), for comparing it with another
 *        implementation: messages of at most 16 bytes (one block).
 * @param key MSTC_SIL_KEY_LEN bytes. @param[out] mac 16 bytes.
 * @retval 0 done. @retval -EINVAL a NULL pointer, or @p len above 16.
 */
int mstc_sil_cmac(const uint8_t *key, const uint8_t *msg, size_t len, uint8_t *mac);

/**
 * @brief Put a frame on the firmware's bus; the firmware handles it before
 *        this returns (its answers wait in mstc_sil_fw_recv()).
 * @retval 0 handled (or dropped and counted by the firmware's checks).
 * @retval -EINVAL bad identifier or length. @retval -EAGAIN queue full.
 */
int mstc_sil_fw_send(const mstc_sil_frame_t *f);

/**
 * @brief Take the next frame the firmware sent.
 * @retval 0 taken. @retval -EAGAIN none waiting.
 */
int mstc_sil_fw_recv(mstc_sil_frame_t *f);

/**
 * @brief Give the firmware instance's board its own wheels: @p mem, a wheel
 *        loop on two motors (mstc_sil_wheels_init(), mstc_sil_wheel.h) that
 *        the caller advances. From now on the instance is an integrated
 *        board (docs/wheel.md, "Two topologies"): before each control step
 *        (a STEP frame, mstc_sil_fw_tick()) it takes that loop's estimate,
 *        faults and age as the measured wheel speeds, ignores WHEEL_SPEED
 *        frames and sends its own, and a re-arm clears the loop's faults.
 *        NULL: external drives again (WHEEL_SPEED from the bus).
 *        mstc_sil_fw_init() forgets them.
 * @retval 0 done.
 */
int mstc_sil_fw_wheels(void *mem);

/**
 * @brief Real-time mode: one control step of the library's firmware at
 *        @p now_us on the latest inputs (app_control_tick), as a board's
 *        timer runs it; its frames wait in mstc_sil_fw_recv(). The caller is
 *        the timer, so a test can drive the firmware from a clock of its own.
 */
void mstc_sil_fw_tick(uint64_t now_us);

/**
 * @brief Where one field of a struct of this header lies, so that a binding
 *        (sim/mstc/can/library.py) can check its own copy of the struct at load
 *        time instead of reading garbage after one side changed.
 */
typedef struct {
    const char *type;  /**< the struct's name, e.g. "mstc_sil_output_t" */
    const char *field; /**< the field's name; NULL: the whole struct */
    uint32_t offset;   /**< offsetof [bytes]; 0 for the whole struct */
    uint32_t size;     /**< sizeof the field (or the struct) [bytes] */
} mstc_sil_layout_t;

/** @brief A layout table's entry for struct type @p t as a whole, and for
 *         its field @p f. */
#define MSTC_SIL_LAYOUT_STRUCT(t)                                                                  \
    {                                                                                              \
#t, NULL, 0u, (uint32_t)sizeof(t)                                                          \
    }
#define MSTC_SIL_LAYOUT_FIELD(t, f)                                                                \
    {                                                                                              \
#t, #f, (uint32_t)offsetof(t, f), (uint32_t)sizeof(((t *)NULL)->f)                         \
    }

/**
 * @brief The layout of every struct above: for each, one entry for the whole
 *        struct followed by one entry per field, in declaration order.
 * @param[out] n the number of entries.
 * @return the entries (static; never NULL).
 */
const mstc_sil_layout_t *mstc_sil_layout(size_t *n);

#endif /* MSTC_SIL_H */
