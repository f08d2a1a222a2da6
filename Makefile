# SPDX-License-Identifier: MIT
# mstc: top-level build. `make help` lists the targets.
#
# The two commands a newcomer runs: `make sim` and `make test`. Both install
# what they need first (tools/setup/): Debian packages (as root), .venv from
# requirements.txt, third-party C sources into deps/. Re-runs are quick: every
# step is guarded by a stamp or by make's own timestamps. Each concern of the
# build is a file of mk/ (docs/architecture.md, "The build").

SHELL := /bin/bash
.DEFAULT_GOAL := help
PY := .venv/bin/python
MSTC := .venv/bin/mstc

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
# ctl_step clears the status member by member: loops that clear stay loops,
# not calls to the C library's memset (some 130 instructions a step on a
# Cortex-M for its 64 B of distances; docs/strategy-cost.md).
SRC_CFLAGS_firmware/ctrl/ctl.c := -fno-tree-loop-distribute-patterns
# What FW_VERSION answers (firmware/app/app.h): the package's version, the
# build id (the git commit's first 7 hex digits, 0 outside a git tree; the
# commit of app.c's last compile), whether the tree had changes, and the
# node id of the build (NODE=0..6: its identifiers are the DBC's plus 0x100
# times it; mstc-fw --node and the in-process firmware can set another).
NODE ?= 0
APP_VERSION := $(subst ., ,$(shell sed -n 's/^version = "\([0-9.]*\)"/\1/p' pyproject.toml))
APP_BUILD := $(shell git rev-parse HEAD 2>/dev/null | cut -c1-7)
APP_DIRTY := $(if $(shell git status --porcelain --untracked-files=no 2>/dev/null),1,0)
SRC_CFLAGS_firmware/app/app.c := -DAPP_VERSION_MAJOR=$(word 1,$(APP_VERSION))u \
  -DAPP_VERSION_MINOR=$(word 2,$(APP_VERSION))u -DAPP_VERSION_PATCH=$(word 3,$(APP_VERSION))u \
  -DAPP_BUILD_ID=0x$(or $(APP_BUILD),0)u -DAPP_BUILD_DIRTY=$(APP_DIRTY)u -DAPP_NODE=$(NODE)u

STAMP := build/.stamps
$(STAMP):
	@mkdir -p $@

# The compile template (BUILD), compile_commands.json, print-cflags.
include mk/compile.mk
# NUMERIC and the numeric modes' flags and sources (NUM_*_<mode>), make numerics.
include mk/numeric.mk
# Authentication: AUTH_SRCS, AUTH_CFLAGS, AUTH_DEPS (Mbed TLS's AES) and the
# keys (mk/auth.mk).
include mk/auth.mk
# The firmware's sources in numeric mode $(1), with the third-party code it
# links: libfixmath's in fixed mode, Mbed TLS's AES.
fw_srcs = $(FW_SRCS) $(NUM_SRCS_$(1)) $(AUTH_SRCS)

# ---------------------------------------------------------------- dependencies
# Debian packages: tools/setup/debian-sim.txt and, for apt-<set>, debian-<set>.txt.
.PHONY: deps-sim deps-test deps-hil venv
$(STAMP)/apt-%: tools/setup/debian-sim.txt tools/setup/debian-%.txt | $(STAMP)
	@tools/setup/apt-install $^
	@touch $@
.venv/.requirements.sha256: requirements.txt pyproject.toml $(STAMP)/apt-sim
	@tools/setup/venv
venv: .venv/.requirements.sha256 .venv/.bytecode
# mstc's own modules compiled once per change: Python reads the cached
# bytecode even where PYTHONDONTWRITEBYTECODE keeps it from writing it (then
# every mstc command would compile them again as it starts: 0.25 s of CPU).
.venv/.bytecode: .venv/.requirements.sha256 $(wildcard sim/mstc/*.py sim/mstc/*/*.py)
	@$(PY) -m compileall -q sim/mstc
	@touch $@
# Third-party C sources (Unity, libfixmath, Mbed TLS): tools/setup/sources.lock.
deps/%/.sha256: tools/setup/sources.lock | $(STAMP)/apt-sim
	@tools/setup/fetch-source $*
