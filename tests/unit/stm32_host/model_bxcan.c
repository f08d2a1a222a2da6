/* SPDX-License-Identifier: MIT */
/* The bxCAN controller's behaviour (model_bxcan.h). Register layout and bits
 * from RM0090 §32.9 (the same in RM0008 §24.9), written out here, not taken
 * from the generated header the driver uses. */
#include "model_bxcan.h"

#include <string.h>

enum {
    MCR = 0x000,
    MSR = 0x004,
    TSR = 0x008,
    RF0R = 0x00C,
    IER = 0x014,
    ESR = 0x018,
    BTR = 0x01C,
    TX0 = 0x180, /* TIR, TDTR, TDLR, TDHR of mailbox i at TX0 + 16 i */
    RX0 = 0x1B0, /* RIR, RDTR, RDLR, RDHR of FIFO 0's output mailbox */
    FMR = 0x200,
    FM1R = 0x204,
    FS1R = 0x20C,
    FFA1R = 0x214,
    FA1R = 0x21C,
    FB0 = 0x240, /* FR1, FR2 of bank i at FB0 + 8 i */
    END = FB0 + 28 * 8,
};
#define R(m, off) ((m)->p.reg[(off) / 4])

/* MCR */
#define INRQ    (1u << 0)
#define SLEEP   (1u << 1)
#define TXFP    (1u << 2)
#define RFLM    (1u << 3)
#define ABOM    (1u << 6)
/* MSR */
#define INAK    (1u << 0)
#define SLAK    (1u << 1)
#define ERRI    (1u << 2)
/* TSR: per mailbox i, RQCPi at 8i, TXOKi at 8i + 1; TMEi at 26 + i */
#define RQCP(i) (1u << (8u * (i)))
#define TXOK(i) (1u << (8u * (i) + 1u))
#define TME(i)  (1u << (26u + (i)))
/* RF0R */
#define FULL0   (1u << 3)
#define FOVR0   (1u << 4)
#define RFOM0   (1u << 5)
/* IER */
#define TMEIE   (1u << 0)
#define FMPIE0  (1u << 1)
#define FFIE0   (1u << 2)
#define FOVIE0  (1u << 3)
#define EWGIE   (1u << 8)
#define EPVIE   (1u << 9)
#define BOFIE   (1u << 10)
#define ERRIE   (1u << 15)
/* ESR */
#define EWGF    (1u << 0)
#define EPVF    (1u << 1)
#define BOFF    (1u << 2)
/* TIR / RIR */
#define TXRQ    (1u << 0)
#define RTR     (1u << 1)
#define IDE     (1u << 2)

/* The interrupts whose condition holds now are pending (RM0090 §32.8: each
 * is a level of its flags and enables). */
static void levels(bxcan_model_t *m);

static void level(void *ctx) { levels(ctx); }

static void levels(bxcan_model_t *m)
{
    const uint32_t ier = R(m, IER);
    if ((ier & TMEIE) != 0u && (m->tsr_flags & (RQCP(0) | RQCP(1) | RQCP(2))) != 0u) {
        stm32_host_pend(m->irq_tx);
    }
    if (((ier & FMPIE0) != 0u && m->fifo_n > 0u) || ((ier & FFIE0) != 0u && m->full) ||
        ((ier & FOVIE0) != 0u && m->fovr)) {
        stm32_host_pend(m->irq_rx0);
    }
    if ((ier & ERRIE) != 0u && m->erri) {
        stm32_host_pend(m->irq_sce);
    }
}

static uint32_t esr(const bxcan_model_t *m)
{
    return (m->tec >= 96u || m->rec >= 96u ? EWGF : 0u) |
           (m->tec > 127u || m->rec > 127u ? EPVF : 0u) | (m->boff ? BOFF : 0u) |
           ((uint32_t)m->tec << 16) | ((uint32_t)m->rec << 24);
}

