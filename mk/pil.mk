# SPDX-License-Identifier: MIT
# Processor in the loop (docs/hil.md): the board images' PIL variant
# (build/firmware/<board>-pil, mk/firmware.mk: the slcan image with two
# simulated motors in place of the wheels' drivers) under qemu-system-arm
# (sim/mstc/firmware/qemu.py), driven by the plant through python-can's slcan
# interface in lock-step (`mstc hil --qemu`). Included by the top Makefile
# after mk/firmware.mk and mk/host.mk; uses MSTC, SCENARIO, the img-<board>-pil
# rules, the host libraries, SIM_KEY_FILE and install_key (mk/auth.mk): QEMU
# runs a copy of each image with the simulations' key installed
# (build/pil/images/), never the device's.
#
#   make pil                      both boards: the paper's scenarios (ideal
#                                 wheels) and its line on "dc" wheels
#   make pil BOARD=stm32f103      one board
#   make pil SCENARIO=file.toml   other scenarios
#
# Each scenario writes build/pil/<board>/<scenario>/: events.json, trace.csv,
# bus.log (candump -L) and loop_stats.json (the board's steps, the
# instructions per control step and per wheel period under QEMU's -icount;
# on "dc" wheels the wheel loop's figures and wheel_trace.csv), and prints the
# table of `make sim`. The plant's twin of a board's "dc" wheels runs in the
# host library of the board's numeric mode.

PIL_ALL := $(IMG_PIL_BOARDS)
PIL_BOARDS := $(if $(filter command line environment,$(origin BOARD)),$(BOARD),$(PIL_ALL))
ifneq ($(filter pil,$(MAKECMDGOALS)),)
ifneq ($(filter-out $(PIL_ALL),$(PIL_BOARDS)),)
$(error make pil: BOARD must be one of: $(PIL_ALL) (not '$(BOARD)'))
endif
endif

# The paper's line on "dc" wheels under "mstc" (the strategy that uses the
# measured wheels), its [[expected]] events dropped: the wheels move them
# (docs/wheel.md, "In the simulation"), the test compares them with the
# simulation's (tests/python/test_pil.py).
PIL_DC := build/pil/scenarios/paper-line-dc.toml
$(PIL_DC): sim/scenarios/paper-line.toml
	@mkdir -p $(@D)
	@sed -e 's/^strategy = "paper"/strategy = "mstc"/' -e '/^\[\[expected\]\]/,$$d' $< > $@
	@printf '\n[actuator]\nmodel = "dc"\n' >> $@

.PHONY: pil
PIL_IMAGES := build/pil/images
$(PIL_IMAGES)/%/mstc.elf: build/firmware/%/mstc.elf $(SIM_KEY_BIN) tools/setup/install-key
	@$(call install_key,$<,$(SIM_KEY_BIN),$@)
pil_lib = build/host/$(IMG_NUMERIC_$(1))/libmstc_sil.so
pil_run = $(MSTC) hil --qemu $(PIL_IMAGES)/$(1)-pil --lib $(call pil_lib,$(1)) \
  --key-file $(SIM_KEY_FILE) --no-figures --out build/pil/$(1)

# The paper's scenarios and the "dc" line: what `make pil` runs unless
# SCENARIO is given, and what `make bench` reports (PIL_STAMPS).
PIL_PAPER := sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml
PIL_DEFAULT := $(if $(filter command line,$(origin SCENARIO)),,yes)
PIL_SCENARIOS := $(if $(PIL_DEFAULT),$(PIL_PAPER) $(PIL_DC),$(SCENARIO))
pil: deps-sim libs-both $(PIL_DC) $(foreach b,$(PIL_BOARDS),img-$(b)-pil $(PIL_IMAGES)/$(b)-pil/mstc.elf)  ## the paper's scenarios and its line on "dc" wheels on the PIL board images under QEMU, lock-step (BOARD=...: one) -> build/pil/
	@set -e; $(foreach b,$(PIL_BOARDS),echo "== $(b): $(PIL_IMAGES)/$(b)-pil under QEMU \
	  (build/firmware/$(b)-pil with the simulations' key)"; \
	  $(call pil_run,$(b)) $(PIL_SCENARIOS); \
	  $(if $(PIL_DEFAULT),touch build/pil/$(b)/.paper;))

# The same on each board, once per change of its image or of the harness,
# for `make bench` (instructions per control step and per wheel period in
# the loop).
PIL_STAMPS := $(foreach b,$(PIL_ALL),build/pil/$(b)/.paper)
build/pil/%/.paper: $(PIL_IMAGES)/%-pil/mstc.elf $(PIL_PAPER) $(PIL_DC) sim/mstc/cli/hil.py \
    sim/mstc/firmware/qemu.py sim/mstc/loop/lockstep.py | .venv/.requirements.sha256 libs-both
	$(call pil_run,$*) $(PIL_PAPER) $(PIL_DC)
	@touch $@
