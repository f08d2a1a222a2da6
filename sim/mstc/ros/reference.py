# SPDX-License-Identifier: MIT
"""The reference the bridge sends, from what ROS 2 gives it; without ROS.

- :class:`PathReference`: a path (Nav2's ``/plan``: a polyline of poses)
  travelled at a set speed. The virtual robot is on the path at arc length
  s = v·τ, τ being the time it has been moving; its heading is the direction
  of the segment it is on (from the point at s to the next segment once s
  reaches a vertex), its angular speed the heading change over the next
  control period divided by the period, and it stops (v_r = ω_r = 0) at the
  path's end. A path whose vertices are the poses of a unicycle integrated
  with forward Euler at that speed and period gives back exactly those poses
  and its (v_r, ω_r).
- :class:`StampedReference`: a stream of time-stamped poses; (v_r, ω_r) from
  each pose and the one before it (the backward difference over their
  stamps), zero for the first.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

from mstc.model import Pose, wrap_angle

VERTEX_TOLERANCE = 1e-9
"""An arc length within this of a vertex [m] is at the vertex: rounding in
s = v·τ must not leave the reference on the segment before it."""


@dataclass(frozen=True)
class ReferenceSample:
    """The reference at one control step."""

    pose: Pose
    v: float
    """v_r [m/s]."""
    w: float
    """ω_r [rad/s]."""


class PathReference:
    """A path travelled at @p speed [m/s], sampled every @p period [s].

    :param points: the path's vertices (x, y) [m]; repeated points are dropped.
    :raises ValueError: fewer than two distinct points, or a speed or period
        that is not positive and finite.
    """

    def __init__(self, points: Sequence[tuple[float, float]], speed: float, period: float) -> None:
        if not (math.isfinite(speed) and speed > 0 and math.isfinite(period) and period > 0):
            raise ValueError(f"speed {speed!r} and period {period!r} must be positive")
        kept: list[tuple[float, float]] = []
        for x, y in points:
            if not (math.isfinite(x) and math.isfinite(y)):
                raise ValueError(f"path point ({x!r}, {y!r}) is not finite")
            if not kept or (x, y) != kept[-1]:
                kept.append((x, y))
        if len(kept) < 2:
            raise ValueError("a path needs two distinct points")
        self.points = kept
        self.speed = speed
        self.period = period
        self.starts = [0.0]
        """Arc length at each vertex [m]."""
        self.headings: list[float] = []
        """Direction of each segment [rad]."""
        for (x0, y0), (x1, y1) in zip(kept, kept[1:], strict=False):
            self.starts.append(self.starts[-1] + math.hypot(x1 - x0, y1 - y0))
            self.headings.append(math.atan2(y1 - y0, x1 - x0))
        self.length = self.starts[-1]

    def _segment(self, s: float) -> int:
        """The segment arc length @p s is on (a vertex belongs to the segment after it)."""
        i = bisect.bisect_right(self.starts, s + VERTEX_TOLERANCE) - 1
        return min(max(i, 0), len(self.headings) - 1)

    def at(self, tau: float) -> ReferenceSample:
        """The reference @p tau [s] after it set off."""
        s = min(max(self.speed * tau, 0.0), self.length)
        i = self._segment(s)
        x0, y0 = self.points[i]
        theta = self.headings[i]
        along = s - self.starts[i]
        pose = Pose(x0 + along * math.cos(theta), y0 + along * math.sin(theta), theta)
        if s >= self.length - VERTEX_TOLERANCE:
            return ReferenceSample(pose, 0.0, 0.0)
        ahead = self.headings[self._segment(min(s + self.speed * self.period, self.length))]
        return ReferenceSample(pose, self.speed, wrap_angle(ahead - theta) / self.period)


class StampedReference:
    """The latest pose of a stream, with (v_r, ω_r) from the one before."""

    def __init__(self) -> None:
        self._last: tuple[int, Pose] | None = None
        self.sample: ReferenceSample | None = None
        """The reference now, None before the first pose."""

    def add(self, stamp_ns: int, pose: Pose) -> bool:
        """A pose stamped @p stamp_ns; one not after the latest is ignored.

        :returns: it was taken.
        """
        if self._last is not None:
            t0, p0 = self._last
            if stamp_ns <= t0:
                return False
            dt = (stamp_ns - t0) / 1e9
            dx, dy = pose.x - p0.x, pose.y - p0.y
            # Signed along the earlier heading: a reference may back up.
            v = (dx * math.cos(p0.theta) + dy * math.sin(p0.theta)) / dt
            w = wrap_angle(pose.theta - p0.theta) / dt
            self.sample = ReferenceSample(pose, v, w)
        else:
            self.sample = ReferenceSample(pose, 0.0, 0.0)
        self._last = (stamp_ns, pose)
        return True
