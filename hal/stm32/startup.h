/* SPDX-License-Identifier: MIT */
/**
 * @file startup.h
 * @brief Start-up of the STM32 ports: the vector table's type (the table
 *        itself is generated from the SVD into stm32_vectors.c), the reset
 *        and default handlers, and the symbols of the linker script
 *        (hal/stm32/sections.ld).
 */
#ifndef STM32_STARTUP_H
#define STM32_STARTUP_H

#include <stdint.h>

#include "stm32_regs.h"

typedef void (*stm32_handler_t)(void);

/** @brief The vector table (ARMv7-M ARM B1.5.3): initial SP, then handlers. */
typedef struct {
    const void *initial_sp;
    stm32_handler_t system[15];           /**< Reset .. SysTick (exceptions 1..15) */
    stm32_handler_t irq[STM32_IRQ_COUNT]; /**< exceptions 16.. */
} stm32_vector_table_t;

extern const stm32_vector_table_t stm32_vectors;

/* Linker-script symbols (sections.ld). */
extern uint32_t __stack_top;
extern uint32_t __data_load__, __data_start__, __data_end__;
extern uint32_t __bss_start__, __bss_end__;

/** @brief Entry after reset: FPU on (M4F), .data copied, .bss zeroed, main(). */
void Reset_Handler(void);

/** @brief Every handler a port does not define (generated, in
 *         stm32_vectors.c, with the weak aliases): calls stm32_unhandled(). */
void Default_Handler(void);

/** @brief A fault or an unexpected interrupt: stops the motors, then waits
 *         for the watchdog. */
void stm32_unhandled(void);

int main(void);

#endif /* STM32_STARTUP_H */
