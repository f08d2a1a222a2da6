# SPDX-License-Identifier: MIT
"""The virtual reference robot of the paper (section 3.1): a unicycle moving at
constant (v_r, ω_r), integrated with the same scheme as the robot."""

from mstc.model import Pose
from mstc.plant.plant import Integrator, integrate


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

    def step(self, dt: float) -> Pose:
        """Advance by ``dt`` [s]; return the new reference pose."""
        self.pose = integrate(self.pose, self.v, self.w, dt, self.integrator)
        return self.pose
