# SPDX-License-Identifier: MIT
"""BARN runs: each world as a scenario of the benchmark's Jackal, run with a
strategy, a reference, a speed and an actuator profile, judged as the
benchmark judges it (docs/barn.md).

A run is a :class:`Run`; a :class:`Task` is some of them, in plan order, with
the worlds they need (small: a world is some 300 pairs of numbers), which
:func:`mstc.sweep.jobs.run_tasks` sends to a worker, local or on Dask;
:class:`BarnWork` runs a task there and gives back its rows of runs.csv. The
firmware's strategies ("paper", "mstc") of a task run together on the batched
engine (:func:`mstc.loop.batched.simulate_batch`), "dwa" run by run through
the lock-step loop with the project's DWA (:mod:`mstc.sweep.dwa`), as
``mstc sweep`` runs them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mstc.barn.worlds import TIME_LIMIT, World, score
from mstc.can.protocol import wire_limits
from mstc.firmware.sil import SilBatch
from mstc.loop.batched import BatchStep, simulate_batch
from mstc.loop.lockstep import simulate
from mstc.loop.result import RunResult
from mstc.model import Strategy
from mstc.plant.scenario import Scenario, parse_scenario
from mstc.sweep.engine import controller_for, one_line, worker_library

STRATEGIES = ("paper", "mstc", "dwa")
"""What --strategy takes: the firmware's two strategies and the project's DWA."""
FIRMWARE = ("paper", "mstc")
"""The strategies the batched engine runs."""
REFERENCES = ("line", "path")
"""What --reference takes: the straight line from start to goal (no map), or
the start, the world's A* path and the goal."""
IDEAL = "ideal"
"""The actuator profile without an [actuator] table: ideal wheels."""
DT = 0.02
"""The control period [s]."""

JACKAL = {
    "R_m": 0.27,
    "wheel_radius": 0.098,
    "track_width": 0.376,
}
"""The benchmark's robot, a Clearpath Jackal: the circle round its 0.42 ×
0.33 m footprint [m], its wheels' radius and its track (docs/barn.md)."""
DISTANCES = {"D_s": 0.35, "D_act": 0.5, "D_det": 1.5}
"""Safety, activation and detection distances [m] (docs/barn.md)."""

COLUMNS = (
    "world",
    "strategy",
    "reference",
    "speed",
    "actuator",
    "status",
    "time",
    "score",
    "clearance",
    "unreported",
    "error",
)
"""Columns of runs.csv, in order (docs/barn.md)."""
STATUSES = ("success", "collision", "timeout")
"""A run's status; "error" when it could not run (its error column says why)."""


@dataclass(frozen=True)
class Run:
    """One run of a plan: a world (its position in its task's worlds), a
    strategy, a reference, a speed [m/s] and an actuator profile."""

    world: int
    strategy: str
    reference: str
    speed: float
    actuator: str


@dataclass(frozen=True)
class Task:
    """Runs ``first``, ``first + 1``, … of a plan, with the worlds they name."""

    first: int
    runs: tuple[Run, ...]
    worlds: tuple[World, ...]


def scenario_doc(
    world: World,
    strategy: str,
    reference: str,
    speed: float,
    actuator: Mapping[str, float | int],
) -> dict[str, object]:
    """The scenario document of a run (docs/scenarios.md): the world's
    cylinders inline, its start, the reference's way points at @p speed
    waiting for the robot and ending at the goal radius, 100 s at 50 Hz,
    the Jackal, and the actuator profile's [actuator] table (none: ideal)."""
    params: dict[str, object] = {**JACKAL, "R_ob": world.cylinder_radius, **DISTANCES}
    if strategy in FIRMWARE:
        params["strategy"] = strategy
    doc: dict[str, object] = {
        "robot": {"pose": list(world.start)},
        "reference": {
            "path": world.polyline(reference),
            "speed": speed,
            "goal_radius": world.goal_radius,
        },
        "world": {"obstacles": [list(c) for c in world.cylinders], "radius": world.cylinder_radius},
        "sim": {"duration": TIME_LIMIT, "dt": DT, "integrator": "euler"},
        "params": params,
    }
    if actuator:
        doc["actuator"] = dict(actuator)
    return doc


def scenario_of(
    world: World, run: Run, profiles: Mapping[str, Mapping[str, float | int]]
) -> Scenario:
    """The parsed scenario of @p run in @p world."""
    doc = scenario_doc(world, run.strategy, run.reference, run.speed, profiles[run.actuator])
    name = f"world-{world.index}-{run.strategy}-{run.reference}-{run.speed:g}-{run.actuator}"
    return parse_scenario(doc, name, wire_limits())


