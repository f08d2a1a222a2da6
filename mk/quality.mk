# Quality checks of the firmware (docs/safety.md): fuzzing, coverage, static
# analysis, the strict warning set on every compiler. Included by the top
# Makefile after mk/numeric.mk. Uses from the Makefile: WARN, CSTD, PY, B,
# STAMP, FW_SRCS, the venv and deps rules; from mk/numeric.mk the
# NUM_*_<mode> variables and LIBFIXMATH_WARN.
#
#   make fuzz [FUZZ_SECONDS=60]  every libFuzzer harness (clang, ASan, UBSan)
#                                for FUZZ_SECONDS each; corpus: fuzz/corpus/
#   make coverage                unit tests with gcov; gcovr report and the
#                                thresholds of tools/quality/coverage_check
#   make static-analysis         cppcheck + MISRA addon, clang-tidy
#   make warnings                the firmware under WARN with clang (host)
#                                and arm-none-eabi-gcc, both numeric modes
#   make quality                 static-analysis and warnings (quick)

FUZZ_SECONDS ?= 60
FUZZ_CC ?= clang
FUZZ_DIR := build/fuzz
FUZZ_FLAGS := -std=c11 -D_DEFAULT_SOURCE -g -O1 -fsanitize=fuzzer,address,undefined \
  -fno-sanitize-recover=all -fno-omit-frame-pointer -Ifirmware -Ihal/include -Ihal/fake
# name:source:numeric mode
FUZZ_HARNESSES := frames:fuzz/fuzz_frames.c:float ctl:fuzz/fuzz_ctl.c:float \
  ctl_fixed:fuzz/fuzz_ctl.c:fixed
