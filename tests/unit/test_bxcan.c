/* SPDX-License-Identifier: MIT */
/*
 * Unity tests of the board-independent part of the bxCAN driver
 * (hal/stm32/bxcan_calc.c: bit timing, filter banks, mailbox packing) and of
 * the lock-free receive/transmit queue (hal/stm32/can_ring.h).
 *
 * bxcan_calc.c is pure (no register access), so the host test build compiles
 * and links it (TEST_SRCS_test_bxcan in the Makefile).
 *
 * Expected values: hand derivations written beside each case, from the
 * reference manual's definitions (RM0090 §32.7.7 bit timing, §32.7.4 and
 * Figure 342 filter banks, §32.9.3 mailbox registers). The filter test also
 * checks the banks against an independent model of the hardware's matching
 * over every standard identifier.
 */
#include <errno.h>
#include <limits.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "bxcan_calc.h"
#include "can_ring.h"
#include "unity.h"

void setUp(void) {}
void tearDown(void) {}

/* ------------------------------------------------------------ bit timing */

static void expect_timing(uint32_t pclk, uint32_t bitrate, unsigned brp, unsigned ts1, unsigned ts2,
                          unsigned sjw, uint32_t btr, unsigned sp_permille)
{
    bxcan_timing_t t;
    TEST_ASSERT_EQUAL_INT(0, bxcan_timing(pclk, bitrate, BXCAN_SAMPLE_POINT_CIA, &t));
    TEST_ASSERT_EQUAL_UINT(brp, t.brp);
    TEST_ASSERT_EQUAL_UINT(ts1, t.ts1);
    TEST_ASSERT_EQUAL_UINT(ts2, t.ts2);
    TEST_ASSERT_EQUAL_UINT(sjw, t.sjw);
    TEST_ASSERT_EQUAL_HEX32(btr, bxcan_btr(&t));
    TEST_ASSERT_EQUAL_UINT(sp_permille, bxcan_sample_point_permille(&t));
    /* The bit rate is exact: pclk = bitrate · brp · (1 + ts1 + ts2). */
    TEST_ASSERT_EQUAL_UINT32(pclk, bitrate * t.brp * (1u + t.ts1 + t.ts2));
}

/* F4, APB1 42 MHz, 500 kbit/s: 84 clocks per bit = brp · N with N in 8..25:
 * N = 12 (brp 7), 14 (brp 6), 21 (brp 4). N = 21 needs ts2 >= 4 (ts1 <= 16):
 * 17/21 = 809.5 ‰; N = 14 with ts2 = 2: 12/14 = 857.1 ‰; N = 12: 11/12 or
 * 10/12, 41.7 ‰ off. Best: N = 14, brp 6, ts1 11, ts2 2, sjw 2.
 * BTR = SJW-1 = 1 <<24 | TS2-1 = 1 <<20 | TS1-1 = 10 <<16 | BRP-1 = 5. */
static void test_bxcan_timing_f4_500k(void)
{
    expect_timing(42000000u, 500000u, 6, 11, 2, 2, 0x011A0005u, 857);
}

/* F4, 42 MHz, 1 Mbit/s: 42 = brp · N: N = 14 (brp 3) or 21 (brp 2, best
 * 809.5 ‰). N = 14: 857.1 ‰. BTR = 1<<24 | 1<<20 | 10<<16 | 2. */
static void test_bxcan_timing_f4_1m(void)
{
    expect_timing(42000000u, 1000000u, 3, 11, 2, 2, 0x011A0002u, 857);
}

/* F1, APB1 36 MHz, 500 kbit/s: 72 = brp · N: N = 8 (brp 9) gives exactly
 * 7/8 = 875 ‰ with ts2 = 1; N = 9 and 18 give 888.9 ‰, N = 12 833/917 ‰,
 * N = 24 (ts2 >= 7) 708 ‰. BTR = 0<<24 | 0<<20 | 5<<16 | 8. */
static void test_bxcan_timing_f1_500k(void)
{
    expect_timing(36000000u, 500000u, 9, 6, 1, 1, 0x00050008u, 875);
}

/* F1, 36 MHz, 1 Mbit/s: 36 = brp · N: N = 9 (brp 4) and N = 18 (brp 2) both
 * reach 888.9 ‰ (8/9, 16/18), N = 12 only 833/917 ‰: the tie goes to more
 * quanta, N = 18: ts1 15, ts2 2. BTR = 1<<24 | 1<<20 | 14<<16 | 1. */
