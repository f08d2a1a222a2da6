# SPDX-License-Identifier: MIT
"""Reading recorded bus logs: ``candump -L``, and ASC and BLF through python-can.

A log becomes a :class:`FrameLog`: the frames in file order, column by column
(numpy arrays), so that the replay and the decoders touch each frame as little
as possible, with every problem found on the way (:class:`LogProblem`).

``candump -L`` logs are read by a strict parser of our own: python-can's
``CanutilsLogReader`` raises on some malformed lines and silently misreads
others, and gives no line numbers. A file whose every line is a classic frame
with 8 data bytes (any log ``make sim`` or candump writes of mstc traffic) is
parsed at once, with numpy over the bytes (one channel name) or one regular
expression over the text; any other file line by line, each bad line reported
as ``path:line: problem``. ASC and BLF go
through python-can's ``ASCReader`` and ``BLFReader``; an ASC file's problems
are reported by line, as candump's are (a line the ASC reader skips without a
word is reported too), a BLF file's by frame number.

What happens to a problem (docs/replay.md):

- **skipped** (the line is not used): a line that is not a frame (garbage,
  truncated, bad hex, a 3-digit identifier above 7FF, a time stamp that is not
  a number or lies beyond ±:data:`MAX_TIME_S`), and frames the firmware
  cannot take: remote, error and CAN FD frames;
- **kept** and reported: an identifier the DBC does not have (or an extended
  one), a DBC frame of the wrong length, a time stamp earlier than the one
  before (the log's order is kept);
- **fatal** (:class:`LogError`): a file that cannot be read, an unknown
  format, a file without a single usable frame.

A reader that fails in the middle of an ASC or BLF file is reported, and the
frames before the damage are used.

Every problem is counted, but only the first ones in file order are kept
(:class:`ProblemList`), so that a log of millions of garbage lines takes no
more memory than its text.
"""

from __future__ import annotations

import enum
import io
import math
import re
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from itertools import repeat
from pathlib import Path
from typing import NamedTuple

import can
import numpy as np
from cantools.database.can import Database
from numpy.lib.stride_tricks import sliding_window_view

from mstc.errors import LogError

FORMATS = ("candump", "asc", "blf")
"""Log formats :func:`read_log` reads."""
EXTENSIONS = {".log": "candump", ".asc": "asc", ".blf": "blf"}
"""The format of a file by its extension (case-insensitive)."""

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


# ------------------------------------------------------------------ candump -L

# A whole file of classic 11-bit frames with 8 data bytes, in one findall.
_FAST = re.compile(r"^\((\d+\.\d+)\) (\S+) ([0-9A-Fa-f]{3})#([0-9A-Fa-f]{16})$", re.MULTILINE)
_HEX = frozenset("0123456789abcdefABCDEF")


class _Columns:
    """Columns being collected by the line-by-line parser."""

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


def _show(text: str, limit: int = 60) -> str:
    """A line as it can be printed: repr, shortened."""
    return repr(text if len(text) <= limit else text[:limit] + "...")


