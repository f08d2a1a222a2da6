/* SPDX-License-Identifier: MIT */
/**
 * @file bxcan_calc.h
 * @brief The board-independent part of the bxCAN driver: bit timing from the
 *        peripheral clock, acceptance-filter bank values, and the packing of
 *        frames into mailbox registers. Pure functions, no register access:
 *        unit-tested on the host (tests/unit/test_bxcan.c).
 *
 * bxCAN is the same IP on the STM32F1 (RM0008 §24) and STM32F4 (RM0090 §32);
 * section numbers below are RM0090's, RM0008's in brackets.
 */
#ifndef STM32_BXCAN_CALC_H
#define STM32_BXCAN_CALC_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_can.h"

/** @brief Bit timing in time quanta (tq), as the bit rate sees it (not the
 *         register encoding, which stores each value minus one). */
typedef struct {
    uint16_t brp; /**< prescaler: tq = brp / f_pclk, 1..1024 */
    uint8_t ts1;  /**< PROP_SEG + PHASE_SEG1 [tq], 1..16 */
    uint8_t ts2;  /**< PHASE_SEG2 [tq], 1..8 */
    uint8_t sjw;  /**< resynchronisation jump width [tq], 1..4, <= ts2 */
} bxcan_timing_t;

/** @brief Sample point CiA 301 recommends for 500 kbit/s and 1 Mbit/s [‰]. */
#define BXCAN_SAMPLE_POINT_CIA 875u

/**
 * @brief Bit timing for @p bitrate from the APB1 clock @p pclk_hz.
 *
 * A bit is 1 (SYNC_SEG) + ts1 + ts2 quanta and the sample point is at
 * (1 + ts1) / N (RM0090 §32.7.7 [§24.7.7]). Only exact bit rates are
 * accepted (pclk = bitrate · brp · N). Among them: the sample point nearest
 * @p sample_point_permille, then the most quanta per bit (finer
 * resynchronisation), then the later sample point. N ranges over 8..25
 * (bxCAN's limits: ts1 <= 16, ts2 <= 8). sjw = min(4, ts2), the largest
 * the hardware allows, as CiA 301 recommends.
 *
 * @param pclk_hz CAN peripheral clock (APB1) [Hz], > 0.
 * @param bitrate [bit/s], > 0.
 * @param sample_point_permille wanted sample point [‰], 500..950.
 * @param[out] t the timing.
 * @retval 0 found. @retval -EINVAL no exact timing, or an argument out of range.
 */
int bxcan_timing(uint32_t pclk_hz, uint32_t bitrate, uint16_t sample_point_permille,
                 bxcan_timing_t *t);

/** @brief Sample point of @p t [‰], rounded down. */
unsigned bxcan_sample_point_permille(const bxcan_timing_t *t);

/** @brief CAN_BTR value of @p t (RM0090 §32.9.2 [§24.9.2]): SJW, TS2, TS1,
 *         BRP each minus one; normal mode (no loop-back, no silent). */
uint32_t bxcan_btr(const bxcan_timing_t *t);

/** @brief Filter banks of one CAN controller (F1: 14; F4 CAN1: 0..13 while
 *         CAN_FMR.CAN2SB keeps its reset value 14). */
#define BXCAN_MAX_BANKS 14u

/** @brief One filter bank, 16-bit scale (RM0090 §32.7.4 [§24.7.4]). */
typedef struct {
    bool list;    /**< identifier-list mode (4 exact ids); else mask mode (2 id/mask pairs) */
    uint32_t fr1; /**< CAN_FiR1 */
    uint32_t fr2; /**< CAN_FiR2 */
} bxcan_bank_t;

/**
 * @brief Filter banks that accept exactly the standard data frames matching
 *        one of @p filters.
 *
 * Filters whose mask is HAL_CAN_MAX_STD_ID (an exact identifier) go four to
 * a bank in 16-bit list mode; the others two to a bank in 16-bit mask mode.
 * Every entry requires IDE = 0 and RTR = 0, so extended and remote frames
 * never pass. An unused list slot repeats the bank's last identifier; an
 * unused mask slot repeats its pair. n = 0 accepts every standard data frame
 * (one mask bank, mask on IDE and RTR only).
 *
 * @param filters the filters (hal_can_filter_t: id and mask, 11 bits each).
 * @param n number of filters, 0..16.
 * @param[out] banks filled with *n_banks banks, at most @p max_banks.
 * @param[out] n_banks banks used.
 * @retval 0 done. @retval -EINVAL n > 16, an id or mask wider than 11 bits,
 *         or more banks needed than @p max_banks.
 */
int bxcan_filter_banks(const hal_can_filter_t *filters, unsigned n, bxcan_bank_t *banks,
                       unsigned max_banks, unsigned *n_banks);

/** @brief The mailbox words of a frame (RM0090 §32.9.3 [§24.9.3]). */
typedef struct {
    uint32_t ir;  /**< CAN_TIxR / CAN_RIxR: STID in bits 31:21, IDE, RTR (TXRQ clear) */
    uint32_t dtr; /**< CAN_TDTxR / CAN_RDTxR: DLC in bits 3:0 */
    uint32_t dlr; /**< data bytes 0..3, byte 0 least significant */
    uint32_t dhr; /**< data bytes 4..7 */
} bxcan_mailbox_t;

/** @brief Mailbox words for @p f (id and dlc already checked by the caller;
 *         the transmit request bit is left to the caller). */
void bxcan_mailbox_from_frame(const hal_can_frame_t *f, bxcan_mailbox_t *mb);

/**
 * @brief A received mailbox as a frame.
 * @retval true a standard data frame, now in @p f (bytes past dlc zeroed; a
 *         DLC of 9..15 means 8 bytes).
 * @retval false an extended or remote frame: @p f is untouched.
 */
bool bxcan_frame_from_mailbox(const bxcan_mailbox_t *mb, hal_can_frame_t *f);

#endif /* STM32_BXCAN_CALC_H */
