# mstc: top-level build. `make help` lists the targets.
#
# The two commands a newcomer runs: `make sim` and `make test`. Both install
# what they need first (tools/deps/): Debian packages (as root), .venv from
# requirements.txt, third-party C sources into deps/. Re-runs are quick: every
# step is guarded by a stamp or by make's own timestamps.

NUMERIC ?= float
ifeq ($(filter $(NUMERIC),float fixed),)
$(error NUMERIC must be float or fixed, not '$(NUMERIC)')
endif

SHELL := /bin/bash
.DEFAULT_GOAL := help
PY := .venv/bin/python
B := build/host/$(NUMERIC)

CC ?= cc
WARN := -Wall -Wextra -Wconversion -Wdouble-promotion -Wshadow -Wstrict-prototypes \
        -Wmissing-prototypes -Wundef -Wcast-align -Werror
CSTD := -std=c11 -D_DEFAULT_SOURCE
OPT ?= -O2 -g
CFLAGS_HOST := $(CSTD) $(OPT) $(WARN) -fPIC -Ifirmware

# Portable core: every firmware module (no HAL, no platform headers).
FW_SRCS := $(sort $(wildcard firmware/*/*.c))
# Numeric mode: NUM_CFLAGS, NUM_SRCS and NUM_DEPS per mode (mk/numeric.mk).
include mk/numeric.mk

STAMP := build/.stamps
$(STAMP):
	@mkdir -p $@

# ---------------------------------------------------------------- dependencies
.PHONY: deps-sim deps-test venv
$(STAMP)/apt-sim: tools/deps/debian-sim.txt | $(STAMP)
	@tools/deps/apt-install $^
	@touch $@
$(STAMP)/apt-test: tools/deps/debian-sim.txt tools/deps/debian-test.txt | $(STAMP)
	@tools/deps/apt-install $^
	@touch $@
.venv/.requirements.sha256: requirements.txt $(STAMP)/apt-sim
	@tools/deps/venv
venv: .venv/.requirements.sha256
deps/unity/.sha256: tools/deps/sources.lock $(STAMP)/apt-sim
	@tools/deps/fetch-source unity
deps/libfixmath/.sha256: tools/deps/sources.lock $(STAMP)/apt-sim
	@tools/deps/fetch-source libfixmath
deps-sim: $(STAMP)/apt-sim venv $(NUM_DEPS)
deps-test: $(STAMP)/apt-test deps-sim deps/unity/.sha256

# ------------------------------------------------------------ host libraries
FW_OBJS := $(patsubst %.c,$(B)/obj/%.o,$(FW_SRCS) $(NUM_SRCS))
$(B)/obj/%.o: %.c $(NUM_DEPS) | $(STAMP)/apt-sim
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_HOST) $(NUM_CFLAGS) -MMD -MP -c $< -o $@
-include $(FW_OBJS:.o=.d)

$(B)/libmstc_sil.so: $(FW_OBJS) $(B)/obj/hal/sil/mstc_sil.o
	$(CC) -shared -o $@ $^ -lm
$(B)/obj/hal/sil/mstc_sil.o: CFLAGS_HOST += -Ihal/sil
.PHONY: lib
lib: $(B)/libmstc_sil.so  ## build the firmware as a shared library (SIL)

# ----------------------------------------------------------------------- sim
SCENARIO ?= sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml
.PHONY: sim
sim: deps-sim $(B)/libmstc_sil.so  ## run the paper's scenarios (or SCENARIO=file.toml)
	PYTHONPATH=sim $(PY) -m mstc_sim run --lib $(B)/libmstc_sil.so --out build/sim $(SCENARIO)

# ---------------------------------------------------------------------- test
UNIT_TESTS := $(patsubst tests/unit/%.c,%,$(sort $(wildcard tests/unit/test_*.c)))
UNIT_BINS := $(addprefix $(B)/tests/,$(UNIT_TESTS))
UNITY_OBJ := $(B)/obj/deps/unity/unity.o
$(UNITY_OBJ): deps/unity/.sha256
	@mkdir -p $(dir $@)
	$(CC) -std=c11 -O1 -g -DUNITY_INCLUDE_DOUBLE -c deps/unity/unity.c -o $@
$(B)/tests/%: tests/unit/%.c $(FW_OBJS) $(UNITY_OBJ) $(wildcard tests/unit/*.h)
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS_HOST) $(NUM_CFLAGS) -DUNITY_INCLUDE_DOUBLE -Ideps/unity -Itests/unit \
	  $< $(FW_OBJS) $(UNITY_OBJ) -lm -o $@

.PHONY: test test-unit test-python
test-unit: deps-test $(UNIT_BINS)  ## Unity tests of every firmware module
	@tools/run-unit-tests $(UNIT_BINS)
test-python: deps-test $(B)/libmstc_sil.so  ## pytest
	MSTC_SIL_LIB=$(B)/libmstc_sil.so PYTHONPATH=sim $(PY) -m pytest -q tests/python
test: test-unit test-python  ## every test

-include mk/*.mk.local

.PHONY: clean help
clean:  ## remove build outputs (keeps .venv and deps/)
	rm -rf build
help:  ## this list
	@grep -hE '^[a-z][a-zA-Z_-]*:.*## ' $(MAKEFILE_LIST) | sed 's/:.*## /\t/' | sort | expand -t 16
