# SPDX-License-Identifier: MIT
# Board images: the firmware cross-compiled and linked for a board
# (hal/<board>/), with its start-up, drivers and main loop; each board is a
# build of mk/compile.mk (img-<board>). Included by the top Makefile after
# mk/cross.mk (the toolchain). Uses from the Makefile: FW_INC, PY, STAMP,
# fw_srcs, the venv rule; from mk/numeric.mk the NUM_*_<mode> variables; from
# mk/auth.mk AUTH_* and install_key (images are built without a key; `make
# flash` installs the device key into a private copy).
#
#   make firmware BOARD=stm32f405   Cortex-M4F, float   -> build/firmware/stm32f405/
#   make firmware BOARD=stm32f103   Cortex-M3, fixed    -> build/firmware/stm32f103/
#   make firmware BOARD=template    the blank port: compiles and links, runs nowhere
#   make firmware BOARD=... CAN=slcan  the same image with CAN over a UART (slcan)
#                                   -> build/firmware/<board>-slcan/ (docs/hil.md)
#   make firmware-all               the three, then the budget check
#   make firmware-budget            flash, RAM, stack of the four STM32 images vs. the budgets
#   make firmware-smoke             both images under QEMU (python -m mstc.bench.qemu_smoke)
#   make flash BOARD=... [FLASH_TOOL=openocd|st-flash|pyocd] [FLASH_DRY_RUN=1]
#
# Each board picks its numeric mode in hal/<board>/board.mk (BOARD_NUMERIC),
# whatever NUMERIC is; BOARD_NUMERIC=float|fixed on the command line
# overrides it. Outputs in build/firmware/<board>/: mstc.elf, mstc.bin,
# mstc.hex, mstc.map, size.txt (bytes per module), and obj-<numeric>/ with a
# .su file per object (-fstack-usage: frame sizes, for python -m mstc.bench.budget).

IMG_BOARDS := stm32f405 stm32f103 template
BOARD ?= stm32f405
# -Os: the images must fit 64 KB of flash (docs/porting.md, budgets).
# -fno-math-errno: sqrtf is the M4F's VSQRT instruction rather than a call
# that also sets errno (the firmware reads no errno; num_sqrt never passes a
# negative), the same correctly rounded result in less flash. It deletes no
# check of non-finite values (-ffast-math would, and is never used).
IMG_OPT ?= -Os -g3 -fno-math-errno
# Loops that copy stay loops, not calls to newlib's memcpy (300 B of flash
# for the start-up's copy of .data and slcan's short answers).
SRC_CFLAGS_hal/stm32/startup.c := -fno-tree-loop-distribute-patterns
SRC_CFLAGS_hal/stm32/slcan_codec.c := -fno-tree-loop-distribute-patterns

