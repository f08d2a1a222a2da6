/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the bxCAN driver (hal/stm32/bxcan.c, with can_queue.c and
 * the time driver) against its registers: the STM32F405's CAN1 as the SVD
 * lays it out, a model of the controller (tests/unit/stm32_host/
 * model_bxcan.h): its initialisation handshake, acceptance filters, three
 * transmit mailboxes, three-deep receive FIFO, error states and automatic
 * bus-off recovery, and its three interrupts through the NVIC model.
 *
 * Expected values by hand: CAN_BTR 0x011A0005 for 500 kbit/s from 42 MHz
 * (docs/porting.md's table: BRP 6, TS1 11, TS2 2, SJW 2); CAN_IER = TMEIE,
 * FMPIE0, FOVIE0, EPVIE, BOFIE, ERRIE = 0x860B (RM0090 §32.9.2); priorities
 * receive 1, transmit and status 2 (bxcan.c's, in the upper nibble); the
 * error states' thresholds 96, 128, 256 (CAN 2.0B, RM0090 §32.7.6); ABOM's
 * recovery after 128 × 11 recessive bits, 2.8 ms at 500 kbit/s.
 */
#include <errno.h>
#include <stdint.h>
#include <string.h>

#include "app/app.h"
#include "board_host.h"
#include "cortex_m.h"
#include "hal/hal_can.h"
#include "hal/hal_time.h"
#include "model_bxcan.h"
#include "stm32_hal.h"
#include "stm32_host.h"
#include "unity.h"

static bxcan_model_t can;

void setUp(void)
{
    stm32_host_reset();
    board_host_reset();
    stm32_host_set_clock(168000000u);
    bxcan_model_init(&can, CAN1_BASE, CAN1_TX_IRQn, CAN1_RX0_IRQn, CAN1_SCE_IRQn);
    stm32_host_vector(-1, SysTick_Handler);
    stm32_host_vector(CAN1_TX_IRQn, CAN1_TX_IRQHandler);
    stm32_host_vector(CAN1_RX0_IRQn, CAN1_RX0_IRQHandler);
    stm32_host_vector(CAN1_SCE_IRQn, CAN1_SCE_IRQHandler);
    stm32_time_init(168000000u);
}

void tearDown(void) {}

static hal_can_frame_t frame(uint32_t id, uint8_t tag)
{
    hal_can_frame_t f = { .id = id, .dlc = 8u };
    for (uint8_t i = 0; i < 8u; i++) {
        f.data[i] = (uint8_t)(tag + i);
    }
    return f;
}

static bxcan_model_frame_t on_bus(uint32_t id, uint8_t tag)
{
    bxcan_model_frame_t f = { .id = id, .dlc = 8u };
    for (uint8_t i = 0; i < 8u; i++) {
        f.data[i] = (uint8_t)(tag + i);
    }
    return f;
}

static hal_can_status_t status(void)
{
    hal_can_status_t st;
    TEST_ASSERT_EQUAL_INT(0, hal_can_status(&st));
    return st;
}

/* ----------------------------------------------------------- the handshake */

static void test_drv_bxcan_open_initialises_and_joins_the_bus(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    TEST_ASSERT_EQUAL_UINT(1u, board_host.can_enabled);
    TEST_ASSERT_FALSE(can.init); /* joined: normal mode */
    TEST_ASSERT_FALSE(can.sleep);
    const uint32_t mcr = can.p.reg[0];
    TEST_ASSERT_EQUAL_HEX32(0u, mcr & 0x3u);           /* INRQ, SLEEP cleared */
    TEST_ASSERT_EQUAL_HEX32(0x44u, mcr & 0x44u);       /* ABOM, TXFP */
    TEST_ASSERT_EQUAL_HEX32(0x10000u, mcr & 0x10000u); /* DBF kept */
    TEST_ASSERT_EQUAL_HEX32(0x011A0005u, can.p.reg[0x1C / 4]);
    TEST_ASSERT_EQUAL_HEX32(0x860Bu, can.p.reg[0x14 / 4]);
    TEST_ASSERT_TRUE(stm32_host_irq_enabled(CAN1_TX_IRQn));
    TEST_ASSERT_TRUE(stm32_host_irq_enabled(CAN1_RX0_IRQn));
    TEST_ASSERT_TRUE(stm32_host_irq_enabled(CAN1_SCE_IRQn));
    TEST_ASSERT_EQUAL_HEX8(1u << 4, stm32_host_irq_priority(CAN1_RX0_IRQn));
    TEST_ASSERT_EQUAL_HEX8(2u << 4, stm32_host_irq_priority(CAN1_TX_IRQn));
    TEST_ASSERT_EQUAL_HEX8(2u << 4, stm32_host_irq_priority(CAN1_SCE_IRQn));
    TEST_ASSERT_EQUAL_UINT32(500000u, stm32_can_bitrate());
    const hal_can_status_t st = status();
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_ERROR_ACTIVE, st.state);
    TEST_ASSERT_EQUAL_UINT32(0u, st.bus_off);
    /* The filters as left: every standard data frame. */
    TEST_ASSERT_EQUAL_HEX32(0u, can.p.reg[0x200 / 4] & 1u); /* FINIT cleared */
    TEST_ASSERT_TRUE(bxcan_model_receive(&can, &(bxcan_model_frame_t){ .id = 0x7FF, .dlc = 1 }));
    TEST_ASSERT_FALSE(
        bxcan_model_receive(&can, &(bxcan_model_frame_t){ .id = 0x7FF, .ide = true }));
    TEST_ASSERT_FALSE(
        bxcan_model_receive(&can, &(bxcan_model_frame_t){ .id = 0x123, .rtr = true }));
    hal_can_close();
    TEST_ASSERT_TRUE(can.init); /* back in initialisation */
    TEST_ASSERT_FALSE(stm32_host_irq_enabled(CAN1_RX0_IRQn));
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_STOPPED, status().state);
    TEST_ASSERT_EQUAL_UINT32(0u, stm32_can_bitrate());
}

