/* SPDX-License-Identifier: MIT */
/**
 * @file model_iwdg.h
 * @brief The independent watchdog (RM0090 §21): started by the key 0xCCCC,
 *        counting down from RLR at f_LSI / (4·2^PR), reloaded by 0xAAAA; PR
 *        and RLR writable only after 0x5555 (any other key protects them
 *        again), each write taking five LSI periods to reach the LSI domain,
 *        while SR.PVU or SR.RVU reads 1; a count reaching 0 resets the MCU.
 */
#ifndef MODEL_IWDG_H
#define MODEL_IWDG_H

#include <stdbool.h>
#include <stdint.h>

#include "stm32_host.h"

typedef struct {
    stm32_host_periph_t p;
    uint32_t lsi_hz; /**< the LSI as it runs (not its nominal figure) */
    bool started;
    bool unlocked;      /**< PR and RLR writable */
    uint32_t pr, rlr;   /**< in force */
    uint64_t pvu_until; /**< core cycle PR's update is done */
    uint64_t rvu_until; /**< ... RLR's */
    uint64_t reloaded;  /**< core cycle of the last reload (or the start) */
    unsigned reloads;   /**< 0xAAAA keys */
    unsigned ignored;   /**< PR/RLR writes while protected */
} iwdg_model_t;

/** @brief Map the IWDG at @p base, its LSI at @p lsi_hz, at reset. */
void iwdg_model_init(iwdg_model_t *w, uint32_t base, uint32_t lsi_hz);

/** @brief Its time-out in force [µs of the core's clock]. */
double iwdg_model_timeout_us(const iwdg_model_t *w);

/** @brief It has reached 0 since its last reload: the MCU would reset. */
bool iwdg_model_expired(const iwdg_model_t *w);

#endif /* MODEL_IWDG_H */
