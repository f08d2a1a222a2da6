# SPDX-License-Identifier: MIT
# STM32F405 board (included by mk/firmware.mk). Cortex-M4F: float mode, with
# the single-precision FPU (hard-float ABI).
BOARD_NUMERIC := float
BOARD_CPU := -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16
BOARD_SRCS := $(STM32_SRCS) hal/stm32f405/board.c
# CAN transports (mk/firmware.mk), the default first.
BOARD_CANS := bxcan slcan
BOARD_INC := -Ihal/stm32f405 -Ihal/stm32
BOARD_LD := hal/stm32f405/link.ld
BOARD_SVD := hal/stm32f405/svd.json
