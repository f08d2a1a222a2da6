# SPDX-License-Identifier: MIT
# make bench: instructions of one control step on Cortex-M (QEMU mps2 boards,
# counted with SysTick under -icount; and on the board images in the loop,
# mk/pil.mk) and nanoseconds per step on the host,
# over a recorded closed loop of the paper's scenarios; prints a table and
# writes it into docs/performance.md (python -m mstc.bench.ctl_step). Results are
# cached in build/bench/*.txt and remade when their image or program changes.
# Uses from the Makefile: CC, CSTD, OPT, FW_INC, PY, STAMP, CORE_SRCS
# (ctl_step's sources: no protocol, no application), the venv rule; from
# mk/numeric.mk the NUM_*_<mode> variables; from mk/cross.mk the configs, their
# libraries and CROSS_FLAGS_<config>. Each program is a build of
# mk/compile.mk. The benchmark's C program is tools/bench/ (bench_core.c; the
# target's start-up and link script, the host's main; can_echo.c).

BENCH_DIR := build/bench
BENCH_SCENARIOS := sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml
QEMU_ARM ?= qemu-system-arm
QEMU_MACHINE_m4f := mps2-an386
QEMU_MACHINE_m3 := mps2-an385
# The wheel loop's benchmark runs against the DC motor model (sim/dcmotor/, mk/host.mk).
BENCH_TARGET_SRCS := tools/bench/startup.c tools/bench/bench_core.c tools/bench/bench_target.c \
  tools/bench/bench_wheel.c $(DCMOTOR_SRCS)
BENCH_HOST_SRCS := tools/bench/bench_core.c tools/bench/bench_host.c
# The benchmark's sources include the scenarios generated into BENCH_DIR.
SRC_CFLAGS_tools/bench := -Itools/bench -I$(BENCH_DIR) $(DCMOTOR_INC)

$(BENCH_DIR)/scenarios.h: sim/mstc/bench/scenarios.py $(BENCH_SCENARIOS) | .venv/.requirements.sha256
	@mkdir -p $(@D)
	$(PY) -m mstc.bench.scenarios $@ $(BENCH_SCENARIOS)

# Cortex-M images: the benchmark compiled as the cross build of the config,
# linked with its library. $(1): config <cpu>-<mode> of mk/cross.mk.
define BENCH_IMAGE_RULES
BUILD_CC_bench-$(1) := $$(CROSS_CC)
BUILD_CFLAGS_bench-$(1) := $$(CROSS_FLAGS_$(1)) -DBENCH_CONFIG='"$(1)"'
BUILD_DIR_bench-$(1) := $(BENCH_DIR)/$(1)/obj
BUILD_SRCS_bench-$(1) := $(BENCH_TARGET_SRCS)
BUILD_DEPS_bench-$(1) := $(BENCH_DIR)/scenarios.h $$(NUM_DEPS_$(call cross_mode,$(1)))
BUILD_ORDER_bench-$(1) := $$(STAMP)/apt-test
$$(eval $$(call BUILD,bench-$(1)))
$(BENCH_DIR)/$(1).elf: $$(BUILD_OBJS_bench-$(1)) build/cross/$(1)/libmstc_fw.a tools/bench/link.ld
	$$(CROSS_CC) $$(CROSS_CPU_$(call cross_cpu,$(1))) $$(filter %.o %.a,$$^) --specs=rdimon.specs \
	  -T tools/bench/link.ld -Wl,--gc-sections -lm -o $$@
$(BENCH_DIR)/$(1).txt: $(BENCH_DIR)/$(1).elf | $$(STAMP)/apt-test
	timeout 600 $$(QEMU_ARM) -M $$(QEMU_MACHINE_$(call cross_cpu,$(1))) -nographic -monitor none \
	  -serial none -semihosting-config enable=on,target=native -icount shift=0 -kernel $$< > $$@.tmp
	@grep -q '^done$$$$' $$@.tmp || { cat $$@.tmp; echo "error: $$< did not finish" >&2; exit 1; }
	@mv $$@.tmp $$@
