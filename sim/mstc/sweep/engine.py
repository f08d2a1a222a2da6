# SPDX-License-Identifier: MIT
"""Running a batch of (scene, strategy) jobs in one process: a worker's part
of a sweep (:mod:`mstc.sweep.plan` cuts a sweep into slices and
:mod:`mstc.sweep.jobs` sends them to the workers).

A job is a scene and a strategy. A scene travels as a small record
(:class:`Scene`): its name and either its scenario, parsed (a suite's scenes
are made so where they run), pickled (a scenario file the client has
validated, :class:`mstc.sweep.spool.Spool`), or the text of its file: plain
data, never a controller. Every worker process loads the firmware library
itself (ctypes handles do not travel) and gives back, per job, its row of
runs.csv and the text of its events.json (:class:`Outcome`).

Two engines run the firmware's strategies. "batched" (the default) runs a
batch's scenes together: the plant steps every scene at once with numpy and
the firmware's step runs for all of them in one call
(:func:`mstc.loop.batched.simulate_batch`), the metrics computed as the run
goes (:class:`mstc.sweep.metrics.RunningMetrics`); its batches are large (up
to ``batch`` scenes) and a worker holds no trace. "scene" runs each scene
alone through :func:`mstc.loop.lockstep.simulate` and judges its trace
(:func:`mstc.sweep.metrics.evaluate`): the reference the batched engine is
compared with (docs/sweeps.md, "Engines"). Both give the same rows and
events.json, with ideal wheels and with "lag" wheels alike. The DWA baseline
always runs scene by scene, and so do scenes on "dc" wheels (the firmware's
wheel loop, which the batched plant does not model).

A scene that fails (an exception, a non-finite state) is a row with its
error, and the batch goes on.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import os
import pickle
import sys
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import get_type_hints

from mstc.can.library import LIB_ENV
from mstc.can.protocol import wire_limits
from mstc.errors import FirmwareError
from mstc.firmware.sil import SilBatch, SilController
from mstc.firmware.wheels import DcWheels, wheels_for
from mstc.loop.batched import simulate_batch
from mstc.loop.lockstep import simulate
from mstc.loop.result import RunResult
from mstc.model import Controller, Strategy
from mstc.plant.batch import table_width
from mstc.plant.scenario import DC_HANDED, Scenario, parse_scenario
from mstc.report.outputs import events_json, events_text
from mstc.sweep.dwa import DwaConfig, DwaController
from mstc.sweep.folder import text_sha256
from mstc.sweep.metrics import METRIC_COLUMNS, Metrics, RunningMetrics, evaluate
from mstc.sweep.spool import Spool

STRATEGIES = ("paper", "mstc", "dwa")
"""What --strategy takes: the firmware's two strategies, and the DWA baseline."""
ROW_COLUMNS = (
    "scene",
    "family",
    "actuator",
    "seed",
    "strategy",
    "steps",
    *METRIC_COLUMNS,
    "error",
)
"""Columns of runs.csv, in order."""
MEASURED_COLUMNS = ("step_us",)
"""Columns that are measurements, different from run to run; every other
column is the same for the same scenes, strategies and library."""
ENGINES = ("batched", "scene")
"""What --engine takes (the module's docstring)."""
BATCH = 4000
"""Most runs (scene and strategy) of one batch of the batched engine (--batch). Its cost per
scene-step falls with the batch's size, as numpy's cost per call (some 230 µs a
step of the batch, whatever its size) is spread over more scenes: on the
standard suite's families, under "mstc" with ideal wheels, 2,000 scenes a
family in batches of 1,000, 2,000 took turns and gave a median of 901,000 and
991,000 scene-steps per CPU-second; 4,000 a family in batches of 2,000 and
4,000, 985,000 and 1,077,000; in batches of 1,000 and 4,000 (another run),
821,000 and 906,000. A batch holds 10 kB a scene (23 kB with noise: its draws
are made 128 steps at a time), 39 to 91 MiB at 4,000."""


