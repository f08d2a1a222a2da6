# SPDX-License-Identifier: MIT
"""Bus logs in Vector's ASC format, read through python-can's ``ASCReader``.

An ASC file's problems are reported by line, as candump's are: a line the
reader passes over without a word (not a frame, and not the header, the
trigger block's bounds or a comment) is reported too. mstc writes no ASC
files (its runs write candump -L).
"""

from __future__ import annotations

import re
from pathlib import Path

import can

from mstc.errors import LogError
from mstc.logs.framelog import (
    FrameLog,
    LogProblem,
    ProblemKind,
    ProblemList,
    binary,
    read_messages,
    show,
)

# Lines of an ASC file that are not frames and that python-can's ASCReader
# rightly passes over: the header, the trigger block's bounds, comments.
_ASC_STRUCTURE = re.compile(
    r"(?:date\s|base\s+(?:hex|dec)|(?:no\s+)?internal\s+events\s+logged"
    r"|begin\s+triggerblock|end\s+triggerblock|//|\d+\.\d+\s+start\s+of\s+measurement)",
    re.IGNORECASE,
)


class AscLines:
    """An ASC file's lines as python-can's ASCReader reads them, numbered, so
    that a line it passes over without yielding a frame is reported.

    The reader asks for line n+1 only after it has yielded the frame of line
    n, if any: :attr:`framed` (set by the caller on each frame) says whether
    line n gave one.
    """

    def __init__(self, path: Path, problems: ProblemList) -> None:
        self.path = path
        self.problems = problems
        self.file = path.open(encoding="utf-8", errors="replace", newline="")
        self.number = 0
        self.text = ""
        self.framed = 0
        """The number of the last line that gave a frame."""

    def __iter__(self) -> AscLines:
        return self

    def __next__(self) -> str:
        self.passed()
        self.text = next(self.file)
        self.number += 1
        return self.text

    def passed(self) -> None:
        """Report the current line if the reader passed over it unduly (once)."""
        line, self.text = self.text.strip(), ""
        if self.number == self.framed or not line or _ASC_STRUCTURE.match(line):
            return
        if "\x00" in line or "\ufffd" in line:
            self.problems.append(binary(self.path, self.number))
            return
        self.problems.append(
            LogProblem(
                f"{self.path}:{self.number}",
                self.number,
                ProblemKind.MALFORMED,
                f"skipped by python-can's ASC reader: {show(line)}",
            )
        )

    def close(self) -> None:
        self.file.close()


def read_asc(path: Path, max_problems: int) -> FrameLog:
    """The frames of the ASC file @p path, its problems by line.

    :raises LogError: python-can cannot read it at all.
    """
    problems = ProblemList(max_problems)
    lines = AscLines(path, problems)
    try:
        reader = can.ASCReader(lines)  # type: ignore[arg-type]  # a file of lines
    except Exception as exc:  # python-can raises what its parser meets
        lines.close()
        raise LogError(f"{path}: not a readable ASC file: {exc}") from exc
    cols, number = read_messages(path, "asc", reader, problems, lines)
    return cols.build(path, "asc", problems, number)
