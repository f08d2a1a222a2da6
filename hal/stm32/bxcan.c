/* SPDX-License-Identifier: MIT */
/* HAL CAN on the STM32 ports: the bxCAN controller (RM0090 §32, RM0008 §24;
 * the same IP on the F1 and F4). Receive FIFO 0 is drained by its interrupt
 * into a lock-free queue that hal_can_recv() empties; hal_can_send() queues
 * into a second one and pends the transmit interrupt, which alone loads the
 * three mailboxes, in request order (TXFP). Bus-off recovers by itself
 * (ABOM); the status-change interrupt counts it (hal_can_status()). */
#include <errno.h>
#include <stddef.h>

#include "board.h"
#include "bxcan_calc.h"
#include "can_queue.h"
#include "can_ring.h"
#include "cortex_m.h"
#include "hal/hal_can.h"
#include "hal/hal_time.h"
#include "stm32_hal.h"

/* Interrupt priorities (0 most urgent): receive first, as the hardware FIFO
 * holds only three frames; the control timer and SysTick last. */
#define PRIO_CAN_RX  1u
#define PRIO_CAN_TX  2u
#define PRIO_CAN_SCE 2u

/* Time-outs of the mode changes. Entering initialisation takes a bit time or
 * so; leaving it needs 11 recessive bits on the bus (RM0090 §32.4.1). */
#define INIT_TIMEOUT_US 10000u

static can_ring_t rx_ring; /* ISR -> task */
static can_ring_t tx_ring; /* task -> ISR */
static volatile uint32_t bus_off_events;
static volatile bool was_bus_off; /* at the last status-change interrupt */
static volatile uint32_t fifo_overruns;
static volatile uint32_t tx_refused;
static volatile bool opened;
static uint32_t bitrate_open;

#define CAN BOARD_CAN

static bool wait_bits(volatile uint32_t *reg, uint32_t mask, uint32_t want)
{
    const uint64_t end = hal_time_now_us() + INIT_TIMEOUT_US;
    while ((*reg & mask) != want) {
        if (hal_time_now_us() > end) {
            return false;
        }
    }
    return true;
}

static void write_filters(const bxcan_bank_t *banks, unsigned n)
{
    CAN->FMR |= CAN_FMR_FINIT_Msk;
    uint32_t used = 0u;
    for (unsigned i = 0; i < n; i++) {
        used |= 1u << i;
    }
    CAN->FA1R &= ~((1u << BXCAN_MAX_BANKS) - 1u); /* deactivate ours */
    for (unsigned i = 0; i < n; i++) {
        const uint32_t bit = 1u << i;
        if (banks[i].list) {
            CAN->FM1R |= bit;
        } else {
            CAN->FM1R &= ~bit;
        }
        CAN->FS1R &= ~bit;  /* 16-bit scale */
        CAN->FFA1R &= ~bit; /* FIFO 0 */
        CAN->FB[i].FR1 = banks[i].fr1;
        CAN->FB[i].FR2 = banks[i].fr2;
    }
    CAN->FA1R |= used;
    CAN->FMR &= ~CAN_FMR_FINIT_Msk;
}

