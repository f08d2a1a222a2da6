/* SPDX-License-Identifier: MIT */
/* HAL for the in-process SIL: CAN as two queues between the plant (through
 * mstc_sil.h) and the firmware, time from the frames, no watchdog. */
#include <errno.h>
#include <string.h>
#include <sys/random.h>

#include "hal/hal_can.h"
#include "hal/hal_sys.h"
#include "hal/hal_time.h"
#include "hal_sil.h"

#define QLEN 64u /* a power of two; a lock-step exchange needs about 25 */

typedef struct {
    hal_can_frame_t f[QLEN];
    uint32_t head; /* next to read */
    uint32_t tail; /* next to write */
} queue_t;

static queue_t to_fw;   /* plant → firmware */
static queue_t from_fw; /* firmware → plant */
static hal_can_filter_t filters[16];
static unsigned n_filters;

static int push(queue_t *q, const hal_can_frame_t *f)
{
    if (q->tail - q->head >= QLEN) {
        return -EAGAIN;
    }
    q->f[q->tail % QLEN] = *f;
    q->tail++;
    return 0;
}

static int pop(queue_t *q, hal_can_frame_t *f)
{
    if (q->tail == q->head) {
        return -EAGAIN;
    }
    *f = q->f[q->head % QLEN];
    q->head++;
    return 0;
}

static int frame_valid(const hal_can_frame_t *f)
{
    return f->id <= HAL_CAN_MAX_STD_ID && f->dlc <= HAL_CAN_MAX_DLC;
}

static int accepted(const hal_can_frame_t *f)
{
    if (n_filters == 0) {
        return 1;
    }
    for (unsigned i = 0; i < n_filters; i++) {
        if ((f->id & filters[i].mask) == (filters[i].id & filters[i].mask)) {
            return 1;
        }
    }
    return 0;
}

void hal_sil_reset(void)
{
    memset(&to_fw, 0, sizeof to_fw);
    memset(&from_fw, 0, sizeof from_fw);
    n_filters = 0;
}

int hal_sil_to_fw(const hal_can_frame_t *f)
{
    if (!frame_valid(f)) {
        return -EINVAL;
    }
    return accepted(f) ? push(&to_fw, f) : 0;
}

int hal_sil_from_fw(hal_can_frame_t *f) { return pop(&from_fw, f); }

int hal_can_open(const char *iface)
{
    (void)iface;
    return 0;
}

int hal_can_set_filters(const hal_can_filter_t *fl, unsigned n)
{
    if (n > sizeof filters / sizeof filters[0] || (n > 0 && fl == NULL)) {
        return -EINVAL;
    }
    memcpy(filters, fl, n * sizeof *fl);
    n_filters = n;
    return 0;
}

int hal_can_send(const hal_can_frame_t *f)
{
    if (!frame_valid(f)) {
        return -EINVAL;
    }
    return push(&from_fw, f);
}

int hal_can_recv(hal_can_frame_t *f, uint32_t timeout_us)
{
    (void)timeout_us; /* in process nothing else can arrive while we wait */
    return pop(&to_fw, f);
}

void hal_can_close(void) {}

int hal_can_status(hal_can_status_t *st)
{
    (void)st;
    return -ENOTSUP; /* no controller: nothing to count */
}

/* The SIL has no clock: the firmware's time comes from STEP frames, or from
 * the caller of mstc_sil_fw_tick() in real-time mode. */
uint64_t hal_time_now_us(void) { return 0; }
void hal_time_sleep_until_us(uint64_t t_us) { (void)t_us; }

int hal_sys_watchdog_start(uint32_t timeout_ms)
{
    (void)timeout_ms;
    return -ENOTSUP;
}
void hal_sys_watchdog_kick(void) {}
hal_reset_cause_t hal_sys_reset_cause(void) { return HAL_RESET_POWER_ON; }

/* The kernel's random source, as hal/linux: every start of the library's
 * firmware instance draws its own session (mstc_sil_fw_set_session() sets
 * one instead, for the replay of a recorded log). */
int hal_sys_boot_nonce(uint32_t *nonce)
{
    return getrandom(nonce, sizeof *nonce, 0) == (ssize_t)sizeof *nonce ? 0 : -EIO;
}