def judge(
    world: World, reached: bool, touched: bool, last: int, nearest: float, unreported: int
) -> dict[str, str]:
    """The judged columns of a run that ended at step @p last: reached the
    goal, touched, or ran out of time; its time (the step's), the score, the
    smallest clearance between the robot's circle and a cylinder (@p nearest:
    the smallest centre distance; the cylinders' true radius, not the one
    OBSTACLE carries) and the unreported periods."""
    status = "success" if reached else "collision" if touched else "timeout"
    time = last * DT
    clearance = nearest - JACKAL["R_m"] - world.cylinder_radius
    return {
        "status": status,
        "time": f"{time:.2f}",
        "score": f"{score(reached, time, world.optimal_time):.6f}",
        "clearance": f"{clearance:.4f}",
        "unreported": str(unreported),
        "error": "",
    }


def new_row(world: World, run: Run) -> dict[str, str]:
    """A row of runs.csv for @p run, nothing judged yet."""
    row = dict.fromkeys(COLUMNS, "")
    row.update(
        world=str(world.index),
        strategy=run.strategy,
        reference=run.reference,
        speed=f"{run.speed:g}",
        actuator=run.actuator,
    )
    return row


def judge_result(world: World, result: RunResult) -> dict[str, str]:
    """The judged columns of a lock-step run (``stop_on_contact``): it ended
    within the goal radius, or early on contact, or at the time limit."""
    trace = result.trace
    last = len(trace.values) - 1
    x, y = float(trace["x"][-1]), float(trace["y"][-1])
    reached = math.hypot(x - world.goal[0], y - world.goal[1]) <= world.goal_radius
    touched = not reached and last < result.scenario.sim.steps
    nearest = min(result.min_distance) if result.min_distance else math.inf
    return judge(world, reached, touched, last, nearest, result.unreported)


@dataclass(frozen=True)
class Track:
    """A run again, for its figure: the robot's path and how it ended."""

    x: np.ndarray
    """The robot's position at each step [m]."""
    y: np.ndarray
    status: str


def tracks(
    picked: Sequence[tuple[World, Run]],
    profiles: Mapping[str, Mapping[str, float | int]],
    lib: str,
) -> list[Track]:
    """@p picked run again in this process with their paths kept: the
    firmware's together on the batched engine, as they ran, the DWA's
    through the lock-step loop."""
    out: dict[int, Track] = {}
    batch: list[tuple[int, Scenario]] = []
    for i, (world, run) in enumerate(picked):
        scenario = scenario_of(world, run, profiles)
        if run.strategy in FIRMWARE:
            params = dataclasses.replace(scenario.params, strategy=Strategy(run.strategy))
            batch.append((i, dataclasses.replace(scenario, params=params)))
            continue
        result = run_one(world, run, scenario, lib)
        status = judge_result(world, result)["status"]
        out[i] = Track(result.trace["x"].copy(), result.trace["y"].copy(), status)
    if batch:
        xs: list[np.ndarray] = []
        ys: list[np.ndarray] = []
        done: list[np.ndarray] = []

        def keep(step: BatchStep) -> None:
            xs.append(step.x.copy())
            ys.append(step.y.copy())
            done.append(step.active.copy())

        controller = SilBatch([s.params for _, s in batch], lib)
        runs = simulate_batch([s for _, s in batch], controller, keep, stop_on_contact=True)
        x, y = np.array(xs), np.array(ys)
        for j, ((i, _), ran) in enumerate(zip(batch, runs, strict=True)):
            world = picked[i][0]
            nearest = min(ran.min_distance) if ran.min_distance else math.inf
            judged = judge(world, ran.reached, ran.touched, ran.last, nearest, ran.unreported)
            out[i] = Track(x[: ran.last + 1, j], y[: ran.last + 1, j], judged["status"])
    return [out[i] for i in range(len(picked))]


def run_one(world: World, run: Run, scenario: Scenario, lib: str) -> RunResult:
    """@p run alone through the lock-step loop (its controller: the DWA, or
    the firmware's control step in memory), ending at the goal or on contact."""
    scenario, controller = controller_for(scenario, run.strategy, lib)
    return simulate(scenario, controller, stop_on_contact=True)


