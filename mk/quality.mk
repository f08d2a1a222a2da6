# SPDX-License-Identifier: MIT
# Quality checks of the firmware (docs/safety.md): fuzzing, coverage, static
# analysis, the strict warning set on every compiler. Included by the top
# Makefile after mk/host.mk and mk/cross.mk; fuzzing and coverage are builds
# of mk/compile.mk. Uses from the Makefile: WARN, CSTD, FW_INC, PY, STAMP,
# FW_SRCS, fw_srcs, the venv and deps rules; from mk/host.mk FAKE_SRCS, the
# unit tests (UNIT_*, TEST_SRCS, UNITY_OBJ, UNIT_TEST_RULES); from
# mk/numeric.mk the NUM_*_<mode> variables; from mk/cross.mk the toolchain.
#
#   make fuzz [FUZZ_SECONDS=60]  every libFuzzer harness (clang, ASan, UBSan)
#                                for FUZZ_SECONDS each; corpus: fuzz/corpus/
#   make coverage                unit tests with gcov; gcovr report and the
#                                thresholds of tools/quality/coverage-check
#   make static-analysis         cppcheck + MISRA addon, clang-tidy
#   make warnings                the firmware under WARN with clang (host)
#                                and arm-none-eabi-gcc, both numeric modes
#   make quality                 static-analysis and warnings (quick)

