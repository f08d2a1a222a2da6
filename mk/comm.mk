# SPDX-License-Identifier: MIT
# The files generated from the CAN protocol's DBC (firmware/comm/mstc.dbc):
# the C codec firmware/comm/mstc_dbc.[ch] (tools/gen-codec, cantools) and
# docs/protocol.md (tools/protocol-doc). Both are committed; check-protocol
# fails, with a diff, when either is stale, and `make test` runs it.
#
# The generated codec compiles under the full WARN of the Makefile, so it
# needs no rule of its own: it is one of the firmware/*/*.c sources.

.PHONY: codec protocol-doc check-protocol
codec: venv  ## regenerate firmware/comm/mstc_dbc.[ch] from mstc.dbc
	$(PY) tools/gen-codec
protocol-doc: venv  ## regenerate docs/protocol.md from mstc.dbc
	$(PY) tools/protocol-doc
check-protocol: venv  ## fail when the generated codec or docs/protocol.md is stale
	$(PY) tools/gen-codec --check
	$(PY) tools/protocol-doc --check
