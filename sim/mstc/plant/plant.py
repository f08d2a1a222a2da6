# SPDX-License-Identifier: MIT
"""Kinematic plant: a differential-drive robot moving as a unicycle.

The robot is driven by the angular speeds of its two wheels. They give the body
velocity (v, ω); the pose then follows the unicycle model
ẋ = v cos θ, ẏ = v sin θ, θ̇ = ω, integrated over one control period with the
wheel speeds held constant (zero-order hold). Everything here is in double
precision, whatever the firmware's numeric mode.
"""

import math
from enum import StrEnum
from typing import Protocol

from mstc.model import Pose


class Integrator(StrEnum):
    """How a pose is advanced over one period of constant (v, ω)."""

    EULER = "euler"
    """Forward Euler: first order, the scheme of the paper's figures."""
    EXACT = "exact"
    """The exact arc (or straight line) of constant (v, ω)."""


_new_pose = tuple.__new__
"""Builds a Pose without NamedTuple's generated __new__ (one call less a
period: the plant and the reference each make one per step)."""
_cos, _sin = math.cos, math.sin

_EULER = Integrator.EULER

# Below this |ω dt| the series of sin(h)/h is exact to double precision.
_SMALL_ANGLE = 1e-4


def _sinc(h: float) -> float:
    """sin(h) / h, continuous at h = 0."""
    if abs(h) < _SMALL_ANGLE:
        return 1.0 - h * h / 6.0
    return math.sin(h) / h


def integrate(pose: Pose, v: float, w: float, dt: float, integrator: Integrator) -> Pose:
    """Advance a unicycle by ``dt`` with constant body velocity.

    :param pose: pose at the start of the period.
    :param v: linear velocity [m/s].
    :param w: angular velocity [rad/s], positive counter-clockwise.
    :param dt: period [s].
    :param integrator: ``EULER``: x += v cos θ dt, y += v sin θ dt, θ += ω dt.
        ``EXACT``: the arc x += v/ω (sin(θ+ω dt) − sin θ),
        y −= v/ω (cos(θ+ω dt) − cos θ), θ += ω dt, evaluated in the
        equivalent form v dt · sinc(ω dt/2) · (cos, sin)(θ + ω dt/2), which
        has no cancellation for small ω and becomes the straight line at
        ω = 0.

    :returns: The pose at the end of the period.
    """
    x, y, theta = pose
    if integrator is _EULER:
        return _new_pose(Pose, (x + v * _cos(theta) * dt, y + v * _sin(theta) * dt, theta + w * dt))
    half = 0.5 * w * dt
    chord = v * dt * _sinc(half)
    mid = theta + half
    return _new_pose(Pose, (x + chord * _cos(mid), y + chord * _sin(mid), theta + w * dt))


def body_velocity(
    wheel_left: float, wheel_right: float, wheel_radius: float, track_width: float
) -> tuple[float, float]:
    """Body velocity of a differential drive.

    :param wheel_left: left wheel angular speed ω_L [rad/s], positive forward.
    :param wheel_right: right wheel angular speed ω_R [rad/s], positive forward.
    :param wheel_radius: r [m].
    :param track_width: L, distance between the wheels [m].

    :returns: (v, ω): v = r (ω_R + ω_L)/2 [m/s], ω = r (ω_R − ω_L)/L [rad/s].
    """
    v = wheel_radius * (wheel_right + wheel_left) / 2.0
    w = wheel_radius * (wheel_right - wheel_left) / track_width
    return v, w


class UnicyclePlant:
    """The robot: a pose moved by wheel speeds.

    :param pose: initial pose.
    :param wheel_radius: r [m].
    :param track_width: L [m].
    :param integrator: scheme used by :meth:`step`.
    """

    def __init__(
        self, pose: Pose, wheel_radius: float, track_width: float, integrator: Integrator
    ) -> None:
        self.pose = pose
        self.wheel_radius = wheel_radius
        self.track_width = track_width
        self.integrator = integrator

    def body_velocity(self, wheel_left: float, wheel_right: float) -> tuple[float, float]:
        """(v, ω) for the given wheel speeds [rad/s], see :func:`body_velocity`."""
        return body_velocity(wheel_left, wheel_right, self.wheel_radius, self.track_width)

    def step(self, wheel_left: float, wheel_right: float, dt: float) -> Pose:
        """Hold the wheel speeds [rad/s] for ``dt`` [s]; return the new pose."""
        v, w = body_velocity(wheel_left, wheel_right, self.wheel_radius, self.track_width)
        self.pose = integrate(self.pose, v, w, dt, self.integrator)
        return self.pose


class WheelDrive(Protocol):
    """Wheels with dynamics of their own, in place of :meth:`UnicyclePlant.step`'s
    ideal ones (a scenario's ``[actuator]``, docs/scenarios.md): they take
    the control step's wheel speeds as setpoints and move the plant's pose
    over the period as the wheels they model turn."""

    def drive(self, plant: UnicyclePlant, left: float, right: float, dt: float) -> None:
        """Setpoints @p left and @p right [rad/s] for @p dt [s]: move
        ``plant.pose`` as the wheels turn meanwhile."""

    @property
    def measured(self) -> tuple[float, float]:
        """The wheel speeds measured at the end of the last period (left,
        right) [rad/s]: what the wheels' WHEEL_SPEED frame carries."""