def parse_candump_line(text: str) -> tuple[float, str, int, bool, bytes] | tuple[ProblemKind, str]:
    """One ``candump -L`` line: ``(time) interface id#data``, optionally followed by
    ``R`` or ``T`` (python-can's direction mark).

    :returns: (time [s], interface, identifier, extended, data) of a classic
        data frame, or (kind, problem) when the line is not one.
    """
    fields = text.split()
    if len(fields) == 4 and fields[3] in ("R", "T", "r", "t"):
        fields = fields[:3]
    if len(fields) != 3:
        return ProblemKind.MALFORMED, (
            f"expected '(time) interface id#data', got {len(fields)} field"
            f"{'s' if len(fields) != 1 else ''}: {_show(text)}"
        )
    stamp, channel, frame = fields
    if not (stamp.startswith("(") and stamp.endswith(")")):
        return ProblemKind.MALFORMED, f"time stamp not in parentheses: {_show(stamp)}"
    try:
        t = float(stamp[1:-1])
    except ValueError:
        return ProblemKind.MALFORMED, f"bad time stamp {_show(stamp)}"
    if math.isnan(t):
        return ProblemKind.MALFORMED, f"time stamp not finite: {_show(stamp)}"
    if not abs(t) <= MAX_TIME_S:
        return ProblemKind.MALFORMED, _time_beyond(_show(stamp))
    ident, sep, payload = frame.partition("#")
    if not sep:
        return ProblemKind.MALFORMED, f"no '#' between identifier and data: {_show(frame)}"
    if not ident or not set(ident) <= _HEX:
        return ProblemKind.MALFORMED, f"identifier is not hexadecimal: {_show(ident)}"
    if len(ident) not in (3, 8):
        return ProblemKind.MALFORMED, (
            f"identifier {ident!r} must have 3 (standard) or 8 (extended) hex digits"
        )
    frame_id = int(ident, 16)
    extended = len(ident) == 8
    if extended and frame_id & CAN_ERR_FLAG:
        return ProblemKind.UNSUPPORTED, f"error frame {ident}#{payload}: not fed"
    frame_id &= 0x1FFFFFFF
    if not extended and frame_id > 0x7FF:
        return ProblemKind.MALFORMED, f"standard identifier {ident} above 7FF"
    if payload.startswith("#"):
        return ProblemKind.UNSUPPORTED, f"CAN FD frame {ident}##...: the firmware takes classic CAN"
    if payload[:1] in ("R", "r"):
        return ProblemKind.UNSUPPORTED, f"remote frame {ident}#{payload}: not fed"
    if not set(payload) <= _HEX:
        return ProblemKind.MALFORMED, f"data is not hexadecimal: {_show(payload)}"
    if len(payload) % 2:
        return ProblemKind.MALFORMED, (
            f"odd number of hex digits in the data ({len(payload)}): truncated? {_show(payload)}"
        )
    if len(payload) > 2 * MAX_DATA:
        return (
            ProblemKind.MALFORMED,
            f"{len(payload) // 2} data bytes: a classic frame has at most 8",
        )
    return t, channel, frame_id, extended, bytes.fromhex(payload)


def _time_beyond(stamp: str) -> str:
    return (
        f"time stamp {stamp} beyond ±{MAX_TIME_S!r} s, where a double stops holding "
        "whole microseconds: not a time"
    )