static void test_drv_bxcan_a_controller_without_a_clock_times_out(void)
{
    can.ack_init = false; /* INRQ never acknowledged */
    const uint64_t t0 = hal_time_now_us();
    TEST_ASSERT_EQUAL_INT(-ENODEV, hal_can_open(NULL));
    const uint64_t waited = hal_time_now_us() - t0;
    TEST_ASSERT_TRUE(waited >= 10000u); /* INIT_TIMEOUT_US */
    TEST_ASSERT_TRUE(waited < 12000u);
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_STOPPED, status().state);
    const hal_can_frame_t f = frame(0x180, 0);
    TEST_ASSERT_EQUAL_INT(-ENODEV, hal_can_send(&f));
}

static void test_drv_bxcan_a_dominant_bus_delays_joining_but_not_open(void)
{
    can.bus_idle = false; /* no 11 recessive bits */
    const uint64_t t0 = hal_time_now_us();
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    TEST_ASSERT_TRUE(hal_time_now_us() - t0 >= 10000u);
    TEST_ASSERT_TRUE(can.init);
    /* A frame queues meanwhile, and goes out once the bus lets it join. */
    const hal_can_frame_t f = frame(0x180, 7);
    TEST_ASSERT_EQUAL_INT(0, hal_can_send(&f));
    TEST_ASSERT_EQUAL_UINT(0u, bxcan_model_transmit(&can, 3u));
    can.bus_idle = true;
    stm32_host_run_us(1u);
    TEST_ASSERT_FALSE(can.init);
    TEST_ASSERT_EQUAL_UINT(1u, bxcan_model_transmit(&can, 3u));
    TEST_ASSERT_EQUAL_UINT32(0x180u, can.sent[0].id);
}

/* ------------------------------------------------------------ the filters */

