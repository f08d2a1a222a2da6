/* SPDX-License-Identifier: MIT */
/* Blank port: start-up for a Cortex-M. TODO for another core: the reset
 * entry your toolchain and MCU expect. On a Cortex-M this is complete except
 * for the device's interrupt vectors: add one entry per interrupt the port
 * uses (the STM32 boards generate the whole table from the vendor's SVD,
 * tools/svd/svd2c). */
#include <stdint.h>

#include "hal/hal_motor.h"

/* Symbols of hal/stm32/sections.ld. */
extern uint32_t __stack_top;
extern uint32_t __data_load__, __data_start__, __data_end__;
extern uint32_t __bss_start__, __bss_end__;

int main(void);
void Reset_Handler(void);
void template_fault(void);

/* Initial stack pointer, then the handlers of exceptions 1.. (ARMv7-M ARM
 * B1.5.3). TODO: the interrupt vectors after the 15 system exceptions. */
typedef void (*handler_t)(void);
typedef struct {
    const void *initial_sp;
    handler_t system[15];
} vector_table_t;

__attribute__((section(".isr_vector"), used)) const vector_table_t template_vectors = {
    .initial_sp = &__stack_top,
    .system = { Reset_Handler, template_fault, template_fault, template_fault, template_fault,
                template_fault },
};

void Reset_Handler(void)
{
    /* TODO on a core with an FPU: enable it here, before any float code. */
    const uint32_t *src = &__data_load__;
    for (uint32_t *dst = &__data_start__; dst < &__data_end__;) {
        *dst++ = *src++;
    }
    for (uint32_t *dst = &__bss_start__; dst < &__bss_end__;) {
        *dst++ = 0u;
    }
    (void)main();
    for (;;) {
    }
}

/* A fault: stop the wheels, then wait for the watchdog. */
void template_fault(void)
{
    hal_motor_stop();
    for (;;) {
    }
}