@dataclass(frozen=True, slots=True)
class Scene:
    """A scene as it travels to a worker: its name and its file's text, or
    the file parsed (:attr:`scenario`, or :attr:`pickled` on the wire).

    ``mstc sweep`` holds each scene as a small record (no text, nothing
    parsed: :meth:`from_scenario`) whose parsed scenario waits in its
    :class:`mstc.sweep.spool.Spool` until its batch is sent."""

    name: str
    """File stem: names DIR/<strategy>/<scene>/."""
    source: str
    """The file, as the user named it (error messages)."""
    text: str
    """The file's text ("" when the scene comes parsed)."""
    family: str = ""
    seed: int | None = None
    actuator: str = ""
    """The suite's actuator profile ("" when the file names none)."""
    scenario: Scenario | None = None
    """The file parsed, when the client has parsed it already (``mstc sweep``
    validates every scene before it runs any): the worker then takes it
    rather than parsing the text again."""
    pickled: bytes | None = None
    """The parsed scenario pickled, as the client's spool holds it: what a
    batch carries instead of :attr:`scenario` (the worker unpickles it)."""
    sha256: str = ""
    """sha256 of the file's text (sources.json, ``--resume``); "": that of
    :attr:`text`."""

    @classmethod
    def from_file(cls, path: Path) -> Scene:
        """Read a scenario file (validated later, by the worker)."""
        text = path.read_text(encoding="utf-8")
        try:
            meta = tomllib.loads(text).get("meta", {})
        except tomllib.TOMLDecodeError:
            meta = {}
        family = meta.get("family", "") if isinstance(meta, dict) else ""
        seed = meta.get("seed") if isinstance(meta, dict) else None
        actuator = meta.get("actuator", "") if isinstance(meta, dict) else ""
        return cls(
            path.stem,
            str(path),
            text,
            family if isinstance(family, str) else "",
            seed if isinstance(seed, int) and not isinstance(seed, bool) else None,
            actuator if isinstance(actuator, str) else "",
        )

    @classmethod
    def from_scenario(cls, scenario: Scenario, sha256: str) -> Scene:
        """The record of a file already parsed into @p scenario (its name,
        family, seed and actuator profile as :meth:`from_file` reads them
        from the text, the validated ``[meta]`` being the same), the text's
        digest @p sha256 standing for the text."""
        meta = scenario.meta
        return cls(
            sys.intern(scenario.path.stem),
            str(scenario.path),
            "",
            sys.intern(meta.family),
            meta.seed,
            sys.intern(meta.actuator),
            sha256=sha256,
        )

    def parsed(self) -> Scenario:
        """The scenario: :attr:`scenario`, else :attr:`pickled` unpickled,
        else the text parsed.

        :raises ScenarioError: the text is not a valid scenario.
        """
        if self.scenario is not None:
            return self.scenario
        if self.pickled is not None:
            scenario: Scenario = pickle.loads(self.pickled)
            return scenario
        return parse_scenario(tomllib.loads(self.text), self.source, wire_limits())

    def digest(self) -> str:
        """sha256 of the file's text: :attr:`sha256`, else the text's."""
        return self.sha256 or text_sha256(self.text)


Job = tuple[Scene, str]
"""A scene and a strategy."""


@dataclass(frozen=True)
class Outcome:
    """What a worker sends back for one job."""

    scene: str
    strategy: str
    row: dict[str, str]
    events: str | None
    """events.json's text, None when the run failed."""
    library: str
    """sha256 of the firmware library the worker ran ("" for none)."""


# ------------------------------------------------------------------ one job

_LIBRARY_SHA: dict[str, str] = {}


def library_sha256(path: str | os.PathLike[str]) -> str:
    """sha256 of a file, remembered per process."""
    key = os.fspath(path)
    if key not in _LIBRARY_SHA:
        _LIBRARY_SHA[key] = hashlib.sha256(Path(key).read_bytes()).hexdigest()
    return _LIBRARY_SHA[key]


def worker_library(lib: str) -> str:
    """The library a worker runs: @p lib where that file exists on the
    worker's machine, else the worker's own $MSTC_SIL_LIB."""
    if Path(lib).is_file():
        return lib
    env = os.environ.get(LIB_ENV)
    if env and Path(env).is_file():
        return env
    raise FirmwareError(
        f"no firmware library on this worker: {lib} does not exist, {LIB_ENV} unset"
    )


def actuator_name(scenario: Scenario) -> str:
    """The actuator column of a run: the suite's profile, else the
    ``[actuator]``'s model (``ideal`` without the table)."""
    if scenario.meta.actuator:
        return scenario.meta.actuator
    return scenario.actuator.model


def controller_for(
    scenario: Scenario, strategy: str, lib: str, wheels: DcWheels | None = None
) -> tuple[Scenario, Controller]:
    """The scenario with @p strategy applied, and its controller (DWA's
    window limited to the actuator's acceleration, when it has one); the
    firmware's measures @p wheels, its own, when given."""
    if strategy == "dwa":
        return scenario, DwaController(scenario.params, dwa_config(scenario))
    params = dataclasses.replace(scenario.params, strategy=Strategy(strategy))
    scenario = dataclasses.replace(scenario, params=params)
    return scenario, SilController(params, lib, wheels)


