# SPDX-License-Identifier: MIT
"""The lock-step loop over many scenes at once: :func:`simulate_batch`.

The loop of :func:`mstc.loop.lockstep.simulate`, run for N scenes together:
the worlds as arrays (:class:`mstc.plant.batch.BatchWorld`), the firmware's
controllers stepped in one call (a :class:`BatchController`: the firmware's
is :class:`mstc.firmware.sil.SilBatch`). At each
step k every scene that has not ended (k ≤ its N) does what the per-scene
loop does, in the same order: the sensor scans from the robot's true pose at
the start of the period, the controller steps on the odometry's pose, the
reference and the scan, then robot and reference are integrated over the
period (by their "lag" wheels in substeps where a scene has them, whose
measured speeds go to the next step's ``in.wheel_speed``, as the per-scene
loop's ``wheel_speeds``). Scenes of different lengths end independently
(masked); the batch ends with its longest scene.

Nothing is kept per step: an observer (``watch``) sees each step's arrays
(:class:`BatchStep`) as the run goes and keeps what it needs (the sweep's
metrics, :class:`mstc.sweep.metrics.RunningMetrics`); the loop itself keeps
each scene's events and its smallest distance to each obstacle, which its
events.json holds. Memory is O(N × obstacles), whatever the lengths.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from mstc.model import Event, Mode
from mstc.plant.batch import BatchWorld, Within, exact_hypot, wrap
from mstc.plant.scenario import Scenario


class BatchController(Protocol):
    """N controllers stepped in one call (:class:`mstc.firmware.sil.SilBatch`),
    on structured arrays laid out as ``mstc_sil_batch_input_t`` and
    ``mstc_sil_output_t`` (hal/sil/mstc_sil.h)."""

    n: int
    """Controllers, inputs and outputs."""
    inputs: np.ndarray[Any, Any]
    """The inputs of the next step, one per controller (the caller fills them)."""
    outputs: np.ndarray[Any, Any]
    """The outputs of the last step."""
    modes: dict[int, Mode]
    """Mode by the output's number."""

    def step(self, active: np.ndarray | None = None) -> None:
        """One control step of every controller (of those where @p active)."""
        ...

    def events(self, rows: Sequence[int]) -> list[tuple[Event, ...]]:
        """The events each controller of @p rows emitted in the last step."""
        ...


@dataclass(frozen=True)
class BatchStep:
    """One step of a batch, as its observer sees it (arrays over the scenes;
    rows of scenes that have ended hold stale values: mask with :attr:`active`)."""

    k: int
    """The step: t = k·dt of each scene."""
    t: np.ndarray
    """[s], t_us / 1e6 as the per-scene trace has it."""
    active: np.ndarray
    """The scenes that run this step (k ≤ their N)."""
    x: np.ndarray
    """The robot's true pose at the start of the period [m]."""
    y: np.ndarray
    x_r: np.ndarray
    """The reference's pose [m]."""
    y_r: np.ndarray
    distance2: np.ndarray
    """(N, width): squared centre distance to each obstacle [m²],
    ``dx·dx + dy·dy`` (decide against a threshold with
    :class:`mstc.plant.batch.Within`, which takes ``math.hypot`` where the
    per-scene code's decision could differ); infinite for the padding."""
    dx: np.ndarray
    dy: np.ndarray
    mode: np.ndarray
    """The firmware's mode number of this step."""
    w: np.ndarray
    """Commanded body ω of this step [rad/s] (the trace's ``w``)."""
    events: Sequence[tuple[int, tuple[Event, ...]]]
    """(scene, its events) for the scenes that emitted some this step."""


Watch = Callable[[BatchStep], None]


@dataclass(frozen=True)
class BatchRun:
    """What a batched run leaves of one scene."""

    scenario: Scenario
    events: tuple[Event, ...]
    min_distance: tuple[float, ...]
    """Smallest centre distance to each obstacle over the run [m]."""
    error: str | None
    """Why the run failed, None if it did not: the text of the
    :class:`~mstc.errors.SimulationError` the per-scene loop raises when the
    plant's state becomes non-finite."""
    step_time: float
    """Mean time of the batched firmware call per scene-step [s] (a measurement)."""
    last: int = -1
    """The scene's last step (its N, or where it ended early)."""
    reached: bool = False
    """It ended within its goal radius."""
    touched: bool = False
    """It ended on contact (``stop_on_contact``)."""
    unreported: int = 0
    """Periods with an obstacle within D_act of the robot's surface not
    reported (worlds' slot sensor)."""