int hal_can_open(const char *iface)
{
    (void)iface; /* one controller per board */
    opened = false;
    can_ring_init(&rx_ring);
    can_ring_init(&tx_ring);
    bus_off_events = 0u;
    was_bus_off = false;
    fifo_overruns = 0u;
    tx_refused = 0u;
    board_can_enable();

    bxcan_timing_t t;
    if (bxcan_timing(board_clocks()->apb1_hz, BOARD_CAN_BITRATE, BXCAN_SAMPLE_POINT_CIA, &t) != 0) {
        return -EINVAL;
    }
    /* Out of sleep, into initialisation (RM0090 §32.4.1). */
    CAN->MCR = (CAN->MCR & ~CAN_MCR_SLEEP_Msk) | CAN_MCR_INRQ_Msk;
    if (!wait_bits(&CAN->MSR, CAN_MSR_INAK_Msk | CAN_MSR_SLAK_Msk, CAN_MSR_INAK_Msk)) {
        return -ENODEV; /* the controller does not answer (no clock?) */
    }
    /* ABOM: leave bus-off by itself after 128 × 11 recessive bits.
     * TXFP: mailboxes go out in request order, so WHEEL_CMD stays last.
     * Automatic retransmission on; RFLM off: an overrun keeps the newest.
     * DBF (reset value 1 on the F4): CAN frozen while a debugger halts. */
    CAN->MCR =
        CAN_MCR_INRQ_Msk | CAN_MCR_ABOM_Msk | CAN_MCR_TXFP_Msk | (CAN->MCR & CAN_MCR_DBF_Msk);
    CAN->BTR = bxcan_btr(&t);

    bxcan_bank_t all;
    unsigned n_banks = 0;
    (void)bxcan_filter_banks(NULL, 0u, &all, 1u, &n_banks);
    write_filters(&all, n_banks);

    CAN->IER = CAN_IER_FMPIE0_Msk | CAN_IER_FOVIE0_Msk | CAN_IER_TMEIE_Msk | CAN_IER_ERRIE_Msk |
               CAN_IER_BOFIE_Msk | CAN_IER_EPVIE_Msk;
    cm_nvic_set_priority(BOARD_CAN_RX0_IRQn, PRIO_CAN_RX);
    cm_nvic_set_priority(BOARD_CAN_TX_IRQn, PRIO_CAN_TX);
    cm_nvic_set_priority(BOARD_CAN_SCE_IRQn, PRIO_CAN_SCE);
    cm_nvic_enable(BOARD_CAN_RX0_IRQn);
    cm_nvic_enable(BOARD_CAN_TX_IRQn);
    cm_nvic_enable(BOARD_CAN_SCE_IRQn);

    CAN->MCR &= ~CAN_MCR_INRQ_Msk;
    bitrate_open = BOARD_CAN_BITRATE;
    opened = true;
    /* Normal mode once 11 recessive bits are seen. A bus held dominant (or a
     * missing transceiver pulling RX low) delays that; frames queue meanwhile
     * and go out when the controller joins, so this is not a failure. */
    (void)wait_bits(&CAN->MSR, CAN_MSR_INAK_Msk, 0u);
    return 0;
}

int hal_can_set_filters(const hal_can_filter_t *filters, unsigned n)
{
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned n_banks = 0;
    const int rc = bxcan_filter_banks(filters, n, banks, BXCAN_MAX_BANKS, &n_banks);
    if (rc != 0) {
        return rc;
    }
    write_filters(banks, n_banks);
    return 0;
}

int hal_can_send(const hal_can_frame_t *frame)
{
    return can_queue_send(&tx_ring, BOARD_CAN_TX_IRQn, frame, opened ? 0 : -ENODEV, &tx_refused);
}

/* hal_can.h: -EIO while the controller is bus-off. */
static bool bus_off_now(void) { return opened && (CAN->ESR & CAN_ESR_BOFF_Msk) != 0u; }

int hal_can_recv(hal_can_frame_t *frame, uint32_t timeout_us)
{
    return can_queue_recv(&rx_ring, frame, timeout_us, bus_off_now);
}

void hal_can_close(void)
{
    cm_nvic_disable(BOARD_CAN_RX0_IRQn);
    cm_nvic_disable(BOARD_CAN_TX_IRQn);
    cm_nvic_disable(BOARD_CAN_SCE_IRQn);
    CAN->IER = 0u;
    CAN->MCR |= CAN_MCR_INRQ_Msk;
    opened = false;
    bitrate_open = 0u;
}

