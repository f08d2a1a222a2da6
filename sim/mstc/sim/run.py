# SPDX-License-Identifier: MIT
"""The closed loop: plant, reference and sensor around a controller."""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mstc.controller import Controller, Event, Fault, Mode
from mstc.errors import SimulationError
from mstc.sim.actuator import Actuator
from mstc.sim.plant import Pose, UnicyclePlant
from mstc.sim.reference import ReferenceRobot
from mstc.sim.scenario import Scenario
from mstc.sim.sensor import Obstacle, RangeSensor
from mstc.sim.timing import Timing

if TYPE_CHECKING:
    from mstc.report.progress import Progress

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
    """A real-time run's timing (:mod:`mstc.sim.realtime`, timing.json);
    None in lock-step, where the plant's time is the firmware's."""


StepValues = tuple[float, float, Mode, int, float, float, float, float, tuple[Event, ...]]
"""What the loop records of one step: the wheel speeds (left, right), the
mode, the fault bits, e1, e2, e3, e and the events."""
StepFunction = Callable[
    [Pose, Pose, float, float, Sequence[Obstacle], int, tuple[float, float] | None], StepValues
]


def step_values(controller: Controller) -> StepFunction:
    """@p controller's step, its result as :data:`StepValues`: the
    controller's own ``step_values`` when it has one (the firmware's, which
    skips building the Status and StepResult objects), else its ``step``
    with the values read from the result."""
    own: StepFunction | None = getattr(controller, "step_values", None)
    if own is not None:
        return own
    step = controller.step

    def values(
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        seen: Sequence[Obstacle],
        t_us: int,
        wheel_speeds: tuple[float, float] | None,
    ) -> StepValues:
        result = step(robot, ref, v_r, w_r, seen, t_us, wheel_speeds)
        s = result.status
        left, right = result.wheel_left, result.wheel_right
        return left, right, s.mode, int(s.faults), s.e1, s.e2, s.e3, s.e, result.events

    return values


def world_obstacles(scenario: Scenario) -> tuple[Obstacle, ...]:
    """The scenario's obstacles at t = 0, numbered from 1 in file order."""
    return tuple(
        Obstacle(i, o.x, o.y, o.radius, o.vx, o.vy)
        for i, o in enumerate(scenario.obstacles, start=1)
    )


def _streams(seed: int) -> tuple[np.random.Generator, np.random.Generator]:
    """Independent random streams of a scene (odometry, sensor), so that one
    imperfection's draws do not move when another is switched on."""
    odometry, sensor = np.random.SeedSequence(seed).spawn(2)
    return np.random.Generator(np.random.PCG64(odometry)), np.random.Generator(
        np.random.PCG64(sensor)
    )


def _fault_counts(masks: list[int]) -> dict[Fault, int]:
    faults: dict[Fault, int] = {}
    for mask in masks:
        for bit in Fault:
            if mask & bit.value:
                faults[bit] = faults.get(bit, 0) + 1
    return faults


@dataclass(frozen=True)
class World:
    """What a run moves and senses, whatever its clock (lock-step here, the
    wall clock in :mod:`mstc.sim.realtime`)."""

    plant: UnicyclePlant
    reference: ReferenceRobot
    obstacles: tuple[Obstacle, ...]
    sensor: RangeSensor
    odometry_rng: np.random.Generator
    """The stream of the odometry noise (the sensor has its own)."""
    actuator: Actuator | None = None
    """The wheels that move the plant (docs/scenarios.md, ``[actuator]``);
    None: ideal wheels, the commanded speeds held over each period."""


def make_world(scenario: Scenario) -> World:
    """The robot, the reference, the obstacles and the sensor at t = 0, with
    the scenario's imperfections (docs/scenarios.md)."""
    p = scenario.params
    sim = scenario.sim
    imp = scenario.imperfections
    plant = UnicyclePlant(scenario.robot, p.wheel_radius, p.track_width, sim.integrator)
    ref = ReferenceRobot(
        scenario.reference.pose, scenario.reference.v, scenario.reference.w, sim.integrator
    )
    obstacles = world_obstacles(scenario)
    odometry_rng, sensor_rng = _streams(imp.seed)
    sensor = RangeSensor(
        obstacles,
        p.d_det if imp.sensor_range is None else imp.sensor_range,
        noise=imp.obstacle_noise,
        dropout=imp.dropout,
        rng=sensor_rng if (imp.obstacle_noise or imp.dropout) else None,
    )
    actuator = None
    if scenario.actuator is not None:
        actuator = Actuator(scenario.actuator, plant, sim.dt, imp.delay + scenario.actuator.delay)
    return World(plant, ref, obstacles, sensor, odometry_rng, actuator)


