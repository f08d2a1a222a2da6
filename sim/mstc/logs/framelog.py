# SPDX-License-Identifier: MIT
"""A recorded bus log as the tools use it, whatever its format.

A log becomes a :class:`FrameLog`: the frames in file order, column by column
(numpy arrays), so that the replay and the decoders touch each frame as little
as possible, with every problem found on the way (:class:`LogProblem`). One
module per format reads it (:mod:`~mstc.logs.candump`, :mod:`~mstc.logs.asc`,
:mod:`~mstc.logs.blf`); :func:`mstc.logs.read.read_log` picks one by the
file's extension.

What happens to a problem (docs/replay.md):

- **skipped** (the line is not used): a line that is not a frame (garbage,
  truncated, bad hex, a 3-digit identifier above 7FF, a time stamp that is not
  a number or lies beyond ±:data:`MAX_TIME_S`), and frames the firmware
  cannot take: remote, error and CAN FD frames;
- **kept** and reported (:func:`check`): an identifier the DBC does not have
  (or an extended one), a DBC frame of the wrong length, a time stamp earlier
  than the one before (the log's order is kept);
- **fatal** (:class:`~mstc.errors.LogError`): a file that cannot be read, an
  unknown format, a file without a single usable frame.

A reader that fails in the middle of an ASC or BLF file is reported, and the
frames before the damage are used (:func:`read_messages`).

Every problem is counted, but only the first ones in file order are kept
(:class:`ProblemList`), so that a log of millions of garbage lines takes no
more memory than its text.
"""

from __future__ import annotations

import enum
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple, Protocol

import can
import numpy as np

from mstc.errors import LogError

CAN_EFF_FLAG = 0x80000000
"""In candump's identifier: an extended frame (also written as 8 hex digits)."""
CAN_ERR_FLAG = 0x20000000
"""In candump's identifier: an error frame."""
MAX_DATA = 8
"""Data bytes of a classic frame."""
MAX_TIME_S = 2.0**53 / 1e6
"""Largest |time stamp| of a log [s] (9007199254.740992, the year 2255 as an
epoch time): beyond it a double no longer holds whole microseconds, and the
tools' sums and waits on it would overflow. A line stamped beyond is not a
frame."""
DEFAULT_MAX_PROBLEMS = 1000
"""Problems a :class:`ProblemList` keeps unless told otherwise."""


class ProblemKind(enum.Enum):
    """What is wrong with a line or frame of a log, and whether it is used."""

    MALFORMED = "malformed"
    """Not a frame (garbage, truncated, bad field): skipped."""
    UNSUPPORTED = "unsupported"
    """A remote, error or CAN FD frame, which the firmware cannot take: skipped."""
    UNKNOWN_ID = "unknown id"
    """An identifier the DBC does not have: kept, but not fed to the firmware."""
    LENGTH = "length"
    """A frame of the DBC with another length than its message's: kept."""
    TIME = "time"
    """A time stamp earlier than the one before: kept, in the log's order."""
    READ = "read"
    """The ASC or BLF reader stopped: the frames before are kept."""

    @property
    def skipped(self) -> bool:
        """Whether the line or frame is left out of the :class:`FrameLog`."""
        return self in (ProblemKind.MALFORMED, ProblemKind.UNSUPPORTED, ProblemKind.READ)


@dataclass(frozen=True)
class LogProblem:
    """A problem with one line (candump) or frame (ASC, BLF) of a log."""

    where: str
    """``path:line`` or ``path: frame N``."""
    line: int
    """The line (candump) or frame number (ASC, BLF)."""
    kind: ProblemKind
    message: str

    def __str__(self) -> str:
        return f"{self.where}: {self.message}"


