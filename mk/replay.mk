# SPDX-License-Identifier: MIT
# Bus logs: replay through the firmware, decode and plot (docs/replay.md).
#
#   make replay LOG=path [REPLAY_ARGS=...]  feed a log's input frames through the
#                                           firmware library, compare what it sends
#   make replay-regress                     replay the committed logs tests/data/*.log
#   make logplot LOG=path                   events, status.csv, trace.csv, figures
#   make replay-logs                        re-record tests/data/*.log with make sim
#   make replay-bench                       replay throughput (frames/s, median of 5)
#
# Uses from the Makefile: PY, NUMERIC, deps-sim; from mk/host.mk B and the
# library rule; from mk/auth.mk SIM_KEY_FILE and TEST_KEY_FILE. The committed
# logs were recorded with the published test key (their authenticated
# commands replay only under it); `make replay LOG=...` replays with the
# simulations' key SIM_KEY_FILE, as `make sim` records.

REPLAY_LOGS := tests/data/paper-line.log tests/data/paper-circle.log

.PHONY: replay replay-regress logplot replay-logs replay-bench
replay: deps-sim $(B)/libmstc_sil.so $(SIM_KEY_FILE)  ## replay LOG=path through the firmware and compare (REPLAY_ARGS=...)
	@test -n "$(LOG)" || { echo "usage: make replay LOG=path/to/bus.log [REPLAY_ARGS=--strict]" >&2; exit 2; }
	$(MSTC) replay --lib $(B)/libmstc_sil.so --key-file $(SIM_KEY_FILE) $(REPLAY_ARGS) $(LOG)

# The committed logs were recorded from the float build: a fixed-point build
# answers differently by design (make replay NUMERIC=fixed LOG=... shows how).
replay-regress: deps-sim $(B)/libmstc_sil.so  ## replay the committed logs tests/data/*.log, bit-exact
	@test "$(NUMERIC)" = float || { echo "error: replay-regress checks the float build (the logs' own); use make replay NUMERIC=$(NUMERIC) LOG=... to see the differences" >&2; exit 2; }
	@for log in $(REPLAY_LOGS); do \
	  echo "$(MSTC) replay --strict --quiet --lib $(B)/libmstc_sil.so --key-file $(TEST_KEY_FILE) $$log"; \
	  $(MSTC) replay --strict --quiet --lib $(B)/libmstc_sil.so --key-file $(TEST_KEY_FILE) $$log \
	    || exit $$?; \
	done

logplot: deps-sim  ## events, status and the paper's figures from LOG=path, into build/logplot/
	@test -n "$(LOG)" || { echo "usage: make logplot LOG=path/to/bus.log [LOGPLOT_ARGS=--scenario file.toml]" >&2; exit 2; }
	$(MSTC) plot --out build/logplot $(LOGPLOT_ARGS) $(LOG)

# After an intended change of what the firmware sends: the diff of the logs
# shows what changed.
replay-logs: deps-sim $(B)/libmstc_sil.so  ## re-record tests/data/*.log: make sim's bus.log of the paper scenarios
	@test "$(NUMERIC)" = float || { echo "error: the regression logs are recorded from the float build" >&2; exit 2; }
	$(MSTC) sim --bus sil --lib $(B)/libmstc_sil.so --key-file $(TEST_KEY_FILE) --out build/replay-logs \
	  sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml > /dev/null
	@mkdir -p tests/data
	cp build/replay-logs/paper-line/bus.log tests/data/paper-line.log
	cp build/replay-logs/paper-circle/bus.log tests/data/paper-circle.log

replay-bench: deps-sim $(B)/libmstc_sil.so  ## replay throughput on a 10-minute log (recorded once into build/)
	MSTC_KEY_FILE=$(TEST_KEY_FILE) $(PY) -m mstc.bench.replay --lib $(B)/libmstc_sil.so \
	  --doc docs/performance.md