static void test_drv_bxcan_filters_let_through_only_what_they_name(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    /* Exact identifiers (list banks) and a mask pair: 0x200..0x20F. */
    const hal_can_filter_t filters[] = {
        { 0x100, HAL_CAN_MAX_STD_ID }, { 0x101, HAL_CAN_MAX_STD_ID }, { 0x104, HAL_CAN_MAX_STD_ID },
        { 0x110, HAL_CAN_MAX_STD_ID }, { 0x121, HAL_CAN_MAX_STD_ID }, { 0x200, 0x7F0 },
    };
    TEST_ASSERT_EQUAL_INT(0, hal_can_set_filters(filters, 6u));
    TEST_ASSERT_EQUAL_HEX32(0u, can.p.reg[0x200 / 4] & 1u); /* FINIT cleared again */
    const uint32_t taken[] = { 0x100, 0x101, 0x104, 0x110, 0x121, 0x200, 0x20F };
    const uint32_t refused[] = { 0x102, 0x111, 0x120, 0x1F0, 0x210, 0x000, 0x7FF };
    uint8_t tag = 0;
    for (size_t i = 0; i < sizeof taken / sizeof taken[0]; i++) {
        const bxcan_model_frame_t f = on_bus(taken[i], tag++);
        TEST_ASSERT_TRUE_MESSAGE(bxcan_model_receive(&can, &f), "a named identifier");
        hal_can_frame_t got;
        TEST_ASSERT_EQUAL_INT(0, hal_can_recv(&got, 0u));
        TEST_ASSERT_EQUAL_UINT32(taken[i], got.id);
        TEST_ASSERT_EQUAL_UINT8(8u, got.dlc);
        TEST_ASSERT_EQUAL_MEMORY(f.data, got.data, 8u);
    }
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++) {
        const bxcan_model_frame_t f = on_bus(refused[i], 0);
        TEST_ASSERT_FALSE_MESSAGE(bxcan_model_receive(&can, &f), "an identifier not named");
    }
    /* Remote and extended frames never pass, whatever their bits. */
    TEST_ASSERT_FALSE(
        bxcan_model_receive(&can, &(bxcan_model_frame_t){ .id = 0x100, .rtr = true }));
    TEST_ASSERT_FALSE(
        bxcan_model_receive(&can, &(bxcan_model_frame_t){ .id = 0x100u << 18, .ide = true }));
    hal_can_frame_t none;
    TEST_ASSERT_EQUAL_INT(-EAGAIN, hal_can_recv(&none, 0u));
    /* Too many to fit the banks: refused, nothing changed. */
    hal_can_filter_t many[17];
    for (unsigned i = 0; i < 17u; i++) {
        many[i] = (hal_can_filter_t){ 0x300u + i, HAL_CAN_MAX_STD_ID };
    }
    TEST_ASSERT_EQUAL_INT(-EINVAL, hal_can_set_filters(many, 17u));
    TEST_ASSERT_TRUE(bxcan_model_receive(&can, &(bxcan_model_frame_t){ .id = 0x104, .dlc = 0 }));
}

/* ------------------------------------------------------------- transmit */

static void test_drv_bxcan_three_mailboxes_full_frames_queue_none_lost_order_kept(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    /* Ten frames, their identifiers falling: by priority the bus would send
     * them backwards; in request order (TXFP) it sends them as queued. */
    for (uint8_t i = 0; i < 10u; i++) {
        const hal_can_frame_t f = frame(0x190u - i, i);
        TEST_ASSERT_EQUAL_INT(0, hal_can_send(&f));
    }
    /* The transmit interrupt filled the three mailboxes; seven wait. */
    TEST_ASSERT_TRUE(can.tx_pending[0] && can.tx_pending[1] && can.tx_pending[2]);
    /* The bus takes one frame at a time; each completion's interrupt loads
     * the next. */
    for (unsigned n = 0; n < 10u; n++) {
        TEST_ASSERT_EQUAL_UINT(1u, bxcan_model_transmit(&can, 1u));
    }
    TEST_ASSERT_EQUAL_UINT(0u, bxcan_model_transmit(&can, 1u));
    TEST_ASSERT_EQUAL_UINT(10u, can.n_sent);
    for (uint8_t i = 0; i < 10u; i++) {
        TEST_ASSERT_EQUAL_UINT32(0x190u - i, can.sent[i].id);
        TEST_ASSERT_EQUAL_UINT8(8u, can.sent[i].dlc);
        TEST_ASSERT_EQUAL_UINT8(i, can.sent[i].data[0]);
        TEST_ASSERT_EQUAL_UINT8(i + 7u, can.sent[i].data[7]);
    }
    TEST_ASSERT_EQUAL_UINT32(0u, status().tx_dropped);
    /* Frames sent with interrupts masked (from a critical section, or an
     * interrupt of higher priority): one transmit interrupt, when they are
     * unmasked, fills every empty mailbox, not one. */
    const uint32_t was = stm32_host_irq_save();
    for (uint8_t i = 0; i < 4u; i++) {
        const hal_can_frame_t f = frame(0x100u + i, i);
        TEST_ASSERT_EQUAL_INT(0, hal_can_send(&f));
    }
    TEST_ASSERT_FALSE(can.tx_pending[0] || can.tx_pending[1] || can.tx_pending[2]);
    stm32_host_irq_restore(was);
    TEST_ASSERT_TRUE(can.tx_pending[0] && can.tx_pending[1] && can.tx_pending[2]);
    TEST_ASSERT_EQUAL_UINT(4u, bxcan_model_transmit(&can, 4u));
    for (uint8_t i = 0; i < 4u; i++) {
        TEST_ASSERT_EQUAL_UINT32(0x100u + i, can.sent[10u + i].id);
    }
}

