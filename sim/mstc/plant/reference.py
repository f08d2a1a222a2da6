# SPDX-License-Identifier: MIT
"""The references a robot tracks: the paper's virtual robot, and paths.

- :class:`ReferenceRobot`: the virtual reference robot of the paper (section
  3.1), a unicycle moving at constant (v_r, ω_r), integrated with the same
  scheme as the robot: the reference of the paper's scenarios, a clock.
- :class:`PathReference`: a path (a polyline, as Nav2's ``/plan`` or a
  scenario's ``[reference] path``) travelled at a set speed. Two ways:

  - :meth:`PathReference.at`: on a clock. The virtual robot is on the path at
    arc length s = v·τ, τ being the time it has been moving; its heading is
    the direction of the segment it is on (from the point at s to the next
    segment once s reaches a vertex), its angular speed the heading change
    over the next control period divided by the period, and it stops
    (v_r = ω_r = 0) at the path's end. A path whose vertices are the poses of
    a unicycle integrated with forward Euler at that speed and period gives
    back exactly those poses and its (v_r, ω_r). The ROS 2 bridge sends a
    Nav2 plan this way.
  - :meth:`PathReference.follow`: a virtual target that waits for the robot
    (path following with a virtual target, as Lapierre and Soetanto's, or
    the carrot of Nav2's regulated pure pursuit; docs/strategy.md, "Clutter").
    The robot's progress q is the farthest arc length at which it has come
    within :data:`ON_PATH` of the path; the target's arc length s advances
    by v·dt a period while it is less than :data:`LEAD` ahead of q, never
    falls behind q, and never goes back. So it runs on the clock while the
    robot keeps up, waits on the path while the robot goes around something
    (v_r stays v: the tracking law keeps steering to it), moves on as soon as
    the robot comes back to the path further along, and stops (v_r = ω_r = 0)
    only at the path's end, where the robot is. The firmware reads the
    target standing still as the sign that the robot has left the path
    (msw.h, the leave rule).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mstc.model import Pose, wrap_angle
from mstc.plant.plant import Integrator, integrate

VERTEX_TOLERANCE = 1e-9
"""An arc length within this of a vertex [m] is at the vertex: rounding in
s = v·τ must not leave the reference on the segment before it."""
LEAD = 0.5
"""How far the waiting target may run ahead of the robot's progress along
the path [m]."""
ON_PATH = 0.2
"""The robot is on the path where it is within this of it [m]: only there
does its progress along the path count."""


@dataclass(frozen=True)
class ReferenceSample:
    """The reference at one control step."""

    pose: Pose
    v: float
    """v_r [m/s]."""
    w: float
    """ω_r [rad/s]."""


class ReferenceRobot:
    """Generates the reference trajectory q_r(t).

    :param pose: initial reference pose q_r(0).
    :param v: reference linear velocity v_r [m/s].
    :param w: reference angular velocity ω_r [rad/s].
    :param integrator: scheme used by :meth:`step`.
    """

    def __init__(self, pose: Pose, v: float, w: float, integrator: Integrator) -> None:
        self.pose = pose
        self.v = v
        self.w = w
        self.integrator = integrator

    def sample(self, robot: Pose) -> ReferenceSample:  # noqa: ARG002 - the robot is not looked at
        """The reference now (a clock: whatever the robot does)."""
        return ReferenceSample(self.pose, self.v, self.w)

    def step(self, dt: float) -> Pose:
        """Advance by ``dt`` [s]; return the new reference pose."""
        self.pose = integrate(self.pose, self.v, self.w, dt, self.integrator)
        return self.pose


def path_points(points: Sequence[Sequence[float]]) -> list[tuple[float, float]]:
    """@p points as (x, y) pairs, repeated points dropped.

    :raises ValueError: a point that is not finite, or fewer than two
        distinct points.
    """
    kept: list[tuple[float, float]] = []
    for point in points:
        x, y = float(point[0]), float(point[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"path point ({x!r}, {y!r}) is not finite")
        if not kept or (x, y) != kept[-1]:
            kept.append((x, y))
    if len(kept) < 2:
        raise ValueError("a path needs two distinct points")
    return kept


class PathReference:
    """A path travelled at @p speed [m/s], sampled every @p period [s].

    :param points: the path's vertices (x, y) [m]; repeated points are dropped.
    :raises ValueError: fewer than two distinct points, or a speed or period
        that is not positive and finite.
    """

    def __init__(
        self,
        points: Sequence[Sequence[float]],
        speed: float,
        period: float,
        *,
        wait: bool = True,
    ) -> None:
        if not (math.isfinite(speed) and speed > 0 and math.isfinite(period) and period > 0):
            raise ValueError(f"speed {speed!r} and period {period!r} must be positive")
        kept = path_points(points)
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
        seg = np.diff(np.array(kept), axis=0)
        self._a = np.array(kept[:-1])
        self._len = np.hypot(seg[:, 0], seg[:, 1])
        self._u = seg / self._len[:, None]
        self._start = np.array(self.starts[:-1])
        self.s = 0.0
        """The waiting target's arc length (:meth:`follow`) [m]."""
        self.q = 0.0
        """The robot's progress along the path (:meth:`follow`) [m]."""
        self.wait = wait
        """:meth:`sample` waits for the robot (:meth:`follow`), or runs on the
        clock (:meth:`at`)."""
        self.k = 0
        """Periods stepped (the clock of :meth:`sample` without waiting)."""
        self._next = 0.0

    def _segment(self, s: float) -> int:
        """The segment arc length @p s is on (a vertex belongs to the segment after it)."""
        i = bisect.bisect_right(self.starts, s + VERTEX_TOLERANCE) - 1
        return min(max(i, 0), len(self.headings) - 1)

    def pose_at(self, s: float) -> Pose:
        """The point at arc length @p s (clamped to the path), with the
        heading of its segment."""
        s = min(max(s, 0.0), self.length)
        i = self._segment(s)
        x0, y0 = self.points[i]
        theta = self.headings[i]
        along = s - self.starts[i]
        return Pose(x0 + along * math.cos(theta), y0 + along * math.sin(theta), theta)

    def at(self, tau: float) -> ReferenceSample:
        """The reference on a clock, @p tau [s] after it set off."""
        s = min(max(self.speed * tau, 0.0), self.length)
        pose = self.pose_at(s)
        if s >= self.length - VERTEX_TOLERANCE:
            return ReferenceSample(pose, 0.0, 0.0)
        ahead = self.headings[self._segment(min(s + self.speed * self.period, self.length))]
        return ReferenceSample(pose, self.speed, wrap_angle(ahead - pose.theta) / self.period)

    def progress(self, x: float, y: float) -> float:
        """The farthest arc length of the path's points nearest to (x, y) on
        each segment that lie within :data:`ON_PATH` of it, or -inf."""
        rx = x - self._a[:, 0]
        ry = y - self._a[:, 1]
        t = np.clip(rx * self._u[:, 0] + ry * self._u[:, 1], 0.0, self._len)
        near = np.hypot(rx - t * self._u[:, 0], ry - t * self._u[:, 1]) <= ON_PATH
        if not near.any():
            return -math.inf
        return float((self._start + t)[near].max())

    def sample(self, robot: Pose) -> ReferenceSample:
        """The reference of this period: the waiting target for a robot at
        @p robot (its odometry, :meth:`follow`), or the clock's (:meth:`at`,
        k periods after the start); :meth:`step` moves to the next period."""
        if self.wait:
            return self.follow(robot)
        return self.at(self.k * self.period)

    def follow(self, robot: Pose) -> ReferenceSample:
        """The waiting target now, given where the robot is; the target of
        the next period is set here (:meth:`step` moves to it)."""
        self.q = max(self.q, self.progress(robot.x, robot.y))
        s = self.s
        pose = self.pose_at(s)
        if s >= self.length - VERTEX_TOLERANCE:
            self._next = s
            return ReferenceSample(pose, 0.0, 0.0)
        step = self.speed * self.period
        self._next = min(max(s, min(s + step, self.q + LEAD), self.q), self.length)
        turn = wrap_angle(self.pose_at(self._next).theta - pose.theta)
        return ReferenceSample(pose, self.speed, turn / self.period)

    def step(self, dt: float) -> None:  # noqa: ARG002 - the period was given at construction
        """The next period: the waiting target to where :meth:`follow` set
        it, the clock one period on."""
        self.s = self._next
        self.k += 1
