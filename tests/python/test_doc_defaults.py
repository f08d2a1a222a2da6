# SPDX-License-Identifier: MIT
"""What the documents say a parameter's default is, is the limits table's
default (issue 21, case 14: docs/hil.md said max_wheel_decel defaults to
100 rad/s²; it is 125).

A claim is a parameter's name in backquotes followed, within a few words, by
a parenthesis that says its default: "`max_wheel_decel` (125 rad/s² by
default)" or "(PARAM index 13, default 125 rad/s², ...)". The defaults are
firmware/ctrl/ctl_params.toml's, the table the firmware's defaults are
generated from (tools/gen-limits).
"""

from __future__ import annotations

import re
from pathlib import Path

from mstc.limits import load_table

ROOT = Path(__file__).resolve().parents[2]
DOCS = (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")))
NUMBER = r"(\d[\d,]*(?:\.\d+)?)"


def _claims() -> list[tuple[str, str, float, float]]:
    """(document, parameter, default claimed, the table's default)."""
    found = []
    for path in DOCS:
        text = " ".join(path.read_text().split())
        for p in load_table().params:
            after = re.finditer(rf"`{re.escape(p.name)}`[^()`]{{0,20}}\(([^()]*)\)", text)
            for m in after:
                inside = m.group(1)
                said = re.search(rf"\bdefault {NUMBER}", inside) or re.search(
                    rf"{NUMBER}[^,;]*? by default", inside
                )
                if said:
                    value = float(said.group(1).replace(",", ""))
                    found.append((str(path.relative_to(ROOT)), p.name, value, p.default))
    return found


def test_every_default_a_document_states_is_the_tables() -> None:
    claims = _claims()
    assert ("docs/hil.md", "max_wheel_decel") in {(d, n) for d, n, _, _ in claims}, claims
    wrong = [f"{d}: {n} default {said:g}, the table's {real:g}" for d, n, said, real in claims
             if said != real]  # fmt: skip
    assert not wrong, wrong
