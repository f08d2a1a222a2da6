# SPDX-License-Identifier: MIT
# Processor in the loop (docs/hil.md): the board images built with CAN=slcan,
# unchanged but for that transport, under qemu-system-arm (sim/mstc/firmware/qemu.py),
# driven by the plant through python-can's slcan interface in lock-step
# (`mstc hil --qemu`). Included by the top Makefile after mk/firmware.mk;
# uses MSTC, SCENARIO, the img-<board>-slcan rules, SIM_KEY_FILE and
# install_key (mk/auth.mk): QEMU runs a copy of each image with the
# simulations' key installed (build/pil/images/), never the device's.
#
#   make pil                      both boards, the paper's scenarios
#   make pil BOARD=stm32f103      one board
#   make pil SCENARIO=file.toml   other scenarios
#
# Each scenario writes build/pil/<board>/<scenario>/: events.json, trace.csv,
# bus.log (candump -L) and loop_stats.json (the board's steps and the
# instructions per control step under QEMU's -icount), and prints the table
# of `make sim`.

PIL_ALL := stm32f405 stm32f103
PIL_BOARDS := $(if $(filter command line environment,$(origin BOARD)),$(BOARD),$(PIL_ALL))
ifneq ($(filter pil,$(MAKECMDGOALS)),)
ifneq ($(filter-out $(PIL_ALL),$(PIL_BOARDS)),)
$(error make pil: BOARD must be one of: $(PIL_ALL) (not '$(BOARD)'))
endif
endif

.PHONY: pil
PIL_IMAGES := build/pil/images
$(PIL_IMAGES)/%/mstc.elf: build/firmware/%/mstc.elf $(SIM_KEY_BIN) tools/setup/install-key
	@$(call install_key,$<,$(SIM_KEY_BIN),$@)

pil: deps-sim $(foreach b,$(PIL_BOARDS),img-$(b)-slcan $(PIL_IMAGES)/$(b)-slcan/mstc.elf)  ## the paper's scenarios on the slcan board images under QEMU, lock-step (BOARD=...: one) -> build/pil/
	@set -e; for b in $(PIL_BOARDS); do \
	  echo "== $$b: $(PIL_IMAGES)/$$b-slcan under QEMU (build/firmware/$$b-slcan with the simulations' key)"; \
	  $(MSTC) hil --qemu $(PIL_IMAGES)/$$b-slcan --key-file $(SIM_KEY_FILE) --no-figures \
	    --out build/pil/$$b $(SCENARIO); \
	  $(if $(filter-out $(SCENARIO),$(PIL_PAPER))$(filter-out $(PIL_PAPER),$(SCENARIO)),,touch build/pil/$$b/.paper;) \
	done

# The paper's scenarios on each board, once per change of its image or of the
# harness, for `make bench` (instructions per control step in the loop).
PIL_PAPER := sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml
PIL_STAMPS := $(foreach b,$(PIL_ALL),build/pil/$(b)/.paper)
build/pil/%/.paper: $(PIL_IMAGES)/%-slcan/mstc.elf $(PIL_PAPER) sim/mstc/cli/hil.py \
    sim/mstc/firmware/qemu.py sim/mstc/loop/lockstep.py | .venv/.requirements.sha256
	$(MSTC) hil --qemu $(PIL_IMAGES)/$*-slcan --key-file $(SIM_KEY_FILE) --no-figures \
	  --out build/pil/$* $(PIL_PAPER)
	@touch $@
