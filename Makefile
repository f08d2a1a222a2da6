# SPDX-License-Identifier: MIT
# mstc: top-level build. `make help` lists the targets.
#
# The two commands a newcomer runs: `make sim` and `make test`. Both install
# what they need first (tools/setup/): Debian packages (as root), .venv from
# requirements.txt, third-party C sources into deps/. Re-runs are quick: every
# step is guarded by a stamp or by make's own timestamps.

NUMERIC ?= float
ifeq ($(filter $(NUMERIC),float fixed),)
$(error NUMERIC must be float or fixed, not '$(NUMERIC)')
endif

SHELL := /bin/bash
.DEFAULT_GOAL := help
PY := .venv/bin/python
MSTC := .venv/bin/mstc
B := build/host/$(NUMERIC)

CC ?= cc
WARN := -Wall -Wextra -Wconversion -Wdouble-promotion -Wshadow -Wstrict-prototypes \
        -Wmissing-prototypes -Wundef -Wcast-align -Werror
CSTD := -std=c11 -D_DEFAULT_SOURCE
OPT ?= -O2 -g
# The include path of every firmware and HAL compile: firmware/ (its modules
# include "ctrl/ctl.h", ...) and the HAL headers ("hal/hal_can.h", ...).
FW_INC := -Ifirmware -Ihal/include

