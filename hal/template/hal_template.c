/* SPDX-License-Identifier: MIT */
/*
 * The blank port: every HAL service (the headers in hal/include/hal) with what to fill
 * in. It compiles and links (`make firmware BOARD=template`), and does
 * nothing: every call reports that the service is missing. Copy hal/template
 * to hal/<yourboard> and replace each TODO; docs/porting.md walks through it
 * and hal/stm32 is a complete port to read beside it.
 *
 * Rules every port keeps (docs/porting.md, docs/architecture.md):
 * - an interrupt handler only moves data (a frame into a queue, a count up);
 *   the main loop calls the firmware, never an ISR;
 * - no heap; queues are static, sized at compile time;
 * - each function's context (ISR or task) and blocking are as the header says.
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal/hal_can.h"
#include "hal/hal_encoder.h"
#include "hal/hal_motor.h"
#include "hal/hal_sys.h"
#include "hal/hal_time.h"
#include "template.h"

/* ------------------------------------------------------------------ time */

/* TODO: a monotonic microsecond clock. On a Cortex-M: SysTick at 1 kHz
 * counting milliseconds, plus the counter's current value for the
 * microseconds (hal/stm32/time.c); or a free-running 32-bit timer at 1 MHz
 * extended to 64 bits in its overflow interrupt. Must be callable from an
 * ISR, must never block, must never go backwards. */
uint64_t hal_time_now_us(void) { return 0u; }

/* TODO: sleep (WFI) until hal_time_now_us() >= t_us; some interrupt must
 * wake the core at least once per millisecond, or use a compare interrupt
 * at t_us. */
void hal_time_sleep_until_us(uint64_t t_us) { (void)t_us; }

/* ------------------------------------------------------------------- CAN */

/* TODO: clock and pins of the CAN controller; bit timing for the board's bit
 * rate computed from the controller's clock (hal/stm32/bxcan_calc.c has a
 * pure function for bxCAN); automatic bus-off recovery on; receive
 * interrupt enabled; accept every standard data frame until
 * hal_can_set_filters(). Return -ENODEV when the controller does not start.
 * @p iface is for ports with several controllers; boards with one ignore it. */
int hal_can_open(const char *iface)
{
    (void)iface;
    return -ENODEV;
}

/* TODO: translate the (id, mask) filters into the controller's acceptance
 * filters (hal/stm32/bxcan_calc.c: bxcan_filter_banks()). Frames that pass
 * may still be dropped in software; frames that do not pass must never
 * reach hal_can_recv(). */
int hal_can_set_filters(const hal_can_filter_t *filters, unsigned n)
{
    (void)filters;
    return n > 16u ? -EINVAL : -ENOTSUP;
}

/* TODO: queue the frame (a single-producer/single-consumer ring: task
 * produces, the transmit interrupt consumes, hal/stm32/can_ring.h) and make
 * sure the transmit interrupt runs (pend it). Frames leave in the order they
 * were queued. Never block: -EAGAIN when the queue is full. */
int hal_can_send(const hal_can_frame_t *frame)
{
    if (frame == NULL || frame->id > HAL_CAN_MAX_STD_ID || frame->dlc > HAL_CAN_MAX_DLC) {
        return -EINVAL;
    }
    return -EAGAIN;
}

/* TODO: take the oldest frame from the receive queue that the receive
 * interrupt fills; with a timeout, sleep (WFI) between checks. -EIO while
 * the controller is bus-off. */
int hal_can_recv(hal_can_frame_t *frame, uint32_t timeout_us)
{
    (void)frame;
    (void)timeout_us;
    return -EAGAIN;
}

/* TODO: disable the controller's interrupts and take it off the bus. */
void hal_can_close(void) {}

/* TODO: the controller's error state and counters (TEC, REC), the bus-off
 * entries counted by the status-change interrupt, and the frames the queues
 * dropped; hal/stm32/bxcan.c shows it for bxCAN. -ENOTSUP until then. */