static void test_bxcan_timing_f1_1m(void)
{
    expect_timing(36000000u, 1000000u, 2, 15, 2, 2, 0x011E0001u, 888);
}

/* HSI fallback of the F4 (APB1 16 MHz), 500 kbit/s: 32 = brp · N: N = 8
 * (7/8) and N = 16 (14/16) are both exactly 875 ‰: N = 16, brp 2. */
static void test_bxcan_timing_hsi_fallback_prefers_more_quanta(void)
{
    expect_timing(16000000u, 500000u, 2, 13, 2, 2, 0x011C0001u, 875);
}

static void test_bxcan_timing_rejects_inexact_and_bad_arguments(void)
{
    bxcan_timing_t t = { 0 };
    /* 42 MHz / 800 kbit/s = 52.5 clocks per bit. */
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_timing(42000000u, 800000u, 875, &t));
    /* 4 MHz at 1 Mbit/s: 4 clocks per bit, fewer than 8 quanta. */
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_timing(4000000u, 1000000u, 875, &t));
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_timing(0u, 500000u, 875, &t));
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_timing(42000000u, 0u, 875, &t));
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_timing(42000000u, 500000u, 400, &t));
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_timing(42000000u, 500000u, 875, NULL));
}

/* Any valid result obeys the hardware's limits (RM0090 §32.9.2: BRP 10 bits,
 * TS1 4 bits, TS2 3 bits, SJW 2 bits) and the exact bit rate. */
static void test_bxcan_timing_results_respect_register_limits(void)
{
    static const uint32_t clocks[] = { 8000000u,  16000000u, 24000000u, 36000000u,
                                       42000000u, 45000000u, 48000000u, 54000000u };
    static const uint32_t rates[] = { 10000u,  20000u,  50000u,  125000u,
                                      250000u, 500000u, 800000u, 1000000u };
    for (size_t i = 0; i < sizeof clocks / sizeof clocks[0]; i++) {
        for (size_t j = 0; j < sizeof rates / sizeof rates[0]; j++) {
            bxcan_timing_t t;
            if (bxcan_timing(clocks[i], rates[j], 875, &t) != 0) {
                continue;
            }
            TEST_ASSERT_TRUE(t.brp >= 1u && t.brp <= 1024u);
            TEST_ASSERT_TRUE(t.ts1 >= 1u && t.ts1 <= 16u);
            TEST_ASSERT_TRUE(t.ts2 >= 1u && t.ts2 <= 8u);
            TEST_ASSERT_TRUE(t.sjw >= 1u && t.sjw <= 4u && t.sjw <= t.ts2);
            TEST_ASSERT_EQUAL_UINT32(clocks[i], rates[j] * t.brp * (1u + t.ts1 + t.ts2));
        }
    }
}

/* ----------------------------------------------------------- filter banks */

/* The receive identifiers of the protocol (comm.h). */
static const uint32_t rx_ids[] = { 0x100, 0x101, 0x102, 0x103, 0x104, 0x110, 0x120, 0x121 };

/* Independent model of the hardware (RM0090 §32.7.4, Figure 342): does a
 * frame with 11-bit @p id, @p ide and @p rtr pass bank @p b? A 16-bit entry
 * is STID<<5 | RTR<<4 | IDE<<3 | EXID[17:15]. */
static bool model_accepts(const bxcan_bank_t *b, uint32_t id, bool ide, bool rtr)
{
    const uint32_t frame = (id << 5) | (rtr ? 1u << 4 : 0u) | (ide ? 1u << 3 : 0u);
    const uint32_t e[4] = { b->fr1 & 0xFFFFu, b->fr1 >> 16, b->fr2 & 0xFFFFu, b->fr2 >> 16 };
    if (b->list) {
        return frame == e[0] || frame == e[1] || frame == e[2] || frame == e[3];
    }
    /* Mask mode: (id, mask) pairs (e[0], e[1]) and (e[2], e[3]); EXID[17:15]
     * of a standard frame is 0, as in the entry. */
    return ((frame ^ e[0]) & e[1]) == 0u || ((frame ^ e[2]) & e[3]) == 0u;
}

static bool spec_accepts(const hal_can_filter_t *f, unsigned n, uint32_t id)
{
    for (unsigned i = 0; i < n; i++) {
        if ((id & f[i].mask) == (f[i].id & f[i].mask)) {
            return true;
        }
    }
    return n == 0u;
}