static void test_drv_bxcan_a_full_transmit_queue_refuses_and_counts(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    /* Nothing goes out: three in the mailboxes, 32 in the queue, the 36th
     * refused and counted. */
    for (unsigned i = 0; i < 35u; i++) {
        const hal_can_frame_t f = frame(0x180u + i, (uint8_t)i);
        TEST_ASSERT_EQUAL_INT(0, hal_can_send(&f));
    }
    const hal_can_frame_t late = frame(0x1FF, 0);
    TEST_ASSERT_EQUAL_INT(-EAGAIN, hal_can_send(&late));
    TEST_ASSERT_EQUAL_UINT32(1u, status().tx_dropped);
    TEST_ASSERT_EQUAL_UINT(35u, bxcan_model_transmit(&can, 64u));
    for (unsigned i = 0; i < 35u; i++) {
        TEST_ASSERT_EQUAL_UINT32(0x180u + i, can.sent[i].id);
    }
    /* A bad frame is refused before it is queued. */
    const hal_can_frame_t bad = { .id = 0x800, .dlc = 1 };
    TEST_ASSERT_EQUAL_INT(-EINVAL, hal_can_send(&bad));
}

/* -------------------------------------------------------------- receive */

static void test_drv_bxcan_receive_fifo_overrun_is_counted_and_reported(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    /* Interrupts masked (a long critical section): four frames arrive, the
     * FIFO holds three, the fourth overruns it and takes the newest's place
     * (RFLM 0). */
    const uint32_t primask = cm_irq_save();
    for (uint8_t i = 0; i < 4u; i++) {
        const bxcan_model_frame_t f = on_bus(0x100u + i, i);
        TEST_ASSERT_TRUE(bxcan_model_receive(&can, &f));
    }
    TEST_ASSERT_TRUE(can.fovr);
    cm_irq_restore(primask);
    /* The interrupt drained the FIFO, counted the overrun, cleared it. */
    TEST_ASSERT_EQUAL_UINT(0u, can.fifo_n);
    TEST_ASSERT_FALSE(can.fovr);
    TEST_ASSERT_FALSE(can.full);
    const uint32_t expect[] = { 0x100, 0x101, 0x103 };
    for (size_t i = 0; i < 3u; i++) {
        hal_can_frame_t got;
        TEST_ASSERT_EQUAL_INT(0, hal_can_recv(&got, 0u));
        TEST_ASSERT_EQUAL_UINT32(expect[i], got.id);
    }
    hal_can_frame_t none;
    TEST_ASSERT_EQUAL_INT(-EAGAIN, hal_can_recv(&none, 0u));
    TEST_ASSERT_EQUAL_UINT32(1u, status().rx_dropped);
}

static void test_drv_bxcan_a_full_receive_queue_counts_what_it_drops(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    /* The main loop does not read: 40 frames, the queue holds 32. */
    for (unsigned i = 0; i < 40u; i++) {
        const bxcan_model_frame_t f = on_bus(0x100u + i, (uint8_t)i);
        TEST_ASSERT_TRUE(bxcan_model_receive(&can, &f));
    }
    TEST_ASSERT_TRUE(stm32_can_rx_pending());
    TEST_ASSERT_EQUAL_UINT32(8u, status().rx_dropped);
    for (unsigned i = 0; i < 32u; i++) {
        hal_can_frame_t got;
        TEST_ASSERT_EQUAL_INT(0, hal_can_recv(&got, 0u));
        TEST_ASSERT_EQUAL_UINT32(0x100u + i, got.id); /* the oldest kept */
    }
    TEST_ASSERT_FALSE(stm32_can_rx_pending());
    /* Waiting for a frame that does not come: the time-out. */
    hal_can_frame_t none;
    const uint64_t t0 = hal_time_now_us();
    TEST_ASSERT_EQUAL_INT(-EAGAIN, hal_can_recv(&none, 3000u));
    TEST_ASSERT_TRUE(hal_time_now_us() - t0 >= 3000u);
}

/* --------------------------------------------------- errors and bus-off */

static void test_drv_bxcan_error_warning_and_passive_are_reported(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    bxcan_model_errors(&can, 100u, 20u);
    hal_can_status_t st = status();
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_ERROR_WARNING, st.state);
    TEST_ASSERT_EQUAL_UINT8(100u, st.tx_err);
    TEST_ASSERT_EQUAL_UINT8(20u, st.rx_err);
    TEST_ASSERT_EQUAL_UINT(0u, stm32_host_taken(CAN1_SCE_IRQn)); /* EWGIE not enabled */
    bxcan_model_errors(&can, 130u, 20u);
    TEST_ASSERT_EQUAL_UINT(1u, stm32_host_taken(CAN1_SCE_IRQn));
    TEST_ASSERT_FALSE(can.erri); /* the handler cleared ERRI */
    st = status();
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_ERROR_PASSIVE, st.state);
    TEST_ASSERT_EQUAL_UINT8(130u, st.tx_err);
    TEST_ASSERT_EQUAL_UINT32(0u, st.bus_off);
    hal_can_frame_t none;
    TEST_ASSERT_EQUAL_INT(-EAGAIN, hal_can_recv(&none, 0u)); /* not a failure */
}

