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

UNIT_SRCS := $(sort $(wildcard tests/unit/test_*.c))
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
TEST_SRCS := $(sort $(foreach t,$(UNIT_TESTS),$(TEST_SRCS_$(t))))
SRC_CFLAGS_tests/unit := -DUNITY_INCLUDE_DOUBLE -Ideps/unity -Itests/unit -Ihal/fake

# make test-unit TEST=test_avd: one suite (or several, TEST="test_avd test_kin").
ifneq ($(filter test-unit%,$(MAKECMDGOALS)),)
ifneq ($(filter-out $(UNIT_TESTS),$(TEST)),)
$(error TEST=$(TEST): no such Unity suite; the suites are: $(UNIT_TESTS))
endif
endif

# Unity (third-party): its own flags, not the project's warning set.
UNITY_OBJ := build/host/unity/unity.o
$(UNITY_OBJ): deps/unity/.sha256
	@mkdir -p $(dir $@)
	$(CC) -std=c11 -O1 -g -DUNITY_INCLUDE_DOUBLE -c deps/unity/unity.c -o $@

# One Unity binary per tests/unit/test_*.c, linked with the firmware, hal/fake,
# Unity and its TEST_SRCS_<test>. $(1): build; $(2): where the binaries go;
# $(3): the build's sources every test links; $(4): link flags.
define UNIT_TEST_RULES
$$(call build_objs,$(1),$$(UNIT_SRCS)): | deps/unity/.sha256
$(2)/%: $$(BUILD_DIR_$(1))/tests/unit/%.o $$(call build_objs,$(1),$(3)) $$(UNITY_OBJ)
	@mkdir -p $$(@D)
	$$(BUILD_CC_$(1)) $(4) $$^ -lm -o $$@
$$(foreach t,$$(UNIT_TESTS),$$(eval $(2)/$$(t): $$(call build_objs,$(1),$$(TEST_SRCS_$$(t)))))
endef

# The host build of numeric mode $(1): its library, mstc-fw, Unity tests.
define HOST_RULES
BUILD_CC_host-$(1) := $$(CC)
BUILD_CFLAGS_host-$(1) := $$(CSTD) $$(OPT) -fPIC $$(FW_INC) $$(NUM_CFLAGS_$(1)) $$(AUTH_CFLAGS)
BUILD_DIR_host-$(1) := build/host/$(1)/obj
BUILD_SRCS_host-$(1) := $$(call fw_srcs,$(1)) $$(SIL_SRCS) $$(LINUX_SRCS) $$(FAKE_SRCS) \
  $$(UNIT_SRCS) $$(TEST_SRCS) $$(sort $$(wildcard tests/codec/*.c))
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
test-unit-$(1): deps-test $$(addprefix build/host/$(1)/tests/,$$(or $$(TEST),$$(UNIT_TESTS)))
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