def simulate_batch(
    scenarios: Sequence[Scenario],
    controller: BatchController,
    watch: Watch | None = None,
    *,
    stop_on_contact: bool = False,
) -> list[BatchRun]:
    """Run every scenario in closed loop with its controller of @p controller
    (one per scenario, in order), as :func:`mstc.loop.lockstep.simulate`
    runs one.

    :param watch: called after each step's controller step, before the plant
        moves.
    :param stop_on_contact: a scene ends at the first step at which the
        robot's centre is within R_m + r of an obstacle's (as
        :func:`~mstc.loop.lockstep.simulate` with the same flag).
    """
    world = BatchWorld(scenarios)
    n, width = world.n, world.width
    slots = world.slot_sensor
    end = world.steps.copy()
    """The last step of each scene: its N, or where it reached its goal or
    touched (the step whose row is its last)."""
    ended = np.zeros(n, dtype=bool)
    touch = Within(world.r_m[:, None] + world.radius)
    reached = np.zeros(n, dtype=bool)
    touched = np.zeros(n, dtype=bool)
    if controller.n != n:
        raise ValueError(f"{controller.n} controllers for {n} scenes")
    inputs = controller.inputs
    given = inputs["in"]
    robot, ref = given["robot"], given["ref"]
    t_us_in = given["t_us"]
    given["v_r"], given["w_r"] = world.v_r, world.w_r
    given["n_obstacles"] = width if slots is not None else world.count
    table = inputs["table"][:, :width]
    if slots is not None:  # slot ids 1..width, filled as the sensor reports
        table["id"] = np.arange(1, width + 1, dtype=np.uint32)
        table["vx"], table["vy"] = 0.0, 0.0
    else:
        table["id"] = world.obstacle_id
        table["radius"] = world.radius
        table["vx"], table["vy"] = world.vx, world.vy
        table["x"], table["y"] = world.ox0, world.oy0
    table_moves = world.moving is not None or world.noisy or slots is not None
    reported = inputs["reported"][:, :width]
    outputs = controller.outputs
    out_left, out_right = outputs["wheel_left"], outputs["wheel_right"]
    out_mode, out_events = outputs["mode"], outputs["n_events"]
    wheels = world.actuator
    speeds = given["wheel_speed"]
    if wheels is not None:  # their drivers report speeds from the first step on (0 at t = 0)
        given["wheel_measured"][wheels.rows] = 1
        speeds[wheels.rows] = 0.0
    straight = world.paths is None and not world.w_r.any()
    if straight:  # the references' headings never change
        ref[:, 2] = wrap(world.theta_r)

    events: list[list[Event]] = [[] for _ in range(n)]
    m = world.world_width
    nearest = np.full((n, m), np.inf)
    near_dx = np.zeros((n, m))
    near_dy = np.zeros((n, m))
    closer = np.empty((n, m), dtype=bool)
    bad_at = np.full(n, -1, dtype=np.int64)
    last = int(world.steps.max(initial=0))
    uniform = bool((world.steps == last).all())
    everyone = np.ones(n, dtype=bool)
    spent, scene_steps = 0, 0
    clock = time.perf_counter_ns
    for k in range(last + 1):
        if ended.any():
            uniform = False
        active = everyone if uniform else k <= end
        if not active.any():
            break
        t_us = k * world.dt_us
        t = t_us / 1e6
        x, y = world.x, world.y
        ox, oy = world.obstacles_at(t)
        dx = ox - x[:, None]
        dy = oy - y[:, None]
        d2 = dx * dx + dy * dy
        if slots is not None:
            slots.scan(np.hypot(dx, dy), active)
            seen, rx, ry, table["radius"] = slots.table(ox, oy)
        else:
            seen, rx, ry = world.scan(k, d2, dx, dy, ox, oy)
        mx, my, mth = world.measured(k)
        robot[:, 0], robot[:, 1], robot[:, 2] = mx, my, wrap(mth)
        world.references(k, mx, my)
        if world.paths is not None:
            given["v_r"], given["w_r"] = world.v_r, world.w_r
        ref[:, 0], ref[:, 1] = world.x_r, world.y_r
        if not straight:
            ref[:, 2] = wrap(world.theta_r)
        t_us_in[:] = t_us
        reported[...] = seen
        if table_moves:
            table["x"], table["y"] = rx, ry
        start = clock()
        controller.step(None if uniform else active)
        spent += clock() - start
        scene_steps += n if uniform else int(active.sum())

        rows = np.flatnonzero(out_events if uniform else out_events * active).tolist()
        emitted = list(zip(rows, controller.events(rows), strict=True))
        for i, got in emitted:
            events[i].extend(got)
        np.less(d2, nearest, out=closer)
        if not uniform:
            closer &= active[:, None]
        np.copyto(nearest, d2, where=closer)
        np.copyto(near_dx, dx, where=closer)
        np.copyto(near_dy, dy, where=closer)
        finite = np.isfinite(x + y + world.theta)
        if not finite.all():
            bad_at = np.where((bad_at < 0) & ~finite & active, k, bad_at)
        left, right = out_left.copy(), out_right.copy()
        v, w = world.body_velocity(left, right)
        if watch is not None:
            watch(
                BatchStep(
                    k, t, active, x, y, world.x_r, world.y_r, d2, dx, dy, out_mode, w, emitted
                )
            )
        # A scene that reached its goal, or touched when told to stop there,
        # ends with this step's row.
        live = active & ~ended
        home = np.zeros(n, dtype=bool)
        goals = np.flatnonzero(live & np.isfinite(world.goal))
        if len(goals):
            gd = exact_hypot(x[goals] - world.goal_x[goals], y[goals] - world.goal_y[goals])
            home[goals] = gd <= world.goal[goals]
        stop = home.copy()
        if stop_on_contact:
            hit = touch.rows(d2, dx, dy) & live
            touched |= hit & ~home
            stop |= hit
        if stop.any():
            end = np.where(stop, k, end)
            ended |= stop
            reached |= home
        if k < last:
            world.advance(k, left, right, v, w)
            if wheels is not None:
                speeds[wheels.rows] = wheels.measured.T

    step_time = spent / 1e9 / max(1, scene_steps)
    runs = []
    for i, scenario in enumerate(world.scenarios):
        m = int(world.count[i])
        exact = exact_hypot(near_dx[i, :m], near_dy[i, :m]) if m else np.zeros(0)
        error = None
        if bad_at[i] >= 0:
            at = int(bad_at[i]) * int(world.dt_us[i]) / 1e6
            error = f"{scenario.path}: the plant's state became non-finite at t = {at:g} s"
        runs.append(
            BatchRun(
                scenario,
                tuple(events[i]),
                tuple(exact.tolist()),
                error,
                step_time,
                int(end[i]),
                bool(reached[i]),
                bool(touched[i]),
                int(slots.unreported[i]) if slots is not None else 0,
            )
        )
    return runs