deps-sim: $(STAMP)/apt-sim venv $(NUM_DEPS_$(NUMERIC)) $(AUTH_DEPS)
# HIL over vcan (docs/hil.md): QEMU and a Debian kernel with vcan, for hosts
# whose kernel has no CAN.
deps/vm-kernel/.stamp: tools/vm/fetch-kernel $(STAMP)/apt-hil
	@tools/vm/fetch-kernel
	@touch $@
deps-hil: deps-sim $(STAMP)/apt-hil deps/vm-kernel/.stamp
deps-test: $(STAMP)/apt-test deps-sim deps-hil deps/unity/.sha256 deps/libfixmath/.sha256

# The host builds of both numeric modes (library, mstc-fw, Unity tests) and B,
# NUMERIC's: build/host/$(NUMERIC).
include mk/host.mk

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

# ---------------------------------------------------------------------- barn
# BARN's 300 worlds (docs/barn.md): the benchmark's Jackal, protocol and
# score, both references, into build/barn/ (runs.csv, summary.md, gallery/).
BARN_STRATEGY ?= paper,mstc
BARN_FLAGS ?=
.PHONY: barn
barn: deps-sim $(B)/libmstc_sil.so  ## run BARN's 300 worlds (BARN_STRATEGY=paper,mstc,dwa, BARN_FLAGS=--speed 1.0)
	$(MSTC) barn --lib $(B)/libmstc_sil.so --strategy $(BARN_STRATEGY) --reference line,path --out build/barn $(BARN_FLAGS)

# ----------------------------------------------------------------------- hil
# The firmware as its own process (mstc-fw) on vcan0, the plant on python-can's
# socketcan interface; inside a VM where the host kernel has no CAN.
# REALTIME=1: mstc-fw on its own timer, the plant on the wall clock
# (docs/hil.md, "Real time"), into build/hil-realtime/ with timing.json.
# In the VM only vcan0 and the firmware run on the emulated CPU: the plant runs
# on the host and reaches vcan0 through the bridge (with-vcan --bridge; the
# guest's end is build/host/can-bridge, tools/vm/can-bridge.c, on hal/linux's
# SocketCAN driver and the slcan codec of the board images).
CAN_BRIDGE_SRCS := tools/vm/can-bridge.c hal/linux/hal_can_socketcan.c hal/stm32/slcan_codec.c
BUILD_CC_can-bridge := $(CC)
BUILD_CFLAGS_can-bridge := $(CSTD) $(OPT) $(FW_INC) -Ihal/linux -Ihal/stm32
BUILD_DIR_can-bridge := build/host/can-bridge-obj
BUILD_SRCS_can-bridge := $(CAN_BRIDGE_SRCS)
BUILD_ORDER_can-bridge := $(STAMP)/apt-sim
$(eval $(call BUILD,can-bridge))
build/host/can-bridge: $(BUILD_OBJS_can-bridge)
	$(CC) $^ -o $@
HIL_TIMEOUT ?= 1800
HIL_OUT := $(if $(REALTIME),build/hil-realtime,build/hil)
.PHONY: hil
hil: deps-hil build/host/mstc-fw build/host/can-bridge $(SIM_KEY_FILE)  ## the paper's scenarios over vcan0 with mstc-fw as its own process (build/hil/; REALTIME=1: in real time)
	MPLCONFIGDIR=$(CURDIR)/build/mplconfig tools/vm/with-vcan -v --bridge --timeout $(HIL_TIMEOUT) -- \
	  $(MSTC) hil $(if $(REALTIME),--realtime) --key-file $(SIM_KEY_FILE) --channel vcan0 \
	  --fw build/host/mstc-fw --no-figures --out $(HIL_OUT) $(SCENARIO)
# The load test's long form (docs/hil.md, "Load"): HIL_LOAD_RUNS real-time runs
# of both paper scenarios with 0, 1, 2 CPU-bound processes beside them, in one
# boot; its table goes into docs/hil.md. Exit status 1 when a run did not hold.
HIL_LOAD_RUNS ?= 5
.PHONY: hil-load
hil-load: deps-hil build/host/mstc-fw build/host/can-bridge  ## real-time HIL beside 0, 1, 2 busy cores, HIL_LOAD_RUNS runs each: docs/hil.md "Load"
	MSTC_KEY_FILE=$(TEST_KEY_FILE) tools/vm/with-vcan -v --bridge --timeout 7200 -- \
	  $(PY) -m mstc.bench.realtime load --fw build/host/mstc-fw --busy 0 1 2 \
	  --runs $(HIL_LOAD_RUNS) --out build/bench/hil-load.json; \
	  status=$$?; $(PY) -m mstc.bench.realtime load-report --doc docs/hil.md \
	  build/bench/hil-load.json && exit $$status

