/* SPDX-License-Identifier: MIT */
/* HAL CAN on the STM32 ports over a serial line (CAN=slcan): the board speaks
 * slcan, the Lawicel ASCII protocol of USB-CAN adapters, on a UART
 * (board_config.h: BOARD_SLCAN_UART, USART2 at 0x40004400 on the F1, F2 and
 * F4), so that a host reaches the firmware through python-can's "slcan"
 * interface, or slcand, as if through an adapter on its bus. The same image
 * runs on a board wired to a USB-serial adapter and under QEMU, whose STM32
 * machines emulate the USART but no bxCAN (docs/hil.md).
 *
 * Structure as bxcan.c: one interrupt does all the UART work, and lock-free
 * queues of frames (can_ring.h) connect it with the task. The interrupt
 * takes each received byte through the line codec (slcan_codec.c); a
 * complete command yields a frame, which passes the acceptance filters in
 * software (bxCAN's are hardware) into the receive queue, and a reply
 * (z, CR, BEL, ...) for the host. hal_can_send() queues the frame and pends
 * the interrupt, which formats one frame line at a time into a small byte
 * queue of its own and feeds the transmitter while it has room (TXE). Replies
 * go into the same byte queue, between whole lines.
 *
 * The channel follows the host's O and C commands and starts closed: frames
 * are exchanged only while it is open (an adapter forwards nothing before
 * O). Meanwhile hal_can_send() refuses frames with -ENETDOWN and
 * hal_can_status() reports STOPPED. */
#include <errno.h>
#include <stddef.h>

#include "board.h"
#include "can_queue.h"
#include "can_ring.h"
#include "cortex_m.h"
#include "hal/hal_can.h"
#include "slcan_codec.h"
#include "stm32_calc.h"
#include "stm32_hal.h"

/* As bxCAN's receive interrupt: a byte must be read before the next one
 * ends (22 µs at 460800 baud), or it is lost (overrun). */
#define PRIO_UART 1u

#define MAX_FILTERS 16u

/* Bytes waiting for the transmitter: one frame line and the replies that
 * come in meanwhile. A power of two. */
#define OUT_SIZE 64u
_Static_assert((OUT_SIZE & (OUT_SIZE - 1u)) == 0u, "OUT_SIZE: power of two");
_Static_assert(OUT_SIZE >= SLCAN_FRAME_LINE_MAX + 2u * SLCAN_REPLY_MAX, "a line and replies");

/* Receive errors in USART_SR (RM0090 §30.6.1 [RM0008 §27.6.1]): overrun,
 * noise (bit 2: NF in the F4's SVD, NE in the F1's), framing, parity. */
#define SR_RX_ERRORS (USART_SR_ORE_Msk | (1u << 2) | USART_SR_FE_Msk | USART_SR_PE_Msk)
/* 8N1, transmitter and receiver on, receive interrupt; TXEIE is the
 * interrupt's own to switch. */
#define CR1_ON       (USART_CR1_UE_Msk | USART_CR1_TE_Msk | USART_CR1_RE_Msk | USART_CR1_RXNEIE_Msk)

#define UART BOARD_SLCAN_UART

static can_ring_t rx_ring;         /* ISR -> task */
static can_ring_t tx_ring;         /* task -> ISR */
static slcan_t line;               /* ISR only, once open */
static volatile bool channel_open; /* written by the ISR: the host's O / C */
static volatile bool opened;
static hal_can_filter_t filters[MAX_FILTERS]; /* written with the interrupt off */
static unsigned n_filters;

/* The transmitter's byte queue: ISR only. */
static char out[OUT_SIZE];
static uint32_t out_head;
static uint32_t out_tail;

/* Counters, for hal_can_status() and a debugger. */
static volatile uint32_t rx_errors;      /* bytes lost or garbled on the line */
static volatile uint32_t tx_refused;     /* hal_can_send(): queue full */
static volatile uint32_t tx_closed;      /* queued, then the channel closed: discarded */
static volatile uint32_t replies_lost;   /* no room for a reply (a host not reading) */
static volatile uint32_t lines_rejected; /* commands answered with BEL */

static bool out_put(const char *bytes, size_t n)
{
    if (OUT_SIZE - (out_head - out_tail) < n) {
        return false;
    }
    for (size_t i = 0; i < n; i++) {
        out[out_head & (OUT_SIZE - 1u)] = bytes[i];
        out_head++;
    }
    return true;
}

/* The next frame line into the empty byte queue. */
static bool refill(void)
{
    hal_can_frame_t f;
    while (can_ring_pop(&tx_ring, &f)) {
        if (channel_open) {
            char text[SLCAN_FRAME_LINE_MAX];
            return out_put(text, slcan_format_frame(&f, text));
        }
        tx_closed = tx_closed + 1u;
    }
    return false;
}

/* Feed the transmitter while it takes bytes. On a board TXE clears after a
 * byte or two and its interrupt (TXEIE) brings us back; QEMU's USART takes
 * every byte at once. */