static uint32_t tsr(const bxcan_model_t *m)
{
    uint32_t v = m->tsr_flags;
    unsigned free_box = 3u;
    for (unsigned i = 0; i < 3u; i++) {
        if (!m->tx_pending[i]) {
            v |= TME(i);
            free_box = free_box == 3u ? i : free_box;
        }
    }
    /* CODE: the next free mailbox (RM0090 §32.9.2); 0 when none (the
     * lowest priority one, which the driver never asks for). */
    return v | ((free_box == 3u ? 0u : free_box) << 24);
}

static uint32_t mailbox_ir(const bxcan_model_frame_t *f)
{
    return f->ide ? (f->id << 3) | IDE | (f->rtr ? RTR : 0u) : (f->id << 21) | (f->rtr ? RTR : 0u);
}

static uint32_t bytes(const uint8_t *d)
{
    return (uint32_t)d[0] | ((uint32_t)d[1] << 8) | ((uint32_t)d[2] << 16) | ((uint32_t)d[3] << 24);
}

static uint32_t bxcan_read(stm32_host_periph_t *p, uint32_t off)
{
    bxcan_model_t *m = (bxcan_model_t *)p;
    switch (off) {
    case MSR: return (m->init ? INAK : 0u) | (m->sleep ? SLAK : 0u) | (m->erri ? ERRI : 0u);
    case TSR: return tsr(m);
    case RF0R: return m->fifo_n | (m->full ? FULL0 : 0u) | (m->fovr ? FOVR0 : 0u);
    case ESR: return esr(m) | (R(m, ESR) & 0x70u); /* LEC as written */
    default: break;
    }
    if (off >= RX0 && off < RX0 + 16u) {
        if (m->fifo_n == 0u) {
            return 0u; /* an empty FIFO's mailbox: undefined, read as 0 here */
        }
        const bxcan_model_frame_t *f = &m->fifo[0];
        switch (off - RX0) {
        case 0: return mailbox_ir(f);
        case 4: return f->dlc | ((uint32_t)m->fifo_fmi[0] << 8);
        case 8: return bytes(f->data);
        default: return bytes(f->data + 4);
        }
    }
    return p->reg[off / 4u];
}

/* The controller reacts to its mode request (RM0090 §32.4). */
static void mode(bxcan_model_t *m)
{
    const uint32_t mcr = R(m, MCR);
    if ((mcr & INRQ) != 0u) {
        if (m->ack_init) {
            m->init = true;
            m->sleep = false;
        }
    } else if ((mcr & SLEEP) != 0u) {
        if (m->ack_init) {
            m->init = false;
            m->sleep = true;
        }
    } else if (m->bus_idle) {
        m->init = false; /* normal mode, after 11 recessive bits */
        m->sleep = false;
    }
}

static bool bank_writable(const bxcan_model_t *m, unsigned bank)
{
    return (R(m, FMR) & 1u) != 0u || (R(m, FA1R) & (1u << bank)) == 0u;
}

static void bxcan_write(stm32_host_periph_t *p, uint32_t off, uint32_t v)
{
    bxcan_model_t *m = (bxcan_model_t *)p;
    if (off == TSR) {
        /* RQCPx written 1 clears the mailbox's flags (rc_w1). */
        for (unsigned i = 0; i < 3u; i++) {
            if ((v & RQCP(i)) != 0u) {
                m->tsr_flags &= ~(RQCP(i) | TXOK(i));
            }
        }
    } else if (off == RF0R) {
        if ((v & RFOM0) != 0u && m->fifo_n > 0u) {
            memmove(&m->fifo[0], &m->fifo[1], 2u * sizeof m->fifo[0]);
            memmove(&m->fifo_fmi[0], &m->fifo_fmi[1], 2u);
            m->fifo_n--;
        }
        /* FULL0 and FOVR0 stay until written 1 (rc_w1). */
        if ((v & FULL0) != 0u) {
            m->full = false;
        }
        if ((v & FOVR0) != 0u) {
            m->fovr = false;
        }
    } else if (off == MSR) {
        if ((v & ERRI) != 0u) {
            m->erri = false; /* rc_w1 */
        }
    } else if (off >= TX0 && off < TX0 + 48u) {
        const unsigned box = (off - TX0) / 16u;
        if (!m->tx_pending[box]) {
            p->reg[off / 4u] = (off - TX0) % 16u == 0u ? v & ~TXRQ : v;
            if ((off - TX0) % 16u == 0u && (v & TXRQ) != 0u) {
                m->tx_pending[box] = true;
                m->tx_order[box] = m->tx_seq++;
            }
        }
    } else if (off >= FB0 && off < END) {
        if (bank_writable(m, (off - FB0) / 8u)) {
            p->reg[off / 4u] = v;
        }
    } else if (off == ESR) {
        p->reg[off / 4u] = v & 0x70u; /* only LEC is writable */
    } else {
        p->reg[off / 4u] = v;
        if (off == MCR) {
            mode(m);
        }
    }
    levels(m);
}

