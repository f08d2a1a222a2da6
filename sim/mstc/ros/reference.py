# SPDX-License-Identifier: MIT
"""The reference the bridge sends, from what ROS 2 gives it; without ROS.

- a path (Nav2's ``/plan``: a polyline of poses) travelled at a set speed:
  :class:`mstc.plant.reference.PathReference` on its clock
  (:meth:`~mstc.plant.reference.PathReference.at`), the one implementation
  the plant's scenarios share. The virtual robot is on the path at arc
  length s = v·τ, τ being the time it has been moving; its heading is the
  direction of the segment it is on (from the point at s to the next segment
  once s reaches a vertex), its angular speed the heading change over the
  next control period divided by the period, and it stops (v_r = ω_r = 0) at
  the path's end. A path whose vertices are the poses of a unicycle
  integrated with forward Euler at that speed and period gives back exactly
  those poses and its (v_r, ω_r).
- :class:`StampedReference`: a stream of time-stamped poses; (v_r, ω_r) from
  each pose and the one before it (the backward difference over their
  stamps), zero for the first.
"""

from __future__ import annotations

import math

from mstc.model import Pose, wrap_angle
from mstc.plant.reference import PathReference, ReferenceSample

__all__ = ["PathReference", "ReferenceSample", "StampedReference"]


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