def simulate(
    scenario: Scenario, controller: Controller, progress: Progress | None = None
) -> RunResult:
    """Run a scenario in closed loop.

    For k = 0..N (N = round(duration/dt)), at t = k·dt: the sensor scans from
    the robot's pose at the start of the period (obstacles where they are at
    t); the controller steps on that pose (with odometry noise, when the
    scenario has some), the reference pose and the scan; the row is
    recorded; then robot and reference are integrated over dt, the robot with
    the wheel speeds commanded ``delay`` periods earlier (standing still
    before the first), or, with an ``[actuator]``, by its wheels in
    substeps (:mod:`mstc.sim.actuator`), whose measured speeds the next step
    gets. The run ends with the row of step N, so the trace spans t = 0 to
    the duration and the minimum distances include the final state.

    The trace is written into an array of the run's size, taken once: a run of
    N steps holds about (15 + obstacles) × 8 bytes per step, whatever the
    controller (the scenario loader bounds N, :data:`~mstc.sim.scenario.MAX_STEPS`).

    :param scenario: the scenario.
    :param controller: a freshly initialised controller for its parameters.
    :param progress: told how many steps are done, now and then, and closed
        when the run ends.

    :returns: The trace, the events and the minimum distance to each obstacle.

    :raises SimulationError: the plant's state became non-finite.
    """
    sim = scenario.sim
    imp = scenario.imperfections
    world = make_world(scenario)
    plant, ref, obstacles, sensor = world.plant, world.reference, world.obstacles, world.sensor
    odometry_rng = world.odometry_rng
    moving = any(o.moving for o in obstacles)
    v_r, w_r = ref.v, ref.w
    steps = sim.steps
    odometry_noise = None
    if imp.position_noise or imp.heading_noise:
        sigma = np.array([imp.position_noise, imp.position_noise, imp.heading_noise])
        odometry_noise = (odometry_rng.standard_normal((steps + 1, 3)) * sigma).tolist()
    actuator = world.actuator
    pending: deque[tuple[float, float]] = deque([(0.0, 0.0)] * imp.delay)
    measured_wheels: tuple[float, float] | None = None if actuator is None else (0.0, 0.0)

    values = np.empty((steps + 1, len(TRACE_COLUMNS)), dtype=float)
    modes: list[Mode] = []
    events: list[Event] = []
    fault_masks: list[int] = []
    clock = time.perf_counter_ns
    spent = 0
    step = step_values(controller)
    body_velocity = plant.body_velocity
    scan, plant_step, ref_step = sensor.scan, plant.step, ref.step
    dt, dt_us = sim.dt, sim.dt_us
    tick = max((steps + 1) // PROGRESS_UPDATES, 1)
    try:
        for k in range(steps + 1):
            t_us = k * dt_us
            t = t_us / 1e6
            robot, reference = plant.pose, ref.pose
            seen = scan(robot, t)
            measured = robot
            if odometry_noise is not None:
                nx, ny, nt = odometry_noise[k]
                measured = Pose(robot.x + nx, robot.y + ny, robot.theta + nt)
            start = clock()
            left, right, mode, faults, e1, e2, e3, e, emitted = step(
                measured, reference, v_r, w_r, seen, t_us, measured_wheels
            )
            spent += clock() - start
            v, w = body_velocity(left, right)
            values[k] = (t, *robot, *reference, v, w, v_r, w_r, e1, e2, e3, e)
            modes.append(mode)
            if emitted:
                events.extend(emitted)
            if faults:
                fault_masks.append(faults)
            if k < steps:
                if actuator is not None:
                    measured_wheels = actuator.step(left, right)
                else:
                    if pending:
                        pending.append((left, right))
                        left, right = pending.popleft()
                    plant_step(left, right, dt)
                ref_step(dt)
            if progress is not None and (k + 1) % tick == 0:
                progress.update(k + 1)
    finally:
        if progress is not None:
            progress.close()

    if not np.isfinite(values[:, 1:7]).all():
        k = int(np.argmin(np.isfinite(values[:, 1:7]).all(axis=1)))
        raise SimulationError(
            f"{scenario.path}: the plant's state became non-finite at t = {values[k, 0]:g} s"
        )
    distance, obstacle_xy = distances(values, obstacles, moving)
    return RunResult(
        scenario=scenario,
        trace=Trace(values, tuple(modes), distance, obstacle_xy),
        events=tuple(events),
        min_distance=tuple(float(d) for d in distance.min(axis=0)) if len(obstacles) else (),
        faults=_fault_counts(fault_masks),
        step_time=spent / 1e9 / (steps + 1),
    )


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