endef
$(foreach c,$(CROSS_CONFIGS),$(eval $(call BENCH_IMAGE_RULES,$(c))))

# Host programs, one per numeric mode: the control core and the benchmark.
# $(1): mode; the build also compiles BENCH_EXTRA_SRCS_<mode>.
define BENCH_HOST_RULES
BUILD_CC_bench-host-$(1) := $$(CC)
BUILD_CFLAGS_bench-host-$(1) := $$(CSTD) $$(OPT) $$(FW_INC) $$(NUM_CFLAGS_$(1))
BUILD_DIR_bench-host-$(1) := $(BENCH_DIR)/host-$(1)/obj
BUILD_SRCS_bench-host-$(1) := $$(CORE_SRCS) $$(NUM_SRCS_$(1)) $(BENCH_HOST_SRCS) $$(BENCH_EXTRA_SRCS_$(1))
BUILD_DEPS_bench-host-$(1) := $$(NUM_DEPS_$(1))
BUILD_ORDER_bench-host-$(1) := $$(STAMP)/apt-sim
$$(eval $$(call BUILD,bench-host-$(1)))
$$(call build_objs,bench-host-$(1),$(BENCH_HOST_SRCS)): $(BENCH_DIR)/scenarios.h
$(BENCH_DIR)/host-$(1)/bench: $$(call build_objs,bench-host-$(1),$(BENCH_HOST_SRCS) $$(CORE_SRCS) \
    $$(NUM_SRCS_$(1)))
	$$(CC) $$^ -lm -o $$@
$(BENCH_DIR)/host-$(1).txt: $(BENCH_DIR)/host-$(1)/bench
	$$< > $$@.tmp
	@mv $$@.tmp $$@
endef
# The CAN echo of the round-trip benchmark (below) is hal/linux's SocketCAN
# driver behind a loop: compiled in the float host build.
BENCH_ECHO_SRCS := tools/bench/can_echo.c hal/linux/hal_can_socketcan.c
BENCH_EXTRA_SRCS_float := $(BENCH_ECHO_SRCS)
$(foreach m,$(NUM_MODES),$(eval $(call BENCH_HOST_RULES,$(m))))

BENCH_RESULTS := $(foreach c,$(CROSS_CONFIGS) $(addprefix host-,$(NUM_MODES)),$(BENCH_DIR)/$(c).txt)

# CAN: steps per second through frames in process, and lock-step round trips
# over vcan (in the VM where the host has no CAN) beside a bare round trip to
# a C echo built on hal/linux, all measured in one run (python -m mstc.bench.canbus).
$(BENCH_DIR)/can_echo: $(call build_objs,bench-host-float,$(BENCH_ECHO_SRCS))
	$(CC) $^ -o $@
$(BENCH_DIR)/can-sil.json: $(B)/libmstc_sil.so sim/mstc/bench/canbus.py | .venv/.requirements.sha256
	MSTC_KEY_FILE=$(TEST_KEY_FILE) $(PY) -m mstc.bench.canbus sil --lib $< --out $@
$(BENCH_DIR)/can-hil.json: build/host/mstc-fw build/host/can-bridge $(BENCH_DIR)/can_echo \
    sim/mstc/bench/canbus.py | deps-hil
	tools/vm/with-vcan --bridge --timeout 1200 -- $(PY) -m mstc.bench.canbus hil \
	  --fw build/host/mstc-fw --echo $(BENCH_DIR)/can_echo --out $@