# Firmware: the portable control core (num, ctrl, kin), the protocol (comm)
# and the application (app). No platform headers; app reaches the outside
# through hal/include/hal/*.h only.
# The control core alone (ctl_step), for the benchmark (mk/bench.mk).
CORE_SRCS := $(sort $(wildcard firmware/num/*.c firmware/ctrl/*.c firmware/kin/*.c))
FW_SRCS := $(sort $(wildcard firmware/*/*.c))
# The host ports: in process (the library), SocketCAN (mstc-fw), the fakes of
# the unit tests.
SIL_SRCS := $(sort $(wildcard hal/sil/*.c))
LINUX_SRCS := $(sort $(wildcard hal/linux/*.c))
FAKE_SRCS := $(sort $(wildcard hal/fake/*.c))
# Numeric mode: NUM_CFLAGS, NUM_SRCS and NUM_DEPS per mode (mk/numeric.mk).
include mk/numeric.mk

STAMP := build/.stamps
# Authentication: AUTH_SRCS, AUTH_CFLAGS, AUTH_DEPS (Mbed TLS's AES) and the
# keys (mk/auth.mk).
include mk/auth.mk
# The compile template (BUILD), compile_commands.json, print-cflags.
include mk/compile.mk
$(STAMP):
	@mkdir -p $@

# ---------------------------------------------------------------- dependencies
.PHONY: deps-sim deps-test venv
$(STAMP)/apt-sim: tools/setup/debian-sim.txt | $(STAMP)
	@tools/setup/apt-install $^
	@touch $@
$(STAMP)/apt-test: tools/setup/debian-sim.txt tools/setup/debian-test.txt | $(STAMP)
	@tools/setup/apt-install $^
	@touch $@
.venv/.requirements.sha256: requirements.txt $(STAMP)/apt-sim
	@tools/setup/venv
venv: .venv/.requirements.sha256
deps/unity/.sha256: tools/setup/sources.lock $(STAMP)/apt-sim
	@tools/setup/fetch-source unity
deps/libfixmath/.sha256: tools/setup/sources.lock $(STAMP)/apt-sim
	@tools/setup/fetch-source libfixmath
deps-sim: $(STAMP)/apt-sim venv $(NUM_DEPS) $(AUTH_DEPS)
# HIL over vcan (docs/hil.md): QEMU and a Debian kernel with vcan, for hosts
# whose kernel has no CAN.
.PHONY: deps-hil
$(STAMP)/apt-hil: tools/setup/debian-sim.txt tools/setup/debian-hil.txt | $(STAMP)
	@tools/setup/apt-install $^
	@touch $@
deps/vm-kernel/.stamp: tools/vm/fetch-kernel $(STAMP)/apt-hil
	@tools/vm/fetch-kernel
	@touch $@
deps-hil: deps-sim $(STAMP)/apt-hil deps/vm-kernel/.stamp
deps-test: $(STAMP)/apt-test deps-sim deps-hil deps/unity/.sha256 deps/libfixmath/.sha256

# ------------------------------------------------------------ host libraries
# The host build (NUMERIC's mode) compiles the firmware, the host ports, the
# unit tests and the board code they test, and the pytest shims' sources
# (tests/codec/, compiled by pytest with these flags: make print-cflags).
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
# The DC motor model (model/: a plant, not firmware) that the wheel loop is
# tested against, here, and simulated against, in the SIL library.
MODEL_SRCS := $(sort $(wildcard model/*.c))
TEST_SRCS_test_dcm := $(MODEL_SRCS)
TEST_SRCS_test_whl := $(MODEL_SRCS)
SRC_CFLAGS_tests/unit/test_dcm.c := -Imodel
SRC_CFLAGS_tests/unit/test_whl.c := -Imodel
SRC_CFLAGS_hal/sil := -Imodel
TEST_SRCS := $(sort $(foreach t,$(UNIT_TESTS),$(TEST_SRCS_$(t))))
SRC_CFLAGS_tests/unit := -DUNITY_INCLUDE_DOUBLE -Ideps/unity -Itests/unit -Ihal/fake

BUILD_CC_host := $(CC)
BUILD_CFLAGS_host := $(CSTD) $(OPT) -fPIC $(FW_INC) $(NUM_CFLAGS) $(AUTH_CFLAGS)
BUILD_DIR_host := $(B)/obj
BUILD_SRCS_host := $(FW_SRCS) $(NUM_SRCS) $(AUTH_SRCS) $(SIL_SRCS) $(LINUX_SRCS) $(FAKE_SRCS) \
  $(UNIT_SRCS) $(TEST_SRCS) $(sort $(wildcard tests/codec/*.c))
BUILD_DEPS_host := $(NUM_DEPS) $(AUTH_DEPS)
BUILD_ORDER_host := $(STAMP)/apt-sim
$(eval $(call BUILD,host))

FW_OBJS := $(call build_objs,host,$(FW_SRCS) $(NUM_SRCS) $(AUTH_SRCS))
SIL_OBJS := $(call build_objs,host,$(SIL_SRCS))
$(B)/libmstc_sil.so: $(FW_OBJS) $(SIL_OBJS) $(call build_objs,host,$(MODEL_SRCS))
	$(CC) -shared -Wl,--no-undefined -o $@ $^ -lm
.PHONY: lib
lib: $(B)/libmstc_sil.so  ## build the firmware as a shared library (SIL)

# The firmware as a Linux process on SocketCAN (hal/linux).
$(B)/mstc-fw: $(FW_OBJS) $(call build_objs,host,$(LINUX_SRCS))
	$(CC) -o $@ $^ -lm
build/host/mstc-fw: $(B)/mstc-fw
	ln -sfn $(NUMERIC)/mstc-fw $@
.PHONY: fw build/host/mstc-fw
fw: build/host/mstc-fw  ## build build/host/mstc-fw (the firmware on SocketCAN)

# ----------------------------------------------------------------------- sim
SCENARIO ?= sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml
BUS ?= sil
.PHONY: sim
sim: deps-sim $(B)/libmstc_sil.so $(SIM_KEY_FILE)  ## run the paper's scenarios through CAN in process (SCENARIO=file.toml, BUS=memory)
	$(MSTC) sim --bus $(BUS) --lib $(B)/libmstc_sil.so --key-file $(SIM_KEY_FILE) --out build/sim $(SCENARIO)

# --------------------------------------------------------------------- sweep
# A scenario suite (or scenario files, folders) for several strategies on
# every core, in memory: DIR/runs.csv, DIR/summary.md (docs/sweeps.md).
SUITE ?= sim/suites/standard.toml
STRATEGY ?= paper,mstc,dwa
SWEEP_OUT ?= build/sweep/$(basename $(notdir $(firstword $(SUITE))))
SWEEP_FLAGS ?=
.PHONY: sweep
sweep: deps-sim $(B)/libmstc_sil.so  ## run a scenario suite for several strategies on every core (SUITE=, STRATEGY=, SWEEP_FLAGS=--resume)
	$(MSTC) sweep --lib $(B)/libmstc_sil.so --strategy $(STRATEGY) --out $(SWEEP_OUT) $(SWEEP_FLAGS) $(SUITE)

# ----------------------------------------------------------------------- hil
# The firmware as its own process (mstc-fw) on vcan0, the plant on python-can's
# socketcan interface; inside a VM where the host kernel has no CAN.
# REALTIME=1: mstc-fw on its own timer, the plant on the wall clock
# (docs/hil.md, "Real time"), into build/hil-realtime/ with timing.json.
HIL_TIMEOUT ?= 1800
HIL_OUT := $(if $(REALTIME),build/hil-realtime,build/hil)
.PHONY: hil
hil: deps-hil build/host/mstc-fw $(SIM_KEY_FILE)  ## the paper's scenarios over vcan0 with mstc-fw as its own process (build/hil/; REALTIME=1: in real time)
	MPLCONFIGDIR=$(CURDIR)/build/mplconfig tools/vm/with-vcan -v --timeout $(HIL_TIMEOUT) -- \
	  $(MSTC) hil $(if $(REALTIME),--realtime) --key-file $(SIM_KEY_FILE) --channel vcan0 \
	  --fw build/host/mstc-fw --no-figures --out $(HIL_OUT) $(SCENARIO)

# ---------------------------------------------------------------------- test
# Unity (third-party): its own flags, not the project's warning set.
UNITY_OBJ := $(B)/obj/deps/unity/unity.o
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
$(eval $(call UNIT_TEST_RULES,host,$(B)/tests,$(FW_SRCS) $(NUM_SRCS) $(AUTH_SRCS) $(FAKE_SRCS),))

# make test-unit TEST=test_avd: one suite (or several, TEST="test_avd test_kin").
ifneq ($(filter test-unit,$(MAKECMDGOALS)),)
ifneq ($(filter-out $(UNIT_TESTS),$(TEST)),)
$(error TEST=$(TEST): no such Unity suite; the suites are: $(UNIT_TESTS))
endif
endif
UNIT_BINS := $(addprefix $(B)/tests/,$(or $(TEST),$(UNIT_TESTS)))

.PHONY: test test-unit test-python lint typecheck
test-unit: deps-test $(UNIT_BINS)  ## Unity tests of every firmware module (in NUMERIC mode; TEST=test_avd: one)
	@tools/run-unit-tests $(UNIT_BINS)
.PHONY: libs-both
libs-both:
	@$(MAKE) --no-print-directory NUMERIC=float lib
	@$(MAKE) --no-print-directory NUMERIC=fixed lib
# PYTEST_ARGS: more arguments for pytest, e.g. PYTEST_ARGS='-m vm' (only the
# tests that boot the vcan VM), PYTEST_ARGS='-k hil'.
test-python: deps-test libs-both build/host/mstc-fw  ## pytest (both numeric modes' libraries; PYTEST_ARGS='-m vm': only those that boot the vcan VM)
	MSTC_SIL_LIB=$(B)/libmstc_sil.so MSTC_SIL_LIB_FLOAT=build/host/float/libmstc_sil.so \
	  MSTC_SIL_LIB_FIXED=build/host/fixed/libmstc_sil.so MSTC_FW=build/host/mstc-fw \
	  $(PY) -m pytest -q --durations=20 $(PYTEST_ARGS) tests/python
# Directories (their *.py) and the Python tools without an extension.
PY_LINT := sim tests/python tools/bench tools/numerics tools/svd tools/wheel tools/gen-codec \
           tools/protocol-doc tools/gen-limits tools/flash \
           tools/quality/spdx tools/quality/coverage_check \
           tools/quality/fuzz_seeds
# C: every tracked source but the generated codec (.clang-format).
C_FORMAT = $(filter-out firmware/comm/mstc_dbc.%,$(shell git ls-files '*.c' '*.h'))
lint: deps-sim $(STAMP)/apt-test  ## ruff (lint, format) over the Python code, clang-format over the C code, SPDX lines
	$(PY) -m ruff check $(PY_LINT)
	$(PY) -m ruff format --check $(PY_LINT)
	@clang-format --dry-run --Werror $(C_FORMAT) && echo "clang-format: $(words $(C_FORMAT)) files ok"
	@$(PY) tools/quality/spdx
typecheck: deps-sim  ## mypy, strict, over the package mstc (settings in pyproject.toml)
	$(PY) -m mypy
# The fuzzers run for a fixed time on one core; the host checks take the
# other meanwhile, one after another (they share build directories). The tests
# that boot the emulated vcan VM come last, alone, so that nothing competes
# with its timing.
test: deps-test  ## every test: lint, types, generated files, static analysis, cross builds, Unity in both modes, coverage, fuzzing, pytest
	@$(MAKE) --no-print-directory lint typecheck check-protocol
	@$(MAKE) --no-print-directory -j2 --output-sync=line fuzz test-host
	@$(MAKE) --no-print-directory NUMERIC=float test-python PYTEST_ARGS='-m vm'
.PHONY: test-host
test-host:
	@$(MAKE) --no-print-directory quality cross coverage
	@$(MAKE) --no-print-directory NUMERIC=fixed test-unit
	@$(MAKE) --no-print-directory NUMERIC=float test-unit
	@$(MAKE) --no-print-directory NUMERIC=float test-python PYTEST_ARGS='-m "not vm"'
include mk/comm.mk
include mk/replay.mk
include mk/firmware.mk
include mk/pil.mk
include mk/cross.mk
include mk/bench.mk
include mk/numerics.mk
include mk/quality.mk
include mk/wheel.mk

.PHONY: clean help
clean:  ## remove build outputs (keeps .venv and deps/)
	rm -rf build
help:  ## this list
	@grep -hE '^[a-z][a-zA-Z_.-]*:.*## ' $(MAKEFILE_LIST) | sed 's/:.*## /\t/' | sort | expand -t 16
