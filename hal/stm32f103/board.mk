# SPDX-License-Identifier: MIT
# STM32F103 board (included by mk/firmware.mk). Cortex-M3 without FPU: fixed
# point (Q16.16), soft-float ABI for the little float left (parameters).
BOARD_NUMERIC := fixed
BOARD_CPU := -mcpu=cortex-m3 -mthumb -mfloat-abi=soft
BOARD_SRCS := $(STM32_SRCS) hal/stm32f103/board.c
# CAN transports (mk/firmware.mk), the default first.
BOARD_CANS := bxcan slcan
BOARD_INC := -Ihal/stm32f103 -Ihal/stm32
BOARD_LD := hal/stm32f103/link.ld
BOARD_SVD := hal/stm32f103/svd.json
