# SPDX-License-Identifier: MIT
"""Play a bus log onto a bus with its original timing, like can-utils' canplayer.

Frames are sent at the log's time line, scaled by a rate factor: frame i goes
out when ``(t_i − t_0) / rate`` seconds of wall clock have passed since the
start of the loop, the player sleeping until then. A frame whose time stamp is
earlier than its predecessor's is sent at once (the log's order is kept), and
a player that falls behind sends at once until it catches up, so lateness
never accumulates into the time line. By default only the firmware's input
frames are sent (a board on the bus answers with the rest); an ID filter
narrows that further.

The clock and the sleep are parameters, so the schedule is tested with a fake
clock on python-can's ``virtual`` interface.
"""

from __future__ import annotations

import errno
import itertools
import re
import time
from collections.abc import Callable, Container, Sequence
from dataclasses import dataclass
from typing import Any

import can
from cantools.database.can import Database

from mstc.errors import BusError, SendError, UsageError
from mstc.logs.framelog import FrameLog
from mstc.model import Progress

SEND_TIMEOUT_S = 1.0
"""How long one send may wait for room in the interface's queue [s]."""
MAX_SLEEP_S = 60.0
"""Longest single sleep [s]: a frame due later is waited for in pieces, so
that no wait, however far off (a slow --rate), asks the system for a sleep
it cannot take."""


@dataclass(frozen=True)
class IdFilter:
    """Identifiers to keep: inclusive ranges of 11- or 29-bit identifiers."""

    ranges: tuple[tuple[int, int], ...]

    def __contains__(self, frame_id: object) -> bool:
        return isinstance(frame_id, int) and any(lo <= frame_id <= hi for lo, hi in self.ranges)

    @classmethod
    def parse(cls, text: str, db: Database | None = None) -> IdFilter:
        """Parse ``0x100,0x104-0x110,STEP``: comma-separated hexadecimal
        identifiers (``0x`` optional) or inclusive ranges of them, or message
        names of @p db.

        :raises UsageError: an item is none of these, or a range is reversed.
        """
        ranges = []
        for item in (part.strip() for part in text.split(",")):
            if not item:
                raise UsageError(f"empty item in ID filter {text!r}")
            if db is not None and item in {m.name for m in db.messages}:
                frame_id = db.get_message_by_name(item).frame_id
                ranges.append((frame_id, frame_id))
                continue
            bounds = item.split("-")
            if len(bounds) > 2:
                raise UsageError(f"bad range {item!r} in ID filter (write LOW-HIGH)")
            try:
                values = [_hex_id(b) for b in bounds]
            except ValueError:
                names = " or a message name" if db is not None else ""
                raise UsageError(
                    f"bad item {item!r} in ID filter: want a hex identifier "
                    f"(0x100), a range (0x104-0x110){names}"
                ) from None
            lo, hi = values[0], values[-1]
            if lo > hi:
                raise UsageError(f"reversed range {item!r} in ID filter")
            ranges.append((lo, hi))
        return cls(tuple(ranges))


def _hex_id(text: str) -> int:
    text = text.strip()
    digits = text[2:] if text.lower().startswith("0x") else text
    if not re.fullmatch(r"[0-9A-Fa-f]{1,8}", digits):
        raise ValueError(text)
    value = int(digits, 16)
    if value > 0x1FFFFFFF:
        raise ValueError(text)
    return value


def select(
    log: FrameLog,
    *,
    inputs: frozenset[int] | None,
    id_filter: IdFilter | None = None,
    channels: Container[str] | None = None,
) -> list[can.Message]:
    """The frames of @p log to play, as messages with the log's time stamps.

    :param inputs: identifiers to send (the firmware's inputs); None sends
        every frame of the log.
    :param id_filter: further keeps only these identifiers.
    :param channels: further keeps only the frames logged on these channels
        (None: every channel).
    """
    out = []
    for row in range(len(log)):
        if channels is not None and log.channel[row] not in channels:
            continue
        frame_id = int(log.frame_id[row])
        extended = bool(log.extended[row])
        if inputs is not None and (extended or frame_id not in inputs):
            continue
        if id_filter is not None and frame_id not in id_filter:
            continue
        out.append(log.message(row))
    return out


@dataclass
class PlayStats:
    """What a play did."""

    sent: int = 0
    """Frames sent, over every loop."""
    loops: int = 0
    """Loops completed."""
    late_max: float = 0.0
    """Largest delay of a send behind its time on the scaled time line [s]."""
    seconds: float = 0.0
    """Wall time [s]."""