class ProblemList(list[LogProblem]):
    """The problems of a log: every one counted, by kind, and the first
    :attr:`limit` in file order kept (the list itself).

    Problems may arrive out of file order (those of kept frames are found
    after the lines are read); the list holds at most twice :attr:`limit`
    until :meth:`finish` sorts it and cuts it to the first :attr:`limit`.

    :param limit: problems to keep.
    """

    def __init__(self, limit: int = DEFAULT_MAX_PROBLEMS) -> None:
        super().__init__()
        self.limit = max(limit, 0)
        self.total = 0
        """Problems found, kept or not."""
        self.counts: Counter[ProblemKind] = Counter()
        """Problems found, by kind."""
        self._last = -1  # the largest line kept

    def append(self, problem: LogProblem) -> None:
        """Count @p problem, and keep it while it is among the first ones."""
        self.total += 1
        self.counts[problem.kind] += 1
        if len(self) >= self.limit and problem.line >= self._last:
            return  # after every kept one: never among the first
        super().append(problem)
        self._last = max(self._last, problem.line)
        if len(self) >= 2 * self.limit:
            self.finish()

    def tally(self, kind: ProblemKind, n: int) -> None:
        """Count @p n problems of @p kind that are not kept."""
        if n:
            self.total += n
            self.counts[kind] += n

    def finish(self) -> None:
        """Sort the kept problems into file order (a line's in the order found)
        and keep the first :attr:`limit`."""
        self.sort(key=lambda p: p.line)
        del self[self.limit :]
        self._last = self[-1].line if self else -1


class LogFrame(NamedTuple):
    """One frame of a log (for reports and decoders; the replay uses the columns)."""

    line: int
    """Line number (candump) or frame number (ASC, BLF), from 1."""
    timestamp: float
    """[s], as recorded."""
    channel: str
    frame_id: int
    is_extended_id: bool
    data: bytes


@dataclass
class FrameLog:
    """The usable frames of a log, in file order, as columns.

    Row i of every array is the i-th frame kept; ``line[i]`` says where it is
    in the file.
    """

    path: Path
    format: str
    """One of :data:`FORMATS`."""
    time: np.ndarray
    """float64 [s]: each frame's time stamp."""
    frame_id: np.ndarray
    """int64: 11- or 29-bit identifier."""
    extended: np.ndarray
    """bool: 29-bit identifier."""
    dlc: np.ndarray
    """uint8: data length, 0..8."""
    data: np.ndarray
    """(N, 8) uint8: the data bytes, zero past ``dlc``."""
    line: np.ndarray
    """int64: line number (candump, ASC) or frame number (BLF), from 1."""
    channel: list[str]
    """Interface each frame was recorded on."""
    problems: ProblemList = field(default_factory=ProblemList)
    """The problems found: all counted, the first ones kept, in file order."""
    lines: int = 0
    """Lines (candump, ASC) or frames (BLF) read."""

    def __len__(self) -> int:
        return len(self.time)

    def where(self, row: int) -> str:
        """``path:line`` (candump, ASC) or ``path: frame N`` (BLF) of a row."""
        return _where(self.path, self.format, int(self.line[row]))

    def frame(self, row: int) -> LogFrame:
        """Row @p row as a :class:`LogFrame`."""
        n = int(self.dlc[row])
        return LogFrame(
            int(self.line[row]),
            float(self.time[row]),
            self.channel[row],
            int(self.frame_id[row]),
            bool(self.extended[row]),
            self.data[row, :n].tobytes(),
        )

    def __iter__(self) -> Iterator[LogFrame]:
        for row in range(len(self)):
            yield self.frame(row)

    def message(self, row: int) -> can.Message:
        """Row @p row as a :class:`can.Message`."""
        f = self.frame(row)
        return can.Message(
            timestamp=f.timestamp,
            arbitration_id=f.frame_id,
            is_extended_id=f.is_extended_id,
            dlc=len(f.data),
            data=f.data,
            channel=f.channel,
        )

    def standard_ids_in(self, ids: Iterable[int]) -> np.ndarray:
        """Boolean mask of the rows with an 11-bit identifier in @p ids."""
        mask: np.ndarray = np.isin(self.frame_id, np.fromiter(ids, dtype=np.int64)) & ~self.extended
        return mask

    @property
    def duration(self) -> float:
        """Last time stamp minus the first [s] (0 for fewer than two frames)."""
        return float(self.time[-1] - self.time[0]) if len(self) > 1 else 0.0