static void tx_pump(void)
{
    while ((UART->SR & USART_SR_TXE_Msk) != 0u) {
        if (out_head == out_tail && !refill()) {
            UART->CR1 = CR1_ON; /* nothing left: no TXE interrupt */
            return;
        }
        UART->DR = (uint8_t)out[out_tail & (OUT_SIZE - 1u)];
        out_tail++;
    }
    UART->CR1 = CR1_ON | USART_CR1_TXEIE_Msk;
}

static void on_command(const slcan_result_t *r)
{
    if (r->has_frame && slcan_accepts(filters, n_filters, r->frame.id)) {
        (void)can_ring_push(&rx_ring, &r->frame); /* a full queue counts the drop */
    }
    if (r->reply_len > 0u) {
        if (r->reply[0] == SLCAN_BEL) {
            lines_rejected = lines_rejected + 1u;
        }
        if (!out_put(r->reply, r->reply_len)) {
            replies_lost = replies_lost + 1u;
        }
    }
    channel_open = line.open;
}

void BOARD_SLCAN_IRQHandler(void)
{
    /* Reading SR then DR clears RXNE and the error flags. */
    uint32_t sr = UART->SR;
    while ((sr & USART_SR_RXNE_Msk) != 0u) {
        const uint8_t byte = (uint8_t)UART->DR;
        if ((sr & SR_RX_ERRORS) != 0u) {
            rx_errors = rx_errors + 1u;
            slcan_rx_error(&line);
        }
        slcan_result_t r;
        if (slcan_rx_byte(&line, byte, &r)) {
            on_command(&r);
        }
        sr = UART->SR;
    }
    tx_pump();
}

int hal_can_open(const char *iface)
{
    (void)iface; /* one serial line per board */
    cm_nvic_disable(BOARD_SLCAN_IRQn);
    opened = false;
    channel_open = false;
    can_ring_init(&rx_ring);
    can_ring_init(&tx_ring);
    const int code = slcan_bitrate_code(BOARD_CAN_BITRATE);
    slcan_init(&line, code >= 0 ? (uint8_t)code : 0u);
    out_head = 0u;
    out_tail = 0u;
    n_filters = 0u;
    board_slcan_enable();

    uint16_t brr;
    int32_t err_ppm;
    if (stm32_usart_brr(board_clocks()->apb1_hz, BOARD_SLCAN_BAUD, &brr, &err_ppm) != 0) {
        return -EINVAL;
    }
    UART->CR1 = 0u;
    UART->CR2 = 0u; /* 1 stop bit */
    UART->CR3 = 0u; /* no flow control */
    UART->BRR = brr;
    UART->CR1 = CR1_ON;
    cm_nvic_set_priority(BOARD_SLCAN_IRQn, PRIO_UART);
    opened = true;
    cm_nvic_enable(BOARD_SLCAN_IRQn);
    return 0;
}

int hal_can_set_filters(const hal_can_filter_t *f, unsigned n)
{
    if (n > MAX_FILTERS || (f == NULL && n != 0u)) {
        return -EINVAL;
    }
    /* The interrupt reads the table: off while it changes. */
    cm_nvic_disable(BOARD_SLCAN_IRQn);
    for (unsigned i = 0; i < n; i++) {
        filters[i] = f[i];
    }
    n_filters = n;
    if (opened) {
        cm_nvic_enable(BOARD_SLCAN_IRQn);
    }
    return 0;
}

int hal_can_send(const hal_can_frame_t *frame)
{
    /* -ENETDOWN: the host has not opened the channel. */
    const int down = !opened ? -ENODEV : (!channel_open ? -ENETDOWN : 0);
    return can_queue_send(&tx_ring, BOARD_SLCAN_IRQn, frame, down, &tx_refused);
}

int hal_can_recv(hal_can_frame_t *frame, uint32_t timeout_us)
{
    return can_queue_recv(&rx_ring, frame, timeout_us, NULL);
}

void hal_can_close(void)
{
    cm_nvic_disable(BOARD_SLCAN_IRQn);
    UART->CR1 = 0u;
    opened = false;
    channel_open = false;
}

int hal_can_status(hal_can_status_t *st)
{
    if (st == NULL) {
        return -EINVAL;
    }
    /* A serial line has no error counters and no bus-off: active while the
     * host has the channel open, stopped otherwise. */
    *st = (hal_can_status_t){
        .state = opened && channel_open ? HAL_CAN_STATE_ERROR_ACTIVE : HAL_CAN_STATE_STOPPED,
        .rx_dropped = rx_ring.dropped + rx_errors,
        .tx_dropped = tx_refused,
    };
    return 0;
}

bool stm32_can_rx_pending(void) { return can_ring_count(&rx_ring) != 0u; }

uint32_t stm32_can_bitrate(void) { return opened ? slcan_bitrate(line.bitrate) : 0u; }