/* Every standard id, data and remote, standard and extended: the banks pass
 * exactly the standard data frames the HAL filters describe. */
static void check_against_model(const hal_can_filter_t *f, unsigned n)
{
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned nb = 0;
    TEST_ASSERT_EQUAL_INT(0, bxcan_filter_banks(f, n, banks, BXCAN_MAX_BANKS, &nb));
    for (uint32_t id = 0; id <= HAL_CAN_MAX_STD_ID; id++) {
        for (int kind = 0; kind < 3; kind++) {
            const bool ide = kind == 1;
            const bool rtr = kind == 2;
            bool passed = false;
            for (unsigned b = 0; b < nb; b++) {
                passed = passed || model_accepts(&banks[b], id, ide, rtr);
            }
            const bool want = !ide && !rtr && spec_accepts(f, n, id);
            if (passed != want) {
                char msg[64];
                snprintf(msg, sizeof msg, "id 0x%03X ide %d rtr %d", (unsigned)id, ide, rtr);
                TEST_FAIL_MESSAGE(msg);
            }
        }
    }
}

/* The protocol's eight ids are exact: two list-mode banks of four entries,
 * entry = id << 5 (RTR = IDE = 0): 0x100 -> 0x2000, 0x101 -> 0x2020,
 * 0x102 -> 0x2040, 0x103 -> 0x2060, 0x104 -> 0x2080, 0x110 -> 0x2200,
 * 0x120 -> 0x2400, 0x121 -> 0x2420; FiR1 = entry1 << 16 | entry0. */
static void test_bxcan_filters_protocol_ids_use_two_list_banks(void)
{
    hal_can_filter_t f[8];
    for (unsigned i = 0; i < 8; i++) {
        f[i] = (hal_can_filter_t){ .id = rx_ids[i], .mask = HAL_CAN_MAX_STD_ID };
    }
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned nb = 0;
    TEST_ASSERT_EQUAL_INT(0, bxcan_filter_banks(f, 8, banks, BXCAN_MAX_BANKS, &nb));
    TEST_ASSERT_EQUAL_UINT(2, nb);
    TEST_ASSERT_TRUE(banks[0].list);
    TEST_ASSERT_EQUAL_HEX32(0x20202000u, banks[0].fr1);
    TEST_ASSERT_EQUAL_HEX32(0x20602040u, banks[0].fr2);
    TEST_ASSERT_TRUE(banks[1].list);
    TEST_ASSERT_EQUAL_HEX32(0x22002080u, banks[1].fr1);
    TEST_ASSERT_EQUAL_HEX32(0x24202400u, banks[1].fr2);
    check_against_model(f, 8);
}

/* No filter: one mask bank whose mask compares only IDE and RTR (0x0018):
 * FiR1 = FiR2 = 0x0018 << 16 | 0. */
static void test_bxcan_filters_none_accepts_all_standard_data_frames(void)
{
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned nb = 0;
    TEST_ASSERT_EQUAL_INT(0, bxcan_filter_banks(NULL, 0, banks, BXCAN_MAX_BANKS, &nb));
    TEST_ASSERT_EQUAL_UINT(1, nb);
    TEST_ASSERT_FALSE(banks[0].list);
    TEST_ASSERT_EQUAL_HEX32(0x00180000u, banks[0].fr1);
    TEST_ASSERT_EQUAL_HEX32(0x00180000u, banks[0].fr2);
    check_against_model(NULL, 0);
}

/* A range: id 0x100, mask 0x7F0 (0x100..0x10F): mask entry 0x7F0 << 5 |
 * 0x18 = 0xFE18, id entry 0x2000; alone in its bank, the pair repeats. */
static void test_bxcan_filters_mask_pairs(void)
{
    const hal_can_filter_t f[] = { { .id = 0x100, .mask = 0x7F0 } };
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned nb = 0;
    TEST_ASSERT_EQUAL_INT(0, bxcan_filter_banks(f, 1, banks, BXCAN_MAX_BANKS, &nb));
    TEST_ASSERT_EQUAL_UINT(1, nb);
    TEST_ASSERT_FALSE(banks[0].list);
    TEST_ASSERT_EQUAL_HEX32(0xFE182000u, banks[0].fr1);
    TEST_ASSERT_EQUAL_HEX32(0xFE182000u, banks[0].fr2);
    check_against_model(f, 1);
}

