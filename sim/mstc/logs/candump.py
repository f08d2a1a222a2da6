# SPDX-License-Identifier: MIT
"""Bus logs in ``candump -L`` format: the reader and the writer.

One frame a line: ``(1700000000.123456) vcan0 123#0011223344556677``: the time
stamp in seconds with six decimals, the interface, the identifier in three
upper-case hex digits (eight for an extended one) and the payload in hex.
canplayer, python-can's ``LogReader`` and ``cantools decode`` read what
:func:`write_candump` writes as it is.

The reader is a strict parser of our own: python-can's ``CanutilsLogReader``
raises on some malformed lines and silently misreads others, and gives no
line numbers. A file whose every line is a classic frame with 8 data bytes on
one interface (any log ``make sim`` or candump writes of mstc traffic) is
parsed at once, with numpy over the bytes; any other file line by line
(:func:`parse_candump_line`), each bad line reported as ``path:line: problem``.
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterable
from pathlib import Path

import can
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from mstc.logs.framelog import (
    CAN_ERR_FLAG,
    MAX_DATA,
    MAX_TIME_S,
    FrameColumns,
    FrameLog,
    LogProblem,
    ProblemKind,
    ProblemList,
    binary,
    show,
    time_beyond,
)

_HEX = frozenset("0123456789abcdefABCDEF")


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
            f"{'s' if len(fields) != 1 else ''}: {show(text)}"
        )
    stamp, channel, frame = fields
    if not (stamp.startswith("(") and stamp.endswith(")")):
        return ProblemKind.MALFORMED, f"time stamp not in parentheses: {show(stamp)}"
    try:
        t = float(stamp[1:-1])
    except ValueError:
        return ProblemKind.MALFORMED, f"bad time stamp {show(stamp)}"
    if math.isnan(t):
        return ProblemKind.MALFORMED, f"time stamp not finite: {show(stamp)}"
    if not abs(t) <= MAX_TIME_S:
        return ProblemKind.MALFORMED, time_beyond(show(stamp))
    ident, sep, payload = frame.partition("#")
    if not sep:
        return ProblemKind.MALFORMED, f"no '#' between identifier and data: {show(frame)}"
    if not ident or not set(ident) <= _HEX:
        return ProblemKind.MALFORMED, f"identifier is not hexadecimal: {show(ident)}"
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
        return ProblemKind.MALFORMED, f"data is not hexadecimal: {show(payload)}"
    if len(payload) % 2:
        return ProblemKind.MALFORMED, (
            f"odd number of hex digits in the data ({len(payload)}): truncated? {show(payload)}"
        )
    if len(payload) > 2 * MAX_DATA:
        return (
            ProblemKind.MALFORMED,
            f"{len(payload) // 2} data bytes: a classic frame has at most 8",
        )
    return t, channel, frame_id, extended, bytes.fromhex(payload)


_HEX_VALUE = np.full(256, 0xFF, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789ABCDEF"):
    _HEX_VALUE[_c] = _HEX_VALUE[bytes([_c]).lower()[0]] = _i
_MAX_SECONDS_DIGITS = 10
"""Digits of the whole seconds of a time stamp (the epoch needs 10)."""


def _columnar(path: Path, raw: bytes) -> FrameLog | None:
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


def read_candump(path: Path, raw: bytes, max_problems: int) -> FrameLog:
    """The frames of the ``candump -L`` text @p raw (the file @p path): at once
    (:func:`_columnar`) when every line is a classic frame with 8 data bytes
    on one interface, else line by line (:func:`parse_candump_line`), every
    bad line a problem."""
    fast = _columnar(path, raw)
    if fast is not None:
        return fast
    lines = raw.count(b"\n") + (0 if raw.endswith(b"\n") or not raw else 1)
    problems = ProblemList(max_problems)
    cols = FrameColumns()
    # Line by line out of the bytes: no list of every line, no second copy.
    for number, chunk in enumerate(io.BytesIO(raw), start=1):
        line = chunk.decode("utf-8", errors="replace").rstrip("\n")
        if not line.strip():
            continue  # blank lines
        if "\x00" in line or "\ufffd" in line:
            problems.append(binary(path, number))
            continue
        parsed = parse_candump_line(line)
        if isinstance(parsed[0], ProblemKind):
            problems.append(LogProblem(f"{path}:{number}", number, parsed[0], str(parsed[1])))
            continue
        t, channel, frame_id, extended, data = parsed
        cols.add(number, t, channel, frame_id, extended, data)
    return cols.build(path, "candump", problems, lines)


# ------------------------------------------------------------------ writing


def candump_line(msg: can.Message, channel: str) -> str:
    """One ``candump -L`` line (without the newline) for a classic data frame."""
    if msg.is_extended_id or msg.is_remote_frame or msg.is_error_frame or msg.is_fd:
        raise ValueError(f"not a classic data frame with an 11-bit identifier: {msg}")
    return (
        f"({msg.timestamp:.6f}) {channel} {msg.arbitration_id:03X}#{bytes(msg.data).hex().upper()}"
    )


def write_candump(path: Path, frames: Iterable[can.Message], channel: str) -> None:
    """Write @p frames to @p path, one line each, in order."""
    path.write_text("".join(candump_line(m, channel) + "\n" for m in frames))
