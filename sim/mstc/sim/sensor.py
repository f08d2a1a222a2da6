# SPDX-License-Identifier: MIT
"""Range sensor: which obstacles the robot sees (Definition 1 of the paper)."""

import math
from collections.abc import Sequence
from dataclasses import dataclass

from mstc.sim.plant import Pose


@dataclass(frozen=True)
class Obstacle:
    """A circular obstacle, as the world holds it and as the sensor reports it."""

    id: int
    """1-based index in the scenario file, stable over the run."""
    x: float
    """Centre [m]."""
    y: float
    """Centre [m]."""
    radius: float
    """[m], > 0."""

    def distance(self, pose: Pose) -> float:
        """Centre-to-centre distance D_r to a robot at ``pose`` [m], eq. (5)."""
        return math.hypot(self.x - pose.x, self.y - pose.y)


class RangeSensor:
    """Reports every obstacle whose centre is within ``d_det`` of the robot.

    :param obstacles: the obstacles of the world.
    :param d_det: sensor range D_det [m]; an obstacle at exactly D_det is seen.
    """

    def __init__(self, obstacles: Sequence[Obstacle], d_det: float) -> None:
        self.obstacles = tuple(obstacles)
        self.d_det = d_det

    def scan(self, pose: Pose) -> list[Obstacle]:
        """Obstacles seen from ``pose``, in world order."""
        return [o for o in self.obstacles if o.distance(pose) <= self.d_det]
