/* SPDX-License-Identifier: MIT */
/**
 * @file stm32_host.h
 * @brief The STM32 drivers (hal/stm32) on the host, against their registers:
 *        each peripheral's register block, laid out by the SVD-generated
 *        stm32_regs.h, is host memory at the block's own address (the
 *        MCU's peripheral and System Control Space addresses are free in a
 *        Linux process) that a small behavioural model of the peripheral
 *        answers.
 *
 * How a model sees the driver's accesses: the pages are kept inaccessible
 * (PROT_NONE); an access traps (SIGSEGV), the model prepares the register
 * the instruction reads (its read hook), the page is opened and the one
 * instruction single-stepped (the x86 trap flag), and on the trap after it
 * (SIGTRAP) the model sees what was written (its write hook) and the page is
 * closed again. So a driver's register accesses meet the hardware's
 * semantics (a bit that clears when written 1, a FIFO that moves when
 * released, a status that changes as time passes), with the driver's source
 * unchanged: the only host difference is the core's few instructions
 * (cortex_m.h under STM32_HOST: these functions).
 *
 * Interrupts: a model raises one (stm32_host_pend()); it is taken where the
 * core would take it, between two instructions while not masked: after any
 * register access (from the trap that ends it: the handler's own accesses
 * trap in turn), when the driver unmasks (cm_irq_restore), pends one itself
 * (cm_nvic_set_pending) or waits (cm_wfi), or the test lets time pass
 * (stm32_host_run_us()). One level: a handler is not interrupted. Time is
 * core cycles: every register access costs STM32_HOST_ACCESS_CYCLES (the
 * instructions around it too), so a driver's polling loop sees time pass,
 * SysTick's interrupt come, and its time-outs expire.
 *
 * x86-64 Linux only (the trap flag, the page-fault error code); elsewhere
 * this fails to compile, loudly.
 */
#ifndef STM32_HOST_H
#define STM32_HOST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/** @brief Cycles each trapped register access costs the core. */
#define STM32_HOST_ACCESS_CYCLES 32u

/** @brief A peripheral model: its block and its two hooks. */
typedef struct stm32_host_periph {
    uint32_t base;    /**< the block's address on the MCU */
    uint32_t size;    /**< bytes (at most one page) */
    const char *name; /**< for messages */
    /** Before the driver reads register @p off (or reads and writes it in
     *  one instruction): its value. NULL: the last value written. */
    uint32_t (*read)(struct stm32_host_periph *p, uint32_t off);
    /** After the driver wrote @p value at @p off (@p bytes wide, 1, 2 or 4:
     *  the whole register with the others' bytes as they read). NULL: kept. */
    void (*write)(struct stm32_host_periph *p, uint32_t off, uint32_t value);
    uint32_t reg[1024];    /**< the registers as the model keeps them, by off / 4 */
    volatile uint8_t *mem; /**< the registers the driver accesses (at base) */
    unsigned accesses;     /**< trapped accesses so far */
} stm32_host_periph_t;

/** @brief Start over: no blocks mapped, time 0, no interrupt enabled or
 *         pending, interrupts unmasked, no handlers. Call from setUp(). */
void stm32_host_reset(void);

/** @brief Map @p p's block at its own address (its reg[] the reset
 *         values), inaccessible until the driver touches it; aborts when
 *         the host has something else there. */
void stm32_host_map(stm32_host_periph_t *p);

/** @brief Core cycles since stm32_host_reset(). */
uint64_t stm32_host_cycles(void);

/** @brief The core runs @p cycles (without taking interrupts). */
void stm32_host_spend(uint64_t cycles);

/** @brief The core clock [Hz], for the SysTick model and stm32_host_run_us(). */
void stm32_host_set_clock(uint32_t hz);
uint32_t stm32_host_clock(void);

/** @brief Let @p us of time pass, taking interrupts as they fall due. */
void stm32_host_run_us(uint64_t us);

/** @brief An interrupt handler: IRQ @p irqn (>= 0), or SysTick (-1). */
void stm32_host_vector(int irqn, void (*handler)(void));

/** @brief A model raises IRQ @p irqn (-1: SysTick): taken when enabled and
 *         not masked, at the next point the core would take it. Raised
 *         while its own handler runs, it is not pending again for that:
 *         a level still asserted when the handler returns is (the model's
 *         level function, stm32_host_on_level()). */
void stm32_host_pend(int irqn);

/** @brief @p level (with @p ctx) is called after every handler returns: a
 *         model pends again what it still asserts, as the NVIC does for a
 *         level-sensitive line at exception return; up to eight. */
void stm32_host_on_level(void (*level)(void *ctx), void *ctx);

/** @brief Take every pending, enabled interrupt now, unless masked. */
void stm32_host_take_interrupts(void);

/** @brief IRQ @p irqn enabled in the NVIC (the driver's ISER writes). */
bool stm32_host_irq_enabled(int irqn);

/** @brief Its priority byte (IPR). */
uint8_t stm32_host_irq_priority(int irqn);

/** @brief Interrupts taken so far, of IRQ @p irqn (-1: SysTick). */
unsigned stm32_host_taken(int irqn);

/** @brief PRIMASK as the driver set it. */
bool stm32_host_masked(void);

/** @brief @p tick (with @p ctx) is called whenever time passes
 *         (stm32_host_spend()), with the core cycle now: a model advances;
 *         up to eight, until stm32_host_reset(). */
void stm32_host_on_time(void (*tick)(void *ctx, uint64_t cycles), void *ctx);

/* ----------------------------------------------- the core's instructions */

uint32_t stm32_host_irq_save(void);
void stm32_host_irq_restore(uint32_t primask);
void stm32_host_irq_enable_all(void);
void stm32_host_irq_disable_all(void);
void stm32_host_wfi(void);
void stm32_host_system_reset(void);

/** @brief A system reset was requested (cm_system_reset()). */
bool stm32_host_reset_requested(void);

#endif /* STM32_HOST_H */