/* Filter bank @p bank takes the standard or extended frame @p f (RM0090
 * §32.7.4): 16-bit scale compares STID, RTR, IDE and EXID[17:15]; 32-bit
 * the whole identifier. */
static bool bank_takes(const bxcan_model_t *m, unsigned bank, const bxcan_model_frame_t *f)
{
    const uint32_t fr1 = R(m, FB0 + 8u * bank);
    const uint32_t fr2 = R(m, FB0 + 8u * bank + 4u);
    const bool list = (R(m, FM1R) & (1u << bank)) != 0u;
    if ((R(m, FS1R) & (1u << bank)) != 0u) {
        const uint32_t v = mailbox_ir(f) & ~TXRQ;
        return list ? (v == fr1 || v == fr2) : ((v & fr2) == (fr1 & fr2));
    }
    const uint32_t stid = f->ide ? f->id >> 18 : f->id;
    const uint32_t exid_hi = f->ide ? (f->id >> 15) & 0x7u : 0u;
    const uint32_t v = (stid << 5) | (f->rtr ? 0x10u : 0u) | (f->ide ? 0x8u : 0u) | exid_hi;
    const uint32_t h[4] = { fr1 & 0xFFFFu, fr1 >> 16, fr2 & 0xFFFFu, fr2 >> 16 };
    if (list) {
        return v == h[0] || v == h[1] || v == h[2] || v == h[3];
    }
    return (v & h[1]) == (h[0] & h[1]) || (v & h[3]) == (h[2] & h[3]);
}

bool bxcan_model_receive(bxcan_model_t *m, const bxcan_model_frame_t *f)
{
    if (m->init || m->sleep || (R(m, FMR) & 1u) != 0u) {
        return false; /* not on the bus, or the filters being set up */
    }
    const unsigned banks = (R(m, FMR) >> 8) & 0x3Fu; /* CAN2SB: CAN1's banks */
    for (unsigned b = 0; b < banks && b < 28u; b++) {
        const bool fifo0 = (R(m, FFA1R) & (1u << b)) == 0u;
        if ((R(m, FA1R) & (1u << b)) == 0u || !fifo0 || !bank_takes(m, b, f)) {
            continue;
        }
        if (m->fifo_n < 3u) {
            m->fifo[m->fifo_n] = *f;
            m->fifo_fmi[m->fifo_n] = (uint8_t)b;
            m->fifo_n++;
        } else {
            m->fovr = true;
            m->lost++;
            if ((R(m, MCR) & RFLM) == 0u) {
                m->fifo[2] = *f; /* not locked: the newest is overwritten */
                m->fifo_fmi[2] = (uint8_t)b;
            }
        }
        m->full = m->full || m->fifo_n == 3u;
        levels(m);
        stm32_host_take_interrupts();
        return true;
    }
    m->refused++;
    return false;
}

static bxcan_model_frame_t mailbox_frame(const bxcan_model_t *m, unsigned box)
{
    const uint32_t ir = R(m, TX0 + 16u * box);
    const uint32_t dtr = R(m, TX0 + 16u * box + 4u);
    const uint32_t lo = R(m, TX0 + 16u * box + 8u);
    const uint32_t hi = R(m, TX0 + 16u * box + 12u);
    bxcan_model_frame_t f = {
        .ide = (ir & IDE) != 0u,
        .rtr = (ir & RTR) != 0u,
        .dlc = (uint8_t)(dtr & 0xFu),
    };
    f.id = f.ide ? ir >> 3 : ir >> 21;
    for (unsigned i = 0; i < 4u; i++) {
        f.data[i] = (uint8_t)(lo >> (8u * i));
        f.data[4u + i] = (uint8_t)(hi >> (8u * i));
    }
    return f;
}

