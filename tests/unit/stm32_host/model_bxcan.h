/* SPDX-License-Identifier: MIT */
/**
 * @file model_bxcan.h
 * @brief The bxCAN controller (RM0090 §32) as the driver meets it:
 *
 * - modes: INRQ asks for initialisation, acknowledged by MSR.INAK once the
 *   controller has a clock (ack_init); leaving it waits for 11 recessive bits
 *   (bus_idle); SLEEP/SLAK as after reset;
 * - three transmit mailboxes: TXRQ requests one, CODE names a free one,
 *   transmission (bxcan_model_transmit(): the bus carries frames) in request
 *   order with TXFP, by identifier without; then RQCPx/TXOKx/TMEx and the
 *   transmit interrupt (TMEIE) while an RQCPx is set; RQCPx clear by writing 1;
 * - receive FIFO 0 three deep behind the acceptance filters (16-bit list and
 *   mask banks, FINIT, FA1R, FFA1R): FMP0, the output mailbox, RFOM0 to
 *   release it, FULL0 and FOVR0 (clear by writing 1; RFLM 0: an overrun
 *   overwrites the newest), the FIFO 0 interrupt (FMPIE0, FFIE0, FOVIE0);
 * - error counters and states: EWGF at 96, EPVF past 127, BOFF past 255 (no
 *   transmission then), the status-change interrupt (ERRIE with EWGIE, EPVIE,
 *   BOFIE) and MSR.ERRI; with ABOM, bus-off left by itself after 128 × 11
 *   recessive bits (2.8 ms at 500 kbit/s), counters cleared.
 */
#ifndef MODEL_BXCAN_H
#define MODEL_BXCAN_H

#include <stdbool.h>
#include <stdint.h>

#include "stm32_host.h"

/** @brief A frame on the model's bus. */
typedef struct {
    uint32_t id; /**< 11-bit (or 29-bit with ide) */
    bool ide, rtr;
    uint8_t dlc;
    uint8_t data[8];
} bxcan_model_frame_t;

#define BXCAN_MODEL_LOG 64u

typedef struct {
    stm32_host_periph_t p;
    int irq_tx, irq_rx0, irq_sce;
    bool ack_init;    /**< the controller has a clock: it acknowledges INRQ */
    bool bus_idle;    /**< the bus gives 11 recessive bits: it may join */
    uint32_t bitrate; /**< for ABOM's recovery time [bit/s] */
    /* mode */
    bool init;  /**< INAK */
    bool sleep; /**< SLAK */
    /* transmit */
    bool tx_pending[3];
    uint64_t tx_order[3]; /**< request sequence number */
    uint64_t tx_seq;
    uint32_t tsr_flags; /**< RQCPx, TXOKx */
    bxcan_model_frame_t sent[BXCAN_MODEL_LOG];
    unsigned n_sent;
    /* receive FIFO 0 */
    bxcan_model_frame_t fifo[3];
    uint8_t fifo_fmi[3];
    unsigned fifo_n;
    bool full, fovr;
    unsigned refused; /**< frames the filters turned away */
    unsigned lost;    /**< frames an overrun overwrote */
    /* errors */
    uint8_t tec, rec;
    bool boff;
    uint64_t boff_since;
    bool erri;
    unsigned bus_off_entries;
} bxcan_model_t;

/** @brief Map the controller at @p base, its interrupts, at its reset state
 *         (sleep), with a clock and an idle bus. */
void bxcan_model_init(bxcan_model_t *m, uint32_t base, int irq_tx, int irq_rx0, int irq_sce);

/** @brief The bus carries up to @p n frames from the pending mailboxes
 *         (none while bus-off or in initialisation). @return frames sent. */
unsigned bxcan_model_transmit(bxcan_model_t *m, unsigned n);

/** @brief A frame arrives: @return true when the filters take it into
 *         FIFO 0 (an overrun too: it overwrites the newest). */
bool bxcan_model_receive(bxcan_model_t *m, const bxcan_model_frame_t *f);

/** @brief The error counters become @p tec and @p rec (tec past 255:
 *         bus-off), with the flags and the status-change interrupt. */
void bxcan_model_errors(bxcan_model_t *m, unsigned tec, unsigned rec);

#endif /* MODEL_BXCAN_H */