# ---------------------------------------------------------------------- test
# pytest with both modes' libraries. $(1): the numeric mode of MSTC_SIL_LIB
# and MSTC_FW; $(2): pytest's arguments.
pytest = MSTC_SIL_LIB=build/host/$(1)/libmstc_sil.so MSTC_SIL_LIB_FLOAT=build/host/float/libmstc_sil.so \
  MSTC_SIL_LIB_FIXED=build/host/fixed/libmstc_sil.so MSTC_FW=build/host/$(1)/mstc-fw \
  $(PY) -m pytest -q --durations=20 $(2) $(if $(filter tests/%,$(2)),,tests/python)
.PHONY: test test-python test-host test-vm lint typecheck
# PYTEST_ARGS: more arguments for pytest, e.g. PYTEST_ARGS='-m vm' (only the
# tests that boot the vcan VM), PYTEST_ARGS='-k hil'.
test-python: deps-test libs-both build/host/mstc-fw build/host/can-bridge  ## pytest (both numeric modes' libraries; PYTEST_ARGS='-m vm': only those that boot the vcan VM)
	$(call pytest,$(NUMERIC),$(PYTEST_ARGS))
# Directories (their *.py) and the Python programs of tools/ (no extension:
# found by their first line).
PY_LINT = sim tests/python \
  $(sort $(filter-out %.py,$(shell grep -rlI --max-count=1 '^#!/usr/bin/env python3' tools)))
# C: every tracked source but the generated codec (.clang-format).
C_FORMAT = $(filter-out firmware/comm/mstc_dbc.%,$(shell git ls-files '*.c' '*.h'))
lint: deps-sim $(STAMP)/apt-test  ## ruff (lint, format) over the Python code, clang-format over the C code, SPDX lines
	$(PY) -m ruff check $(PY_LINT)
	$(PY) -m ruff format --check $(PY_LINT)
	@clang-format --dry-run --Werror $(C_FORMAT) && echo "clang-format: $(words $(C_FORMAT)) files ok"
	@$(PY) tools/quality/spdx
typecheck: deps-sim  ## mypy, strict, over the package mstc (settings in pyproject.toml)
	$(PY) -m mypy
# make test: first the checks of the sources (lint, types, generated files);
# then, in one make with two jobs, the fuzzers (one job: FUZZ_SECONDS per
# harness) beside the host checks (the other job), and last the tests that
# boot the emulated vcan VM: test-vm needs all the rest, so it runs alone and
# nothing competes with the VM's timing. The one inner make is the barrier
# after the checks: make 4.3 (Debian 12) has no .WAIT, and in a make with two
# jobs the builds would start beside lint.
test: deps-test lint typecheck check-protocol  ## every test: lint, types, generated files, static analysis, cross builds, Unity in both modes, coverage, fuzzing, pytest
	@$(MAKE) --no-print-directory -j2 --output-sync=line test-vm
# The host checks, one after another on the job the fuzzers leave: quality,
# cross builds, coverage, the Cortex-M4F benchmark image's checks
# (mk/bench.mk), Unity in both modes, then pytest but the VM tests.
test-host: quality cross coverage bench-check test-unit-fixed test-unit-float deps-test libs-both \
    build/host/float/mstc-fw build/host/can-bridge
	$(call pytest,float,-m "not vm")
test-vm: fuzz test-host
	$(call pytest,float,-m vm)

include mk/comm.mk
include mk/replay.mk
include mk/cross.mk
include mk/firmware.mk
include mk/pil.mk
include mk/bench.mk
include mk/quality.mk
include mk/wheel.mk

.PHONY: clean help
clean:  ## remove build outputs (keeps .venv and deps/)
	rm -rf build
help:  ## this list
	@grep -hE '^[a-z][a-zA-Z_.-]*:.*## ' $(MAKEFILE_LIST) | sed 's/:.*## /\t/' | sort | expand -t 16
