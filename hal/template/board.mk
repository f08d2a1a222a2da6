# SPDX-License-Identifier: MIT
# The blank port (included by mk/firmware.mk for BOARD=template): compiles and
# links against every HAL service, runs nowhere. Copy hal/template to
# hal/<yourboard>, then change the four lines below (docs/porting.md).
#
# TODO numeric mode: float with an FPU, fixed without one.
BOARD_NUMERIC := float
# TODO the compiler's CPU flags (here: any Cortex-M3, soft float).
BOARD_CPU := -mcpu=cortex-m3 -mthumb -mfloat-abi=soft
# TODO your sources; add $(STM32_SRCS) to reuse hal/stm32 on an STM32, and
# then name its CAN transports, the default first (mk/firmware.mk):
# BOARD_CANS := bxcan slcan
BOARD_SRCS := $(sort $(wildcard hal/template/*.c))
BOARD_INC := -Ihal/template
# TODO your MCU's memory map.
BOARD_LD := hal/template/link.ld
# Register header generated from a vendor SVD (tools/svd/svd2c): set to
# hal/<yourboard>/svd.json to have build/firmware/<board>/gen/stm32_regs.h.
BOARD_SVD :=