def dwa_config(scenario: Scenario) -> DwaConfig:
    """DWA's parameters for @p scenario: its window's accelerations are the
    wheels' when the actuator limits them (a wheel at a rad/s² gives the
    robot r·a m/s² and 2·r·a/L rad/s²), never more than DWA's own."""
    config = DwaConfig()
    act = scenario.actuator
    accel = {"lag": act.max_accel, "dc": DC_HANDED["wheel_accel"]}.get(act.model, math.inf)
    if not math.isfinite(accel):
        return config
    p = scenario.params
    linear = p.wheel_radius * accel
    return dataclasses.replace(
        config,
        max_accel=min(config.max_accel, linear),
        max_delta_yaw_rate=min(config.max_delta_yaw_rate, 2.0 * linear / p.track_width),
    )


def new_row(scene: Scene, strategy: str) -> dict[str, str]:
    """A row of runs.csv for @p scene and @p strategy, nothing run yet."""
    row = {c: "" for c in ROW_COLUMNS}
    row.update(scene=scene.name, family=scene.family, strategy=strategy, actuator=scene.actuator)
    row["seed"] = "" if scene.seed is None else str(scene.seed)
    return row


def run_job(scene: Scene, strategy: str, lib: str) -> tuple[RunResult | None, dict[str, str]]:
    """Run one scene with one strategy; the result (None on failure) and its row."""
    row = new_row(scene, strategy)
    try:
        scenario = scene.parsed()
        row["family"] = scenario.meta.family or scene.family
        row["actuator"] = actuator_name(scenario)
        wheels = wheels_for(scenario, lib)
        scenario, controller = controller_for(scenario, strategy, lib, wheels)
        result = simulate(scenario, controller, wheels=wheels)
        metrics = evaluate(result)
    except Exception as exc:  # any failure of one scene is its row, not the sweep's end
        row["error"] = one_line(exc)
        return None, row
    row["steps"] = str(scenario.sim.steps + 1)
    row.update(format_metrics(metrics))
    return result, row


def one_line(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())


def _fmt(value: float | bool | int | None, measured: bool = False) -> str:
    if value is None:  # not judged (rejoined: metrics.py)
        return ""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    if math.isnan(value) or math.isinf(value):
        return str(value)
    return f"{value:.4g}" if measured else f"{value:.6g}"


def format_metrics(m: Metrics) -> dict[str, str]:
    """The metric columns as runs.csv writes them (6 significant digits)."""
    return {name: _fmt(getattr(m, name), name in MEASURED_COLUMNS) for name in METRIC_COLUMNS}


def _with_strategy(scenario: Scenario, strategy: str) -> Scenario:
    params = dataclasses.replace(scenario.params, strategy=Strategy(strategy))
    return dataclasses.replace(scenario, params=params)


def run_jobs_batched(jobs: Sequence[Job], lib: str, sha: str) -> list[Outcome]:
    """Run @p jobs with the batched engine in this process: the firmware's
    jobs together, on ideal or "lag" wheels; the DWA's, and those whose wheels
    run the firmware's wheel loop (``[actuator] model = "dc"``, not batched),
    one by one; outcomes in job order."""
    outcomes: dict[int, Outcome] = {}
    ready: list[tuple[int, Scenario, dict[str, str]]] = []
    for index, (scene, strategy) in enumerate(jobs):
        row = new_row(scene, strategy)
        try:
            scenario = scene.parsed()
        except Exception as exc:  # as run_job: a scene's failure is its row
            row["error"] = one_line(exc)
            outcomes[index] = Outcome(scene.name, strategy, row, None, sha)
            continue
        if strategy == "dwa" or scenario.actuator.model == "dc":
            result, row = run_job(scene, strategy, lib)
            events = events_json(result) if result is not None else None
            outcomes[index] = Outcome(scene.name, strategy, row, events, sha)
            continue
        row["family"] = scenario.meta.family or scene.family
        row["actuator"] = actuator_name(scenario)
        ready.append((index, _with_strategy(scenario, strategy), row))
    try:
        controller = SilBatch([s.params for _, s, _ in ready], lib, strict=False)
        if controller.rejected:
            for i in sorted(controller.rejected, reverse=True):
                index, _, row = ready.pop(i)
                row["error"] = f"FirmwareError: {controller.rejected[i]}"
                outcomes[index] = Outcome(row["scene"], row["strategy"], row, None, sha)
            controller = SilBatch([s.params for _, s, _ in ready], lib)
        scenarios = tuple(s for _, s, _ in ready)
        metrics = RunningMetrics(scenarios, table_width(scenarios), controller.modes)
        runs = simulate_batch(scenarios, controller, metrics)
    except Exception as exc:  # the batch's failure is each of its rows
        for index, _, row in ready:
            row["error"] = one_line(exc)
            outcomes[index] = Outcome(row["scene"], row["strategy"], row, None, sha)
        ready = []
        runs = []
    for i, ((index, scenario, row), run) in enumerate(zip(ready, runs, strict=True)):
        events = None
        if run.error is not None:
            row["error"] = f"SimulationError: {run.error}"
        else:
            row["steps"] = str(scenario.sim.steps + 1)
            row.update(format_metrics(metrics.result(i, run)))
            events = events_text(run.events, run.min_distance)
        outcomes[index] = Outcome(row["scene"], row["strategy"], row, events, sha)
    return [outcomes[i] for i in range(len(jobs))]