FUZZ_SECONDS ?= 60
FUZZ_CC ?= clang
FUZZ_DIR := build/fuzz
FUZZ_SANITIZE := -fsanitize=fuzzer,address,undefined
# The harnesses, in the order make fuzz runs them. Harness <name> is
# fuzz/fuzz_<name>.c in float mode unless FUZZ_SRC_<name>, FUZZ_MODE_<name>
# say otherwise, and links FUZZ_EXTRA_<name> beyond the firmware: the board
# images' slcan parser, which is not part of the firmware proper (hal/stm32).
FUZZ_NAMES := frames ctl ctl_fixed auth slcan
FUZZ_SRC_ctl_fixed := fuzz/fuzz_ctl.c
FUZZ_MODE_ctl_fixed := fixed
FUZZ_EXTRA_slcan := hal/stm32/slcan_codec.c
SRC_CFLAGS_fuzz/fuzz_slcan.c := -Ihal/stm32
fuzz_srcs = $(or $(FUZZ_SRC_$(1)),fuzz/fuzz_$(1).c) $(FUZZ_EXTRA_$(1))
FW_HDRS := $(wildcard firmware/*/*.h)

# One build per numeric mode (fuzz-<mode>): the firmware, hal/fake and the
# harnesses of that mode, each linked from them.
define FUZZ_BUILD
FUZZ_NAMES_$(1) := $$(foreach n,$$(FUZZ_NAMES),$$(if $$(filter $(1),$$(or $$(FUZZ_MODE_$$(n)),float)),$$(n)))
BUILD_CC_fuzz-$(1) := $$(FUZZ_CC)
BUILD_CFLAGS_fuzz-$(1) := $$(CSTD) -g -O1 $$(FUZZ_SANITIZE) -fno-sanitize-recover=all \
  -fno-omit-frame-pointer $$(FW_INC) -Ihal/fake $$(NUM_CFLAGS_$(1)) $$(AUTH_CFLAGS)
BUILD_DIR_fuzz-$(1) := $$(FUZZ_DIR)/obj-$(1)
BUILD_SRCS_fuzz-$(1) := $$(FW_SRCS) $$(FAKE_SRCS) $$(NUM_SRCS_$(1)) $$(AUTH_SRCS) \
  $$(sort $$(foreach n,$$(FUZZ_NAMES_$(1)),$$(call fuzz_srcs,$$(n))))
BUILD_DEPS_fuzz-$(1) := $$(NUM_DEPS_$(1)) $$(AUTH_DEPS)
BUILD_ORDER_fuzz-$(1) := $$(STAMP)/apt-test
$$(eval $$(call BUILD,fuzz-$(1)))
$$(foreach n,$$(FUZZ_NAMES_$(1)),$$(eval $$(FUZZ_DIR)/$$(n): $$(call build_objs,fuzz-$(1),$$(call \
  fuzz_srcs,$$(n)) $$(FW_SRCS) $$(FAKE_SRCS) $$(NUM_SRCS_$(1)) $$(AUTH_SRCS))))
$$(addprefix $$(FUZZ_DIR)/,$$(FUZZ_NAMES_$(1))):
	$$(FUZZ_CC) $$(FUZZ_SANITIZE) $$^ -lm -o $$@
endef
$(foreach m,$(NUM_MODES),$(eval $(call FUZZ_BUILD,$(m))))

# fuzz_frames sends every frame of the DBC and allows every halt reason of
# its STATUS_halt table: both lists are written at build time from the
# codec's header, which tools/gen-codec generates from firmware/comm/mstc.dbc
# (make check-protocol fails when it is stale), so that a frame or a halt
# added to the DBC is fuzzed from the first build that has it.
FUZZ_DBC_H := $(FUZZ_DIR)/include/fuzz_dbc_ids.h $(FUZZ_DIR)/include/fuzz_dbc_halts.h
# The recipe of such a list: $(1), the pattern of the defines it lists.
define FUZZ_DBC_LIST
@mkdir -p $(@D)
sed -n 's/^#define \($(1)\) .*/    \1,/p' $< > $@.tmp
@test -s $@.tmp || { echo "error: nothing matches $(1) in $<" >&2; exit 1; }
mv $@.tmp $@
endef
$(FUZZ_DIR)/include/fuzz_dbc_ids.h: firmware/comm/mstc_dbc.h
	$(call FUZZ_DBC_LIST,MSTC_DBC_[A-Z0-9_]*_FRAME_ID)
$(FUZZ_DIR)/include/fuzz_dbc_halts.h: firmware/comm/mstc_dbc.h
	$(call FUZZ_DBC_LIST,MSTC_DBC_STATUS_STATUS_HALT_[A-Z0-9_]*_CHOICE)
SRC_CFLAGS_fuzz/fuzz_frames.c := -I$(FUZZ_DIR)/include
$(call build_objs,fuzz-float,fuzz/fuzz_frames.c): $(FUZZ_DBC_H)

.PHONY: fuzz fuzz-build
fuzz-build: $(addprefix $(FUZZ_DIR)/,$(FUZZ_NAMES))
# tests/python/test_fuzz_frames.py runs the frames harness on inputs of its
# own: built before pytest, once, also when make test builds it beside it.
test-host: $(FUZZ_DIR)/frames
fuzz: fuzz-build  ## run every libFuzzer harness for FUZZ_SECONDS (default 60) each
	@set -e; for n in $(FUZZ_NAMES); do \
	  mkdir -p $(FUZZ_DIR)/corpus/$$n $(FUZZ_DIR)/findings/$$n; \
	  echo "fuzz $$n: $(FUZZ_SECONDS) s"; \
	  $(FUZZ_DIR)/$$n -max_total_time=$(FUZZ_SECONDS) -timeout=10 -print_final_stats=1 \
	    -artifact_prefix=$(FUZZ_DIR)/findings/$$n/ $(FUZZ_DIR)/corpus/$$n fuzz/corpus/$$n \
	    > $(FUZZ_DIR)/$$n.log 2>&1 || { tail -n 40 $(FUZZ_DIR)/$$n.log; \
	    echo "error: fuzz $$n found a failure: $(FUZZ_DIR)/findings/$$n/" >&2; exit 1; }; \
	  grep -E '^stat::number_of_executed_units|^stat::average_exec_per_sec|^stat::peak_rss_mb' \
	    $(FUZZ_DIR)/$$n.log | sed 's/^/  /'; \
	done

# ------------------------------------------------------------------ coverage
# The unit tests again, built with gcov at -O0 in build/coverage (float mode:
# the mode whose branches include the non-finite checks), then gcovr over the
# firmware and the STM32 drivers the register tests run (mk/host.mk).
COV_DIR := build/coverage
BUILD_CC_cov := $(CC)
BUILD_CFLAGS_cov := $(CSTD) -O0 -g --coverage $(FW_INC) $(AUTH_CFLAGS)
BUILD_DIR_cov := $(COV_DIR)/obj
BUILD_SRCS_cov := $(call fw_srcs,float) $(FAKE_SRCS) $(UNIT_SRCS) $(DRV_SRCS) $(TEST_SRCS)
BUILD_DEPS_cov := $(AUTH_DEPS)
BUILD_ORDER_cov := $(STAMP)/apt-sim
$(eval $(call BUILD,cov))
$(eval $(call UNIT_TEST_RULES,cov,$(COV_DIR)/tests,$(call fw_srcs,float) $(FAKE_SRCS),--coverage))
COV_TESTS := $(addprefix $(COV_DIR)/tests/,$(UNIT_TESTS) $(DRV_TESTS))
# The STM32 drivers the register tests run (tools/quality/coverage-check).
COV_DRIVERS := encoder motor_pwm bxcan can_queue tick time sys

.PHONY: coverage
coverage: deps-test $(COV_TESTS)  ## unit tests under gcov; gcovr report, thresholds of docs/safety.md
	@find $(COV_DIR) -name '*.gcda' -delete
	@tools/run-unit-tests $(COV_TESTS) > $(COV_DIR)/tests.log || { cat $(COV_DIR)/tests.log; exit 1; }
	@tail -n 1 $(COV_DIR)/tests.log
	@$(PY) -m gcovr --root . --filter 'firmware/' \
	  $(foreach d,$(COV_DRIVERS),--filter 'hal/stm32/$(d)\.c') --exclude 'firmware/comm/mstc_dbc\.c' \
	  --exclude-unreachable-branches --json-summary $(COV_DIR)/summary.json \
	  --html-details $(COV_DIR)/index.html --txt $(COV_DIR)/coverage.txt $(COV_DIR)/obj
	@cat $(COV_DIR)/coverage.txt
	@$(PY) tools/quality/coverage-check $(COV_DIR)/summary.json

# ----------------------------------------------------------- static analysis
# The firmware's own sources: the generated codec is checked by its golden
# file and its -Werror compile (mk/comm.mk), libfixmath and Mbed TLS are
# third-party (cppcheck is given Mbed TLS's configuration, not its headers:
# it would explore their MBEDTLS_CONFIG_FILE branches, which have no header);
# docs/misra-deviations.md lists both and every rule not followed.
SA_SRCS := $(filter-out firmware/comm/mstc_dbc.c,$(FW_SRCS))
SA_DIR := build/static-analysis
CPPCHECK_FLAGS := --std=c11 --language=c --enable=warning,style,performance,portability \
  --inline-suppr --error-exitcode=1 --quiet --addon=tools/quality/misra.json \
  --suppressions-list=tools/quality/cppcheck-suppressions.txt \
  --suppress=missingIncludeSystem $(FW_INC) $(AUTH_CONFIG_INC) \
  --cppcheck-build-dir=$(SA_DIR)/cppcheck

$(SA_DIR)/cppcheck.ok: $(SA_SRCS) $(FW_HDRS) $(AUTH_DEPS) tools/quality/misra.json \
    tools/quality/cppcheck-suppressions.txt | $(STAMP)/apt-test
	@mkdir -p $(SA_DIR)/cppcheck
	cppcheck $(CPPCHECK_FLAGS) $(SA_SRCS)
	cppcheck $(CPPCHECK_FLAGS) -DNUM_FIXED $(SA_SRCS)
	@touch $@

$(SA_DIR)/clang-tidy.ok: $(SA_SRCS) $(FW_HDRS) .clang-tidy $(NUM_DEPS_fixed) $(AUTH_DEPS) \
    | $(STAMP)/apt-test
	@mkdir -p $(@D)
	clang-tidy --quiet $(SA_SRCS) -- $(CSTD) $(FW_INC) $(AUTH_CFLAGS)
	clang-tidy --quiet $(SA_SRCS) -- $(CSTD) $(FW_INC) $(NUM_CFLAGS_fixed) $(AUTH_CFLAGS)
	@touch $@

.PHONY: static-analysis cppcheck clang-tidy
cppcheck: $(SA_DIR)/cppcheck.ok
clang-tidy: $(SA_DIR)/clang-tidy.ok
static-analysis: cppcheck clang-tidy  ## cppcheck with the MISRA addon, clang-tidy: zero findings

# ------------------------------------------------------------ driver mutants
# Each STM32 driver broken on purpose, one bug at a time: the test of it
# against its registers' models must fail (tools/quality/driver-mutants;
# docs/porting.md). Not part of make test: about 15 minutes.
.PHONY: driver-mutants
driver-mutants: deps-test test-unit-float  ## break each STM32 driver on purpose: its register test must catch every bug (tools/quality/driver-mutants)
	$(PY) tools/quality/driver-mutants

# ------------------------------------------------------------------ warnings
# Every firmware source under WARN with clang on the host and with the
# cross compiler, in both numeric modes (gcc on the host: every build).
$(SA_DIR)/warnings.ok: $(FW_SRCS) $(FW_HDRS) $(NUM_DEPS_fixed) $(AUTH_DEPS) | $(STAMP)/apt-test
	@mkdir -p $(@D)
	@set -e; $(foreach m,$(NUM_MODES),flags="$(CSTD) $(WARN) $(FW_INC) $(NUM_CFLAGS_$(m)) $(AUTH_CFLAGS)"; \
	  for f in $(FW_SRCS) $(AUTH_SRCS); do \
	    clang $$flags -fsyntax-only $$f; \
	    $(CROSS_CC) $$flags $(CROSS_CPU_m3) -fsyntax-only $$f; \
	    $(CROSS_CC) $$flags $(CROSS_CPU_m4f) -fsyntax-only $$f; \
	  done; \
	  echo "warnings ($(m)): clang, arm-none-eabi-gcc (M3, M4F): none";)
	@touch $@

.PHONY: warnings quality
warnings: $(SA_DIR)/warnings.ok  ## the firmware under WARN with clang and arm-none-eabi-gcc: zero warnings
quality: static-analysis warnings  ## static analysis and the warning check