/* Five exact ids and three masks: ceil(5/4) = 2 list banks, ceil(3/2) = 2
 * mask banks; the id bits outside a mask do not matter. */
static void test_bxcan_filters_mixed(void)
{
    const hal_can_filter_t f[] = {
        { .id = 0x7FF, .mask = 0x7FF }, { .id = 0x000, .mask = 0x7FF },
        { .id = 0x123, .mask = 0x7FF }, { .id = 0x2FF, .mask = 0x700 },
        { .id = 0x456, .mask = 0x7FF }, { .id = 0x555, .mask = 0x000 },
        { .id = 0x001, .mask = 0x7FF }, { .id = 0x180, .mask = 0x7C0 },
    };
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned nb = 0;
    TEST_ASSERT_EQUAL_INT(0, bxcan_filter_banks(f, 8, banks, BXCAN_MAX_BANKS, &nb));
    TEST_ASSERT_EQUAL_UINT(4, nb);
    TEST_ASSERT_TRUE(banks[0].list && banks[1].list);
    TEST_ASSERT_FALSE(banks[2].list || banks[3].list);
    /* Second list bank: 0x001 alone, repeated: 0x0020 in all four slots. */
    TEST_ASSERT_EQUAL_HEX32(0x00200020u, banks[1].fr1);
    TEST_ASSERT_EQUAL_HEX32(0x00200020u, banks[1].fr2);
    check_against_model(f, 8);
    /* A mask of 0 accepts every standard id. */
    for (uint32_t id = 0; id <= HAL_CAN_MAX_STD_ID; id++) {
        TEST_ASSERT_TRUE(spec_accepts(f, 8, id));
    }
}

static void test_bxcan_filters_sixteen_masks_fit(void)
{
    hal_can_filter_t f[16];
    for (unsigned i = 0; i < 16; i++) {
        f[i] = (hal_can_filter_t){ .id = 0x40u * i, .mask = 0x7C0 };
    }
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned nb = 0;
    TEST_ASSERT_EQUAL_INT(0, bxcan_filter_banks(f, 16, banks, BXCAN_MAX_BANKS, &nb));
    TEST_ASSERT_EQUAL_UINT(8, nb);
    check_against_model(f, 16);
}

static void test_bxcan_filters_reject_bad_input(void)
{
    hal_can_filter_t f[17];
    for (unsigned i = 0; i < 17; i++) {
        f[i] = (hal_can_filter_t){ .id = i, .mask = HAL_CAN_MAX_STD_ID };
    }
    bxcan_bank_t banks[BXCAN_MAX_BANKS];
    unsigned nb = 0;
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_filter_banks(f, 17, banks, BXCAN_MAX_BANKS, &nb));
    const hal_can_filter_t wide_id[] = { { .id = 0x800, .mask = 0x7FF } };
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_filter_banks(wide_id, 1, banks, BXCAN_MAX_BANKS, &nb));
    const hal_can_filter_t wide_mask[] = { { .id = 0x100, .mask = 0xFFF } };
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_filter_banks(wide_mask, 1, banks, BXCAN_MAX_BANKS, &nb));
    /* Eight exact ids need two banks. */
    TEST_ASSERT_EQUAL_INT(-EINVAL, bxcan_filter_banks(f, 8, banks, 1, &nb));
}

/* -------------------------------------------------------------- mailboxes */

/* STID in bits 31:21: 0x123 << 21 = 0x24600000; DLC in TDTR; bytes little
 * end first in TDLR/TDHR. */
static void test_bxcan_mailbox_packing(void)
{
    const hal_can_frame_t f = { .id = 0x123, .dlc = 6, .data = { 1, 2, 3, 4, 5, 6, 0, 0 } };
    bxcan_mailbox_t mb;
    bxcan_mailbox_from_frame(&f, &mb);
    TEST_ASSERT_EQUAL_HEX32(0x24600000u, mb.ir);
    TEST_ASSERT_EQUAL_HEX32(6u, mb.dtr);
    TEST_ASSERT_EQUAL_HEX32(0x04030201u, mb.dlr);
    TEST_ASSERT_EQUAL_HEX32(0x00000605u, mb.dhr);

    hal_can_frame_t back;
    memset(&back, 0xAA, sizeof back);
    TEST_ASSERT_TRUE(bxcan_frame_from_mailbox(&mb, &back));
    TEST_ASSERT_EQUAL_UINT32(0x123u, back.id);
    TEST_ASSERT_EQUAL_UINT8(6u, back.dlc);
    TEST_ASSERT_EQUAL_UINT8_ARRAY(f.data, back.data, 8);
}

