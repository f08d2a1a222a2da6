# SPDX-License-Identifier: MIT
"""Progress of long runs on stderr, without a dependency.

On a terminal, a bar redrawn in place with the share done and an estimate of
the time left; when stderr is not a terminal, or when ``CI=true``, one plain
line at every tenth done, so that CI logs stay readable. Runs shorter than a
second show nothing.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import TextIO

BAR_WIDTH = 28
"""Characters of the bar."""
REDRAW_S = 0.1
"""Least time between two redraws of the bar [s]."""


def plain_output(stream: TextIO) -> bool:
    """Whether progress on @p stream must be plain lines: not a terminal, or CI."""
    if os.environ.get("CI", "").strip().lower() in ("true", "1", "yes"):
        return True
    isatty = getattr(stream, "isatty", None)
    return not (isatty is not None and isatty())


def _clock_text(seconds: float) -> str:
    """``m:ss``, or ``h:mm:ss`` from an hour."""
    s = max(0, round(seconds))
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class Progress:
    """Reports how far a run of @p total units has come.

    :param total: units of the whole run (frames, say); 0 shows nothing.
    :param label: what runs, first on each line (``"replay"``).
    :param unit: the units' name (``"frames"``).
    :param stream: where to write (default: stderr).
    :param plain: plain lines instead of a bar; default: :func:`plain_output`.
    :param delay: show nothing until the run has lasted this long [s].
    :param clock: a monotonic clock [s] (tests pass a fake one).
    :param enabled: False shows nothing at all (``--quiet``).
    """

    def __init__(
        self,
        total: int,
        label: str,
        unit: str = "frames",
        *,
        stream: TextIO | None = None,
        plain: bool | None = None,
        delay: float = 1.0,
        clock: Callable[[], float] = time.monotonic,
        enabled: bool = True,
    ) -> None:
        self.total = total
        self.label = label
        self.unit = unit
        self.stream = stream if stream is not None else sys.stderr
        self.plain = plain_output(self.stream) if plain is None else plain
        self.delay = delay
        self.clock = clock
        self.enabled = enabled and total > 0
        self._start = clock()
        self._last_draw = -float("inf")
        self._decile = 0
        self._drawn = False

    def _eta(self, done: int, elapsed: float) -> str:
        if done <= 0:
            return "?"
        return _clock_text(elapsed * (self.total - done) / done)

    def update(self, done: int) -> None:
        """@p done units of :attr:`total` are done."""
        if not self.enabled:
            return
        now = self.clock()
        elapsed = now - self._start
        if elapsed < self.delay:
            return
        share = min(max(done / self.total, 0.0), 1.0)
        if self.plain:
            decile = int(share * 10)
            if decile <= self._decile or decile >= 10:
                return
            self._decile = decile
            self.stream.write(
                f"{self.label}: {decile * 10}% ({done:,}/{self.total:,} {self.unit}), "
                f"{_clock_text(elapsed)} elapsed, {self._eta(done, elapsed)} left\n"
            )
            self.stream.flush()
            self._drawn = True
            return
        if now - self._last_draw < REDRAW_S:
            return
        self._last_draw = now
        filled = int(share * BAR_WIDTH)
        bar = "#" * filled + "-" * (BAR_WIDTH - filled)
        self.stream.write(
            f"\r{self.label} [{bar}] {share * 100:3.0f}% {done:,}/{self.total:,} {self.unit} "
            f"ETA {self._eta(done, elapsed)} "
        )
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """The run is over: clear the bar (a terminal), or say so (plain lines,
        when any was written)."""
        if not (self.enabled and self._drawn):
            return
        if self.plain:
            elapsed = self.clock() - self._start
            self.stream.write(f"{self.label}: done in {_clock_text(elapsed)}\n")
        else:
            self.stream.write("\r\x1b[K")
        self.stream.flush()
