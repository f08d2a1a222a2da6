/* SPDX-License-Identifier: MIT */
/* mstc-fw: the firmware as a Linux process on a SocketCAN interface. */
#include <ctype.h>
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "app/app.h"
#include "ctrl/cbf.h"
#include "hal/hal_can.h"
#include "hal/hal_sys.h"
#include "hal/hal_time.h"

static volatile sig_atomic_t stop;
static app_t app; /* static: no heap, as on a board */

static void on_signal(int sig)
{
    (void)sig;
    stop = 1;
}

/* Real-time mode, as a board's main loop runs (hal/stm32/main.c): when a
 * control period has elapsed, every frame queued since the last step goes in
 * first, then one control step runs, stamped with the end of that period on
 * the nominal grid (k * period since start), so steps stay evenly spaced
 * whatever the scheduling delay. Periods missed while the process did not run
 * (an overloaded host, a VM) are skipped and counted, not made up in a burst:
 * a burst of steps on the same inputs would time them out and halt the robot
 * for nothing.
 *
 * Unlike the board, which wakes for each frame, the process sleeps until the
 * tick and then takes what the socket queued (its receive buffer is the
 * board's receive ring): each step sees the same frames either way, since in
 * real-time mode the application acts on inputs only at its step, and only
 * PARAM_SET/GET answers wait for the tick. A process woken by every frame
 * costs the sender a wake-up per frame: in the software-emulated vcan VM that
 * alone took the plant from about 11 to about 25 ms of CPU per 20 ms sample
 * (docs/hil.md).
 *
 * A tick that comes late means the process was held (an overloaded host, a
 * stalled VM), and what was sent to it meanwhile may still be on its way in:
 * in the vcan VM the guest's can-bridge was held too, and runs after the
 * overdue tick as often as before it. A tick half a period late or more is
 * skipped (never two in a row: a process always woken that late still steps):
 * the next one, on the grid, steps, and the frames come in while the process
 * sleeps until it. A tick later than RT_LATE_US, but by less, first waits up
 * to RT_LATE_WAIT_US for a frame, as a board's receive interrupt would have
 * taken it on time. */
#define RT_LATE_US      2000u
#define RT_LATE_WAIT_US 2000u

static uint64_t run_realtime(uint64_t period_us)
{
    uint64_t overruns = 0;
    uint64_t next = hal_time_now_us() + period_us;
    bool skipped = false; /* the last tick */
    while (!stop) {
        const uint64_t now = hal_time_now_us();
        if (now < next) {
            hal_time_sleep_until_us(next);
            continue;
        }
        const uint64_t late = (now - next) / period_us; /* whole periods missed */
        const uint64_t t = next + late * period_us;     /* the grid's tick just passed */
        next = t + period_us;
        if (now - t >= period_us / 2u && !skipped) {
            overruns += late + 1u; /* this tick too: the next one steps */
            skipped = true;
            continue;
        }
        skipped = false;
        overruns += late;
        if (now - t >= RT_LATE_US) {
            (void)app_poll(&app, RT_LATE_WAIT_US);
        }
        (void)app_poll(&app, 0u);
        app_control_tick(&app, t);
    }
    return overruns;
}

static void usage(FILE *out)
{
    fprintf(out, "usage: mstc-fw --can IFACE [--key-file PATH] [--node N] [--realtime]\n"
                 "               [--period-ms MS]\n"
                 "\n"
                 "Run the mstc firmware on a SocketCAN interface (e.g. vcan0) until\n"
                 "SIGINT or SIGTERM. The protocol is firmware/comm/mstc.dbc.\n"
                 "\n"
                 "  --can IFACE     SocketCAN interface to use (required)\n"
                 "  --realtime      step on this process's own timer every --period-ms,\n"
                 "                  with the latest inputs, as on a board (periods the\n"
                 "                  process could not keep are skipped and counted);\n"
                 "                  without it the firmware runs lock-step: one control\n"
                 "                  step per STEP frame, stamped with the frame's time\n"
                 "  --period-ms MS  control period in real-time mode, 1..50 (default 20):\n"
                 "                  the safety filter's guarantee needs alpha dt <= 1\n"
                 "  --key-file PATH the device key of authenticated commands: 32 hex\n"
                 "                  digits, # comments (default: $MSTC_KEY as hex digits,\n"
                 "                  else the file $MSTC_KEY_FILE; without a key every\n"
                 "                  PARAM_SET is refused; docs/safety.md)\n"
                 "  --node N        node id 0..6: the identifiers are mstc.dbc's plus\n"
                 "                  0x100 times N, so that boards share a bus (default:\n"
                 "                  the build's, NODE= of make, 0)\n"
                 "  --help          this text\n");
}

/* The key in @p text: 32 hex digits, lines starting with '#' skipped
 * (tools/setup/device-key writes such files). */
static int parse_key(const char *text, uint8_t key[AUTH_KEY_LEN])
{
    size_t n = 0;
    bool line_start = true;
    bool comment = false;
    for (const char *p = text; *p != '\0'; p++) {
        const unsigned char ch = (unsigned char)*p;
        if (ch == '\n') {
            line_start = true;
            comment = false;
            continue;
        }
        if (line_start && ch == '#') {
            comment = true;
        }
        if (!isspace(ch)) {
            line_start = false;
        }
        if (comment || isspace(ch)) {
            continue;
        }
        if (!isxdigit(ch) || n >= 2u * AUTH_KEY_LEN) {
            return -EINVAL;
        }
        const unsigned v = isdigit(ch) ? (unsigned)(ch - '0') : (unsigned)(tolower(ch) - 'a' + 10);
        key[n / 2u] = (uint8_t)((n % 2u == 0u) ? v << 4 : (key[n / 2u] | v));
        n++;
    }
    return n == 2u * AUTH_KEY_LEN ? 0 : -EINVAL;
}