static void test_bxcan_mailbox_receive_edge_cases(void)
{
    hal_can_frame_t f;
    memset(&f, 0x55, sizeof f);
    /* Extended (IDE, bit 2) and remote (RTR, bit 1) frames are refused and
     * leave the frame untouched. */
    const bxcan_mailbox_t ext = { .ir = 0x24600000u | 4u, .dtr = 8, .dlr = 1, .dhr = 2 };
    const bxcan_mailbox_t rtr = { .ir = 0x24600000u | 2u, .dtr = 0, .dlr = 0, .dhr = 0 };
    TEST_ASSERT_FALSE(bxcan_frame_from_mailbox(&ext, &f));
    TEST_ASSERT_FALSE(bxcan_frame_from_mailbox(&rtr, &f));
    TEST_ASSERT_EQUAL_HEX8(0x55, f.dlc);
    /* DLC 9..15 means 8 bytes; bytes past the DLC read 0 whatever the
     * register holds (the FMI and time stamp bits of RDTR are ignored). */
    const bxcan_mailbox_t long_dlc = {
        .ir = 0x7FFu << 21, .dtr = 0xFFFF000Cu, .dlr = 0x44332211u, .dhr = 0x88776655u
    };
    TEST_ASSERT_TRUE(bxcan_frame_from_mailbox(&long_dlc, &f));
    TEST_ASSERT_EQUAL_UINT32(0x7FFu, f.id);
    TEST_ASSERT_EQUAL_UINT8(8u, f.dlc);
    const uint8_t all[8] = { 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88 };
    TEST_ASSERT_EQUAL_UINT8_ARRAY(all, f.data, 8);
    const bxcan_mailbox_t short_dlc = {
        .ir = 0x100u << 21, .dtr = 2, .dlr = 0x44332211u, .dhr = 0x88776655u
    };
    TEST_ASSERT_TRUE(bxcan_frame_from_mailbox(&short_dlc, &f));
    const uint8_t two[8] = { 0x11, 0x22, 0, 0, 0, 0, 0, 0 };
    TEST_ASSERT_EQUAL_UINT8_ARRAY(two, f.data, 8);
}

/* ----------------------------------------------------------------- ring */

static can_ring_t ring;

static hal_can_frame_t frame(uint32_t id)
{
    return (hal_can_frame_t){ .id = id, .dlc = 1, .data = { (uint8_t)id } };
}

static void test_can_ring_fifo_order(void)
{
    can_ring_init(&ring);
    hal_can_frame_t f;
    TEST_ASSERT_FALSE(can_ring_pop(&ring, &f));
    for (uint32_t i = 0; i < 5; i++) {
        const hal_can_frame_t in = frame(0x100 + i);
        TEST_ASSERT_TRUE(can_ring_push(&ring, &in));
    }
    TEST_ASSERT_EQUAL_UINT(5, can_ring_count(&ring));
    for (uint32_t i = 0; i < 5; i++) {
        TEST_ASSERT_TRUE(can_ring_pop(&ring, &f));
        TEST_ASSERT_EQUAL_UINT32(0x100 + i, f.id);
        TEST_ASSERT_EQUAL_UINT8((uint8_t)(0x100 + i), f.data[0]);
    }
    TEST_ASSERT_FALSE(can_ring_pop(&ring, &f));
    TEST_ASSERT_EQUAL_UINT32(0, ring.dropped);
}

/* Full: the new frame is refused and counted, the queued ones are kept. */
static void test_can_ring_full_keeps_oldest_and_counts_drops(void)
{
    can_ring_init(&ring);
    for (uint32_t i = 0; i < CAN_RING_SIZE; i++) {
        const hal_can_frame_t in = frame(i);
        TEST_ASSERT_TRUE(can_ring_push(&ring, &in));
    }
    const hal_can_frame_t extra = frame(0x7FF);
    TEST_ASSERT_FALSE(can_ring_push(&ring, &extra));
    TEST_ASSERT_FALSE(can_ring_push(&ring, &extra));
    TEST_ASSERT_EQUAL_UINT32(2, ring.dropped);
    TEST_ASSERT_EQUAL_UINT(CAN_RING_SIZE, can_ring_count(&ring));
    hal_can_frame_t f;
    for (uint32_t i = 0; i < CAN_RING_SIZE; i++) {
        TEST_ASSERT_TRUE(can_ring_pop(&ring, &f));
        TEST_ASSERT_EQUAL_UINT32(i, f.id);
    }
    /* Room again after popping. */
    TEST_ASSERT_TRUE(can_ring_push(&ring, &extra));
}

