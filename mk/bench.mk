# make bench: instructions of one control step on Cortex-M (QEMU mps2 boards,
# counted with SysTick under -icount) and nanoseconds per step on the host,
# over a recorded closed loop of the paper's scenarios; prints a table and
# writes it into docs/performance.md (tools/bench/report.py). Results are
# cached in build/bench/*.txt and remade when their image or program changes.
# Uses from the Makefile: CC, CSTD, OPT, WARN, PY, STAMP, CORE_SRCS (ctl_step's
# sources: no protocol, no application), the venv rule; from
# mk/numeric.mk the NUM_*_<mode> variables; from mk/cross.mk the libraries.

BENCH_DIR := build/bench
BENCH_SCENARIOS := sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml
QEMU_ARM ?= qemu-system-arm
QEMU_MACHINE_m4f := mps2-an386
QEMU_MACHINE_m3 := mps2-an385
BENCH_TARGET_SRCS := tools/bench/startup.c tools/bench/bench_core.c tools/bench/bench_target.c
BENCH_HOST_SRCS := tools/bench/bench_core.c tools/bench/bench_host.c

$(BENCH_DIR)/scenarios.h: tools/bench/gen_scenarios.py $(BENCH_SCENARIOS) | .venv/.requirements.sha256
	@mkdir -p $(@D)
	$(PY) tools/bench/gen_scenarios.py $@ $(BENCH_SCENARIOS)

# Cortex-M images. $(1): config <cpu>-<mode> of mk/cross.mk; $(2): cpu.
define BENCH_IMAGE_RULES
$(BENCH_DIR)/$(1).elf: $(BENCH_TARGET_SRCS) tools/bench/bench.h tools/bench/link.ld \
    $(BENCH_DIR)/scenarios.h build/cross/$(1)/libmstc_fw.a
	$$(CROSS_CC) $$(CROSS_FLAGS_$(1)) $$(WARN) -Itools/bench -I$(BENCH_DIR) \
	  -DBENCH_CONFIG='"$(1)"' $(BENCH_TARGET_SRCS) build/cross/$(1)/libmstc_fw.a \
	  --specs=rdimon.specs -T tools/bench/link.ld -Wl,--gc-sections -lm -o $$@
$(BENCH_DIR)/$(1).txt: $(BENCH_DIR)/$(1).elf | $$(STAMP)/apt-test
	timeout 600 $$(QEMU_ARM) -M $$(QEMU_MACHINE_$(2)) -nographic -monitor none -serial none \
	  -semihosting-config enable=on,target=native -icount shift=0 -kernel $$< > $$@.tmp
	@grep -q '^done$$$$' $$@.tmp || { cat $$@.tmp; echo "error: $$< did not finish" >&2; exit 1; }
	@mv $$@.tmp $$@
endef
$(eval $(call BENCH_IMAGE_RULES,m4f-float,m4f))
$(eval $(call BENCH_IMAGE_RULES,m3-fixed,m3))
$(eval $(call BENCH_IMAGE_RULES,m3-float,m3))

# Host programs, one per numeric mode. $(1): mode.
BENCH_HOST_WARN := $(WARN)
define BENCH_HOST_RULES
BENCH_HOST_OBJS_$(1) := $$(patsubst %.c,$(BENCH_DIR)/host-$(1)/obj/%.o,$$(CORE_SRCS) $$(NUM_SRCS_$(1)))
$(BENCH_DIR)/host-$(1)/obj/%.o: %.c $$(NUM_DEPS_$(1)) | $$(STAMP)/apt-sim
	@mkdir -p $$(dir $$@)
	$$(CC) $$(CSTD) $$(OPT) $$(BENCH_HOST_WARN) -Ifirmware -Ihal/include $$(NUM_CFLAGS_$(1)) \
	  -MMD -MP -c $$< -o $$@
$(BENCH_DIR)/host-$(1)/obj/$$(LIBFIXMATH_DIR)/%.o: BENCH_HOST_WARN := $$(LIBFIXMATH_WARN)
-include $$(BENCH_HOST_OBJS_$(1):.o=.d)
$(BENCH_DIR)/host-$(1)/bench: $(BENCH_HOST_SRCS) tools/bench/bench.h $(BENCH_DIR)/scenarios.h \
    $$(BENCH_HOST_OBJS_$(1))
	$$(CC) $$(CSTD) $$(OPT) $$(WARN) -Ifirmware -Ihal/include -Itools/bench -I$(BENCH_DIR) \
	  $$(NUM_CFLAGS_$(1)) $(BENCH_HOST_SRCS) $$(BENCH_HOST_OBJS_$(1)) -lm -o $$@
$(BENCH_DIR)/host-$(1).txt: $(BENCH_DIR)/host-$(1)/bench
	$$< > $$@.tmp
	@mv $$@.tmp $$@
endef
$(eval $(call BENCH_HOST_RULES,float))
$(eval $(call BENCH_HOST_RULES,fixed))

BENCH_RESULTS := $(foreach c,m4f-float m3-fixed m3-float,$(BENCH_DIR)/$(c).txt) \
                 $(BENCH_DIR)/host-float.txt $(BENCH_DIR)/host-fixed.txt

# CAN: steps per second through frames in process, and lock-step round trips
# over vcan (in the VM where the host has no CAN) beside a bare round trip to
# a C echo built on hal/linux, all measured in one run (tools/bench/can_bench.py).
$(BENCH_DIR)/can_echo: tools/bench/can_echo.c hal/linux/hal_can_socketcan.c | $(STAMP)/apt-sim
	@mkdir -p $(@D)
	$(CC) $(CSTD) $(OPT) $(WARN) -Ihal/include $^ -o $@
$(BENCH_DIR)/can-sil.json: $(B)/libmstc_sil.so tools/bench/can_bench.py | .venv/.requirements.sha256
	$(PY) tools/bench/can_bench.py sil --lib $< --out $@
$(BENCH_DIR)/can-hil.json: build/host/mstc-fw $(BENCH_DIR)/can_echo tools/bench/can_bench.py | deps-hil
	tools/vm/with-vcan --timeout 1200 -- $(PY) tools/bench/can_bench.py hil \
	  --fw build/host/mstc-fw --echo $(BENCH_DIR)/can_echo --out $@
BENCH_CAN := $(BENCH_DIR)/can-sil.json $(BENCH_DIR)/can-hil.json

.PHONY: bench
bench: $(BENCH_RESULTS) $(BENCH_CAN) | .venv/.requirements.sha256  ## instructions per control step on Cortex-M (QEMU), ns on the host, CAN throughput: docs/performance.md
	@$(PY) tools/bench/report.py --doc docs/performance.md $(BENCH_RESULTS)
	@$(PY) tools/bench/can_bench.py report --doc docs/performance.md $(BENCH_CAN)
	@$(MAKE) --no-print-directory replay-bench
	@$(MAKE) --no-print-directory firmware-budget | tee $(BENCH_DIR)/boards.txt
	@$(PY) tools/bench/report.py --doc docs/performance.md \
	  --text "boards:Board images: flash, RAM and stack against the budgets (make firmware-budget)" \
	  < $(BENCH_DIR)/boards.txt
