/* SPDX-License-Identifier: MIT */
/* can-bridge: the emulated side of the vcan VM's bridge (tools/vm/with-vcan
 * --bridge, docs/hil.md "The bridge"). It joins a SocketCAN interface (vcan0)
 * and a byte stream to the host (a virtio-serial port, which QEMU connects to
 * a TCP socket) and speaks slcan on the stream, as a USB-CAN adapter does on
 * its serial line: the host reaches vcan0 with python-can's own slcan
 * interface. Each frame goes through once, in order, both ways; what cannot
 * go through is counted, never lost silently.
 *
 * Why a program of its own (docs/hil.md measures the alternatives): the
 * kernel's slcan line discipline needs a tty, and the guest's only fast tty,
 * the virtio console (hvc), waits with interrupts off until QEMU has taken
 * every write: under software emulation about 7 ms of each 20 ms period.
 * A virtio-serial port written from user space does not wait, and a batch of
 * frames costs one write.
 *
 * Batching: the firmware sends its frames of a step in a burst. Under
 * SCHED_BATCH this process does not preempt it on wake-up, so in a VM with
 * one vCPU it runs once the burst is done and takes every frame of the step
 * in one pass: one write to the port per step. From the host, every byte
 * that arrived is read at once and its frames written to vcan0.
 *
 * Commands (hal/stm32/slcan_codec.h): 'O' opens the channel, 'C' closes it;
 * only standard data frames ("tiiildd..") pass to vcan0, and vcan0's frames
 * go to the host only while the channel is open (as an adapter's would).
 * Frames are not acknowledged with 'z' (python-can needs no acknowledgement;
 * it would only be one more line per frame for the host to read).
 *
 * Once running it says so in one line on stdout; then SIGUSR1 prints the
 * counters on stdout, one line of "name value" pairs; SIGTERM and SIGINT end
 * the program (after printing them). */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "hal/hal_can.h"
#include "hal_can_linux.h"
#include "slcan_codec.h"

/* Frames to the host waiting for room in the port: far more than a control
 * step sends (about ten frames); beyond it they are counted as dropped. */
#define OUT_MAX         (64u * SLCAN_FRAME_LINE_MAX)
#define IN_CHUNK        4096u
/* While no host is connected the port reports a hang-up at once: look again
 * this often [ms] rather than spin. */
#define NO_HOST_POLL_MS 50

static volatile sig_atomic_t stop;
static volatile sig_atomic_t report;

static void on_signal(int sig)
{
    if (sig == SIGUSR1) {
        report = 1;
    } else {
        stop = 1;
    }
}

/* Everything counted since the start. */
static struct {
    uint64_t to_vcan;       /* host frames written to vcan0 */
    uint64_t to_host;       /* vcan0 frames written to the port (or queued for it) */
    uint64_t vcan_failed;   /* host frames vcan0 refused (hal_can_send) */
    uint64_t host_rejected; /* host lines that carried no standard data frame
                             * for the bus: malformed (BEL), extended or
                             * remote frames, frames while the channel was
                             * closed */
    uint64_t host_dropped;  /* vcan0 frames for the host that found no room */
    uint64_t closed;        /* vcan0 frames while the channel was closed or no
                             * host was connected (not sent, as an adapter's) */
    uint64_t port_writes;   /* write() calls to the port */
    uint64_t port_reads;    /* read() calls that returned bytes */
} n;

static void print_counters(void)
{
    printf("to_vcan %" PRIu64 " to_host %" PRIu64 " vcan_failed %" PRIu64 " host_rejected %" PRIu64
           " host_dropped %" PRIu64 " closed %" PRIu64 " port_writes %" PRIu64
           " port_reads %" PRIu64 "\n",
           n.to_vcan, n.to_host, n.vcan_failed, n.host_rejected, n.host_dropped, n.closed,
           n.port_writes, n.port_reads);
    fflush(stdout);
}

static char out[OUT_MAX];
static size_t out_len;

/* Frame lines ('t' at a line's start) in @p b. */
static uint64_t frame_lines(const char *b, size_t len)
{
    uint64_t k = 0;
    for (size_t i = 0; i < len; i++) {
        k += b[i] == 't' && (i == 0u || b[i - 1u] == SLCAN_CR);
    }
    return k;
}

/* Write what waits for the port; keep the rest for POLLOUT. */
static void flush_out(int port)
{
    while (out_len > 0u) {
        const ssize_t w = write(port, out, out_len);
        if (w < 0) {
            if (errno == EINTR) {
                continue;
            }
            if (errno != EAGAIN) { /* the host went away: nobody to send to */
                const uint64_t k = frame_lines(out, out_len);
                n.to_host -= k;
                n.host_dropped += k;
                out_len = 0u;
            }
            return;
        }
        n.port_writes++;
        memmove(out, out + w, out_len - (size_t)w);
        out_len -= (size_t)w;
    }
}

