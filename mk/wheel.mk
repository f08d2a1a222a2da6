# SPDX-License-Identifier: MIT
# make wheel-figures: the measurements behind the wheel loop's design and the
# figures of docs/wheel.md (tools/wheel/): the speed estimate's noise and lag,
# window against tracking loop, and the closed loop against the DC motor
# model in the acceptance's situations, in both numeric modes. Included by
# the top Makefile after mk/host.mk; uses CC, CSTD, OPT, FW_INC, PY, STAMP,
# mk/host.mk's DCMOTOR_SRCS and DCMOTOR_INC, and mk/numeric.mk's NUM_MODES,
# NUM_*_<mode>. Each mode is a build of mk/compile.mk (wheel-<mode>).

WHEEL_DIR := build/wheel
# The wheel loop and what its defaults come from (the limits table).
WHEEL_CORE_SRCS := firmware/wheel/whl.c firmware/ctrl/ctl_params.c firmware/ctrl/ctl_limits.c \
  $(sort $(wildcard firmware/num/*.c))
SRC_CFLAGS_tools/wheel := $(DCMOTOR_INC)

# $(1): numeric mode.
define WHEEL_RULES
BUILD_CC_wheel-$(1) := $$(CC)
BUILD_CFLAGS_wheel-$(1) := $$(CSTD) $$(OPT) $$(FW_INC) $$(NUM_CFLAGS_$(1))
BUILD_DIR_wheel-$(1) := $(WHEEL_DIR)/$(1)/obj
BUILD_SRCS_wheel-$(1) := tools/wheel/wheel_study.c $$(WHEEL_CORE_SRCS) $$(DCMOTOR_SRCS) \
  $$(NUM_SRCS_$(1))
BUILD_DEPS_wheel-$(1) := $$(NUM_DEPS_$(1))
BUILD_ORDER_wheel-$(1) := $$(STAMP)/apt-sim
$$(eval $$(call BUILD,wheel-$(1)))
$(WHEEL_DIR)/$(1)/wheel_study: $$(BUILD_OBJS_wheel-$(1))
	$$(CC) $$^ -lm -o $$@
$(WHEEL_DIR)/$(1)/.done: $(WHEEL_DIR)/$(1)/wheel_study
	$$< estimator > $(WHEEL_DIR)/$(1)/estimator.txt
	$$< response $(WHEEL_DIR)/$(1)
	@touch $$@
endef
$(foreach m,$(NUM_MODES),$(eval $(call WHEEL_RULES,$(m))))

.PHONY: wheel-figures
wheel-figures: $(WHEEL_DIR)/float/.done $(WHEEL_DIR)/fixed/.done | .venv/.requirements.sha256  ## the wheel loop's estimator study and closed-loop figures: docs/wheel.md, docs/img/wheel-*.png
	MPLCONFIGDIR=$(CURDIR)/build/mplconfig $(PY) tools/wheel/figures --doc docs/wheel.md \
	  --img docs/img $(WHEEL_DIR)/float $(WHEEL_DIR)/fixed

# make wheel-sil: the firmware's wheel loop in the simulation (docs/wheel.md):
# the paper's two scenarios under "mstc" through CAN, and WHEEL_SIL_COUNT
# seeded scenes of every family of the standard suite in memory (mstc sweep),
# each with `[actuator] model = "dc"` instead of the suite's actuator
# profiles, in both numeric modes; results under
# build/wheel/sil/ (summary.md of each sweep).
WHEEL_SIL_COUNT ?= 50
WHEEL_SIL := $(WHEEL_DIR)/sil
.PHONY: wheel-sil
wheel-sil: deps-sim libs-both $(KEY_FILE)  ## the paper's scenarios and a subset of every suite family on dc wheels under the firmware's wheel loop (WHEEL_SIL_COUNT=50): build/wheel/sil/
	@rm -rf $(WHEEL_SIL) && mkdir -p $(WHEEL_SIL)/paper
	@for s in paper-line paper-circle; do \
	  sed -e 's/^strategy = "paper"/strategy = "mstc"/' -e '/^\[\[expected\]\]/,$$d' \
	    sim/scenarios/$$s.toml > $(WHEEL_SIL)/paper/$$s-dc.toml; \
	  printf '\n[actuator]\nmodel = "dc"\n' >> $(WHEEL_SIL)/paper/$$s-dc.toml; done
	@# The suite's actuator profiles give way to the dc wheels: the scenes of
	@# its ideal profile (no [actuator] table) get them.
	$(MSTC) sweep --generate-only --actuator ideal --count $(WHEEL_SIL_COUNT) \
	  --out $(WHEEL_SIL) sim/suites/standard.toml
	@for f in $(WHEEL_SIL)/scenes/*/*.toml; do printf '\n[actuator]\nmodel = "dc"\n' >> $$f; done
	@set -e; for m in $(NUM_MODES); do \
	  $(MSTC) sim --bus sil --lib build/host/$$m/libmstc_sil.so --key-file $(KEY_FILE) \
	    --no-figures --out $(WHEEL_SIL)/paper/$$m $(WHEEL_SIL)/paper/*.toml; \
	  $(MSTC) sweep -q --strategy mstc --gallery 0 --lib build/host/$$m/libmstc_sil.so \
	    --out $(WHEEL_SIL)/$$m $(WHEEL_SIL)/scenes; done