FUZZ_NAMES := $(foreach h,$(FUZZ_HARNESSES),$(word 1,$(subst :, ,$(h))))
FW_HDRS := $(wildcard firmware/*/*.h)

define FUZZ_RULES
$(FUZZ_DIR)/$(1): $(2) $(FW_SRCS) $(FW_HDRS) hal/fake/hal_fake.c $(NUM_DEPS_$(3)) \
    | $(STAMP)/apt-test
	@mkdir -p $$(@D)
	$(FUZZ_CC) $(FUZZ_FLAGS) $(WARN) $(NUM_CFLAGS_$(3)) $(2) \
	  $(FW_SRCS) hal/fake/hal_fake.c \
	  $(if $(NUM_SRCS_$(3)),$(NUM_SRCS_$(3)) -Wno-conversion -Wno-sign-conversion) -lm -o $$@
endef
$(foreach h,$(FUZZ_HARNESSES),$(eval $(call FUZZ_RULES,$(word 1,$(subst :, ,$(h))),$(word 2,$(subst :, ,$(h))),$(word 3,$(subst :, ,$(h))))))

.PHONY: fuzz fuzz-build
fuzz-build: $(addprefix $(FUZZ_DIR)/,$(FUZZ_NAMES))
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
# the mode whose branches include the non-finite checks), then gcovr.
COV_DIR := build/coverage
COV_CFLAGS := $(CSTD) -O0 -g --coverage $(WARN) -Ifirmware -Ihal/include -Ihal/fake
COV_OBJS := $(patsubst %.c,$(COV_DIR)/obj/%.o,$(FW_SRCS) hal/fake/hal_fake.c)
COV_TESTS := $(addprefix $(COV_DIR)/tests/,$(UNIT_TESTS))
$(COV_DIR)/obj/%.o: %.c | $(STAMP)/apt-sim
	@mkdir -p $(@D)
	$(CC) $(COV_CFLAGS) -MMD -MP -c $< -o $@
.SECONDARY: $(COV_OBJS)
-include $(COV_OBJS:.o=.d)
$(COV_DIR)/tests/%: tests/unit/%.c $(COV_OBJS) $(UNITY_OBJ) $(wildcard tests/unit/*.h)
	@mkdir -p $(@D)
	$(CC) $(COV_CFLAGS) -DUNITY_INCLUDE_DOUBLE -Ideps/unity -Itests/unit $< $(COV_OBJS) \
	  $(UNITY_OBJ) -lm -o $@

.PHONY: coverage
coverage: deps-test $(COV_TESTS)  ## unit tests under gcov; gcovr report, thresholds of docs/safety.md
	@find $(COV_DIR) -name '*.gcda' -delete
	@tools/run-unit-tests $(COV_TESTS) > $(COV_DIR)/tests.log || { cat $(COV_DIR)/tests.log; exit 1; }
	@tail -n 1 $(COV_DIR)/tests.log
	@$(PY) -m gcovr --root . --filter 'firmware/' --exclude 'firmware/comm/mstc_dbc\.c' \
	  --exclude-unreachable-branches --json-summary $(COV_DIR)/summary.json \
	  --html-details $(COV_DIR)/index.html --txt $(COV_DIR)/coverage.txt $(COV_DIR)/obj
	@cat $(COV_DIR)/coverage.txt
	@$(PY) tools/quality/coverage_check $(COV_DIR)/summary.json

# ----------------------------------------------------------- static analysis
# The firmware's own sources: the generated codec is checked by its golden
# file and its -Werror compile (mk/comm.mk), libfixmath is third-party;
# docs/misra-deviations.md lists both and every rule not followed.
SA_SRCS := $(filter-out firmware/comm/mstc_dbc.c,$(FW_SRCS))
SA_DIR := build/static-analysis
CPPCHECK_FLAGS := --std=c11 --language=c --enable=warning,style,performance,portability \
  --inline-suppr --error-exitcode=1 --quiet --addon=tools/quality/misra.json \
  --suppressions-list=tools/quality/cppcheck-suppressions.txt \
  --suppress=missingIncludeSystem -Ifirmware -Ihal/include \
  --cppcheck-build-dir=$(SA_DIR)/cppcheck

$(SA_DIR)/cppcheck.ok: $(SA_SRCS) $(FW_HDRS) tools/quality/misra.json \
    tools/quality/cppcheck-suppressions.txt | $(STAMP)/apt-test
	@mkdir -p $(SA_DIR)/cppcheck
	cppcheck $(CPPCHECK_FLAGS) $(SA_SRCS)
	cppcheck $(CPPCHECK_FLAGS) -DNUM_FIXED $(SA_SRCS)
	@touch $@

$(SA_DIR)/clang-tidy.ok: $(SA_SRCS) $(FW_HDRS) .clang-tidy $(NUM_DEPS_fixed) | $(STAMP)/apt-test
	@mkdir -p $(@D)
	clang-tidy --quiet $(SA_SRCS) -- $(CSTD) -Ifirmware -Ihal/include
	clang-tidy --quiet $(SA_SRCS) -- $(CSTD) -DNUM_FIXED -Ifirmware -Ihal/include -I$(LIBFIXMATH_DIR)
	@touch $@

.PHONY: static-analysis cppcheck clang-tidy
cppcheck: $(SA_DIR)/cppcheck.ok
clang-tidy: $(SA_DIR)/clang-tidy.ok
static-analysis: cppcheck clang-tidy  ## cppcheck with the MISRA addon, clang-tidy: zero findings

# ------------------------------------------------------------------ warnings
# Every firmware source under WARN with clang on the host and with the
# cross compiler, in both numeric modes (gcc on the host: every build).
WARN_MODES := float fixed
$(SA_DIR)/warnings.ok: $(FW_SRCS) $(FW_HDRS) $(NUM_DEPS_fixed) | $(STAMP)/apt-test
	@mkdir -p $(@D)
	@set -e; for m in $(WARN_MODES); do \
	  flags="$(CSTD) $(WARN) -Ifirmware -Ihal/include"; \
	  [ $$m = fixed ] && flags="$$flags $(NUM_CFLAGS_fixed)"; \
	  for f in $(FW_SRCS); do \
	    clang $$flags -fsyntax-only $$f; \
	    arm-none-eabi-gcc $$flags -mcpu=cortex-m3 -mthumb -fsyntax-only $$f; \
	    arm-none-eabi-gcc $$flags -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 \
	      -fsyntax-only $$f; \
	  done; \
	  echo "warnings ($$m): clang, arm-none-eabi-gcc (M3, M4F): none"; \
	done
	@touch $@

.PHONY: warnings quality
warnings: $(SA_DIR)/warnings.ok  ## the firmware under WARN with clang and arm-none-eabi-gcc: zero warnings
quality: static-analysis warnings  ## static analysis and the warning check