def _where(path: Path, fmt: str, line: int) -> str:
    """Where a line (candump, ASC: text files) or a frame (BLF) is."""
    return f"{path}: frame {line}" if fmt == "blf" else f"{path}:{line}"


def where_in(log: FrameLog, line: int) -> str:
    """``path:line`` (candump, ASC) or ``path: frame N`` (BLF) of a line of @p log."""
    return _where(log.path, log.format, line)


class FrameColumns:
    """The columns of a :class:`FrameLog`, collected frame by frame (the
    line-by-line candump parser, python-can's readers)."""

    def __init__(self) -> None:
        self.time: list[float] = []
        self.frame_id: list[int] = []
        self.extended: list[bool] = []
        self.data: list[bytes] = []
        self.line: list[int] = []
        self.channel: list[str] = []

    def add(
        self, line: int, t: float, channel: str, frame_id: int, extended: bool, data: bytes
    ) -> None:
        self.line.append(line)
        self.time.append(t)
        self.channel.append(channel)
        self.frame_id.append(frame_id)
        self.extended.append(extended)
        self.data.append(data)

    def build(self, path: Path, fmt: str, problems: ProblemList, lines: int) -> FrameLog:
        n = len(self.time)
        data = np.zeros((n, MAX_DATA), dtype=np.uint8)
        dlc = np.fromiter(map(len, self.data), dtype=np.uint8, count=n)
        for row, payload in enumerate(self.data):
            data[row, : len(payload)] = np.frombuffer(payload, dtype=np.uint8)
        return FrameLog(
            path=path,
            format=fmt,
            time=np.array(self.time, dtype=np.float64),
            frame_id=np.array(self.frame_id, dtype=np.int64),
            extended=np.array(self.extended, dtype=bool),
            dlc=dlc,
            data=data,
            line=np.array(self.line, dtype=np.int64),
            channel=self.channel,
            problems=problems,
            lines=lines,
        )


def show(text: str, limit: int = 60) -> str:
    """A line as it can be printed: repr, shortened."""
    return repr(text if len(text) <= limit else text[:limit] + "...")


def time_beyond(stamp: str) -> str:
    return (
        f"time stamp {stamp} beyond ±{MAX_TIME_S!r} s, where a double stops holding "
        "whole microseconds: not a time"
    )


def binary(path: Path, number: int) -> LogProblem:
    return LogProblem(f"{path}:{number}", number, ProblemKind.MALFORMED, "binary data, not text")


# ------------------------------------------------------------------ python-can's readers


class Lines(Protocol):
    """A text log's lines as a python-can reader reads them, numbered
    (:class:`mstc.logs.asc.AscLines`)."""

    number: int
    """The line read last."""
    framed: int
    """The number of the last line that gave a frame."""

    def passed(self) -> None:
        """Report the current line if the reader passed over it unduly."""


