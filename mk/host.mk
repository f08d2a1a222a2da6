# SPDX-License-Identifier: MIT
# The host builds, one per numeric mode (host-<mode>, a build of mk/compile.mk),
# into build/host/<mode>/: libmstc_sil.so (hal/sil), mstc-fw (hal/linux), a
# Unity binary per tests/unit/test_*.c (hal/fake, and the board code a test
# tests), and the pytest shims' sources (tests/codec/: make print-cflags).
# One template makes both modes, so one make builds and tests both; the
# targets of one mode (lib, fw, test-unit) take NUMERIC's, in B.

B := build/host/$(NUMERIC)

# The host ports: in process (the library), SocketCAN (mstc-fw), the fakes of
# the unit tests.
SIL_SRCS := $(sort $(wildcard hal/sil/*.c))
LINUX_SRCS := $(sort $(wildcard hal/linux/*.c))
FAKE_SRCS := $(sort $(wildcard hal/fake/*.c))

# The STM32 drivers against their registers (tests/unit/test_drv_*.c) are
# built apart: below.
DRV_SRCS := $(sort $(wildcard tests/unit/test_drv_*.c))
DRV_TESTS := $(patsubst tests/unit/%.c,%,$(DRV_SRCS))
UNIT_SRCS := $(filter-out $(DRV_SRCS),$(sort $(wildcard tests/unit/test_*.c)))
UNIT_TESTS := $(patsubst tests/unit/%.c,%,$(UNIT_SRCS))
# Board code a unit test tests, beyond the firmware and hal/fake, and the
# include path its headers need: TEST_SRCS_<test>, SRC_CFLAGS_<test source>.
TEST_SRCS_test_bxcan := hal/stm32/bxcan_calc.c hal/stm32/div64.c
TEST_SRCS_test_stm32_calc := hal/stm32/stm32_calc.c hal/stm32/wheel_cmd.c hal/stm32/div64.c
TEST_SRCS_test_slcan := hal/stm32/slcan_codec.c
SRC_CFLAGS_tests/unit/test_bxcan.c := -Ihal/stm32
SRC_CFLAGS_tests/unit/test_stm32_calc.c := -Ihal/stm32
SRC_CFLAGS_tests/unit/test_slcan.c := -Ihal/stm32
# The DC motor model, sim/dcmotor/ (the plant's motors in C, not firmware):
# what the wheel loop is tested against (Unity, here), simulated against (the
# SIL library, here) and measured against (the benchmarks, mk/bench.mk,
# mk/wheel.mk). Every user compiles with DCMOTOR_INC and links DCMOTOR_SRCS.
DCMOTOR_SRCS := $(sort $(wildcard sim/dcmotor/*.c))
DCMOTOR_INC := -Isim/dcmotor
TEST_SRCS_test_dcm := $(DCMOTOR_SRCS)
TEST_SRCS_test_whl := $(DCMOTOR_SRCS)
SRC_CFLAGS_tests/unit/test_dcm.c := $(DCMOTOR_INC)
SRC_CFLAGS_tests/unit/test_whl.c := $(DCMOTOR_INC)
SRC_CFLAGS_hal/sil := $(DCMOTOR_INC)
SRC_CFLAGS_tests/unit := -DUNITY_INCLUDE_DOUBLE -Ideps/unity -Itests/unit -Ihal/fake

# The STM32 drivers of hal/stm32 compiled for the host (STM32_HOST) against
# the STM32F405's register blocks, laid out by the header generated from its
# SVD (mk/firmware.mk's rule), each block answered by a model of its
# peripheral (tests/unit/stm32_host/, stm32_host.h says how). A driver comes
# in through a unit of tests/unit/stm32_host/ that includes its source, so
# that STM32_HOST is that unit's flag, not the source's in every build. Each
# test_drv_<name> links its drivers and models (TEST_SRCS_<test>), the core's
# model and Unity, the firmware where it runs the application over them
# (DRV_FW_TESTS), and never hal/fake: the drivers are the HAL.
STM32_HOST_GEN := build/firmware/stm32f405/gen
STM32_HOST := tests/unit/stm32_host
STM32_HOST_SRCS := $(STM32_HOST)/stm32_host.c $(STM32_HOST)/board_host.c
STM32_HOST_CFLAGS := -DSTM32_HOST -I$(STM32_HOST) -Ihal/stm32 -Ihal/stm32f405 -I$(STM32_HOST_GEN)
SRC_CFLAGS_$(STM32_HOST) := $(STM32_HOST_CFLAGS)
$(foreach t,$(DRV_SRCS),$(eval SRC_CFLAGS_$(t) := $(STM32_HOST_CFLAGS)))
TEST_SRCS_test_drv_encoder := $(STM32_HOST)/drv_encoder.c $(STM32_HOST)/model_tim.c \
  hal/stm32/stm32_calc.c hal/stm32/div64.c
TEST_SRCS_test_drv_pwm := $(STM32_HOST)/drv_motor_pwm.c $(STM32_HOST)/model_tim.c \
  hal/stm32/stm32_calc.c hal/stm32/div64.c
TEST_SRCS_test_drv_time := $(STM32_HOST)/drv_time.c $(STM32_HOST)/drv_tick.c \
  $(STM32_HOST)/model_tim.c hal/stm32/stm32_calc.c hal/stm32/div64.c
TEST_SRCS_test_drv_iwdg := $(STM32_HOST)/drv_sys.c $(STM32_HOST)/model_iwdg.c \
  hal/stm32/stm32_calc.c hal/stm32/div64.c
TEST_SRCS_test_drv_bxcan := $(STM32_HOST)/drv_bxcan.c $(STM32_HOST)/drv_can_queue.c \
  $(STM32_HOST)/drv_time.c $(STM32_HOST)/model_bxcan.c hal/stm32/bxcan_calc.c \
  hal/stm32/stm32_calc.c hal/stm32/div64.c
# The driver tests that run the application over their drivers: with the firmware.
DRV_FW_TESTS := test_drv_bxcan
DRV_HOST_SRCS := $(STM32_HOST_SRCS) $(sort $(foreach t,$(DRV_TESTS),$(TEST_SRCS_$(t))))
TEST_SRCS := $(sort $(foreach t,$(UNIT_TESTS),$(TEST_SRCS_$(t))) $(DRV_HOST_SRCS))

# make test-unit TEST=test_avd: one suite (or several, TEST="test_avd test_kin").
ifneq ($(filter test-unit%,$(MAKECMDGOALS)),)
ifneq ($(filter-out $(UNIT_TESTS) $(DRV_TESTS),$(TEST)),)
$(error TEST=$(TEST): no such Unity suite; the suites are: $(UNIT_TESTS) $(DRV_TESTS))
endif
endif

# Unity (third-party): its own flags, not the project's warning set.
UNITY_OBJ := build/host/unity/unity.o
$(UNITY_OBJ): deps/unity/.sha256
	@mkdir -p $(dir $@)
	$(CC) -std=c11 -O1 -g -DUNITY_INCLUDE_DOUBLE -c deps/unity/unity.c -o $@

# One Unity binary per tests/unit/test_*.c, linked with the firmware, hal/fake,
# Unity and its TEST_SRCS_<test>; each test_drv_*.c with the firmware, the
# core's model, Unity and its TEST_SRCS_<test>, not hal/fake. $(1): build;
# $(2): where the binaries go; $(3): the build's sources every test links
# (the firmware, hal/fake); $(4): link flags.
define UNIT_TEST_RULES
$$(call build_objs,$(1),$$(UNIT_SRCS) $$(DRV_SRCS)): | deps/unity/.sha256
$$(call build_objs,$(1),$$(DRV_SRCS) $$(DRV_HOST_SRCS)): | $$(STM32_HOST_GEN)/stm32_regs.h
$(2)/%: $$(BUILD_DIR_$(1))/tests/unit/%.o $$(call build_objs,$(1),$(3)) $$(UNITY_OBJ)
	@mkdir -p $$(@D)
	$$(BUILD_CC_$(1)) $(4) $$^ -lm -o $$@
$$(foreach t,$$(UNIT_TESTS),$$(eval $(2)/$$(t): $$(call build_objs,$(1),$$(TEST_SRCS_$$(t)))))
$$(addprefix $(2)/,$$(DRV_TESTS)): $(2)/%: $$(BUILD_DIR_$(1))/tests/unit/%.o \
    $$(call build_objs,$(1),$$(STM32_HOST_SRCS)) $$(UNITY_OBJ)
	@mkdir -p $$(@D)
	$$(BUILD_CC_$(1)) $(4) $$^ -lm -o $$@
$$(foreach t,$$(DRV_TESTS),$$(eval $(2)/$$(t): $$(call build_objs,$(1),$$(TEST_SRCS_$$(t)))))
$$(addprefix $(2)/,$$(DRV_FW_TESTS)): $$(call build_objs,$(1),$$(filter-out $$(FAKE_SRCS),$(3)))
endef

# The host build of numeric mode $(1): its library, mstc-fw, Unity tests.
define HOST_RULES
BUILD_CC_host-$(1) := $$(CC)
BUILD_CFLAGS_host-$(1) := $$(CSTD) $$(OPT) -fPIC $$(FW_INC) $$(NUM_CFLAGS_$(1)) $$(AUTH_CFLAGS)
BUILD_DIR_host-$(1) := build/host/$(1)/obj
BUILD_SRCS_host-$(1) := $$(call fw_srcs,$(1)) $$(SIL_SRCS) $$(LINUX_SRCS) $$(FAKE_SRCS) \
  $$(UNIT_SRCS) $$(DRV_SRCS) $$(TEST_SRCS) $$(sort $$(wildcard tests/codec/*.c))
BUILD_DEPS_host-$(1) := $$(NUM_DEPS_$(1)) $$(AUTH_DEPS)
BUILD_ORDER_host-$(1) := $$(STAMP)/apt-sim
$$(eval $$(call BUILD,host-$(1)))
build/host/$(1)/libmstc_sil.so: $$(call build_objs,host-$(1),$$(call fw_srcs,$(1)) $$(SIL_SRCS) \
    $$(DCMOTOR_SRCS))
	$$(CC) -shared -Wl,--no-undefined -o $$@ $$^ -lm
build/host/$(1)/mstc-fw: $$(call build_objs,host-$(1),$$(call fw_srcs,$(1)) $$(LINUX_SRCS))
	$$(CC) -o $$@ $$^ -lm
$$(eval $$(call UNIT_TEST_RULES,host-$(1),build/host/$(1)/tests,$$(call fw_srcs,$(1)) $$(FAKE_SRCS),))
.PHONY: test-unit-$(1)
test-unit-$(1): deps-test $$(addprefix build/host/$(1)/tests/,$$(or $$(TEST),$$(UNIT_TESTS) $$(DRV_TESTS)))
	@tools/run-unit-tests $$(filter build/%,$$^)
endef
$(foreach m,$(NUM_MODES),$(eval $(call HOST_RULES,$(m))))

.PHONY: lib fw libs-both test-unit build/host/mstc-fw
lib: $(B)/libmstc_sil.so  ## build the firmware as a shared library (SIL)
libs-both: $(foreach m,$(NUM_MODES),build/host/$(m)/libmstc_sil.so)
# The firmware as a Linux process on SocketCAN (hal/linux).
build/host/mstc-fw: $(B)/mstc-fw
	ln -sfn $(NUMERIC)/mstc-fw $@
fw: build/host/mstc-fw  ## build build/host/mstc-fw (the firmware on SocketCAN)
test-unit: test-unit-$(NUMERIC)  ## Unity tests of every firmware module (in NUMERIC mode; TEST=test_avd: one; test-unit-float, test-unit-fixed: that mode)
