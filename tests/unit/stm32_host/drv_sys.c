/* SPDX-License-Identifier: MIT */
/* hal/stm32/sys.c compiled for the host, against the register models
 * (stm32_host.h): its own source, unchanged, in a unit of its own so that
 * STM32_HOST is this unit's flag and not the source's in every build. */
#include "sys.c"
