# SPDX-License-Identifier: MIT
"""Progress of long runs on stderr.

On a terminal, a tqdm bar redrawn in place with the share done and an
estimate of the time left; when stderr is not a terminal, or when ``CI=true``,
one plain line at every tenth done instead, so that CI logs stay readable
(tqdm writes carriage returns there, or with ``mininterval`` a line per
interval, not per share). Runs shorter than a second show nothing.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

from tqdm import tqdm

BAR_WIDTH = 28
"""Characters of the bar."""
REDRAW_S = 0.1
"""Least time between two redraws of the bar [s]."""
BAR_FORMAT = (
    f"{{desc}} [{{bar:{BAR_WIDTH}}}] {{percentage:3.0f}}% {{n:,}}/{{total:,}} {{unit}} "
    "ETA {remaining}"
)
"""The bar's line (tqdm's ``bar_format``)."""


def plain_output(stream: TextIO) -> bool:
    """Whether progress on @p stream must be plain lines: not a terminal, or CI."""
    if os.environ.get("CI", "").strip().lower() in ("true", "1", "yes"):
        return True
    isatty = getattr(stream, "isatty", None)
    return not (isatty is not None and isatty())


class _Bar(tqdm):  # type: ignore[type-arg]  # tqdm is generic over its iterable; none here
    """tqdm on a given clock (tests pass a fake one): tqdm reads its clock
    through the instance attribute ``_time``, set in its constructor."""

    def __init__(self, clock: Callable[[], float], **kwargs: Any) -> None:
        super().__init__(**kwargs)  # with delay > 0, nothing is drawn yet
        self._time = clock
        self.start_t = self.last_print_t = clock()


class ProgressBar:
    """Reports how far a run of @p total units has come (a
    :class:`mstc.model.Progress`).

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
        self._decile = 0
        self._drawn = False
        self._bar: _Bar | None = None
        if self.enabled and not self.plain:
            self._bar = _Bar(
                clock,
                total=total,
                desc=label,
                unit=unit,
                file=self.stream,
                # tqdm draws at once, on its own clock, when delay is 0.
                delay=max(delay, 1e-9),
                mininterval=REDRAW_S,
                smoothing=0,
                ascii="-#",
                leave=False,
                dynamic_ncols=False,
                bar_format=BAR_FORMAT,
            )

    def update(self, done: int) -> None:
        """@p done units of :attr:`total` are done."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.update(done - self._bar.n)
            return
        elapsed = self.clock() - self._start
        if elapsed < self.delay:
            return
        decile = int(min(max(done / self.total, 0.0), 1.0) * 10)
        if decile <= self._decile or decile >= 10:
            return
        self._decile = decile
        left = tqdm.format_interval(elapsed * (self.total - done) / done) if done > 0 else "?"
        self.stream.write(
            f"{self.label}: {decile * 10}% ({done:,}/{self.total:,} {self.unit}), "
            f"{tqdm.format_interval(elapsed)} elapsed, {left} left\n"
        )
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """The run is over: clear the bar (a terminal), or say so (plain lines,
        when any was written)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
            return
        if self.enabled and self._drawn:
            elapsed = tqdm.format_interval(self.clock() - self._start)
            self.stream.write(f"{self.label}: done in {elapsed}\n")
            self.stream.flush()