int hal_can_status(hal_can_status_t *st)
{
    (void)st;
    return -ENOTSUP;
}

/* ---------------------------------------------------------------- system */

/* TODO: start the MCU's independent watchdog (its own clock, not stoppable
 * by software) with at least @p timeout_ms at the oscillator's fastest
 * tolerance; hal/stm32/stm32_calc.c: stm32_iwdg_config() for the STM32
 * IWDG. */
int hal_sys_watchdog_start(uint32_t timeout_ms)
{
    (void)timeout_ms;
    return -ENOTSUP;
}

/* TODO: reload the watchdog. Any context, never blocks. */
void hal_sys_watchdog_kick(void) {}

/* TODO: read the reset controller's flags once (and clear them, so that the
 * next reset tells its own cause); hal/stm32/stm32_calc.c:
 * stm32_reset_cause() orders them. */
hal_reset_cause_t hal_sys_reset_cause(void) { return HAL_RESET_OTHER; }

/* A port with a TRNG reads it; one without keeps a counter across resets
 * (backup registers, flash); docs/safety.md, "Sessions". */
int hal_sys_boot_nonce(uint32_t *nonce)
{
    *nonce = 0u;
    return -ENOTSUP;
}

/* ----------------------------------------------------------------- motor */

/* TODO: the wheel outputs: a PWM timer at an inaudible frequency (20 kHz),
 * one direction pin per wheel and a driver-enable pin, all at their safe
 * levels (driver disabled) before they become outputs
 * (hal/stm32/motor_pwm.c). -ENODEV on a board without motor outputs. */
int hal_motor_init(void) { return -ENODEV; }

/* TODO: direction pins from the signs, duty from the magnitudes
 * (stm32_pwm_compare()), then enable the driver. */
int hal_motor_set(int16_t left, int16_t right)
{
    (void)left;
    (void)right;
    return -ENODEV;
}

/* TODO: disable the driver and set duty 0. Must work from a fault handler:
 * no waiting, no state that a fault could have left inconsistent. */
void hal_motor_stop(void) {}

/* --------------------------------------------------------------- encoder */

/* TODO: a timer per wheel counting the encoder's edges in hardware (STM32:
 * encoder mode, hal/stm32/encoder.c), its pins as inputs with pull-ups and
 * an input filter. Until then the port has no encoders: -ENODEV, and the
 * main loop drives the motors open loop. */
int hal_encoder_init(void) { return -ENODEV; }

/* TODO: each counter's signed difference since the last read (sign-extended
 * from the counter's width) added to a 32-bit running count; a difference of
 * a quarter of the counter's range or more not taken but reported (-ERANGE,
 * hal_encoder_overran(); hal/stm32/encoder.c). Called from the wheel loop
 * only, at least once per HAL_ENCODER_MAX_STEP counts. */
int hal_encoder_read(int32_t *left, int32_t *right)
{
    *left = 0;
    *right = 0;
    return -ENODEV;
}

/* TODO: the wheels the last hal_encoder_read() did not take. */
uint8_t hal_encoder_overran(void) { return 0u; }

/* ------------------------------------------------------ board (template.h) */

/* TODO: clocks at the datasheet maximum (flash wait states first), GPIO at
 * safe levels. */
void template_board_init(void) {}

/* TODO: start a timer whose interrupt counts control periods of
 * @p period_us (and only counts). Return 0, or -EINVAL. */
int template_tick_start(uint32_t period_us)
{
    (void)period_us;
    return -ENOTSUP;
}

/* TODO: the periods counted since the last call (0 when none). */
uint32_t template_tick_take(void) { return 0u; }

/* TODO: sleep until an interrupt, unless a period or a frame is already
 * waiting: mask interrupts, check, WFI, unmask (WFI wakes with interrupts
 * masked, so nothing is missed). */
void template_wait_for_event(void) {}