@dataclass(frozen=True)
class BarnWork:
    """Runs a :class:`Task` on a worker (:class:`mstc.sweep.jobs.Work`)."""

    lib: str
    """The firmware library (a worker's own :data:`~mstc.can.library.LIB_ENV`
    where the path does not exist there)."""
    profiles: Mapping[str, Mapping[str, float | int]]
    """Each actuator profile's [actuator] table (ideal: empty)."""

    def __call__(self, task: Task) -> list[list[str]]:
        rows = [new_row(task.worlds[r.world], r) for r in task.runs]
        batch: list[tuple[int, Scenario]] = []
        lib = ""
        try:
            if any(r.strategy in FIRMWARE for r in task.runs):
                lib = worker_library(self.lib)
        except Exception as exc:  # the library missing: every firmware row says so
            failure = one_line(exc)
        else:
            failure = ""
        for i, run in enumerate(task.runs):
            world = task.worlds[run.world]
            try:
                if run.strategy in FIRMWARE and failure:
                    raise RuntimeError(failure)
                scenario = scenario_of(world, run, self.profiles)
                if run.strategy in FIRMWARE:
                    params = dataclasses.replace(scenario.params, strategy=Strategy(run.strategy))
                    batch.append((i, dataclasses.replace(scenario, params=params)))
                    continue
                rows[i].update(judge_result(world, run_one(world, run, scenario, lib)))
            except Exception as exc:  # a run's failure is its row, not the task's end
                rows[i].update(status="error", error=one_line(exc))
        if batch:
            self._batched(task, batch, rows, lib)
        return [[row[c] for c in COLUMNS] for row in rows]

    def _batched(
        self,
        task: Task,
        batch: Sequence[tuple[int, Scenario]],
        rows: list[dict[str, str]],
        lib: str,
    ) -> None:
        """The firmware's runs of @p task together on the batched engine."""
        try:
            controller = SilBatch([s.params for _, s in batch], lib)
            runs = simulate_batch([s for _, s in batch], controller, stop_on_contact=True)
        except Exception as exc:  # the batch's failure is each of its rows
            for i, _ in batch:
                rows[i].update(status="error", error=one_line(exc))
            return
        for (i, _), run in zip(batch, runs, strict=True):
            world = task.worlds[task.runs[i].world]
            if run.error is not None:
                rows[i].update(status="error", error=f"SimulationError: {run.error}")
                continue
            nearest = min(run.min_distance) if run.min_distance else math.inf
            rows[i].update(
                judge(world, run.reached, run.touched, run.last, nearest, run.unreported)
            )

    def split(self, task: Task) -> list[Task]:
        """Halves of @p task; [] when it is one run."""
        if len(task.runs) < 2:
            return []
        half = len(task.runs) // 2
        return [
            Task(task.first, task.runs[:half], task.worlds),
            Task(task.first + half, task.runs[half:], task.worlds),
        ]

    def crashed(self, task: Task, why: str) -> list[list[str]]:
        """The row of a one-run task that kills its worker."""
        run = task.runs[0]
        row = new_row(task.worlds[run.world], run)
        row.update(status="error", error=why)
        return [[row[c] for c in COLUMNS]]


def plan(
    worlds: Sequence[World],
    strategies: Sequence[str],
    references: Sequence[str],
    speeds: Sequence[float],
    actuators: Sequence[str],
) -> list[tuple[World, Run]]:
    """Every run, in runs.csv's order: strategy, reference, speed, actuator,
    then world (a configuration's worlds together)."""
    runs = []
    for strategy in strategies:
        for reference in references:
            for speed in speeds:
                for actuator in actuators:
                    for world in worlds:
                        runs.append((world, Run(0, strategy, reference, speed, actuator)))
    return runs


BATCH = 600
"""Most runs of the firmware's strategies in one task: a batch of the batched
engine. A batch steps until its longest run ends, its arrays as wide as the
batch whatever has ended (a BARN batch of 300 under "mstc" spent 71 % of its
CPU time in steps with fewer than 100 runs going, 3.6 ms a step against 6.0
with all 300), so smaller batches cost no more: paper and mstc, both
references, 300 worlds took 85.6 s of CPU in batches of 300 and 86.5 s in
batches of 75, with the same rows; smaller ones share the workers better."""
PER_WORKER = 8
"""Tasks of the firmware's runs a worker gets at least (while :data:`BATCH`
and :data:`LEAST` allow)."""
LEAST = 32
"""Fewest runs of a task of the firmware's, while every worker still gets
one: a step costs about 1 ms whatever the batch's width, so a batch of a few
runs costs nearly as much as one of 32."""
DWA_BATCH = 4
"""Runs of "dwa" in one task (each runs alone, in Python)."""


def tasks(
    planned: Sequence[tuple[World, Run]], workers: int, per_worker: int = PER_WORKER
) -> list[Task]:
    """@p planned cut into tasks: the firmware's runs in batches that give
    every worker @p per_worker at least (at most :data:`BATCH` runs), the DWA's in
    tasks of :data:`DWA_BATCH`; each task carries the worlds it names."""
    firmware = sum(1 for _, r in planned if r.strategy in FIRMWARE)
    size = max(1, min(BATCH, math.ceil(firmware / max(1, per_worker * workers))))
    size = max(size, min(LEAST, math.ceil(firmware / max(1, workers))))
    out: list[Task] = []
    start = 0
    while start < len(planned):
        limit = size if planned[start][1].strategy in FIRMWARE else DWA_BATCH
        stop = start
        while (
            stop < len(planned)
            and stop - start < limit
            and (planned[stop][1].strategy in FIRMWARE) == (planned[start][1].strategy in FIRMWARE)
        ):
            stop += 1
        worlds: dict[int, int] = {}
        runs = []
        for world, run in planned[start:stop]:
            position = worlds.setdefault(world.index, len(worlds))
            runs.append(dataclasses.replace(run, world=position))
        by_index = {w.index: w for w, _ in planned[start:stop]}
        out.append(Task(start, tuple(runs), tuple(by_index[i] for i in worlds)))
        start = stop
    return out