class Player:
    """Sends frames onto a bus at their time stamps.

    :param bus: the bus.
    :param rate: time scale: 2 plays twice as fast as recorded, 0.5 at half
        speed, ``inf`` back to back.
    :param loops: times to play the frames; 0 repeats until interrupted.
    :param clock: a monotonic clock [s].
    :param sleep: sleeps a number of seconds.
    :param limit: stop after this many frames in all (0: no limit).
    :param echo: called with each frame sent.
    :param route: the bus to send each frame on (default: @p bus).
    """

    def __init__(
        self,
        bus: can.BusABC,
        *,
        rate: float = 1.0,
        loops: int = 1,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        limit: int = 0,
        echo: Callable[[can.Message], None] | None = None,
        route: Callable[[can.Message], can.BusABC] | None = None,
    ) -> None:
        if not rate > 0:
            raise ValueError(f"rate must be > 0, got {rate}")
        if loops < 0:
            raise ValueError(f"loops must be >= 0, got {loops}")
        self.bus = bus
        self.rate = rate
        self.loops = loops
        self.clock = clock
        self.sleep = sleep
        self.limit = limit
        """Stop after this many frames sent in all (0: no limit; canplayer -n)."""
        self.echo = echo
        """Called with each frame once sent (canplayer -v)."""
        self.route = route
        """The bus of each frame (interface mapping, canplayer's vcan0=can0);
        None: :attr:`bus`."""
        self.stats = PlayStats()
        """What the current (or last) :meth:`play` did so far."""

    def play(self, frames: Sequence[can.Message], progress: Progress | None = None) -> PlayStats:
        """Send @p frames, :attr:`loops` times, each loop on the frames' time line.

        :returns: What the play did; also in :attr:`stats` as it goes, so that
            a play that failed or was interrupted can say how far it came.
        :raises SendError: a frame could not be sent.
        """
        stats = self.stats = PlayStats()
        if not frames:
            return stats
        begin = self.clock()
        t0 = frames[0].timestamp
        loops = itertools.count() if self.loops == 0 else range(self.loops)
        for _ in loops:
            start = self.clock()
            for msg in frames:
                due = start + (msg.timestamp - t0) / self.rate
                now = self.clock()
                while due > now:
                    self.sleep(min(due - now, MAX_SLEEP_S))
                    now = self.clock()
                stats.late_max = max(stats.late_max, now - due)
                bus = self.bus if self.route is None else self.route(msg)
                try:
                    bus.send(msg, timeout=SEND_TIMEOUT_S)
                except can.CanError as exc:
                    stats.seconds = self.clock() - begin
                    raise SendError(f"cannot send {msg.arbitration_id:03X}: {exc}") from exc
                stats.sent += 1
                if self.echo is not None:
                    self.echo(msg)
                if progress is not None:
                    progress.update(stats.sent)
                if stats.sent == self.limit:
                    stats.seconds = self.clock() - begin
                    return stats
            stats.loops += 1
        stats.seconds = self.clock() - begin
        return stats


_ERRNO_HINTS = {
    errno.EAFNOSUPPORT: "this kernel has no SocketCAN (modules can, can-raw); "
    "docs/hil.md runs it in a VM",
    errno.ENODEV: "no such interface; a virtual one is made with "
    "`ip link add dev {channel} type vcan && ip link set up {channel}`",
    errno.ENETDOWN: "the interface is down: `ip link set up {channel}`",
    errno.EPERM: "not permitted: run as a user allowed to open CAN sockets",
}


def open_bus(interface: str, channel: str | None, **config: Any) -> can.BusABC:
    """The python-can bus @p interface on @p channel (None: the interface's
    default), with the interface's other settings @p config (an slcan bit
    rate, mstc-sil's library).

    :raises BusError: it cannot be opened; the error says why, with a hint
        for the usual SocketCAN causes.
    """
    try:
        return can.Bus(interface=interface, channel=channel, **config)
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        text = f"cannot open {interface} bus {channel!r}: {exc}"
        code = getattr(exc, "errno", None) or getattr(exc, "error_code", None)
        hint = _ERRNO_HINTS.get(code) if isinstance(code, int) else None
        if hint is None and isinstance(exc.__cause__, OSError):
            hint = _ERRNO_HINTS.get(exc.__cause__.errno or 0)
        if hint is not None:
            text += f" ({hint.format(channel=channel)})"
        raise BusError(text) from exc