_HEX_VALUE = np.full(256, 0xFF, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789ABCDEF"):
    _HEX_VALUE[_c] = _HEX_VALUE[bytes([_c]).lower()[0]] = _i
_MAX_SECONDS_DIGITS = 10
"""Digits of the whole seconds of a time stamp (the epoch needs 10)."""


def _columnar_candump(path: Path, raw: bytes) -> FrameLog | None:
    """The whole file with numpy, without a Python step per line, when every
    line is ``(S.UUUUUU) CHANNEL III#DDDDDDDDDDDDDDDD`` with one channel name;
    else None.

    Time stamps are computed as whole microseconds / 1e6, which is the same
    double as ``float()`` of the six-decimal text.
    """
    pad = 16  # bytes before the text, so that windows never start before 0
    buf = np.frombuffer(b"\n" * pad + raw, dtype=np.uint8)
    ends = np.flatnonzero(buf[pad:] == 0x0A) + pad
    if len(raw) and raw[-1] != 0x0A:
        ends = np.append(ends, len(buf))
        buf = np.append(buf, np.uint8(0x0A))
    n = len(ends)
    if n == 0:
        return None
    starts = np.concatenate(([pad], ends[:-1] + 1))
    if ((ends - starts) < 32).any():  # shorter than the shortest such line
        return None
    close = np.flatnonzero(buf == ord(")"))
    if len(close) != n or (close <= starts).any() or (close >= ends).any():
        return None
    point = close - 7
    n_digits = point - starts - 1
    ok = (
        (buf[starts] == ord("("))
        & (buf[point] == ord("."))
        & (buf[close + 1] == ord(" "))
        & (buf[ends - 21] == ord(" "))
        & (buf[ends - 17] == ord("#"))
        & (n_digits >= 1)
        & (n_digits <= _MAX_SECONDS_DIGITS)
    )
    if not ok.all():
        return None
    # Whole seconds: the 10 bytes before the point, those before the first
    # digit masked out; digits as uint8 (a non-digit wraps above 9), summed in
    # float64, exact below 2^53.
    zero = np.uint8(ord("0"))
    digits = sliding_window_view(buf, _MAX_SECONDS_DIGITS)[point - _MAX_SECONDS_DIGITS] - zero
    present = np.arange(_MAX_SECONDS_DIGITS)[None, :] >= (_MAX_SECONDS_DIGITS - n_digits)[:, None]
    fraction = sliding_window_view(buf, 6)[close - 6] - zero
    if ((digits > 9) & present).any() or (fraction > 9).any():
        return None
    powers = 10.0 ** np.arange(_MAX_SECONDS_DIGITS - 1, -1, -1)
    micros = (np.where(present, digits, 0) @ powers) * 1e6 + fraction @ powers[-6:]
    if (micros >= 2.0**53).any():
        return None
    # One channel name, the same on every line.
    width = ends - 21 - (close + 2)
    if width[0] < 1 or (width != width[0]).any():
        return None
    names = sliding_window_view(buf, int(width[0]))[close + 2]
    if not (names == names[0]).all() or (names[0] <= ord(" ")).any():
        return None
    nibbles = _HEX_VALUE[sliding_window_view(buf, 3)[ends - 20]]
    data_nibbles = _HEX_VALUE[sliding_window_view(buf, 16)[ends - 16]]
    if (nibbles == 0xFF).any() or (data_nibbles == 0xFF).any():
        return None
    frame_id = nibbles.astype(np.int64) @ np.array([256, 16, 1], dtype=np.int64)
    if (frame_id > 0x7FF).any():
        return None
    data = (data_nibbles[:, 0::2] << 4) | data_nibbles[:, 1::2]
    return FrameLog(
        path=path,
        format="candump",
        time=micros / 1e6,
        frame_id=frame_id,
        extended=np.zeros(n, dtype=bool),
        dlc=np.full(n, MAX_DATA, dtype=np.uint8),
        data=data,
        line=np.arange(1, n + 1, dtype=np.int64),
        channel=[names[0].tobytes().decode("utf-8", errors="replace")] * n,
        lines=n,
    )


def _fast_candump(path: Path, text: str, lines: int) -> FrameLog | None:
    """The whole file at once when every line is a classic 11-bit frame with 8
    bytes and a time stamp within ±MAX_TIME_S; else None (the line-by-line
    reader then says what is wrong with the others)."""
    rows = _FAST.findall(text)
    if len(rows) != lines or not rows:
        return None
    stamps, channels, ids, payloads = zip(*rows, strict=True)
    n = len(rows)
    time = np.fromiter(map(float, stamps), dtype=np.float64, count=n)
    frame_id = np.fromiter(map(int, ids, repeat(16)), dtype=np.int64, count=n)
    if (frame_id > 0x7FF).any() or (time > MAX_TIME_S).any():
        return None
    return FrameLog(
        path=path,
        format="candump",
        time=time,
        frame_id=frame_id,
        extended=np.zeros(n, dtype=bool),
        dlc=np.full(n, MAX_DATA, dtype=np.uint8),
        data=np.frombuffer(bytes.fromhex("".join(payloads)), dtype=np.uint8).reshape(n, MAX_DATA),
        line=np.arange(1, n + 1, dtype=np.int64),
        channel=list(channels),
        lines=lines,
    )


def _read_candump(path: Path, raw: bytes, max_problems: int) -> FrameLog:
    columnar = _columnar_candump(path, raw)
    if columnar is not None:
        return columnar
    lines = raw.count(b"\n") + (0 if raw.endswith(b"\n") or not raw else 1)
    fast = _fast_candump(path, raw.decode("utf-8", errors="replace"), lines)
    if fast is not None:
        return fast
    problems = ProblemList(max_problems)
    cols = _Columns()
    # Line by line out of the bytes: no list of every line, no second copy.
    for number, chunk in enumerate(io.BytesIO(raw), start=1):
        line = chunk.decode("utf-8", errors="replace").rstrip("\n")
        if not line.strip():
            continue  # blank lines
        if "\x00" in line or "\ufffd" in line:
            problems.append(_binary(path, number))
            continue
        parsed = parse_candump_line(line)
        if isinstance(parsed[0], ProblemKind):
            problems.append(LogProblem(f"{path}:{number}", number, parsed[0], str(parsed[1])))
            continue
        t, channel, frame_id, extended, data = parsed
        cols.add(number, t, channel, frame_id, extended, data)
    return cols.build(path, "candump", problems, lines)


def _binary(path: Path, number: int) -> LogProblem:
    return LogProblem(f"{path}:{number}", number, ProblemKind.MALFORMED, "binary data, not text")


# ---------------------------------------------------------------- ASC and BLF

# Lines of an ASC file that are not frames and that python-can's ASCReader
# rightly passes over: the header, the trigger block's bounds, comments.
_ASC_STRUCTURE = re.compile(
    r"(?:date\s|base\s+(?:hex|dec)|(?:no\s+)?internal\s+events\s+logged"
    r"|begin\s+triggerblock|end\s+triggerblock|//|\d+\.\d+\s+start\s+of\s+measurement)",
    re.IGNORECASE,
)


class _AscLines:
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

    def __iter__(self) -> _AscLines:
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
            self.problems.append(_binary(self.path, self.number))
            return
        self.problems.append(
            LogProblem(
                f"{self.path}:{self.number}",
                self.number,
                ProblemKind.MALFORMED,
                f"skipped by python-can's ASC reader: {_show(line)}",
            )
        )

    def close(self) -> None:
        self.file.close()


def _read_python_can(path: Path, fmt: str, max_problems: int) -> FrameLog:
    problems = ProblemList(max_problems)
    cols = _Columns()
    number = 0
    asc = _AscLines(path, problems) if fmt == "asc" else None
    try:
        reader = can.ASCReader(asc) if asc is not None else can.BLFReader(str(path))  # type: ignore[arg-type]
    except Exception as exc:  # python-can raises what its parser meets
        if asc is not None:
            asc.close()
        raise LogError(f"{path}: not a readable {fmt.upper()} file: {exc}") from exc
    try:
        for count, msg in enumerate(reader, start=1):
            number = count if asc is None else asc.number
            if asc is not None:
                asc.framed = number
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
                    LogProblem(where, number, ProblemKind.MALFORMED, _time_beyond(f"{t!r}"))
                )
                continue
            channel = "" if msg.channel is None else str(msg.channel)
            cols.add(number, t, channel, msg.arbitration_id, msg.is_extended_id, data)
        if asc is not None:
            asc.passed()  # the last line
    except Exception as exc:  # a damaged file: keep what came before
        after = number if asc is None else asc.number
        where = f"{path}: after frame {after}" if asc is None else f"{path}:{after}"
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
    declared = getattr(reader, "file_size", 0)  # BLF: the writer's size, set on closing
    actual = path.stat().st_size
    if fmt == "blf" and declared and actual < declared:
        problems.append(
            LogProblem(
                f"{path}: after frame {number}",
                number,
                ProblemKind.READ,
                f"truncated: the header says {declared} bytes, the file has {actual}; "
                "the frames before are used",
            )
        )
    return cols.build(path, fmt, problems, number if asc is None else asc.number)


# ------------------------------------------------------------------ checking


def _check(log: FrameLog, lengths: Mapping[int, int]) -> None:
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
        log = _read_candump(path, raw, max_problems)
    else:
        if not path.is_file():
            raise LogError(f"{path}: cannot read: no such file")
        log = _read_python_can(path, fmt, max_problems)
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
    _check(log, {m.frame_id: m.length for m in db.messages})
    return log
