# SPDX-License-Identifier: MIT
"""A sweep's output folder: one sweep at a time, and what its rows were run
from.

Two sweeps writing one folder at once would each rewrite runs.csv and lose the
other's rows, so a sweep holds the folder with an advisory lock (``flock`` on
``DIR/.lock``, which the kernel drops when the process ends, however it ends).

``--resume`` keeps a row only if it was run from the scene it would run now:
``DIR/sources.json`` holds the sha256 of the firmware library the rows were
run with, of each scenario file's text, and of each suite family's
definition under each actuator profile (:mod:`mstc.sweep.plan`), so that a
suite changed since (another seed, another range) or another build is run
again, not kept.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

from mstc.errors import OutputError, writing

LOCK = ".lock"
"""The lock file in a sweep's folder (it holds the pid of its holder)."""
SOURCES = "sources.json"
"""What the rows of runs.csv were run from."""


@contextmanager
def locked(out: Path) -> Iterator[None]:
    """Hold @p out (created if need be) while the block runs.

    :raises OutputError: another process holds it.
    :raises WriteError: it cannot be created.
    """
    with writing(str(out)):
        out.mkdir(parents=True, exist_ok=True)
        f = (out / LOCK).open("a+")
    try:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.seek(0)
            holder = f.read().strip() or "?"
            raise OutputError(
                f"{out}: another mstc sweep (pid {holder}) is writing into this folder; "
                "wait for it to end, or choose another --out"
            ) from None
        f.truncate(0)
        f.write(f"{os.getpid()}\n")
        f.flush()
        yield
    finally:
        f.close()


def text_sha256(text: str) -> str:
    """sha256 of @p text (UTF-8), in hex."""
    return hashlib.sha256(text.encode()).hexdigest()


def read_sources(out: Path) -> dict[str, object]:
    """``DIR/sources.json``, or nothing when it is missing or unreadable (no row
    can then be shown to come from the scenes of now)."""
    try:
        data = json.loads((out / SOURCES).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def write_sources(out: Path, sources: Mapping[str, object]) -> None:
    """Write ``DIR/sources.json``: what the rows are run from
    (:meth:`mstc.sweep.plan.Plan.sources`)."""
    tmp = out / f"{SOURCES}.tmp"
    tmp.write_text(json.dumps(sources, indent=1) + "\n")
    tmp.replace(out / SOURCES)