def read_messages(
    path: Path,
    fmt: str,
    reader: can.io.generic.MessageReader,
    problems: ProblemList,
    lines: Lines | None = None,
) -> tuple[FrameColumns, int]:
    """The frames a python-can reader gives, checked one by one, then the
    reader stopped: remote, error and FD frames, more than 8 data bytes and a
    time stamp beyond ±:data:`MAX_TIME_S` are problems, not frames; a reader
    that fails in the middle is a problem, and the frames before are kept;
    one that refuses to go on (a :class:`LogError`: a bound) is an error.

    :param fmt: the format's name, for ``where`` (:func:`where_in`).
    :param lines: a text format's numbered lines (ASC); None numbers the
        frames (BLF).
    :returns: The columns, and the number of the last line or frame read.
    """
    cols = FrameColumns()
    number = 0
    try:
        for count, msg in enumerate(reader, start=1):
            number = count if lines is None else lines.number
            if lines is not None:
                lines.framed = number
            where = _where(path, fmt, number)
            if msg.is_error_frame or msg.is_remote_frame or msg.is_fd:
                what = "error" if msg.is_error_frame else "remote" if msg.is_remote_frame else "FD"
                problems.append(
                    LogProblem(where, number, ProblemKind.UNSUPPORTED, f"{what} frame: not fed")
                )
                continue
            data = bytes(msg.data)
            if len(data) > MAX_DATA:
                problems.append(
                    LogProblem(where, number, ProblemKind.MALFORMED, f"{len(data)} data bytes")
                )
                continue
            t = float(msg.timestamp)
            if not abs(t) <= MAX_TIME_S:
                problems.append(
                    LogProblem(where, number, ProblemKind.MALFORMED, time_beyond(f"{t!r}"))
                )
                continue
            channel = "" if msg.channel is None else str(msg.channel)
            cols.add(number, t, channel, msg.arbitration_id, msg.is_extended_id, data)
        if lines is not None:
            lines.passed()  # the last line
    except LogError:
        raise  # a bound of the reader's (mstc.logs.blf): not damage, a refusal
    except Exception as exc:  # a damaged file: keep what came before
        after = number if lines is None else lines.number
        where = f"{path}: after frame {after}" if lines is None else f"{path}:{after}"
        problems.append(
            LogProblem(
                where,
                after,
                ProblemKind.READ,
                f"cannot read further ({type(exc).__name__}: {exc}); the frames before are used",
            )
        )
    finally:
        reader.stop()
    return cols, number if lines is None else lines.number


# ------------------------------------------------------------------ checking


def check(log: FrameLog, lengths: Mapping[int, int]) -> None:
    """Add the problems of frames that are kept: unknown identifiers, wrong
    lengths, time going backwards; then sort the kept problems into file
    order. Of each kind, only the first rows can be among the first problems
    kept: the others are counted, not described."""
    problems = log.problems

    def add(kind: ProblemKind, rows: np.ndarray, describe: Callable[[int], str]) -> None:
        for row in rows[: problems.limit].tolist():
            problems.append(LogProblem(log.where(row), int(log.line[row]), kind, describe(row)))
        problems.tally(kind, max(len(rows) - problems.limit, 0))

    def unknown(row: int) -> str:
        kind, digits = ("extended identifier", 8) if log.extended[row] else ("identifier", 3)
        return f"{kind} {int(log.frame_id[row]):0{digits}X} is not in the DBC: not fed"

    known = np.fromiter(lengths, dtype=np.int64)
    in_dbc = np.isin(log.frame_id, known) & ~log.extended
    add(ProblemKind.UNKNOWN_ID, np.flatnonzero(~in_dbc), unknown)
    table = np.full(0x800, -1, dtype=np.int64)  # DBC length by 11-bit identifier
    for frame_id, length in lengths.items():
        if frame_id <= 0x7FF:
            table[frame_id] = length
    want = np.where(in_dbc, table[np.where(in_dbc, log.frame_id, 0)], -1)
    add(
        ProblemKind.LENGTH,
        np.flatnonzero(in_dbc & (log.dlc != want)),
        lambda row: (
            f"{int(log.frame_id[row]):03X} has {int(log.dlc[row])} data bytes, "
            f"the DBC says {int(want[row])}"
        ),
    )
    add(
        ProblemKind.TIME,
        np.flatnonzero(np.diff(log.time) < 0) + 1,
        lambda row: f"time goes backwards: {log.time[row]:.6f} s after {log.time[row - 1]:.6f} s",
    )
    problems.finish()