static void test_drv_bxcan_bus_off_recovers_by_itself_and_is_reported(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    bxcan_model_errors(&can, 256u, 0u);
    TEST_ASSERT_EQUAL_UINT(1u, stm32_host_taken(CAN1_SCE_IRQn));
    TEST_ASSERT_EQUAL_UINT(1u, can.bus_off_entries);
    hal_can_status_t st = status();
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_BUS_OFF, st.state);
    TEST_ASSERT_EQUAL_UINT32(1u, st.bus_off);
    hal_can_frame_t got;
    TEST_ASSERT_EQUAL_INT(-EIO, hal_can_recv(&got, 0u));
    /* A frame sent meanwhile waits in its mailbox. */
    const hal_can_frame_t f = frame(0x185, 1);
    TEST_ASSERT_EQUAL_INT(0, hal_can_send(&f));
    TEST_ASSERT_EQUAL_UINT(0u, bxcan_model_transmit(&can, 3u));
    /* ABOM: back after 128 × 11 recessive bits (2.8 ms), counters cleared,
     * the frame out, the event still counted. */
    stm32_host_run_us(2000u);
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_BUS_OFF, status().state);
    stm32_host_run_us(1000u);
    st = status();
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_ERROR_ACTIVE, st.state);
    TEST_ASSERT_EQUAL_UINT8(0u, st.tx_err);
    TEST_ASSERT_EQUAL_UINT32(1u, st.bus_off);
    TEST_ASSERT_EQUAL_UINT(1u, bxcan_model_transmit(&can, 3u));
    TEST_ASSERT_EQUAL_UINT32(0x185u, can.sent[0].id);
    /* A second bus-off is a second event: the errors climb again, through
     * error-passive, to bus-off. */
    bxcan_model_errors(&can, 130u, 0u);
    TEST_ASSERT_EQUAL_UINT32(1u, status().bus_off);
    bxcan_model_errors(&can, 256u, 0u);
    TEST_ASSERT_EQUAL_UINT32(2u, status().bus_off);
}

static app_t app;

static void test_drv_bxcan_bus_off_halts_the_application(void)
{
    TEST_ASSERT_EQUAL_INT(0, hal_can_open(NULL));
    TEST_ASSERT_EQUAL_INT(0, app_init(&app, NULL));
    app.halt = (uint8_t)COMM_HALT_NONE; /* as if armed and running */
    app_control_tick(&app, 20000u);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_ODOMETRY, app.halt); /* no inputs: it halts */
    app.halt = (uint8_t)COMM_HALT_NONE;
    bxcan_model_errors(&can, 256u, 0u);
    app_control_tick(&app, 40000u);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_BUS_OFF, app.halt); /* bus-off comes first */
    /* Recovered: the halt stays latched (docs/safety.md: re-armed by the
     * operator only). */
    stm32_host_run_us(3000u);
    TEST_ASSERT_EQUAL_INT(HAL_CAN_STATE_ERROR_ACTIVE, status().state);
    app_control_tick(&app, 60000u);
    TEST_ASSERT_EQUAL_UINT8(COMM_HALT_BUS_OFF, app.halt);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_drv_bxcan_open_initialises_and_joins_the_bus);
    RUN_TEST(test_drv_bxcan_a_controller_without_a_clock_times_out);
    RUN_TEST(test_drv_bxcan_a_dominant_bus_delays_joining_but_not_open);
    RUN_TEST(test_drv_bxcan_filters_let_through_only_what_they_name);
    RUN_TEST(test_drv_bxcan_three_mailboxes_full_frames_queue_none_lost_order_kept);
    RUN_TEST(test_drv_bxcan_a_full_transmit_queue_refuses_and_counts);
    RUN_TEST(test_drv_bxcan_receive_fifo_overrun_is_counted_and_reported);
    RUN_TEST(test_drv_bxcan_a_full_receive_queue_counts_what_it_drops);
    RUN_TEST(test_drv_bxcan_error_warning_and_passive_are_reported);
    RUN_TEST(test_drv_bxcan_bus_off_recovers_by_itself_and_is_reported);
    RUN_TEST(test_drv_bxcan_bus_off_halts_the_application);
    return UNITY_END();
}
