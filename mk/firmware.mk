# SPDX-License-Identifier: MIT
# Board images: the firmware cross-compiled and linked for a board
# (hal/<board>/), with its start-up, drivers and main loop; each board is a
# build of mk/compile.mk (img-<board>). Included by the top Makefile after
# mk/compile.mk. Uses from the Makefile: FW_INC, PY, STAMP, FW_SRCS, the venv
# rule; from mk/numeric.mk the NUM_*_<mode> variables; from mk/auth.mk AUTH_*
# and KEY_HEADER, the device key compiled into every image.
#
#   make firmware BOARD=stm32f405   Cortex-M4F, float   -> build/firmware/stm32f405/
#   make firmware BOARD=stm32f103   Cortex-M3, fixed    -> build/firmware/stm32f103/
#   make firmware BOARD=template    the blank port: compiles and links, runs nowhere
#   make firmware-all               the three, then the budget check
#   make firmware-budget            flash, RAM, stack of both images vs. the budgets
#   make firmware-smoke             both images under QEMU (tools/bench/qemu_smoke)
#   make flash BOARD=... [FLASH_TOOL=openocd|st-flash|pyocd] [FLASH_DRY_RUN=1]
#
# Each board picks its numeric mode in hal/<board>/board.mk (BOARD_NUMERIC),
# whatever NUMERIC is; BOARD_NUMERIC=float|fixed on the command line
# overrides it. Outputs in build/firmware/<board>/: mstc.elf, mstc.bin,
# mstc.hex, mstc.map, size.txt (bytes per module), and obj-<numeric>/ with a
# .su file per object (-fstack-usage: frame sizes, for tools/bench/board_budget).

IMG_BOARDS := stm32f405 stm32f103 template
BOARD ?= stm32f405
CROSS_COMPILE ?= arm-none-eabi-
IMG_CC := $(CROSS_COMPILE)gcc
IMG_OBJCOPY := $(CROSS_COMPILE)objcopy
# -Os: the images must fit 32 KB of flash (docs/porting.md, budgets).
IMG_OPT ?= -Os -g3

