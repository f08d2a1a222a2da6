# SPDX-License-Identifier: MIT
# The cross toolchain (arm-none-eabi-gcc, Debian gcc-arm-none-eabi), for these
# builds and for the board images (mk/firmware.mk), and the cross builds of
# the firmware (its sources, and libfixmath in fixed mode) for Cortex-M,
# warnings as errors, into build/cross/<config>/libmstc_fw.a. A config is
# <cpu>-<numeric mode>:
#
#   m4f-float  Cortex-M4F, single-precision float on the FPU (NUMERIC=float)
#   m3-fixed   Cortex-M3, Q16.16 (NUMERIC=fixed)
#   m3-float   Cortex-M3, float in software (newlib's soft float): the
#              comparison the fixed-point mode exists to beat (make bench)
#
# `make cross` builds all three whatever NUMERIC is, each a build of
# mk/compile.mk (cross-<config>); mk/bench.mk runs the benchmark on each.
# Uses from the Makefile: CSTD, FW_INC, fw_srcs, STAMP, mk/numeric.mk's
# NUM_*_<mode> variables and mk/auth.mk's AUTH_*.

CROSS_COMPILE ?= arm-none-eabi-
CROSS_CC ?= $(CROSS_COMPILE)gcc
CROSS_AR ?= $(CROSS_COMPILE)ar
CROSS_SIZE ?= $(CROSS_COMPILE)size
CROSS_OBJCOPY ?= $(CROSS_COMPILE)objcopy
CROSS_OPT ?= -O2 -g

CROSS_CPU_m4f := -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard
CROSS_CPU_m3 := -mcpu=cortex-m3 -mthumb -mfloat-abi=soft
CROSS_CONFIGS := m4f-float m3-fixed m3-float
# The cpu and the numeric mode of config $(1).
cross_cpu = $(firstword $(subst -, ,$(1)))
cross_mode = $(lastword $(subst -, ,$(1)))

# $(1): config.
define CROSS_CONFIG_RULES
CROSS_FLAGS_$(1) := $$(CROSS_CPU_$(call cross_cpu,$(1))) $$(CSTD) $$(CROSS_OPT) -ffunction-sections \
  -fdata-sections $$(FW_INC) $$(NUM_CFLAGS_$(call cross_mode,$(1))) $$(AUTH_CFLAGS)
BUILD_CC_cross-$(1) := $$(CROSS_CC)
BUILD_CFLAGS_cross-$(1) := $$(CROSS_FLAGS_$(1))
BUILD_DIR_cross-$(1) := build/cross/$(1)/obj
BUILD_SRCS_cross-$(1) := $$(call fw_srcs,$(call cross_mode,$(1)))
BUILD_DEPS_cross-$(1) := $$(NUM_DEPS_$(call cross_mode,$(1))) $$(AUTH_DEPS)
BUILD_ORDER_cross-$(1) := $$(STAMP)/apt-test
$$(eval $$(call BUILD,cross-$(1)))
build/cross/$(1)/libmstc_fw.a: $$(BUILD_OBJS_cross-$(1))
	@rm -f $$@
	$$(CROSS_AR) rcs $$@ $$^
endef
$(foreach c,$(CROSS_CONFIGS),$(eval $(call CROSS_CONFIG_RULES,$(c))))

CROSS_LIBS := $(foreach c,$(CROSS_CONFIGS),build/cross/$(c)/libmstc_fw.a)

.PHONY: cross
cross: $(CROSS_LIBS)  ## cross-compile the firmware for Cortex-M4F (float) and M3 (fixed, soft float)
	@for c in $(CROSS_CONFIGS); do \
	  printf '%-10s %s\n' $$c "$$($(CROSS_SIZE) -t build/cross/$$c/libmstc_fw.a | tail -1 | \
	    awk '{printf "text %s B, data %s B, bss %s B", $$1, $$2, $$3}')"; done
