# SPDX-License-Identifier: MIT
"""The benchmarks' figures in docs/performance.md: each benchmark writes its
section between its own markers (:func:`update_doc`), so the others are kept.

As a command, it puts another tool's printed report into the document:

    make firmware-budget | python -m mstc.bench.doc --doc docs/performance.md \\
        --text "boards:Board images: flash, RAM and stack against the budgets"
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping
from pathlib import Path


def vcan_where(where: object, peer: str = "the peer") -> str:
    """Where a benchmark over vcan ran, from its ``MSTC_VCAN_WHERE``
    (tools/vm/with-vcan): in the vcan VM, through its bridge, or on the
    host's vcan. @p peer names what ran on vcan0."""
    return {
        "vm": f"the vcan VM under software emulation, plant and {peer} both inside "
        "(tools/vm/with-vcan)",
        "bridge": f"the vcan VM's bridge: the plant on the host, {peer} on vcan0 in the VM "
        "under software emulation (tools/vm/with-vcan --bridge, docs/hil.md)",
    }.get(str(where), "the host's vcan")


def update_doc(doc: Path, body: str, begin: str, end: str) -> bool:
    """Replace (or add) the section between @p begin and @p end in the
    document; True when it changed. Other tools' sections are left alone. The
    section is found by its name (``<!-- bench:NAME:begin``), whatever the
    rest of its marker says (the tool that wrote it)."""
    block = f"{begin}\n{body}{end}\n"
    name = begin.split(":begin", 1)[0] + ":begin"
    if doc.exists():
        text = doc.read_text()
        at = text.find(name)
        if at >= 0 and end in text[at:]:
            post = text[at:].split(end, 1)[1]
            new = text[:at] + block + post.lstrip("\n")
        else:
            new = text.rstrip("\n") + "\n\n" + block
    else:
        new = (
            "# Performance\n\n"
            "Measured figures of the firmware, written by `make bench` (sections between "
            "markers are generated; do not edit them by hand).\n\n" + block
        )
    if doc.exists() and doc.read_text() == new:
        return False
    doc.parent.mkdir(parents=True, exist_ok=True)
    doc.write_text(new)
    return True


def report(doc: Path, body: str, begin: str, end: str) -> None:
    """Print a benchmark's section, write it into @p doc (:func:`update_doc`)
    and say whether that changed the document."""
    print(body)
    changed = update_doc(doc, body, begin, end)
    print(f"{doc}: {'updated' if changed else 'unchanged'}")


def write_result(out: Path, result: Mapping[str, object]) -> None:
    """A benchmark's raw result, as JSON (build/bench/*.json, which ``report``
    reads)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1) + "\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m mstc.bench.doc", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--doc", type=Path, required=True)
    ap.add_argument(
        "--text",
        metavar="NAME:TITLE",
        required=True,
        help="put standard input, as preformatted text under ## TITLE, into the "
        "document's section NAME (another tool's printed report)",
    )
    a = ap.parse_args(argv)
    name, _, title = a.text.partition(":")
    body = f"## {title}\n\n```\n{sys.stdin.read().rstrip()}\n```\n"
    begin = f"<!-- bench:{name}:begin (written by make bench) -->"
    changed = update_doc(a.doc, body, begin, f"<!-- bench:{name}:end -->")
    print(f"{a.doc}: {'updated' if changed else 'unchanged'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