/* Bytes from the host: each complete command in turn. */
static void from_host(slcan_t *s, int port, const uint8_t *buf, size_t len)
{
    for (size_t i = 0; i < len; i++) {
        slcan_result_t r;
        if (!slcan_rx_byte(s, buf[i], &r)) {
            continue;
        }
        if (r.has_frame) {
            if (hal_can_send(&r.frame) == 0) {
                n.to_vcan++;
            } else {
                n.vcan_failed++;
            }
        } else if (r.reply_len > 0u && r.reply[0] != 'z' && r.reply[0] != 'Z') {
            /* Replies to O, C, S, V, N, and BEL for what could not be done. */
            if (r.reply[0] == SLCAN_BEL) {
                n.host_rejected++;
            }
            if (out_len + r.reply_len <= OUT_MAX) {
                memcpy(out + out_len, r.reply, r.reply_len);
                out_len += r.reply_len;
            }
        } else if (r.reply_len > 0u) {
            n.host_rejected++; /* an extended or remote frame: not for this bus */
        }
    }
    flush_out(port);
}

/* Every frame vcan0 has queued, as lines for the host. */
static void from_vcan(const slcan_t *s, int port, bool host)
{
    hal_can_frame_t f;
    while (hal_can_recv(&f, 0u) == 0) {
        if (!host || !s->open) {
            n.closed++;
            continue;
        }
        if (out_len + SLCAN_FRAME_LINE_MAX > OUT_MAX) {
            n.host_dropped++;
            continue;
        }
        out_len += slcan_format_frame(&f, out + out_len);
        n.to_host++;
    }
    flush_out(port);
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: can-bridge PORT IFACE   (e.g. /dev/vport1p1 vcan0)\n");
        return 2;
    }
    const int port = open(argv[1], O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (port < 0) {
        fprintf(stderr, "can-bridge: cannot open %s: %s\n", argv[1], strerror(errno));
        return 1;
    }
    const int rc = hal_can_open(argv[2]);
    if (rc != 0) {
        fprintf(stderr, "can-bridge: cannot open %s: %s\n", argv[2], strerror(-rc));
        return 1;
    }
    const struct sched_param batch = { .sched_priority = 0 };
    if (sched_setscheduler(0, SCHED_BATCH, &batch) != 0) {
        fprintf(stderr, "can-bridge: SCHED_BATCH: %s (frames go out one wake-up at a time)\n",
                strerror(errno));
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal; /* no SA_RESTART: poll() returns EINTR */
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGUSR1, &sa, NULL);
    /* One line on stdout once the signals are handled: the agent waits for it. */
    printf("can-bridge: %s <-> %s (slcan)\n", argv[2], argv[1]);
    fflush(stdout);

    slcan_t s;
    slcan_init(&s, 6u);
    bool host = true;
    static uint8_t in[IN_CHUNK];
    while (!stop) {
        if (report) {
            report = 0;
            print_counters();
        }
        struct pollfd p[2] = {
            { .fd = hal_can_linux_fd(), .events = POLLIN },
            { .fd = port, .events = (short)(POLLIN | (out_len > 0u ? POLLOUT : 0)) },
        };
        /* Without a host the port hangs up at once: look again later. */
        const int r = poll(p, host ? 2u : 1u, host ? -1 : NO_HOST_POLL_MS);
        if (r < 0) {
            continue; /* EINTR: a signal */
        }
        if (!host || (p[1].revents & POLLHUP) != 0) {
            struct pollfd q = { .fd = port, .events = POLLIN };
            host = poll(&q, 1u, 0) >= 0 && (q.revents & POLLHUP) == 0;
            if (!host) {
                slcan_init(&s, s.bitrate); /* a new host opens the channel anew */
                out_len = 0u;
            }
        }
        if (host && (p[1].revents & POLLIN) != 0) {
            const ssize_t got = read(port, in, sizeof in);
            if (got > 0) {
                n.port_reads++;
                from_host(&s, port, in, (size_t)got);
            }
        }
        if (host && (p[1].revents & POLLOUT) != 0) {
            flush_out(port);
        }
        if ((p[0].revents & POLLIN) != 0) {
            from_vcan(&s, port, host);
        }
    }
    print_counters();
    hal_can_close();
    close(port);
    return 0;
}
