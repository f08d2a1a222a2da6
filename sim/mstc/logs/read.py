# SPDX-License-Identifier: MIT
"""Reading recorded bus logs, whatever their format (as python-can's
``LogReader`` picks a reader by suffix): ``candump -L``
(:mod:`~mstc.logs.candump`), ASC (:mod:`~mstc.logs.asc`) and BLF
(:mod:`~mstc.logs.blf`), into a :class:`~mstc.logs.framelog.FrameLog` checked
against the DBC (:func:`~mstc.logs.framelog.check`)."""

from __future__ import annotations

from pathlib import Path

from cantools.database.can import Database

from mstc.errors import LogError
from mstc.logs.asc import read_asc
from mstc.logs.blf import read_blf
from mstc.logs.candump import read_candump
from mstc.logs.framelog import DEFAULT_MAX_PROBLEMS, FrameLog, ProblemList, check

FORMATS = ("candump", "asc", "blf")
"""Log formats :func:`read_log` reads."""
EXTENSIONS = {".log": "candump", ".asc": "asc", ".blf": "blf"}
"""The format of a file by its extension (case-insensitive)."""


def format_for(path: Path, override: str | None = None) -> str:
    """The format of @p path: @p override, else by extension.

    :raises LogError: neither gives one of :data:`FORMATS`.
    """
    if override is not None:
        if override not in FORMATS:
            raise LogError(f"unknown log format {override!r} (one of {', '.join(FORMATS)})")
        return override
    fmt = EXTENSIONS.get(path.suffix.lower())
    if fmt is None:
        known = ", ".join(f"{ext} ({name})" for ext, name in EXTENSIONS.items())
        raise LogError(
            f"{path}: cannot tell the log format from the extension {path.suffix or '(none)'!r}: "
            f"known are {known}; name it with --format"
        )
    return fmt


def read_log(
    path: Path, db: Database, fmt: str | None = None, *, max_problems: int = DEFAULT_MAX_PROBLEMS
) -> FrameLog:
    """Read and check a log.

    :param path: the file.
    :param db: the DBC, for the identifiers and lengths it knows.
    :param fmt: one of :data:`FORMATS`; by default from the extension.
    :param max_problems: problems to keep (all are counted).
    :returns: The usable frames, with :attr:`FrameLog.problems`.
    :raises LogError: the file cannot be read, its format is unknown, or it
        holds no usable frame.
    """
    fmt = format_for(path, fmt)
    if path.is_dir():
        raise LogError(f"{path}: is a directory, not a log")
    if fmt == "candump":
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise LogError(f"{path}: cannot read: {exc.strerror or exc}") from exc
        log = read_candump(path, raw, max_problems)
    else:
        if not path.is_file():
            raise LogError(f"{path}: cannot read: no such file")
        log = read_asc(path, max_problems) if fmt == "asc" else read_blf(path, max_problems)
    if not log.problems.total:  # read at once, without a problem
        log.problems = ProblemList(max_problems)
    if not len(log):
        if fmt == "candump":
            what = f"in {log.lines} lines" if log.lines else "(the file is empty)"
        else:
            what = f"that python-can's {fmt.upper()} reader could read"
        reasons = {kind.value for kind in log.problems.counts}
        if reasons:
            n = log.problems.total
            what += f" ({n} problem{'s' if n != 1 else ''}: {', '.join(sorted(reasons))})"
        raise LogError(f"{path}: no usable CAN frame {what}: is it a {fmt} log? (--format)")
    check(log, {m.frame_id: m.length for m in db.messages})
    return log
