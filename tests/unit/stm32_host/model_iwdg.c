/* SPDX-License-Identifier: MIT */
/* The independent watchdog's behaviour (model_iwdg.h; RM0090 §21.3). */
#include "model_iwdg.h"

enum { KR = 0x0, PR = 0x4, RLR = 0x8, SR = 0xC };
#define KEY_RELOAD 0xAAAAu
#define KEY_ACCESS 0x5555u
#define KEY_START  0xCCCCu
#define PVU        0x1u
#define RVU        0x2u

/* Core cycles of @p n LSI periods. */
static uint64_t lsi_cycles(const iwdg_model_t *w, double n)
{
    return (uint64_t)(n * (double)stm32_host_clock() / (double)w->lsi_hz);
}

static uint32_t iwdg_read(stm32_host_periph_t *p, uint32_t off)
{
    iwdg_model_t *w = (iwdg_model_t *)p;
    const uint64_t now = stm32_host_cycles();
    switch (off) {
    case SR: return (now < w->pvu_until ? PVU : 0u) | (now < w->rvu_until ? RVU : 0u);
    case PR: return w->pr;
    case RLR: return w->rlr;
    default: return 0u; /* KR reads 0 */
    }
}

static void iwdg_write(stm32_host_periph_t *p, uint32_t off, uint32_t v)
{
    iwdg_model_t *w = (iwdg_model_t *)p;
    const uint64_t now = stm32_host_cycles();
    if (off == KR) {
        const uint32_t key = v & 0xFFFFu;
        w->unlocked = key == KEY_ACCESS;
        if (key == KEY_START && !w->started) {
            w->started = true;
            w->reloaded = now;
        } else if (key == KEY_RELOAD) {
            w->reloaded = now;
            w->reloads++;
        }
        return;
    }
    if (off != PR && off != RLR) {
        return;
    }
    if (!w->unlocked) {
        w->ignored++;
        return;
    }
    /* The new value reaches the LSI domain five LSI periods later. */
    if (off == PR) {
        w->pr = v & 0x7u;
        w->pvu_until = now + lsi_cycles(w, 5.0);
    } else {
        w->rlr = v & 0xFFFu;
        w->rvu_until = now + lsi_cycles(w, 5.0);
    }
}

void iwdg_model_init(iwdg_model_t *w, uint32_t base, uint32_t lsi_hz)
{
    *w = (iwdg_model_t){
        .p = { .base = base,
               .size = 0x10u,
               .name = "IWDG",
               .read = iwdg_read,
               .write = iwdg_write },
        .lsi_hz = lsi_hz,
        .rlr = 0xFFFu,
    };
    stm32_host_map(&w->p);
}

double iwdg_model_timeout_us(const iwdg_model_t *w)
{
    const unsigned pr = w->pr > 6u ? 6u : w->pr;
    return 4.0 * (double)(1u << pr) * ((double)w->rlr + 1.0) / (double)w->lsi_hz * 1e6;
}

bool iwdg_model_expired(const iwdg_model_t *w)
{
    if (!w->started) {
        return false;
    }
    const double elapsed_us =
        (double)(stm32_host_cycles() - w->reloaded) / (double)stm32_host_clock() * 1e6;
    return elapsed_us >= iwdg_model_timeout_us(w);
}
