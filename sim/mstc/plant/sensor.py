# SPDX-License-Identifier: MIT
"""Range sensor: which obstacles the robot sees (Definition 1 of the paper),
with the imperfections a real one has when a scenario asks for them."""

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from mstc.model import Obstacle, Pose


class RangeSensor:
    """Reports every obstacle within ``d_det`` of the robot: centre to
    centre for an obstacle of radius ``r_ob``, from its boundary for any
    other (one of radius r within d_det + r − r_ob of its centre), as the
    firmware's D_s and D_act move with r − R_ob (docs/scenarios.md).

    Ideal by default. A scenario's ``[imperfections]`` (docs/scenarios.md) add
    Gaussian noise on the reported centres, drawn from @p rng, and random
    dropouts, drawn from @p dropout_rng (else from @p rng too, after the
    noise): one draw of every obstacle's noise and dropout per scan, in
    range or not, so that the draws of a step do not depend on what was seen.

    :param obstacles: the obstacles of the world (their positions at t = 0).
    :param d_det: sensor range [m]; an obstacle at exactly this distance is seen.
    :param r_ob: the obstacle radius @p d_det is given for (params.R_ob); None:
        every obstacle's centre within d_det.
    :param noise: standard deviation of the noise on reported x and y [m].
    :param dropout: probability that an obstacle in range is not reported.
    :param rng: the random stream; required when noise or dropout is not 0.
    :param dropout_rng: a stream of the dropouts' own (None: @p rng).
    """

    def __init__(
        self,
        obstacles: Sequence[Obstacle],
        d_det: float,
        *,
        r_ob: float | None = None,
        noise: float = 0.0,
        dropout: float = 0.0,
        rng: np.random.Generator | None = None,
        dropout_rng: np.random.Generator | None = None,
    ) -> None:
        self.obstacles = tuple(obstacles)
        self.d_det = d_det
        # The reach of each obstacle, in world order (a radius never changes).
        self._reach = tuple(
            d_det if r_ob is None else d_det + (o.radius - r_ob) for o in self.obstacles
        )
        self.noise = noise
        self.dropout = dropout
        if (noise or dropout) and rng is None:
            raise ValueError("a noisy sensor needs a random stream (rng)")
        self.rng = rng
        self.dropout_rng = dropout_rng or rng
        self._moving = any(o.moving for o in self.obstacles)

    def world(self, t: float) -> tuple[Obstacle, ...]:
        """Where the obstacles are at time @p t [s]."""
        if not self._moving:
            return self.obstacles
        return tuple(o.at(t) for o in self.obstacles)

    def scan(self, pose: Pose, t: float = 0.0) -> list[Obstacle]:
        """Obstacles seen from ``pose`` at time @p t [s], in world order."""
        if self.rng is None:
            # Obstacle.distance inlined (the same math.hypot): a scan a step.
            x, y, hypot = pose.x, pose.y, math.hypot
            return [
                o
                for o, reach in zip(self.world(t), self._reach, strict=True)
                if hypot(o.x - x, o.y - y) <= reach
            ]
        world = self.world(t)
        n = len(world)
        noise = self.rng.standard_normal((n, 2)) * self.noise if self.noise else None
        kept = None
        if self.dropout:
            assert self.dropout_rng is not None  # checked in __init__
            kept = self.dropout_rng.random(n) >= self.dropout
        result = []
        for i, o in enumerate(world):
            if o.distance(pose) > self._reach[i] or (kept is not None and not kept[i]):
                continue
            if noise is not None:
                o = replace(o, x=o.x + float(noise[i, 0]), y=o.y + float(noise[i, 1]))
            result.append(o)
        return result


class SlotSensor:
    """An obstacle sensor node for worlds of many obstacles (a scenario's
    ``[world]``, docs/scenarios.md): each period it reports the obstacles in
    range (as :class:`RangeSensor`: centre within d_det + (r − r_ob)),
    nearest first by the distance to their surface, at most @p slots of them,
    each under a slot id 1..slots that it keeps while it stays reported; an
    obstacle that drops out frees its slot, and a newcomer takes the lowest
    free one, nearest first. The firmware thus meets an id that comes back
    elsewhere, which it takes as a new obstacle (msw.h). The reports come in
    slot order.

    It also counts the periods in which an obstacle whose surface is within
    @p d_act of the robot's surface (centre distance <= r_m + r + d_act) was
    not reported (:attr:`unreported`): zero when the firmware's table holds
    every obstacle that could activate.

    :param obstacles: the world (static obstacles).
    :param slots: the ids the frames and the firmware's table have.
    """

    def __init__(
        self,
        obstacles: Sequence[Obstacle],
        d_det: float,
        *,
        r_ob: float,
        slots: int,
        r_m: float,
        d_act: float,
    ) -> None:
        self.obstacles = tuple(obstacles)
        self.d_det = d_det
        self.slots = slots
        xy = np.array([(o.x, o.y) for o in self.obstacles], dtype=float).reshape(-1, 2)
        radius = np.array([o.radius for o in self.obstacles], dtype=float)
        self._x, self._y = xy[:, 0].copy(), xy[:, 1].copy()
        self._radius = radius
        self._reach = d_det + (radius - r_ob)
        self._near = r_m + radius + d_act
        self._slot_of: dict[int, int] = {}
        """World index → slot id of the obstacles reported last period."""
        self.unreported = 0
        """Periods with an obstacle within d_act of the robot's surface not reported."""

    def world(self, t: float) -> tuple[Obstacle, ...]:  # noqa: ARG002 - a static world
        """Where the obstacles are (static)."""
        return self.obstacles

    def scan(self, pose: Pose, t: float = 0.0) -> list[Obstacle]:  # noqa: ARG002
        """The reports from @p pose, with their slot ids, in slot order."""
        d = np.hypot(self._x - pose.x, self._y - pose.y)
        seen = np.flatnonzero(d <= self._reach)
        if len(seen) > self.slots:
            # Nearest first by surface distance; ties by world order (stable).
            order = np.argsort(d[seen] - self._radius[seen], kind="stable")
            seen = np.sort(seen[order[: self.slots]])
        kept = set(seen.tolist())
        if bool(((d <= self._near) & ~np.isin(np.arange(len(d)), seen)).any()):
            self.unreported += 1
        old = self._slot_of
        slot_of = {i: s for i, s in old.items() if i in kept}
        used = set(slot_of.values())
        free = (s for s in range(1, self.slots + 1) if s not in used)
        newcomers = [i for i in seen.tolist() if i not in slot_of]
        newcomers.sort(key=lambda i: (d[i] - self._radius[i], i))
        for i in newcomers:
            slot_of[i] = next(free)
        self._slot_of = slot_of
        reports = [replace(self.obstacles[i], id=s) for i, s in slot_of.items()]
        reports.sort(key=lambda o: o.id)
        return reports
