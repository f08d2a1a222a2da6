/* SPDX-License-Identifier: MIT */
/**
 * @file cortex_m.h
 * @brief The few ARMv7-M core registers and instructions the STM32 ports use
 *        (Cortex-M3 and Cortex-M4 alike). Hand-written: they belong to the
 *        architecture, not to a vendor's SVD. Addresses from the ARMv7-M
 *        Architecture Reference Manual (ARM DDI 0403E): B3.2.2 (System
 *        Control Block), B3.3.2 (SysTick), B3.4.3 (NVIC); CPACR from B3.2.20.
 */
#ifndef STM32_CORTEX_M_H
#define STM32_CORTEX_M_H

#include <stdint.h>

#if defined(STM32_HOST)
/* The drivers compiled for the host (tests/unit/stm32_host): the registers
 * are at their own addresses, in host memory a model answers; the core's
 * instructions are the model's functions (below). */
#include "stm32_host.h"
#endif

#define CM_REG(addr)  (*(volatile uint32_t *)(uintptr_t)(addr))
#define CM_REG8(addr) (*(volatile uint8_t *)(uintptr_t)(addr))

/* System Control Block (B3.2.2). */
#define CM_SCB_ICSR             CM_REG(0xE000ED04u) /**< Interrupt Control and State */
#define CM_SCB_VTOR             CM_REG(0xE000ED08u) /**< Vector Table Offset */
#define CM_SCB_AIRCR            CM_REG(0xE000ED0Cu) /**< Application Interrupt and Reset Control */
#define CM_SCB_SHPR3            CM_REG(0xE000ED20u) /**< System Handler Priority 3 (PendSV, SysTick) */
#define CM_SCB_CPACR            CM_REG(0xE000ED88u) /**< Coprocessor Access Control */
#define CM_ICSR_PENDSTSET       (1u << 26)          /**< SysTick exception pending */
#define CM_AIRCR_VECTKEY        (0x05FAu << 16)
#define CM_AIRCR_SYSRESETREQ    (1u << 2)
#define CM_CPACR_CP10_CP11_FULL (0xFu << 20) /**< FPU (CP10, CP11): full access */

/* SysTick (B3.3.2). */
#define CM_SYST_CSR           CM_REG(0xE000E010u)
#define CM_SYST_RVR           CM_REG(0xE000E014u)
#define CM_SYST_CVR           CM_REG(0xE000E018u)
#define CM_SYST_CSR_ENABLE    (1u << 0)
#define CM_SYST_CSR_TICKINT   (1u << 1)
#define CM_SYST_CSR_CLKSOURCE (1u << 2) /**< processor clock */

/* NVIC (B3.4.3): 32 interrupts per word; priority bytes. */
#define CM_NVIC_ISER(n)   CM_REG(0xE000E100u + 4u * (n))
#define CM_NVIC_ICER(n)   CM_REG(0xE000E180u + 4u * (n))
#define CM_NVIC_ISPR(n)   CM_REG(0xE000E200u + 4u * (n))
#define CM_NVIC_IPR8(irq) CM_REG8(0xE000E400u + (irq))

/** @brief Priority bits the STM32 implement (the upper nibble of each byte). */
#define CM_PRIO_BITS 4u

#if defined(STM32_HOST)
static inline void cm_irq_enable_all(void) { stm32_host_irq_enable_all(); }
static inline void cm_irq_disable_all(void) { stm32_host_irq_disable_all(); }
static inline uint32_t cm_irq_save(void) { return stm32_host_irq_save(); }
static inline void cm_irq_restore(uint32_t primask) { stm32_host_irq_restore(primask); }
static inline void cm_wfi(void) { stm32_host_wfi(); }
static inline void cm_dsb(void) {}
static inline void cm_isb(void) {}
#else
static inline void cm_irq_enable_all(void) { __asm volatile("cpsie i" ::: "memory"); }
static inline void cm_irq_disable_all(void) { __asm volatile("cpsid i" ::: "memory"); }

/** @brief PRIMASK now (1: interrupts masked). */
static inline uint32_t cm_primask(void)
{
    uint32_t r;
    __asm volatile("mrs %0, primask" : "=r"(r));
    return r;
}

/** @brief Mask interrupts; returns the previous PRIMASK for cm_irq_restore(). */
static inline uint32_t cm_irq_save(void)
{
    const uint32_t r = cm_primask();
    cm_irq_disable_all();
    return r;
}

static inline void cm_irq_restore(uint32_t primask)
{
    if (primask == 0u) {
        cm_irq_enable_all();
    }
}

/** @brief Sleep until an interrupt is pending; wakes even with PRIMASK set,
 *         which is what makes "mask, check, wfi, unmask" free of races. */
static inline void cm_wfi(void) { __asm volatile("wfi" ::: "memory"); }
static inline void cm_dsb(void) { __asm volatile("dsb" ::: "memory"); }
static inline void cm_isb(void) { __asm volatile("isb" ::: "memory"); }
#endif

static inline void cm_nvic_enable(unsigned irq) { CM_NVIC_ISER(irq >> 5) = 1u << (irq & 31u); }
static inline void cm_nvic_disable(unsigned irq) { CM_NVIC_ICER(irq >> 5) = 1u << (irq & 31u); }
static inline void cm_nvic_set_pending(unsigned irq)
{
    CM_NVIC_ISPR(irq >> 5) = 1u << (irq & 31u);
#if defined(STM32_HOST)
    stm32_host_take_interrupts(); /* taken at once when not masked, as by the core */
#endif
}

/** @brief Priority of an IRQ, 0 (most urgent) .. 15. */
static inline void cm_nvic_set_priority(unsigned irq, unsigned prio)
{
    CM_NVIC_IPR8(irq) = (uint8_t)(prio << (8u - CM_PRIO_BITS));
}

/** @brief Request a system reset (B3.2.6); does not return. */
static inline void cm_system_reset(void)
{
    cm_dsb();
    CM_SCB_AIRCR = CM_AIRCR_VECTKEY | CM_AIRCR_SYSRESETREQ;
    cm_dsb();
#if defined(STM32_HOST)
    stm32_host_system_reset();
#else
    for (;;) {
    }
#endif
}

#endif /* STM32_CORTEX_M_H */