/* The indices run freely and wrap at 2^32: still FIFO, still the right count. */
static void test_can_ring_index_wrap(void)
{
    can_ring_init(&ring);
    atomic_store(&ring.head, UINT_MAX - 2u);
    atomic_store(&ring.tail, UINT_MAX - 2u);
    hal_can_frame_t f;
    for (uint32_t round = 0; round < 3; round++) {
        for (uint32_t i = 0; i < CAN_RING_SIZE; i++) {
            const hal_can_frame_t in = frame(i + round);
            TEST_ASSERT_TRUE(can_ring_push(&ring, &in));
        }
        TEST_ASSERT_EQUAL_UINT(CAN_RING_SIZE, can_ring_count(&ring));
        const hal_can_frame_t extra = frame(0x7FF);
        TEST_ASSERT_FALSE(can_ring_push(&ring, &extra));
        for (uint32_t i = 0; i < CAN_RING_SIZE; i++) {
            TEST_ASSERT_TRUE(can_ring_pop(&ring, &f));
            TEST_ASSERT_EQUAL_UINT32(i + round, f.id);
        }
        TEST_ASSERT_EQUAL_UINT(0, can_ring_count(&ring));
    }
    TEST_ASSERT_TRUE(atomic_load(&ring.head) < 1000u); /* it did wrap */
}

/* Interleaved use as the ISR and the main loop make it: pushes and pops in
 * an irregular pattern, every frame out once and in order. */
static void test_can_ring_interleaved_sequence(void)
{
    can_ring_init(&ring);
    uint32_t next_in = 0;
    uint32_t next_out = 0;
    hal_can_frame_t f;
    for (uint32_t step = 0; step < 1000; step++) {
        const uint32_t pushes = (step * 7u) % 5u;
        const uint32_t pops = (step * 3u) % 4u;
        for (uint32_t k = 0; k < pushes; k++) {
            const hal_can_frame_t in = frame(next_in & 0x7FFu);
            if (can_ring_push(&ring, &in)) {
                next_in++;
            }
        }
        for (uint32_t k = 0; k < pops && can_ring_pop(&ring, &f); k++) {
            TEST_ASSERT_EQUAL_UINT32(next_out & 0x7FFu, f.id);
            next_out++;
        }
    }
    while (can_ring_pop(&ring, &f)) {
        TEST_ASSERT_EQUAL_UINT32(next_out & 0x7FFu, f.id);
        next_out++;
    }
    TEST_ASSERT_EQUAL_UINT32(next_in, next_out);
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_bxcan_timing_f4_500k);
    RUN_TEST(test_bxcan_timing_f4_1m);
    RUN_TEST(test_bxcan_timing_f1_500k);
    RUN_TEST(test_bxcan_timing_f1_1m);
    RUN_TEST(test_bxcan_timing_hsi_fallback_prefers_more_quanta);
    RUN_TEST(test_bxcan_timing_rejects_inexact_and_bad_arguments);
    RUN_TEST(test_bxcan_timing_results_respect_register_limits);
    RUN_TEST(test_bxcan_filters_protocol_ids_use_two_list_banks);
    RUN_TEST(test_bxcan_filters_none_accepts_all_standard_data_frames);
    RUN_TEST(test_bxcan_filters_mask_pairs);
    RUN_TEST(test_bxcan_filters_mixed);
    RUN_TEST(test_bxcan_filters_sixteen_masks_fit);
    RUN_TEST(test_bxcan_filters_reject_bad_input);
    RUN_TEST(test_bxcan_mailbox_packing);
    RUN_TEST(test_bxcan_mailbox_receive_edge_cases);
    RUN_TEST(test_can_ring_fifo_order);
    RUN_TEST(test_can_ring_full_keeps_oldest_and_counts_drops);
    RUN_TEST(test_can_ring_index_wrap);
    RUN_TEST(test_can_ring_interleaved_sequence);
    return UNITY_END();
}