/* The key from --key-file, else $MSTC_KEY, else $MSTC_KEY_FILE. Returns 1
 * when there is none, 0 when @p key holds it, -1 after printing why not. */
static int load_key(const char *file, uint8_t key[AUTH_KEY_LEN], const char **source)
{
    const char *hex = getenv("MSTC_KEY");
    if (file == NULL && hex != NULL && hex[0] != '\0') {
        *source = "$MSTC_KEY";
        if (parse_key(hex, key) != 0) {
            fprintf(stderr, "mstc-fw: $MSTC_KEY: expected 32 hex digits (an AES-128 key)\n");
            return -1;
        }
        return 0;
    }
    if (file == NULL) {
        file = getenv("MSTC_KEY_FILE");
    }
    if (file == NULL || file[0] == '\0') {
        return 1;
    }
    *source = file;
    char text[4096];
    FILE *fp = fopen(file, "r");
    if (fp == NULL) {
        fprintf(stderr, "mstc-fw: cannot read key file '%s': %s\n", file, strerror(errno));
        return -1;
    }
    const size_t got = fread(text, 1, sizeof text - 1u, fp);
    const bool longer = fgetc(fp) != EOF;
    fclose(fp);
    text[got] = '\0';
    if (longer || parse_key(text, key) != 0) {
        fprintf(stderr, "mstc-fw: key file '%s': expected 32 hex digits (an AES-128 key)\n", file);
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    const char *iface = NULL;
    const char *key_file = NULL;
    int realtime = 0;
    long period_ms = 20;
    long node = -1; /* the build's (APP_NODE) */
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(argv[i], "--can") == 0 && i + 1 < argc) {
            iface = argv[++i];
        } else if (strcmp(argv[i], "--key-file") == 0 && i + 1 < argc) {
            key_file = argv[++i];
        } else if (strcmp(argv[i], "--realtime") == 0) {
            realtime = 1;
        } else if (strcmp(argv[i], "--period-ms") == 0 && i + 1 < argc) {
            char *end = NULL;
            period_ms = strtol(argv[++i], &end, 10);
            if (end == NULL || *end != '\0' || period_ms < 1 ||
                period_ms > (long)CBF_MAX_PERIOD_MS) {
                fprintf(stderr,
                        "mstc-fw: --period-ms: expected an integer in 1..%u, got '%s' (the safety "
                        "filter's guarantee needs alpha dt <= 1, alpha = %g/s: docs/strategy.md)\n",
                        CBF_MAX_PERIOD_MS, argv[i], CBF_ALPHA_PER_S);
                return 2;
            }
        } else if (strcmp(argv[i], "--node") == 0 && i + 1 < argc) {
            char *end = NULL;
            node = strtol(argv[++i], &end, 10);
            if (end == NULL || *end != '\0' || node < 0 || node > (long)COMM_MAX_NODE) {
                fprintf(stderr, "mstc-fw: --node: expected an integer in 0..%u, got '%s'\n",
                        COMM_MAX_NODE, argv[i]);
                return 2;
            }
        } else {
            fprintf(stderr, "mstc-fw: unknown or incomplete option '%s' (see --help)\n", argv[i]);
            return 2;
        }
    }
    if (iface == NULL) {
        fprintf(stderr, "mstc-fw: --can IFACE is required (see --help)\n");
        return 2;
    }
    uint8_t key[AUTH_KEY_LEN];
    const char *key_source = NULL;
    const int key_rc = load_key(key_file, key, &key_source);
    if (key_rc < 0) {
        return 2;
    }
    const int rc = hal_can_open(iface);
    if (rc != 0) {
        fprintf(stderr, "mstc-fw: cannot open CAN interface '%s': %s%s\n", iface, strerror(-rc),
                rc == -EAFNOSUPPORT ? " (this kernel has no SocketCAN; see docs/hil.md)" : "");
        return 1;
    }
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    app_init(&app, NULL);
    if (node >= 0) {
        (void)app_set_node(&app, (uint8_t)node); /* in range: checked above */
    }
    if (key_rc == 0) {
        /* A session of its own for every start (docs/safety.md, "Sessions"). */
        uint32_t session;
        if (hal_sys_boot_nonce(&session) != 0) {
            fprintf(stderr, "mstc-fw: the kernel gave no random value for the session\n");
            return 1;
        }
        app_set_key(&app, key, session);
        memset(key, 0, sizeof key);
    }
    /* One line: tools wait for it to know the firmware is on the bus. */
    char period[32] = "";
    if (realtime) {
        (void)snprintf(period, sizeof period, ", period %ld ms", period_ms);
    }
    fprintf(stderr, "mstc-fw: %s mode on %s (%s)%s, node %u, %s%s\n",
            realtime ? "real-time" : "lock-step", iface, NUM_MODE_NAME, period,
            (unsigned)app.comm.node,
            key_rc == 0 ? "key from " : "no key: every PARAM_SET is refused",
            key_rc == 0 ? key_source : "");

    uint64_t overruns = 0;
    if (realtime) {
        overruns = run_realtime((uint64_t)period_ms * 1000u);
    } else {
        while (!stop) {
            app_poll(&app, 100000u); /* wake up now and then to notice signals */
        }
    }
    hal_can_close();
    const comm_counters_t *d = &app.comm.drops;
    fprintf(stderr,
            "mstc-fw: %u steps; dropped frames: crc %u, sequence %u, length %u, unknown id %u\n",
            (unsigned)app.steps, d->crc, d->seq, d->len, d->unknown);
    if (realtime) {
        fprintf(stderr, "mstc-fw: %llu control periods missed (skipped)\n",
                (unsigned long long)overruns);
    }
    return 0;
}