# CAN transport of the STM32 images, the only sources in which the two
# variants of a board's image differ (docs/hil.md): bxCAN, the default, or
# slcan over a UART. A board lists the ones it has in BOARD_CANS, default
# first; the other variants get their own directory, <board>-<can>.
CAN ?= bxcan
STM32_CAN_SRCS_bxcan := hal/stm32/bxcan.c hal/stm32/bxcan_calc.c
STM32_CAN_SRCS_slcan := hal/stm32/slcan.c hal/stm32/slcan_codec.c
# The processor-in-the-loop variant (docs/hil.md): the wheels' drivers
# (encoder timers, PWM) give way to two simulated motors, the DC motor model
# of sim/dcmotor/ behind hal_encoder and hal_motor (hal/stm32/pil_wheels.c).
# Built as <board>-pil, on the slcan transport, for `make pil`; `make flash`
# cannot name it (no CAN transport is called pil), so no flashed image has it.
STM32_WHEEL_SRCS := hal/stm32/encoder.c hal/stm32/motor_pwm.c
PIL_WHEEL_SRCS := hal/stm32/pil_wheels.c $(DCMOTOR_SRCS)
IMG_PIL_BOARDS := stm32f405 stm32f103
# Shared STM32 code: IWDG, SysTick, timers, start-up, main loop.
STM32_SRCS := $(filter-out $(STM32_CAN_SRCS_bxcan) $(STM32_CAN_SRCS_slcan) $(PIL_WHEEL_SRCS), \
  $(sort $(wildcard hal/stm32/*.c)))

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
IMG_CANS_$(1) := $$(BOARD_CANS)
BOARD_CANS :=
endef
$(foreach b,$(IMG_BOARDS),$(eval $(call IMG_BOARD_LOAD,$(b))))

# Image name of board $(1) with transport $(2): the board itself for its
# first (default) transport or when it has no choice, <board>-<can> else.
img_name = $(1)$(if $(filter-out $(firstword $(IMG_CANS_$(1))),$(filter $(2),$(IMG_CANS_$(1)))),-$(2))

# Rules of one image. $(1): image; $(2): its numeric mode; $(3): board;
# $(4): CAN transport (empty for a board without the choice); $(5): pil for
# the simulated motors in place of the wheels' drivers, else empty. The register
# header is the board's, shared by its images, so that their common objects
# are compiled from the same files and come out identical.
define IMG_RULES
IMG_DIR_$(1) := build/firmware/$(1)
IMG_OBJ_$(1) := build/firmware/$(1)/obj-$(2)
IMG_GEN_$(1) := build/firmware/$(3)/gen
IMG_GENH_$(1) := $$(if $$(IMG_SVD_$(3)),$$(IMG_GEN_$(1))/stm32_regs.h)
BUILD_CC_img-$(1) := $$(CROSS_CC)
BUILD_CFLAGS_img-$(1) := -std=c11 $$(IMG_OPT) $$(IMG_CPU_$(3)) -ffunction-sections \
  -fdata-sections -fno-common -fstack-usage $$(FW_INC) $$(IMG_INC_$(3)) \
  $$(if $$(IMG_SVD_$(3)),-I$$(IMG_GEN_$(1))) $$(NUM_CFLAGS_$(2)) \
  $$(AUTH_CFLAGS) $$(if $(5),$$(DCMOTOR_INC))
BUILD_DIR_img-$(1) := $$(IMG_OBJ_$(1))
BUILD_SRCS_img-$(1) := $$(call fw_srcs,$(2)) $$(STM32_CAN_SRCS_$(4)) \
  $$(if $(5),$$(filter-out $$(STM32_WHEEL_SRCS),$$(IMG_SRCS_$(3))) $$(PIL_WHEEL_SRCS),$$(IMG_SRCS_$(3)))
BUILD_DEPS_img-$(1) := $$(NUM_DEPS_$(2)) $$(AUTH_DEPS)
BUILD_ORDER_img-$(1) := $$(STAMP)/apt-test $$(IMG_GENH_$(1))
$$(eval $$(call BUILD,img-$(1)))
IMG_OBJS_$(1) := $$(BUILD_OBJS_img-$(1)) $$(if $$(IMG_SVD_$(3)),$$(IMG_OBJ_$(1))/gen/stm32_vectors.o)

ifneq ($$(IMG_SVD_$(3)),)
ifeq ($(1),$(3))
# Register header and vector table from the vendor's SVD (tools/svd/).
$$(IMG_GEN_$(1))/stm32_regs.h $$(IMG_GEN_$(1))/stm32_vectors.c &: $$(IMG_SVD_$(1)) \
    tools/svd/svd2c deps/svd/.sha256 | .venv/.requirements.sha256
	$$(PY) tools/svd/svd2c $$(IMG_SVD_$(1)) deps/svd $$(IMG_GEN_$(1))
endif
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
$$(IMG_DIR_$(1))/mstc.elf: $$(IMG_OBJS_$(1)) $$(IMG_LD_$(3)) hal/stm32/sections.ld \
    $$(IMG_DIR_$(1))/numeric.txt
	$$(CROSS_CC) $$(IMG_CPU_$(3)) -nostartfiles --specs=nano.specs -Wl,--gc-sections \
	  -Wl,-Map=$$(IMG_DIR_$(1))/mstc.map -Wl,--no-warn-rwx-segments -Lhal/stm32 \
	  -T$$(IMG_LD_$(3)) -o $$@ $$(IMG_OBJS_$(1)) -Wl,--start-group -lc -lm -lgcc -Wl,--end-group
$$(IMG_DIR_$(1))/mstc.bin: $$(IMG_DIR_$(1))/mstc.elf
	$$(CROSS_OBJCOPY) -O binary $$< $$@
$$(IMG_DIR_$(1))/mstc.hex: $$(IMG_DIR_$(1))/mstc.elf
	$$(CROSS_OBJCOPY) -O ihex $$< $$@
$$(IMG_DIR_$(1))/size.txt: $$(IMG_DIR_$(1))/mstc.elf sim/mstc/bench/budget.py \
    | .venv/.requirements.sha256
	$$(PY) -m mstc.bench.budget --modules $$(IMG_DIR_$(1)) > $$@
.PHONY: img-$(1)
img-$(1): $$(addprefix $$(IMG_DIR_$(1))/,mstc.elf mstc.bin mstc.hex size.txt)
endef
$(foreach b,$(IMG_BOARDS),$(foreach c,$(or $(IMG_CANS_$(b)),none),$(eval \
  $(call IMG_RULES,$(call img_name,$(b),$(c)),$(IMG_NUMERIC_$(b)),$(b),$(filter-out none,$(c))))))
$(foreach b,$(IMG_PIL_BOARDS),$(eval $(call IMG_RULES,$(b)-pil,$(IMG_NUMERIC_$(b)),$(b),slcan,pil)))
# The image `make firmware` and `make flash` mean.
IMG := $(call img_name,$(BOARD),$(CAN))
ifneq ($(filter firmware flash,$(MAKECMDGOALS)),)
ifeq ($(filter $(CAN),$(or $(IMG_CANS_$(BOARD)),bxcan)),)
$(error CAN must be one of: $(or $(IMG_CANS_$(BOARD)),bxcan) for BOARD=$(BOARD) (not '$(CAN)'))
endif
endif

.PHONY: FORCE
FORCE:

deps/svd/.sha256: tools/svd/svd.lock tools/svd/fetch | .venv/.requirements.sha256
	@tools/svd/fetch && touch $@

.PHONY: firmware firmware-all firmware-budget firmware-smoke flash
firmware: img-$(IMG)  ## build a board image: BOARD=stm32f405|stm32f103|template [CAN=bxcan|slcan]
	@cat build/firmware/$(IMG)/size.txt

# The STM32 images, bxCAN and slcan, whose budgets are checked (and make bench
# reports).
BUDGET_IMGS := stm32f405 stm32f103 stm32f405-slcan stm32f103-slcan
BOARD_BUDGET := $(PY) -m mstc.bench.budget $(addprefix build/firmware/,$(BUDGET_IMGS))
firmware-all: $(addprefix img-,$(IMG_BOARDS)) firmware-budget  ## build every board image, then check the budgets
firmware-budget: $(addprefix img-,$(BUDGET_IMGS))  ## flash, RAM and stack of the board images vs. budgets
	@$(BOARD_BUDGET)

firmware-smoke: img-stm32f405 img-stm32f103  ## run both board images under QEMU: does the loop run?
	@$(PY) -m mstc.bench.qemu_smoke build/firmware/stm32f405 build/firmware/stm32f103

# make flash BOARD=... [FLASH_TOOL=openocd|st-flash|pyocd] [FLASH_DRY_RUN=1]
# [FLASH_ARGS="--interface cmsis-dap.cfg"]: tools/flash says how each works.
FLASH_TOOL ?= openocd
# What is flashed: a private copy of the image with the device key installed.
build/flash/%/mstc.elf: build/firmware/%/mstc.elf $(KEY_BIN) tools/setup/install-key
	@$(call install_key,$<,$(KEY_BIN),$@)
flash: img-$(IMG) build/flash/$(IMG)/mstc.elf  ## flash BOARD's image with the device key (FLASH_TOOL=openocd|st-flash|pyocd; FLASH_DRY_RUN=1: print only)
ifeq ($(FLASH_DRY_RUN),)
	@tools/setup/apt-install tools/setup/debian-flash.txt
endif
	@$(PY) tools/flash --board $(BOARD) --tool $(FLASH_TOOL) $(if $(FLASH_DRY_RUN),--dry-run) \
	  $(FLASH_ARGS) build/flash/$(IMG)/mstc.elf