BENCH_CAN := $(BENCH_DIR)/can-sil.json $(BENCH_DIR)/can-hil.json
# Real time: one mstc hil --realtime run per paper scenario against
# mstc-fw --realtime, its timing.json figures (python -m mstc.bench.realtime).
$(BENCH_DIR)/can-realtime.json: build/host/mstc-fw build/host/can-bridge sim/mstc/bench/realtime.py \
    $(wildcard sim/mstc/loop/*.py sim/mstc/plant/*.py sim/mstc/can/*.py) | deps-hil
	MSTC_KEY_FILE=$(TEST_KEY_FILE) MPLCONFIGDIR=$(CURDIR)/build/mplconfig \
	  tools/vm/with-vcan --bridge --timeout 1200 -- \
	  $(PY) -m mstc.bench.realtime run --fw build/host/mstc-fw --out $@

# Sweeps: scene-steps per second in memory, the batched engine against the
# per-scene one, `mstc sweep` of 10,000 scenes end to end against its engine's
# own CPU time, 1,000 paper-like scenes on every core and the same on a local
# Dask cluster (python -m mstc.bench.sweep).
$(BENCH_DIR)/sweep.json: $(B)/libmstc_sil.so sim/mstc/bench/sweep.py | .venv/.bytecode
	$(PY) -m mstc.bench.sweep run --lib $< --out $@

.PHONY: bench
BENCH_ALL := $(BENCH_RESULTS) $(BENCH_CAN) $(PIL_STAMPS) $(BENCH_DIR)/sweep.json \
  $(BENCH_DIR)/can-realtime.json replay-bench $(addprefix img-,$(BUDGET_IMGS))
bench: $(BENCH_ALL) | .venv/.bytecode  ## instructions per control step on Cortex-M (QEMU, alone and in the closed loop of the board images), ns on the host, CAN, sweep and real-time figures: docs/performance.md
	@$(PY) -m mstc.bench.ctl_step --doc docs/performance.md --pil build/pil $(BENCH_RESULTS)
	@$(PY) -m mstc.bench.canbus report --doc docs/performance.md $(BENCH_CAN)
	@$(PY) -m mstc.bench.sweep report --doc docs/performance.md $(BENCH_DIR)/sweep.json
	@$(PY) -m mstc.bench.realtime report --doc docs/performance.md \
	  $(BENCH_DIR)/can-realtime.json
	@$(BOARD_BUDGET) | tee $(BENCH_DIR)/boards.txt
	@$(PY) -m mstc.bench.doc --doc docs/performance.md \
	  --text "boards:Board images: flash, RAM and stack against the budgets (make firmware-budget)" \
	  < $(BENCH_DIR)/boards.txt

# make test's run of the Cortex-M4F benchmark image (test-host): the only
# -O2 Cortex-M4F build, so the only one with num_float.h's inline newlib
# steps (NUM_NEWLIB_INLINE). Every replayed step as recorded, the paper's
# events (scenario lines), and num_sincos, num_sqrt and num_hypot bit for bit
# newlib's own (the *_differs lines): any difference, or a missing line,
# fails.
bench-check: $(BENCH_DIR)/m4f-float.txt  ## run the Cortex-M4F benchmark image and check its replays and its bit-for-bit comparisons with newlib
	@awk '/^scenario / { s++; if ($$0 !~ / events_match 1 replay_differs 0 /) bad = bad "\n  " $$0 } \
	  /^load / { l++; if ($$0 !~ / replay_differs 0 /) bad = bad "\n  " $$0 } \
	  $$1 ~ /^[a-z]+_differs$$/ { d++; if ($$2 != "0") bad = bad "\n  " $$0 } \
	  END { if (s < 2 || l < 10 || d < 3) { printf "bench-check: %s: %d scenario, %d load, %d *_differs lines (want 2, 10, 3)\n", \
	          FILENAME, s, l, d; exit 1 } \
	        if (bad != "") { printf "bench-check: %s differs:%s\n", FILENAME, bad; exit 1 } \
	        printf "bench-check: %s: %d scenarios, %d load runs replayed alike; %d comparisons with newlib, no difference\n", \
	          FILENAME, s, l, d }' $<
.PHONY: bench-check
