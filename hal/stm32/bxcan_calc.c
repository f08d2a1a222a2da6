/* SPDX-License-Identifier: MIT */
/* bxCAN: the board-independent computations (see bxcan_calc.h). */
#include "bxcan_calc.h"

#include <errno.h>
#include <stddef.h>

#include "div64.h"

/* Register encodings (RM0090 §32.9.2-3 [RM0008 §24.9.2-3]). */
#define BTR_BRP_POS  0u
#define BTR_TS1_POS  16u
#define BTR_TS2_POS  20u
#define BTR_SJW_POS  24u
#define IR_STID_POS  21u
#define IR_IDE       (1u << 2)
#define IR_RTR       (1u << 1)
/* A 16-bit filter entry: STID[10:0] in 15:5, RTR in 4, IDE in 3, EXID[17:15]
 * in 2:0 (RM0090 Figure 342 [RM0008 Figure 230]). */
#define F16_STID_POS 5u
#define F16_RTR      (1u << 4)
#define F16_IDE      (1u << 3)

#define MIN_TQ 8u
#define MAX_TQ 25u

int bxcan_timing(uint32_t pclk_hz, uint32_t bitrate, uint16_t sample_point_permille,
                 bxcan_timing_t *t)
{
    if (t == NULL || pclk_hz == 0u || bitrate == 0u || sample_point_permille < 500u ||
        sample_point_permille > 950u) {
        return -EINVAL;
    }
    bool found = false;
    uint32_t best_err = 0u;
    bxcan_timing_t best = { 0 };
    /* From the most quanta down and the shortest ts2 up: a tie keeps the
     * larger N, then the later sample point. */
    for (uint32_t n = MAX_TQ; n >= MIN_TQ; n--) {
        const uint64_t per_bit = (uint64_t)bitrate * n;
        uint64_t left = 0u;
        const uint64_t brp = div64_u(pclk_hz, per_bit, &left);
        if (left != 0u) {
            continue;
        }
        if (brp < 1u || brp > 1024u) {
            continue;
        }
        for (uint32_t ts2 = 1u; ts2 <= 8u; ts2++) {
            const uint32_t ts1 = n - 1u - ts2;
            if (ts1 < 1u || ts1 > 16u) {
                continue;
            }
            /* The sample point is sp_num / n ‰; its error is diff / n ‰,
             * compared exactly across different n by cross-multiplying. */
            const uint32_t sp_num = 1000u * (1u + ts1);
            const uint32_t target = (uint32_t)sample_point_permille * n;
            const uint32_t diff = sp_num > target ? sp_num - target : target - sp_num;
            const uint32_t best_n = found ? 1u + best.ts1 + best.ts2 : 1u;
            if (!found || (uint64_t)diff * best_n < (uint64_t)best_err * n) {
                found = true;
                best_err = diff;
                best = (bxcan_timing_t){ .brp = (uint16_t)brp,
                                         .ts1 = (uint8_t)ts1,
                                         .ts2 = (uint8_t)ts2,
                                         .sjw = (uint8_t)(ts2 < 4u ? ts2 : 4u) };
            }
        }
    }
    if (!found) {
        return -EINVAL;
    }
    *t = best;
    return 0;
}

unsigned bxcan_sample_point_permille(const bxcan_timing_t *t)
{
    const unsigned n = 1u + t->ts1 + t->ts2;
    return 1000u * (1u + t->ts1) / n;
}

uint32_t bxcan_btr(const bxcan_timing_t *t)
{
    return ((uint32_t)(t->sjw - 1u) << BTR_SJW_POS) | ((uint32_t)(t->ts2 - 1u) << BTR_TS2_POS) |
           ((uint32_t)(t->ts1 - 1u) << BTR_TS1_POS) | ((uint32_t)(t->brp - 1u) << BTR_BRP_POS);
}

/* A 16-bit entry matching a standard data frame with identifier @p id. */
static uint32_t f16_id(uint32_t id) { return (id & HAL_CAN_MAX_STD_ID) << F16_STID_POS; }

/* The 16-bit mask of a filter: the id bits of @p mask, and IDE and RTR
 * always compared (they must be 0). */
static uint32_t f16_mask(uint32_t mask)
{
    return ((mask & HAL_CAN_MAX_STD_ID) << F16_STID_POS) | F16_RTR | F16_IDE;
}

