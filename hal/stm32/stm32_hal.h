/* SPDX-License-Identifier: MIT */
/**
 * @file stm32_hal.h
 * @brief Internal interface between the shared STM32 drivers (hal/stm32)
 *        and the board main loop (hal/stm32/main.c). Not a HAL service: the
 *        firmware never sees it.
 */
#ifndef STM32_HAL_H
#define STM32_HAL_H

#include <stdbool.h>
#include <stdint.h>

/** @brief Start SysTick (hal_time) from the core clock. Task context. */
void stm32_time_init(uint32_t sysclk_hz);

/** @brief Core clock cycles since stm32_time_init(), modulo 2^32, from
 *         SysTick: differences time code to the cycle (under QEMU's -icount,
 *         SysTick counts executed instructions: docs/hil.md). Task or ISR. */
uint32_t stm32_time_cycles(void);

/**
 * @brief Start the control-period timer (board_config.h: BOARD_TICK_TIM):
 *        an update interrupt every @p period_us, which only counts.
 * @retval 0 started. @retval -EINVAL no setting for this period.
 */
int stm32_tick_start(uint32_t period_us);

/** @brief Control periods elapsed since the last call (0 when none): the
 *         main loop's "timer flag". Task context. */
uint32_t stm32_tick_take(void);

/** @brief A period elapsed that stm32_tick_take() has not taken yet (the
 *         main loop checks it, interrupts masked, before sleeping). */
bool stm32_tick_pending(void);

/** @brief Periods the main loop missed (more than one elapsed between two
 *         stm32_tick_take() calls), since start. */
uint32_t stm32_tick_overruns(void);

/** @brief A received frame is waiting (the main loop checks it, interrupts
 *         masked, before sleeping). */
bool stm32_can_rx_pending(void);

/** @brief The bit rate hal_can_open() set up [bit/s] (0 when not open). */
uint32_t stm32_can_bitrate(void);

/** @brief What the main loop has done, for a debugger (and the QEMU smoke
 *         test, mstc.bench.qemu_smoke): words only, so its layout is plain.
 *
 * A debugger reads these words while the board runs, one at a time, so a
 * read can fall between two of the main loop's writes (a step counted in
 * `frame_steps` but not yet in `steps`). `seq` makes every copy a reader
 * keeps consistent, as a seqlock does: the main loop, the only writer, makes
 * it odd before it changes any other word and even again after the last,
 * with a barrier each time; a reader keeps a copy only when `seq` read before
 * it and `seq` read after it are the same even number (sim/mstc/firmware/qemu.py). */
typedef struct {
    uint32_t steps;       /**< control steps run */
    uint32_t overruns;    /**< control periods skipped because the loop was late */
    int32_t can_open;     /**< hal_can_open() result (0, or a negative errno) */
    uint32_t reset_cause; /**< hal_reset_cause_t at start */
    uint32_t sysclk_hz;   /**< core clock in force */
    uint32_t lockstep;    /**< 1 once a STEP frame ran a step: the timer steps no more */
    uint32_t frame_steps; /**< control steps run by STEP frames (lock-step) */
    /** Core clock cycles (stm32_time_cycles()) of one control step: handling
     *  the STEP frame, or the timer's app_control_tick(), with the frames it
     *  sends and the interrupts that run meanwhile. Over the steps of the
     *  mode in force: the `steps` of real-time mode, then, from the first
     *  STEP frame on, the `frame_steps`. */
    uint32_t step_cycles_min;
    uint32_t step_cycles_max;
    uint32_t step_cycles_sum_lo; /**< sum over the steps, low word ... */
    uint32_t step_cycles_sum_hi; /**< ... and high word */
    /** Sequence word: incremented before the main loop changes any word
     *  above (odd while it does) and again after (even); a seqlock, see
     *  above. Last, so that the words above keep their offsets. */
    uint32_t seq;
} stm32_loop_stats_t;

/** @brief Written by the main loop only. */
extern volatile stm32_loop_stats_t stm32_loop_stats;

/** @brief What the wheel loop has done (hal/stm32/main.c), for a debugger:
 *         words only. */
typedef struct {
    uint32_t periods;        /**< wheel periods run */
    uint32_t overruns;       /**< periods skipped because the main loop was late */
    uint32_t closed_loop;    /**< 1: encoders read; 0: open loop (no encoders) */
    uint32_t faults;         /**< WHL_FAULT_* bits of the last period */
    int32_t speed_mrad_s[2]; /**< measured speeds of the last period [mrad/s] */
    /** Longest period, encoders to motors [core cycles], and the sum over
     *  all (low, high word): the firmware's, a simulated motor's excluded
     *  (stm32_wheels_model_cycles()). */
    uint32_t cycles_max;
    uint32_t cycles_sum_lo;
    uint32_t cycles_sum_hi;
    /** Periods run on the plant's time (lock-step with simulated motors). */
    uint32_t step_periods;
} stm32_wheel_stats_t;

/** @brief Written by the main loop only. */
extern volatile stm32_wheel_stats_t stm32_wheel_stats;

/**
 * @brief The wheel loop's period [µs], after each change (the main loop).
 *        A board's drivers take no notice; a PIL image's simulated motors
 *        (pil_wheels.c) move on by it at each encoder read.
 * @return true when the motors are simulated: in lock-step the main loop then
 *         runs the wheel periods on the plant's time (the STEP frames'),
 *         not on its millisecond tick.
 */
bool stm32_wheels_period(uint32_t period_us);

/** @brief The main loop runs the wheel periods on the plant's time from now
 *         on (simulated motors in lock-step): a PIL image starts its trace. */
void stm32_wheels_lockstep(void);

/** @brief Core cycles the simulated motors took in the last encoder read
 *         (0 on a board): not the firmware's, not in its statistics. */
uint32_t stm32_wheels_model_cycles(void);

/** @brief Periods stm32_pil_trace holds, from the first on the plant's time. */
#define STM32_PIL_TRACE_N     1000u
/** @brief Its scale: counts per rad/s. */
#define STM32_PIL_TRACE_SCALE 512.0

/** @brief A PIL image's simulated motors (pil_wheels.c): each wheel's true
 *         speed [1/STM32_PIL_TRACE_SCALE rad/s] after each of the first
 *         STM32_PIL_TRACE_N periods on the plant's time, for the harness
 *         (mstc hil --qemu). */
typedef struct {
    uint32_t n; /**< periods held */
    int16_t speed[STM32_PIL_TRACE_N][2];
} stm32_pil_trace_t;

/** @brief In the PIL images only. */
extern volatile stm32_pil_trace_t stm32_pil_trace;

#endif /* STM32_HAL_H */