int hal_can_status(hal_can_status_t *st)
{
    if (st == NULL) {
        return -EINVAL;
    }
    const uint32_t esr = CAN->ESR;
    const uint8_t tec = (uint8_t)((esr & CAN_ESR_TEC_Msk) >> CAN_ESR_TEC_Pos);
    const uint8_t rec = (uint8_t)((esr & CAN_ESR_REC_Msk) >> CAN_ESR_REC_Pos);
    hal_can_state_t state = HAL_CAN_STATE_ERROR_ACTIVE;
    if (!opened) {
        state = HAL_CAN_STATE_STOPPED;
    } else if ((esr & CAN_ESR_BOFF_Msk) != 0u) {
        state = HAL_CAN_STATE_BUS_OFF;
    } else if ((esr & CAN_ESR_EPVF_Msk) != 0u) {
        state = HAL_CAN_STATE_ERROR_PASSIVE;
    } else if ((esr & CAN_ESR_EWGF_Msk) != 0u) {
        state = HAL_CAN_STATE_ERROR_WARNING;
    }
    *st = (hal_can_status_t){
        .state = state,
        .tx_err = tec,
        .rx_err = rec,
        .bus_off = bus_off_events,
        .rx_dropped = rx_ring.dropped + fifo_overruns,
        .tx_dropped = tx_refused,
    };
    return 0;
}

bool stm32_can_rx_pending(void) { return can_ring_count(&rx_ring) != 0u; }

uint32_t stm32_can_bitrate(void) { return bitrate_open; }

/* Receive FIFO 0: move every pending frame into the queue. */
void BOARD_CAN_RX0_IRQHandler(void)
{
    while ((CAN->RF0R & CAN_RF0R_FMP0_Msk) != 0u) {
        const bxcan_mailbox_t mb = {
            .ir = CAN->RX[0].RIR,
            .dtr = CAN->RX[0].RDTR,
            .dlr = CAN->RX[0].RDLR,
            .dhr = CAN->RX[0].RDHR,
        };
        CAN->RF0R = CAN_RF0R_RFOM0_Msk; /* release the output mailbox */
        hal_can_frame_t f;
        if (bxcan_frame_from_mailbox(&mb, &f)) {
            (void)can_ring_push(&rx_ring, &f); /* a full queue counts the drop */
        }
    }
    const uint32_t rf0r = CAN->RF0R;
    if ((rf0r & CAN_RF0R_FOVR0_Msk) != 0u) {
        fifo_overruns = fifo_overruns + 1u;
    }
    /* FULL0 and FOVR0 clear by writing 1 (rc_w1); RFOM0 stays 0 here. */
    CAN->RF0R = rf0r & (CAN_RF0R_FULL0_Msk | CAN_RF0R_FOVR0_Msk);
}

/* Transmit: acknowledge finished mailboxes, then fill every empty one from
 * the queue. Runs on TMEIE and when hal_can_send() pends it. */
void BOARD_CAN_TX_IRQHandler(void)
{
    CAN->TSR = CAN->TSR & (CAN_TSR_RQCP0_Msk | CAN_TSR_RQCP1_Msk | CAN_TSR_RQCP2_Msk);
    const uint32_t empty_mask = CAN_TSR_TME0_Msk | CAN_TSR_TME1_Msk | CAN_TSR_TME2_Msk;
    hal_can_frame_t f;
    while ((CAN->TSR & empty_mask) != 0u && can_ring_pop(&tx_ring, &f)) {
        /* CODE: the number of an empty mailbox (RM0090 §32.9.2, CAN_TSR). */
        const uint32_t box = (CAN->TSR & CAN_TSR_CODE_Msk) >> CAN_TSR_CODE_Pos;
        bxcan_mailbox_t mb;
        bxcan_mailbox_from_frame(&f, &mb);
        CAN->TX[box].TDTR = mb.dtr;
        CAN->TX[box].TDLR = mb.dlr;
        CAN->TX[box].TDHR = mb.dhr;
        CAN->TX[box].TIR = mb.ir | CAN_TIR_TXRQ_Msk; /* last: requests transmission */
    }
}

/* Status change: count entries into bus-off (the event; ABOM recovers). A
 * bus that fails again after a recovery passes error-passive first (the
 * transmit error count climbs through 128 to 256), whose interrupt (EPVIE)
 * brings was_bus_off back to false before the next entry. */
void BOARD_CAN_SCE_IRQHandler(void)
{
    const bool bus_off = (CAN->ESR & CAN_ESR_BOFF_Msk) != 0u;
    if (bus_off && !was_bus_off) {
        bus_off_events = bus_off_events + 1u;
    }
    was_bus_off = bus_off;
    CAN->MSR = CAN_MSR_ERRI_Msk; /* rc_w1 */
}
