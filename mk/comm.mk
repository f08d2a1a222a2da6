# SPDX-License-Identifier: MIT
# The files generated from the CAN protocol's DBC (firmware/comm/mstc.dbc):
# the C codec firmware/comm/mstc_dbc.[ch] (tools/gen-codec, cantools) and
# docs/protocol.md (tools/protocol-doc); and from the parameter limits table
# (firmware/ctrl/ctl_params.toml, checked against the DBC): the firmware's
# copy firmware/ctrl/ctl_limits.[ch] and the parameter section of
# docs/safety.md (tools/gen-limits). All are committed; check-protocol fails,
# with a diff, when any is stale, and `make test` runs it.
#
# The generated codec compiles under the full WARN of the Makefile, so it
# needs no rule of its own: it is one of the firmware/*/*.c sources.

.PHONY: codec protocol-doc limits check-protocol
codec: venv  ## regenerate firmware/comm/mstc_dbc.[ch] from mstc.dbc
	$(PY) tools/gen-codec
protocol-doc: venv  ## regenerate docs/protocol.md from mstc.dbc
	$(PY) tools/protocol-doc
limits: venv  ## regenerate firmware/ctrl/ctl_limits.[ch] and docs/safety.md's parameter table from ctl_params.toml
	$(PY) tools/gen-limits
check-protocol: venv  ## fail when the generated codec, docs/protocol.md or the limits files are stale
	$(PY) tools/gen-codec --check
	$(PY) tools/protocol-doc --check
	$(PY) tools/gen-limits --check
