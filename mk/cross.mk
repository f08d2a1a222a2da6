# SPDX-License-Identifier: MIT
# Cross builds of the firmware (firmware/*/*.c, and libfixmath in fixed mode)
# for Cortex-M with arm-none-eabi-gcc (Debian gcc-arm-none-eabi), warnings as
# errors, into build/cross/<config>/libmstc_fw.a:
#
#   m4f-float  Cortex-M4F, single-precision float on the FPU (NUMERIC=float)
#   m3-fixed   Cortex-M3, Q16.16 (NUMERIC=fixed)
#   m3-float   Cortex-M3, float in software (newlib's soft float): the
#              comparison the fixed-point mode exists to beat (make bench)
#
# `make cross` builds all three whatever NUMERIC is, each a build of
# mk/compile.mk (cross-<config>). Uses from the Makefile: CSTD, FW_INC,
# FW_SRCS, STAMP, mk/numeric.mk's NUM_*_<mode> variables and mk/auth.mk's AUTH_*.

CROSS_COMPILE ?= arm-none-eabi-
CROSS_CC ?= $(CROSS_COMPILE)gcc
CROSS_AR ?= $(CROSS_COMPILE)ar
CROSS_SIZE ?= $(CROSS_COMPILE)size
CROSS_OPT ?= -O2 -g

CROSS_CPU_m4f := -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard
CROSS_CPU_m3 := -mcpu=cortex-m3 -mthumb -mfloat-abi=soft
CROSS_CONFIGS := m4f-float m3-fixed m3-float

# $(1): config name <cpu>-<mode>; $(2): cpu; $(3): numeric mode.
define CROSS_CONFIG_RULES
CROSS_FLAGS_$(1) := $$(CROSS_CPU_$(2)) $$(CSTD) $$(CROSS_OPT) -ffunction-sections -fdata-sections \
  $$(FW_INC) $$(NUM_CFLAGS_$(3)) $$(AUTH_CFLAGS)
BUILD_CC_cross-$(1) := $$(CROSS_CC)
BUILD_CFLAGS_cross-$(1) := $$(CROSS_FLAGS_$(1))
BUILD_DIR_cross-$(1) := build/cross/$(1)/obj
BUILD_SRCS_cross-$(1) := $$(FW_SRCS) $$(NUM_SRCS_$(3)) $$(AUTH_SRCS)
BUILD_DEPS_cross-$(1) := $$(NUM_DEPS_$(3)) $$(AUTH_DEPS)
BUILD_ORDER_cross-$(1) := $$(STAMP)/apt-test
$$(eval $$(call BUILD,cross-$(1)))
build/cross/$(1)/libmstc_fw.a: $$(BUILD_OBJS_cross-$(1))
	@rm -f $$@
	$$(CROSS_AR) rcs $$@ $$^
endef
$(eval $(call CROSS_CONFIG_RULES,m4f-float,m4f,float))
$(eval $(call CROSS_CONFIG_RULES,m3-fixed,m3,fixed))
$(eval $(call CROSS_CONFIG_RULES,m3-float,m3,float))

CROSS_LIBS := $(foreach c,$(CROSS_CONFIGS),build/cross/$(c)/libmstc_fw.a)

.PHONY: cross
cross: $(CROSS_LIBS)  ## cross-compile the firmware for Cortex-M4F (float) and M3 (fixed, soft float)
	@for c in $(CROSS_CONFIGS); do \
	  printf '%-10s %s\n' $$c "$$($(CROSS_SIZE) -t build/cross/$$c/libmstc_fw.a | tail -1 | \
	    awk '{printf "text %s B, data %s B, bss %s B", $$1, $$2, $$3}')"; done
