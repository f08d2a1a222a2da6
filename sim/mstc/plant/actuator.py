# SPDX-License-Identifier: MIT
"""Wheels that lag and cannot accelerate at will: the plant's "lag" actuator.

A scenario's ``[actuator]`` table of model "lag" (docs/scenarios.md) describes each wheel as
a CAN motor driver with its own speed loop presents it: the wheel's speed
follows its setpoint through a first-order lag (``time_constant`` τ, the
closed speed loop), never changes faster than ``max_accel`` a, and an encoder
of ``encoder_counts`` N counts per revolution measures it. The setpoints are
the firmware's wheel commands, ``delay`` whole control periods late.

Each control period of length dt is cut into n = ceil(dt / 1 ms) substeps of
h = dt / n. With the period's setpoints u_L, u_R (held), one substep does, for
each wheel, in this order and in double precision:

1. ``target = u + (w - u) * k`` with ``k = exp(-h / τ)`` (``k = 0`` for
   τ = 0): where the lag alone would take the speed w over h (exact for a
   constant setpoint);
2. ``step = target - w``, limited to ``[-a·h, a·h]`` (no limit for a = ∞);
3. ``w_new = w + step``;
4. ``angle += 0.5 * h * (w + w_new)``: the wheel's angle, trapezoidal (exact
   for the linear ramp of step 2);
5. ``w = w_new``;

then the body velocity of the substep from the two wheels' mean speeds over
it, ``v = r (m_R + m_L) / 2``, ``ω = r (m_R − m_L) / L`` with
``m = 0.5 (w + w_new)``, and the pose advanced over h with the scenario's
integrator (:func:`~mstc.plant.plant.integrate`'s formulas). At the end of the
period each wheel's encoder count is ``floor(angle · N / 2π)`` and the speed
the driver reports is ``(count − count_before) · 2π / (N · dt)``: the mean
speed over the period, quantised as a real encoder's is (without
``encoder_counts``: ``(angle − angle_before) / dt``, unquantised).

The state is the two wheels' speeds, angles and counts, and the delay line of
setpoints; nothing else is kept between periods, and every operation is plain
float arithmetic on them, so that a batched plant runs the same updates over
many scenes as array operations and agrees bit for bit, using the same
operations in the same order (:class:`mstc.plant.batch.BatchActuator`).

Without an ``[actuator]`` table (model "ideal") the plant is the ideal one
of :mod:`mstc.plant.plant`: the wheels turn at their commanded speed for the
whole period, and nothing here runs.
"""

from __future__ import annotations

import math
from collections import deque

from mstc.model import Pose
from mstc.plant.plant import Integrator, UnicyclePlant
from mstc.plant.scenario import ActuatorSpec

SUBSTEP = 0.001
"""Longest substep [s]."""


def substeps(dt: float) -> int:
    """n: substeps of at most :data:`SUBSTEP` in a period of @p dt [s]."""
    return max(1, math.ceil(dt / SUBSTEP - 1e-9))


class Actuator:
    """Two wheels driving a :class:`~mstc.plant.plant.UnicyclePlant` in substeps.

    :param spec: the wheels.
    :param plant: the robot whose pose the wheels move (its wheel radius,
        track width and integrator).
    :param dt: the control period [s].
    :param delay: whole periods between a command and its setpoint (the
        actuator's own and the scenario's imperfection together).
    """

    def __init__(self, spec: ActuatorSpec, plant: UnicyclePlant, dt: float, delay: int) -> None:
        self.spec = spec
        self.plant = plant
        self.dt = dt
        self.n = substeps(dt)
        self.h = dt / self.n
        tau = spec.time_constant
        self.k = math.exp(-self.h / tau) if tau > 0.0 else 0.0
        self.limit = spec.max_accel * self.h
        """The largest change of a wheel's speed in one substep [rad/s]."""
        self.counts_per_rad = spec.encoder_counts / math.tau
        self.speed = [0.0, 0.0]
        """Wheel speeds now, left and right [rad/s]."""
        self.angle = [0.0, 0.0]
        """Wheel angles since the start [rad]."""
        self.count = [0, 0]
        """Encoder counts at the end of the last period."""
        self.pending: deque[tuple[float, float]] = deque([(0.0, 0.0)] * delay)
        """Setpoints on their way (the delay line), oldest first."""

    def step(self, left: float, right: float) -> tuple[float, float]:
        """Command (@p left, @p right) [rad/s] now; run one period.

        :returns: the speeds the driver reports at the end of the period
            (left, right) [rad/s].
        """
        if self.pending:
            self.pending.append((left, right))
            left, right = self.pending.popleft()
        plant = self.plant
        r, track = plant.wheel_radius, plant.track_width
        euler = plant.integrator is Integrator.EULER
        h, k, limit, n = self.h, self.k, self.limit, self.n
        wl, wr = self.speed
        al, ar = self.angle
        x, y, theta = plant.pose
        cos, sin = math.cos, math.sin
        for _ in range(n):
            tl = left + (wl - left) * k
            tr = right + (wr - right) * k
            sl = tl - wl
            sr = tr - wr
            if sl > limit:
                sl = limit
            elif sl < -limit:
                sl = -limit
            if sr > limit:
                sr = limit
            elif sr < -limit:
                sr = -limit
            nl = wl + sl
            nr = wr + sr
            ml = 0.5 * (wl + nl)
            mr = 0.5 * (wr + nr)
            al += h * ml
            ar += h * mr
            wl, wr = nl, nr
            v = r * (mr + ml) / 2.0
            w = r * (mr - ml) / track
            if euler:
                x += v * cos(theta) * h
                y += v * sin(theta) * h
            else:
                half = 0.5 * w * h
                chord = v * h * (1.0 - half * half / 6.0 if abs(half) < 1e-4 else sin(half) / half)
                x += chord * cos(theta + half)
                y += chord * sin(theta + half)
            theta += w * h
        plant.pose = Pose(x, y, theta)
        self.speed = [wl, wr]
        before = self.angle
        self.angle = [al, ar]
        if self.counts_per_rad:
            cl = math.floor(al * self.counts_per_rad)
            cr = math.floor(ar * self.counts_per_rad)
            ml = (cl - self.count[0]) / self.counts_per_rad / self.dt
            mr = (cr - self.count[1]) / self.counts_per_rad / self.dt
            self.count = [cl, cr]
            return ml, mr
        return (al - before[0]) / self.dt, (ar - before[1]) / self.dt
