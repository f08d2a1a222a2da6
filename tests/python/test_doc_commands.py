# SPDX-License-Identifier: MIT
"""Every shell block of README.md and docs/getting-started.md, run as
pasted, in order, from the top of the tree, in the environment a user has
(none of the test suite's variables: no $MSTC_KEY_FILE, no $MSTC_SIL_LIB).

A block is skipped only when the line before it says it needs hardware
(``<!-- doc-test: needs hardware (...) -->``). A block that runs until
Ctrl-C says so (``<!-- doc-test: stop with Ctrl-C after N s -->``): it gets
SIGINT after N seconds and must then exit 0, as it does for a user. Each
block must exit 0; an expected failure is written into the block itself
(``|| test $? -eq 1``), where a reader sees it.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
from dataclasses import dataclass

import pytest

from conftest import ROOT

PAGES = ("README.md", "docs/getting-started.md")
HARDWARE = re.compile(r"<!-- doc-test: needs hardware \((.+)\) -->")
CTRL_C = re.compile(r"<!-- doc-test: stop with Ctrl-C after (\d+) s -->")
BLOCK_TIMEOUT = 900.0
"""A block's limit [s]: make hil boots a VM where the kernel has no vcan."""
USER_ENV_DROPPED = ("MSTC_KEY", "MSTC_KEY_FILE", "MSTC_SIL_LIB", "MSTC_SIL_LIB_FLOAT")
USER_ENV_DROPPED += ("MSTC_SIL_LIB_FIXED", "MSTC_FW", "PYTEST_CURRENT_TEST")


@dataclass(frozen=True)
class Block:
    page: str
    line: int
    text: str
    hardware: str
    """Why it is skipped ("" when it runs)."""
    ctrl_c: float
    """Seconds after which it gets SIGINT (0: it ends by itself)."""


def blocks(page: str) -> list[Block]:
    """The ``sh`` blocks of @p page, with their markers."""
    lines = (ROOT / page).read_text().splitlines()
    found = []
    i = 0
    while i < len(lines):
        if lines[i].strip() in ("```sh", "```bash"):
            start = i
            i += 1
            body = []
            while lines[i].strip() != "```":
                body.append(lines[i])
                i += 1
            before = next((x for x in reversed(lines[:start]) if x.strip()), "")
            hardware = HARDWARE.search(before)
            ctrl_c = CTRL_C.search(before)
            found.append(
                Block(
                    page,
                    start + 1,
                    "\n".join(body),
                    hardware[1] if hardware else "",
                    float(ctrl_c[1]) if ctrl_c else 0.0,
                )
            )
        i += 1
    return found


def test_every_page_has_blocks_and_markers_name_their_reason() -> None:
    for page in PAGES:
        found = blocks(page)
        assert found, page
        assert any(not b.hardware for b in found), page
    # A marker that is not exactly one of the two forms would be ignored:
    for page in PAGES:
        for line in (ROOT / page).read_text().splitlines():
            if "doc-test:" in line:
                assert HARDWARE.search(line) or CTRL_C.search(line), f"{page}: {line}"


def run_block(block: Block, env: dict[str, str]) -> None:
    where = f"{block.page}:{block.line}"
    proc = subprocess.Popen(
        ["bash", "-e", "-o", "pipefail", "-c", block.text],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        if block.ctrl_c:
            try:
                out, _ = proc.communicate(timeout=block.ctrl_c)
                pytest.fail(f"{where}: ended before Ctrl-C (exit {proc.returncode}):\n{out}")
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C goes to the terminal's group
        out, _ = proc.communicate(timeout=BLOCK_TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        pytest.fail(f"{where}: still running after {BLOCK_TIMEOUT:g} s:\n{out[-4000:]}")
    assert proc.returncode == 0, (
        f"{where}: exit {proc.returncode}\n--- block\n{block.text}\n--- output\n{out[-6000:]}"
    )


@pytest.mark.vm  # make hil boots the vcan VM where the kernel has no CAN
def test_the_pages_commands_run_as_pasted() -> None:
    """README.md's blocks, then docs/getting-started.md's, in one sequence
    (a reader does both); a block the same as one run already (`make sim`,
    `make hil` in both pages) is not run twice."""
    env = {k: v for k, v in os.environ.items() if k not in USER_ENV_DROPPED}
    done: set[str] = set()
    for page in PAGES:
        for block in blocks(page):
            if block.hardware or block.text in done:
                continue  # needs a board or an adapter this machine does not have; or ran
            run_block(block, env)
            done.add(block.text)


def test_the_markers_skip_only_what_needs_hardware() -> None:
    """The blocks skipped, listed: each names the hardware it needs."""
    skipped = [(b.page, b.hardware) for page in PAGES for b in blocks(page) if b.hardware]
    for _, why in skipped:
        assert re.search(r"board|adapter|can0|probe", why), why


def test_the_index_links_every_page() -> None:
    """docs/index.md links every page of docs/, and every link it has exists."""
    index = (ROOT / "docs" / "index.md").read_text()
    linked = set(re.findall(r"\]\(([^)#]+\.md)\)", index))
    pages = {p.name for p in (ROOT / "docs").glob("*.md")} - {"index.md"}
    assert pages - linked == set(), "not linked from docs/index.md"
    assert {x for x in linked if not (ROOT / "docs" / x).is_file()} == set()
