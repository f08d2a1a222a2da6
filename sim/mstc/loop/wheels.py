# SPDX-License-Identifier: MIT
"""The plant's "dc" actuator: DC gearmotors under the firmware's own wheel loop.

A scenario's ``[actuator] model = "dc"`` (docs/scenarios.md) drives the robot
with two brushed DC gearmotors (model/dcm.h) whose speed loop is the
firmware's own (firmware/wheel/whl.h), both running in this process in
``libmstc_sil.so`` (:mod:`mstc.firmware.wheels`): the control step's wheel
speeds are the loop's setpoints, the loop runs at its rate (1 kHz) on the
motors' encoders, and the plant's pose follows the wheels as they turn, in
substeps of at most 1 ms. So ``mstc sim`` and the sweeps run the complete
firmware, outer and inner loops, against motors (docs/wheel.md).
"""

from __future__ import annotations

from pathlib import Path

from mstc.can.library import Library
from mstc.firmware.wheels import Motor, WheelLoop, WheelParams
from mstc.plant.plant import UnicyclePlant, body_velocity, integrate
from mstc.plant.scenario import Scenario

SUBSTEP_US = 1000
"""Longest substep of the pose [µs]: the wheel loop's default period."""


class DcWheels:
    """The plant's "dc" actuator: a :class:`~mstc.plant.plant.WheelDrive`.

    Each control period is cut into substeps of at most 1 ms; over each, the
    motors and their loop advance in the library, and the plant's pose moves
    with the body velocity of the wheels' mean speeds over the substep (their
    angle turned, divided by its length), by the scenario's integrator.

    :param lib: the firmware library (its numeric mode is the loop's).
    :param params: see :class:`WheelLoop`.
    :param motor: see :class:`WheelLoop`.
    """

    def __init__(
        self, lib: Library, params: WheelParams | None = None, motor: Motor | None = None
    ) -> None:
        self.loop = WheelLoop(lib, params, motor)
        self.state = self.loop.advance(0.0, 0.0, 0)
        self.load = (0.0, 0.0)
        """Torque against each wheel's forward motion [N·m]."""

    @property
    def measured(self) -> tuple[float, float]:
        """The wheel loop's measured speeds at the end of the last period."""
        return self.state.measured

    def drive(self, plant: UnicyclePlant, left: float, right: float, dt: float) -> None:
        """See :meth:`mstc.plant.plant.WheelDrive.drive`."""
        dt_us = round(dt * 1e6)
        n = max(1, -(-dt_us // SUBSTEP_US))
        r, track, integrator = plant.wheel_radius, plant.track_width, plant.integrator
        pose = plant.pose
        state = self.state
        done = 0
        for k in range(1, n + 1):
            h_us = dt_us * k // n - done
            done += h_us
            before = state.angle
            state = self.loop.advance(left, right, h_us, self.load)
            h = h_us * 1e-6
            mean_l = (state.angle[0] - before[0]) / h
            mean_r = (state.angle[1] - before[1]) / h
            v, w = body_velocity(mean_l, mean_r, r, track)
            pose = integrate(pose, v, w, h, integrator)
        plant.pose = pose
        self.state = state


def wheels_for(scenario: Scenario, lib: str | Path | None) -> DcWheels | None:
    """The wheels @p scenario's ``[actuator]`` asks for: :class:`DcWheels` on
    the firmware library @p lib for "dc", None for the ideal ones."""
    if scenario.actuator.model != "dc":
        return None
    return DcWheels(Library.open(lib))
