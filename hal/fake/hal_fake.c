/* SPDX-License-Identifier: MIT */
/* Recording fakes of the HAL (hal_fake.h). */
#include "hal_fake.h"

#include <errno.h>
#include <string.h>

#include "hal/hal_time.h"

hal_fake_t hal_fake;

void hal_fake_reset(void) { memset(&hal_fake, 0, sizeof hal_fake); }

void hal_fake_push_rx(const hal_can_frame_t *f)
{
    if (hal_fake.n_rx < HAL_FAKE_MAX_FRAMES) {
        hal_fake.rx[hal_fake.n_rx++] = *f;
    }
}

int hal_can_open(const char *iface)
{
    (void)iface;
    return 0;
}

int hal_can_set_filters(const hal_can_filter_t *filters, unsigned n)
{
    (void)filters;
    return n > 16u ? -EINVAL : 0;
}

int hal_can_send(const hal_can_frame_t *frame)
{
    if (hal_fake.n_sent < HAL_FAKE_MAX_FRAMES) {
        hal_fake.sent[hal_fake.n_sent++] = *frame;
    }
    return hal_fake.send_rc;
}

int hal_can_recv(hal_can_frame_t *frame, uint32_t timeout_us)
{
    hal_fake.n_recv_calls++;
    hal_fake.last_timeout_us = timeout_us;
    if (hal_fake.rx_head >= hal_fake.n_rx) {
        return -EAGAIN;
    }
    *frame = hal_fake.rx[hal_fake.rx_head++];
    return 0;
}

void hal_can_close(void) {}

int hal_can_status(hal_can_status_t *st)
{
    *st = hal_fake.can_status;
    return hal_fake.can_status_rc;
}

uint64_t hal_time_now_us(void) { return hal_fake.now_us; }

void hal_time_sleep_until_us(uint64_t t_us)
{
    if (t_us > hal_fake.now_us) {
        hal_fake.now_us = t_us;
    }
}

int hal_sys_watchdog_start(uint32_t timeout_ms)
{
    (void)timeout_ms;
    return 0;
}

void hal_sys_watchdog_kick(void) { hal_fake.kicks++; }

hal_reset_cause_t hal_sys_reset_cause(void) { return hal_fake.reset_cause; }

int hal_sys_boot_nonce(uint32_t *nonce)
{
    *nonce = hal_fake.boot_nonce++;
    return hal_fake.boot_nonce_rc;
}

int hal_encoder_init(void) { return hal_fake.encoder_rc; }

uint8_t hal_encoder_overran(void) { return hal_fake.encoder_overran; }

int hal_encoder_read(int32_t *left, int32_t *right)
{
    hal_fake.encoder_reads++;
    const bool ok = hal_fake.encoder_rc != -ENODEV;
    *left = ok ? hal_fake.encoder[0] : 0;
    *right = ok ? hal_fake.encoder[1] : 0;
    return hal_fake.encoder_rc;
}

int hal_motor_init(void) { return 0; }

int hal_motor_set(int16_t left, int16_t right)
{
    hal_fake.motor[0] = left;
    hal_fake.motor[1] = right;
    hal_fake.motor_enabled = true;
    hal_fake.motor_sets++;
    return 0;
}

void hal_motor_stop(void)
{
    hal_fake.motor[0] = 0;
    hal_fake.motor[1] = 0;
    hal_fake.motor_enabled = false;
    hal_fake.motor_stops++;
}
