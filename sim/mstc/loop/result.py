# SPDX-License-Identifier: MIT
"""What a closed-loop run leaves, whichever loop ran it: the trace, the events,
the distances to the obstacles and the faults (:class:`RunResult`)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from mstc.loop.timing import Timing
from mstc.model import Event, Fault, Mode, Obstacle
from mstc.plant.scenario import Scenario

PROGRESS_UPDATES = 200
"""How many times a run tells its progress display how far it is."""

TRACE_COLUMNS = (
    "t",
    "x",
    "y",
    "theta",
    "x_r",
    "y_r",
    "theta_r",
    "v",
    "w",
    "v_r",
    "w_r",
    "e1",
    "e2",
    "e3",
    "e",
)
"""Numeric columns of :attr:`Trace.values`, in order."""


@dataclass(frozen=True)
class Trace:
    """One row per control step k = 0..N, taken at the start of the period."""

    values: np.ndarray
    """(N+1, len(TRACE_COLUMNS)) array: t [s], robot pose, reference pose, the
    robot's body velocity (v, ω) from the commanded wheel speeds, (v_r, ω_r),
    and the controller's errors e1, e2, e3, e."""
    mode: tuple[Mode, ...]
    """The controller that ran at each step."""
    distance: np.ndarray
    """(N+1, number of obstacles): centre distance to each obstacle at the
    same step [m]."""
    obstacle_xy: np.ndarray | None = None
    """(N+1, number of obstacles, 2): each obstacle's centre at each step
    [m], when any obstacle moves; None when all stand still."""

    def __getitem__(self, column: str) -> np.ndarray:
        """One numeric column by name, e.g. ``trace["e1"]``."""
        return self.values[:, TRACE_COLUMNS.index(column)]

    @property
    def avoiding(self) -> np.ndarray:
        """Boolean mask of the steps run by the avoidance controller."""
        return np.array([m is Mode.AVOID for m in self.mode], dtype=bool)


@dataclass(frozen=True)
class RunResult:
    """Everything a run produced."""

    scenario: Scenario
    trace: Trace
    events: tuple[Event, ...]
    """Events in the order the controller emitted them."""
    min_distance: tuple[float, ...]
    """Smallest centre distance to each obstacle over the run [m]."""
    faults: dict[Fault, int]
    """Steps that reported each fault bit (only bits that occurred)."""
    step_time: float = 0.0
    """Mean wall time of one controller step in this process [s] (the
    controller's own work and the call into it; a measurement, so it
    differs from run to run)."""
    timing: Timing | None = None
    """A real-time run's timing (:mod:`mstc.loop.realtime`, timing.json);
    None in lock-step, where the plant's time is the firmware's."""
    halt: int | None = None
    """STATUS_halt of the firmware's last step of the run: 0 running, else why
    it holds the robot (docs/safety.md); None where the run has no such
    state (the control step in memory)."""
    unreported: int = 0
    """Periods in which an obstacle within D_act of the robot's surface was
    not reported (a world's slot sensor, :class:`mstc.plant.sensor.SlotSensor`)."""


def fault_counts(masks: Iterable[int]) -> dict[Fault, int]:
    """Steps that reported each fault bit, from each step's fault bits."""
    faults: dict[Fault, int] = {}
    for mask in masks:
        for bit in Fault:
            if mask & bit.value:
                faults[bit] = faults.get(bit, 0) + 1
    return faults


def distances(
    values: np.ndarray, obstacles: tuple[Obstacle, ...], moving: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    """Centre distance from the robot to each obstacle at each step, and the
    obstacles' track when any moves."""
    t = values[:, 0]
    x, y = values[:, 1], values[:, 2]
    n = len(obstacles)
    distance = np.empty((len(t), n))
    track = np.empty((len(t), n, 2)) if moving else None
    for i, o in enumerate(obstacles):
        ox = o.x + o.vx * t if o.vx else np.full_like(t, o.x)
        oy = o.y + o.vy * t if o.vy else np.full_like(t, o.y)
        # math.hypot, as Obstacle.distance: the same bits as a step-by-step loop.
        distance[:, i] = list(map(math.hypot, (ox - x).tolist(), (oy - y).tolist()))
        if track is not None:
            track[:, i, 0], track[:, i, 1] = ox, oy
    return distance, track
