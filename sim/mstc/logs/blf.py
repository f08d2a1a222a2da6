# SPDX-License-Identifier: MIT
"""Bus logs in Vector's BLF format, read through python-can's ``BLFReader``.

Binary: a problem is reported by frame number. A file shorter than its header
says (a recording cut off) is reported, and the frames before are used. mstc
writes no BLF files (its runs write candump -L).
"""

from __future__ import annotations

from pathlib import Path

import can

from mstc.errors import LogError
from mstc.logs.framelog import FrameLog, LogProblem, ProblemKind, ProblemList, read_messages


def read_blf(path: Path, max_problems: int) -> FrameLog:
    """The frames of the BLF file @p path, its problems by frame number.

    :raises LogError: python-can cannot read it at all.
    """
    problems = ProblemList(max_problems)
    try:
        reader = can.BLFReader(str(path))
    except Exception as exc:  # python-can raises what its parser meets
        raise LogError(f"{path}: not a readable BLF file: {exc}") from exc
    cols, number = read_messages(path, "blf", reader, problems)
    declared = getattr(reader, "file_size", 0)  # the writer's size, set on closing
    actual = path.stat().st_size
    if declared and actual < declared:
        problems.append(
            LogProblem(
                f"{path}: after frame {number}",
                number,
                ProblemKind.READ,
                f"truncated: the header says {declared} bytes, the file has {actual}; "
                "the frames before are used",
            )
        )
    return cols.build(path, "blf", problems, number)