unsigned bxcan_model_transmit(bxcan_model_t *m, unsigned n)
{
    unsigned sent = 0;
    while (sent < n && !m->init && !m->sleep && !m->boff) {
        /* The next mailbox: the oldest request with TXFP, else the highest
         * priority identifier (the lowest), then the lowest mailbox. */
        unsigned next = 3u;
        for (unsigned i = 0; i < 3u; i++) {
            if (!m->tx_pending[i]) {
                continue;
            }
            if (next == 3u) {
                next = i;
            } else if ((R(m, MCR) & TXFP) != 0u) {
                next = m->tx_order[i] < m->tx_order[next] ? i : next;
            } else {
                next = (R(m, TX0 + 16u * i) >> 3) < (R(m, TX0 + 16u * next) >> 3) ? i : next;
            }
        }
        if (next == 3u) {
            break;
        }
        if (m->n_sent < BXCAN_MODEL_LOG) {
            m->sent[m->n_sent] = mailbox_frame(m, next);
        }
        m->n_sent++;
        m->tx_pending[next] = false;
        m->tsr_flags |= RQCP(next) | TXOK(next);
        sent++;
        levels(m);
        stm32_host_take_interrupts(); /* the core refills while the bus sends */
    }
    return sent;
}

void bxcan_model_errors(bxcan_model_t *m, unsigned tec, unsigned rec)
{
    const uint32_t before = esr(m);
    if (tec > 255u && !m->boff) {
        m->boff = true;
        m->boff_since = stm32_host_cycles();
        m->bus_off_entries++;
        tec = 255u;
    }
    m->tec = (uint8_t)(tec > 255u ? 255u : tec);
    m->rec = (uint8_t)(rec > 255u ? 255u : rec);
    const uint32_t raised = esr(m) & ~before;
    const uint32_t ier = R(m, IER);
    if (((raised & EWGF) != 0u && (ier & EWGIE) != 0u) ||
        ((raised & EPVF) != 0u && (ier & EPVIE) != 0u) ||
        ((raised & BOFF) != 0u && (ier & BOFIE) != 0u)) {
        m->erri = true;
    }
    levels(m);
    stm32_host_take_interrupts();
}

/* ABOM: a bus-off controller rejoins after 128 × 11 recessive bits; one
 * waiting to leave initialisation joins once the bus is idle. */
static void tick(void *ctx, uint64_t now)
{
    bxcan_model_t *m = ctx;
    if (m->init && (R(m, MCR) & (INRQ | SLEEP)) == 0u && m->bus_idle) {
        m->init = false;
    }
    if (!m->boff || (R(m, MCR) & ABOM) == 0u || m->bitrate == 0u) {
        return;
    }
    const uint64_t need = (uint64_t)128u * 11u * stm32_host_clock() / m->bitrate;
    if (now - m->boff_since >= need) {
        m->boff = false;
        m->tec = 0u;
        m->rec = 0u;
    }
}

void bxcan_model_init(bxcan_model_t *m, uint32_t base, int irq_tx, int irq_rx0, int irq_sce)
{
    *m = (bxcan_model_t){
        .p = { .base = base, .size = END, .name = "CAN", .read = bxcan_read, .write = bxcan_write },
        .irq_tx = irq_tx,
        .irq_rx0 = irq_rx0,
        .irq_sce = irq_sce,
        .ack_init = true,
        .bus_idle = true,
        .bitrate = 500000u,
        .sleep = true,
    };
    R(m, MCR) = 0x00010002u; /* reset: SLEEP, DBF (RM0090 §32.9.2) */
    R(m, FMR) = 0x2A1C0E01u; /* FINIT, CAN2SB 14 */
    stm32_host_map(&m->p);
    stm32_host_on_time(tick, m);
    stm32_host_on_level(level, m);
}