int bxcan_filter_banks(const hal_can_filter_t *filters, unsigned n, bxcan_bank_t *banks,
                       unsigned max_banks, unsigned *n_banks)
{
    if (n > 16u || (n > 0u && filters == NULL) || banks == NULL || n_banks == NULL) {
        return -EINVAL;
    }
    if (n == 0u) {
        if (max_banks < 1u) {
            return -EINVAL;
        }
        const uint32_t pair = (f16_mask(0u) << 16) | f16_id(0u);
        banks[0] = (bxcan_bank_t){ .list = false, .fr1 = pair, .fr2 = pair };
        *n_banks = 1u;
        return 0;
    }
    unsigned n_exact = 0u;
    unsigned n_masked = 0u;
    for (unsigned i = 0; i < n; i++) {
        if (filters[i].id > HAL_CAN_MAX_STD_ID || filters[i].mask > HAL_CAN_MAX_STD_ID) {
            return -EINVAL;
        }
        if (filters[i].mask == HAL_CAN_MAX_STD_ID) {
            n_exact++;
        } else {
            n_masked++;
        }
    }
    const unsigned need = (n_exact + 3u) / 4u + (n_masked + 1u) / 2u;
    if (need > max_banks) {
        return -EINVAL;
    }
    unsigned b = 0u;
    /* Exact identifiers: four 16-bit entries per bank, in the order given.
     * FiR1 holds entries 0 (bits 15:0) and 1 (31:16), FiR2 entries 2 and 3. */
    uint32_t slot[4];
    unsigned k = 0u;
    for (unsigned i = 0; i <= n; i++) {
        const bool flush = i == n ? k > 0u : k == 4u;
        if (flush) {
            for (unsigned j = k; j < 4u; j++) {
                slot[j] = slot[k - 1u];
            }
            banks[b++] = (bxcan_bank_t){ .list = true,
                                         .fr1 = (slot[1] << 16) | slot[0],
                                         .fr2 = (slot[3] << 16) | slot[2] };
            k = 0u;
        }
        if (i < n && filters[i].mask == HAL_CAN_MAX_STD_ID) {
            slot[k++] = f16_id(filters[i].id);
        }
    }
    /* Masked filters: two id/mask pairs per bank; each pair is one register,
     * the id in bits 15:0 and the mask in 31:16. */
    uint32_t pair[2];
    k = 0u;
    for (unsigned i = 0; i <= n; i++) {
        const bool flush = i == n ? k > 0u : k == 2u;
        if (flush) {
            if (k == 1u) {
                pair[1] = pair[0];
            }
            banks[b++] = (bxcan_bank_t){ .list = false, .fr1 = pair[0], .fr2 = pair[1] };
            k = 0u;
        }
        if (i < n && filters[i].mask != HAL_CAN_MAX_STD_ID) {
            pair[k++] = (f16_mask(filters[i].mask) << 16) | f16_id(filters[i].id & filters[i].mask);
        }
    }
    *n_banks = b;
    return 0;
}

void bxcan_mailbox_from_frame(const hal_can_frame_t *f, bxcan_mailbox_t *mb)
{
    mb->ir = (f->id & HAL_CAN_MAX_STD_ID) << IR_STID_POS;
    mb->dtr = f->dlc & 0xFu;
    mb->dlr = (uint32_t)f->data[0] | ((uint32_t)f->data[1] << 8) | ((uint32_t)f->data[2] << 16) |
              ((uint32_t)f->data[3] << 24);
    mb->dhr = (uint32_t)f->data[4] | ((uint32_t)f->data[5] << 8) | ((uint32_t)f->data[6] << 16) |
              ((uint32_t)f->data[7] << 24);
}

bool bxcan_frame_from_mailbox(const bxcan_mailbox_t *mb, hal_can_frame_t *f)
{
    if ((mb->ir & (IR_IDE | IR_RTR)) != 0u) {
        return false;
    }
    uint8_t dlc = (uint8_t)(mb->dtr & 0xFu);
    if (dlc > HAL_CAN_MAX_DLC) {
        dlc = HAL_CAN_MAX_DLC;
    }
    f->id = mb->ir >> IR_STID_POS;
    f->dlc = dlc;
    for (unsigned i = 0; i < HAL_CAN_MAX_DLC; i++) {
        const uint32_t word = i < 4u ? mb->dlr : mb->dhr;
        f->data[i] = i < dlc ? (uint8_t)(word >> (8u * (i & 3u))) : 0u;
    }
    return true;
}