# Shared STM32 code: bxCAN, IWDG, SysTick, timers, start-up, main loop.
STM32_SRCS := $(sort $(wildcard hal/stm32/*.c))

ifneq ($(filter firmware flash,$(MAKECMDGOALS)),)
ifeq ($(filter $(BOARD),$(IMG_BOARDS)),)
$(error BOARD must be one of: $(IMG_BOARDS) (not '$(BOARD)'))
endif
endif

# Each board's settings, read from its board.mk into IMG_<var>_<board>.
define IMG_BOARD_LOAD
include hal/$(1)/board.mk
IMG_NUMERIC_$(1) := $$(BOARD_NUMERIC)
IMG_CPU_$(1) := $$(BOARD_CPU)
IMG_SRCS_$(1) := $$(BOARD_SRCS)
IMG_INC_$(1) := $$(BOARD_INC)
IMG_LD_$(1) := $$(BOARD_LD)
IMG_SVD_$(1) := $$(BOARD_SVD)
endef
$(foreach b,$(IMG_BOARDS),$(eval $(call IMG_BOARD_LOAD,$(b))))

# Rules of one board. $(1): board; $(2): its numeric mode.
define IMG_RULES
IMG_DIR_$(1) := build/firmware/$(1)
IMG_OBJ_$(1) := build/firmware/$(1)/obj-$(2)
IMG_GEN_$(1) := build/firmware/$(1)/gen
IMG_GENH_$(1) := $$(if $$(IMG_SVD_$(1)),$$(IMG_GEN_$(1))/stm32_regs.h)
BUILD_CC_img-$(1) := $$(IMG_CC)
BUILD_CFLAGS_img-$(1) := -std=c11 $$(IMG_OPT) $$(IMG_CPU_$(1)) -ffunction-sections \
  -fdata-sections -fno-common -fstack-usage $$(FW_INC) $$(IMG_INC_$(1)) \
  $$(if $$(IMG_SVD_$(1)),-I$$(IMG_GEN_$(1))) -I$$(dir $$(KEY_HEADER)) $$(NUM_CFLAGS_$(2)) \
  $$(AUTH_CFLAGS)
BUILD_DIR_img-$(1) := $$(IMG_OBJ_$(1))
BUILD_SRCS_img-$(1) := $$(FW_SRCS) $$(NUM_SRCS_$(2)) $$(AUTH_SRCS) $$(IMG_SRCS_$(1))
BUILD_DEPS_img-$(1) := $$(NUM_DEPS_$(2)) $$(AUTH_DEPS)
BUILD_ORDER_img-$(1) := $$(STAMP)/apt-test $$(IMG_GENH_$(1)) $$(KEY_HEADER)
$$(eval $$(call BUILD,img-$(1)))
IMG_OBJS_$(1) := $$(BUILD_OBJS_img-$(1)) $$(if $$(IMG_SVD_$(1)),$$(IMG_OBJ_$(1))/gen/stm32_vectors.o)

ifneq ($$(IMG_SVD_$(1)),)
# Register header and vector table from the vendor's SVD (tools/svd/).
$$(IMG_GEN_$(1))/stm32_regs.h $$(IMG_GEN_$(1))/stm32_vectors.c &: $$(IMG_SVD_$(1)) \
    tools/svd/svd2c.py deps/svd/.sha256 | .venv/.requirements.sha256
	$$(PY) tools/svd/svd2c.py $$(IMG_SVD_$(1)) deps/svd $$(IMG_GEN_$(1))
# The generated vector table: the board's compile, its object in gen/.
$$(IMG_OBJ_$(1))/gen/stm32_vectors.o: $$(IMG_GEN_$(1))/stm32_vectors.c \
    $$(IMG_GEN_$(1))/stm32_regs.h | $$(STAMP)/apt-test
	@mkdir -p $$(dir $$@)
	$$(call build_cmd,img-$(1),$$<,$$@)
-include $$(IMG_OBJ_$(1))/gen/stm32_vectors.d
COMPILES += img-$(1)@$$(IMG_GEN_$(1))/stm32_vectors.c@$$(IMG_OBJ_$(1))/gen/stm32_vectors.o
endif

# Relink when the numeric mode changes (the objects live in obj-<numeric>/).
$$(IMG_DIR_$(1))/numeric.txt: FORCE
	@mkdir -p $$(@D)
	@echo $(2) | cmp -s - $$@ || echo $(2) > $$@
$$(IMG_DIR_$(1))/mstc.elf: $$(IMG_OBJS_$(1)) $$(IMG_LD_$(1)) hal/stm32/sections.ld \
    $$(IMG_DIR_$(1))/numeric.txt
	$$(IMG_CC) $$(IMG_CPU_$(1)) -nostartfiles --specs=nano.specs -Wl,--gc-sections \
	  -Wl,-Map=$$(IMG_DIR_$(1))/mstc.map -Wl,--no-warn-rwx-segments -Lhal/stm32 \
	  -T$$(IMG_LD_$(1)) -o $$@ $$(IMG_OBJS_$(1)) -Wl,--start-group -lc -lm -lgcc -Wl,--end-group
$$(IMG_DIR_$(1))/mstc.bin: $$(IMG_DIR_$(1))/mstc.elf
	$$(IMG_OBJCOPY) -O binary $$< $$@
$$(IMG_DIR_$(1))/mstc.hex: $$(IMG_DIR_$(1))/mstc.elf
	$$(IMG_OBJCOPY) -O ihex $$< $$@
$$(IMG_DIR_$(1))/size.txt: $$(IMG_DIR_$(1))/mstc.elf tools/bench/board_budget \
    | .venv/.requirements.sha256
	$$(PY) tools/bench/board_budget --modules $$(IMG_DIR_$(1)) > $$@
.PHONY: img-$(1)
img-$(1): $$(addprefix $$(IMG_DIR_$(1))/,mstc.elf mstc.bin mstc.hex size.txt)
endef
$(foreach b,$(IMG_BOARDS),$(eval $(call IMG_RULES,$(b),$(IMG_NUMERIC_$(b)))))

.PHONY: FORCE
FORCE:

deps/svd/.sha256: tools/svd/svd.lock tools/svd/fetch | .venv/.requirements.sha256
	@tools/svd/fetch && touch $@

.PHONY: firmware firmware-all firmware-budget firmware-smoke flash
firmware: img-$(BOARD)  ## build a board image: BOARD=stm32f405|stm32f103|template
	@cat build/firmware/$(BOARD)/size.txt

firmware-all: $(addprefix img-,$(IMG_BOARDS))  ## build every board image, then check the budgets
	@$(PY) tools/bench/board_budget build/firmware/stm32f405 build/firmware/stm32f103

firmware-budget: img-stm32f405 img-stm32f103  ## flash, RAM and stack of the board images vs. budgets
	@$(PY) tools/bench/board_budget build/firmware/stm32f405 build/firmware/stm32f103

firmware-smoke: img-stm32f405 img-stm32f103  ## run both board images under QEMU: does the loop run?
	@$(PY) tools/bench/qemu_smoke build/firmware/stm32f405 build/firmware/stm32f103

# make flash BOARD=... [FLASH_TOOL=openocd|st-flash|pyocd] [FLASH_DRY_RUN=1]
# [FLASH_ARGS="--interface cmsis-dap.cfg"]: tools/flash says how each works.
FLASH_TOOL ?= openocd
flash: img-$(BOARD)  ## flash BOARD's image (FLASH_TOOL=openocd|st-flash|pyocd; FLASH_DRY_RUN=1: print only)
ifeq ($(FLASH_DRY_RUN),)
	@tools/setup/apt-install tools/setup/debian-flash.txt
endif
	@$(PY) tools/flash --board $(BOARD) --tool $(FLASH_TOOL) $(if $(FLASH_DRY_RUN),--dry-run) \
	  $(FLASH_ARGS) build/firmware/$(BOARD)/mstc.elf