def _unpickled(jobs: Sequence[Job]) -> list[Job]:
    """@p jobs with each pickled scene unpickled once, however many of the
    jobs run it (a scene's strategies share it); a scene that does not
    unpickle is left for its jobs to fail on, each as its row."""
    opened: dict[int, Scene] = {}
    out = []
    for scene, strategy in jobs:
        if scene.pickled is not None and id(scene) not in opened:
            try:
                opened[id(scene)] = dataclasses.replace(
                    scene, scenario=scene.parsed(), pickled=None
                )
            except Exception:  # as run_job: the scene's failure is its rows'
                opened[id(scene)] = scene
        out.append((opened.get(id(scene), scene), strategy))
    return out


def run_batch(jobs: Sequence[Job], lib: str, engine: str = "scene") -> list[Outcome]:
    """Run a batch of jobs in this process (a pool's or a Dask worker's) with
    @p engine (:data:`ENGINES`)."""
    jobs = _unpickled(jobs)
    try:
        path = worker_library(lib)
        sha = library_sha256(path)
    except (OSError, FirmwareError) as exc:
        path, sha = lib, ""
        failure = one_line(exc)
    else:
        failure = ""
    if engine == "batched" and not failure:
        return run_jobs_batched(jobs, path, sha)
    outcomes = []
    for scene, strategy in jobs:
        if failure and strategy != "dwa":
            outcomes.append(crash_row((scene, strategy), failure))
            continue
        result, row = run_job(scene, strategy, path)
        events = events_json(result) if result is not None else None
        outcomes.append(Outcome(scene.name, strategy, row, events, sha))
    return outcomes


# ------------------------------------------------------------------ rows


_METRIC_TYPES = get_type_hints(Metrics)


def well_formed(row: Mapping[str, str]) -> bool:
    """Whether @p row holds what this module writes: a failed run's metrics
    empty, a finished run's each a value of its type."""
    if row["error"]:
        return all(row[c] == "" for c in ("steps", *METRIC_COLUMNS))
    try:
        int(row["steps"])
        for name, kind in _METRIC_TYPES.items():
            value = row[name]
            if kind is bool or kind == bool | None:
                if value not in ("0", "1") and (kind is bool or value != ""):
                    return False
            elif kind is int:
                int(value)
            else:
                float(value)
    except ValueError:
        return False
    return True


def crash_row(job: Job, why: str) -> Outcome:
    """The outcome of @p job that failed before it could run (@p why)."""
    scene, strategy = job
    row = new_row(scene, strategy)
    row["error"] = why
    return Outcome(scene.name, strategy, row, None, "")


def shipped(jobs: list[Job], spool: Spool) -> list[Job]:
    """@p jobs as a worker needs them: each scene of @p spool carrying its
    pickled scenario, one object per scene (its strategies' jobs share it,
    and so does the batch's pickle); a scene that carries its text or
    scenario already, or is not in the spool, as it is."""
    sent: dict[str, Scene] = {}
    out = []
    for scene, strategy in jobs:
        carries = scene.text or scene.scenario is not None or scene.pickled is not None
        if carries or scene.name not in spool:
            out.append((scene, strategy))
            continue
        if scene.name not in sent:
            sent[scene.name] = dataclasses.replace(scene, pickled=spool.read(scene.name))
        out.append((sent[scene.name], strategy))
    return out
