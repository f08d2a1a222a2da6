# SPDX-License-Identifier: MIT
"""The closed loop: plant, reference and sensor around a controller."""

from dataclasses import dataclass

import numpy as np

from mstc.controller import Controller, Event, Fault, Mode
from mstc.sim.plant import UnicyclePlant
from mstc.sim.reference import ReferenceRobot
from mstc.sim.scenario import Scenario
from mstc.sim.sensor import Obstacle, RangeSensor
from mstc.sim.timing import Timing

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
    """(N+1, number of obstacles): centre distance to each obstacle [m]."""

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
    timing: Timing | None = None
    """A real-time run's timing (:mod:`mstc.sim.realtime`, timing.json);
    None in lock-step, where the plant's time is the firmware's."""


def world_obstacles(scenario: Scenario) -> tuple[Obstacle, ...]:
    """The scenario's obstacles, numbered from 1 in file order."""
    return tuple(Obstacle(i, o.x, o.y, o.radius) for i, o in enumerate(scenario.obstacles, start=1))


@dataclass(frozen=True)
class World:
    """What a run moves and senses, whatever its clock (lock-step here, the
    wall clock in :mod:`mstc.sim.realtime`)."""

    plant: UnicyclePlant
    reference: ReferenceRobot
    obstacles: tuple[Obstacle, ...]
    sensor: RangeSensor


def make_world(scenario: Scenario) -> World:
    """The robot, the reference, the obstacles and the sensor at t = 0."""
    p = scenario.params
    sim = scenario.sim
    plant = UnicyclePlant(scenario.robot, p.wheel_radius, p.track_width, sim.integrator)
    ref = ReferenceRobot(
        scenario.reference.pose, scenario.reference.v, scenario.reference.w, sim.integrator
    )
    obstacles = world_obstacles(scenario)
    return World(plant, ref, obstacles, RangeSensor(obstacles, p.d_det))


def simulate(scenario: Scenario, controller: Controller) -> RunResult:
    """Run a scenario in closed loop.

    For k = 0..N (N = round(duration/dt)), at t = k·dt: the sensor scans from
    the robot's pose at the start of the period; the controller steps on that
    pose, the reference pose and the scan; the row is recorded; then robot
    and reference are integrated over dt with the wheel speeds held. The run
    ends with the row of step N, so the trace spans t = 0 to the duration and
    the minimum distances include the final state.

    :param scenario: the scenario.
    :param controller: a freshly initialised controller for its parameters.

    :returns: The trace, the events and the minimum distance to each obstacle.
    """
    sim = scenario.sim
    world = make_world(scenario)
    plant, ref, obstacles, sensor = world.plant, world.reference, world.obstacles, world.sensor
    v_r, w_r = ref.v, ref.w

    rows: list[tuple[float, ...]] = []
    modes: list[Mode] = []
    distances: list[list[float]] = []
    events: list[Event] = []
    faults: dict[Fault, int] = {}
    for k in range(sim.steps + 1):
        t_us = k * sim.dt_us
        robot, reference = plant.pose, ref.pose
        result = controller.step(robot, reference, v_r, w_r, sensor.scan(robot), t_us)
        v, w = plant.body_velocity(result.wheel_left, result.wheel_right)
        s = result.status
        rows.append((t_us / 1e6, *robot, *reference, v, w, v_r, w_r, s.e1, s.e2, s.e3, s.e))
        modes.append(s.mode)
        distances.append([o.distance(robot) for o in obstacles])
        events.extend(result.events)
        for bit in Fault:
            if s.faults & bit:
                faults[bit] = faults.get(bit, 0) + 1
        if k < sim.steps:
            plant.step(result.wheel_left, result.wheel_right, sim.dt)
            ref.step(sim.dt)

    distance = np.array(distances, dtype=float).reshape(len(rows), len(obstacles))
    return RunResult(
        scenario=scenario,
        trace=Trace(np.array(rows, dtype=float), tuple(modes), distance),
        events=tuple(events),
        min_distance=tuple(float(d) for d in distance.min(axis=0)) if len(obstacles) else (),
        faults=faults,
    )
