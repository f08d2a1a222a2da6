# SPDX-License-Identifier: MIT
"""Running a sweep: many scenes, several strategies, on every core or on a
Dask cluster, resumable.

Work is cut into batches of (scene, strategy) jobs. A batch carries each
scene's name and either the text of its file or, when the client has parsed
it (as ``mstc sweep`` does to validate every scene first), the parsed
scenario, pickled (:class:`mstc.sweep.spool.Spool`): plain data, never a
controller. The client sends a batch when a worker is about to need it
(two batches a worker in flight), reading its scenes from the spool then,
so its memory holds the batches in flight, not every scene. Every worker
process loads the firmware library itself (ctypes handles do not travel),
parses or unpickles its scenes, runs them and sends back one small row and
the text of events.json per job. The client writes DIR/<strategy>/<scene>/events.json,
then appends the row to DIR/runs.csv, so a row on disk always has its
events.json and ``--resume`` can skip it. When all is done runs.csv is
rewritten in plan order (scene order, then strategy order), the same
whichever worker finished first.

Two engines run the firmware's strategies. "batched" (the default) runs a
batch's scenes together: the plant steps every scene at once with numpy and
the firmware's step runs for all of them in one call
(:func:`mstc.loop.batched.simulate_batch`), the metrics computed as the run
goes (:class:`mstc.sweep.metrics.RunningMetrics`); its batches are large (up
to ``batch`` scenes) and a worker holds no trace. "scene" runs each scene
alone through :func:`mstc.loop.lockstep.simulate` and judges its trace
(:func:`mstc.sweep.metrics.evaluate`): the reference the batched engine is
compared with (docs/sweeps.md, "Engines"). Both write the same rows and
events.json, with ideal wheels and with "lag" wheels alike. The DWA baseline
always runs scene by scene, and so do scenes on "dc" wheels (the firmware's
wheel loop, which the batched plant does not model).

A scene that fails (an exception, a non-finite state) is a row with its
error. A worker that dies (a crash in the library) takes its batch down:
those jobs run again one at a time on a single worker, which names the one
that kills it; that job becomes an error row and the rest go on.
"""

from __future__ import annotations

import collections
import csv
import dataclasses
import functools
import hashlib
import importlib.util
import io
import itertools
import math
import multiprocessing
import os
import pickle
import socket
import sys
import tomllib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import get_type_hints

from mstc.can.library import LIB_ENV
from mstc.can.protocol import wire_limits
from mstc.errors import ClusterError, DependencyError, FirmwareError, UsageError
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
from mstc.sweep.folder import read_sources, text_sha256, write_sources
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


def _new_row(scene: Scene, strategy: str) -> dict[str, str]:
    """A row of runs.csv for @p scene and @p strategy, nothing run yet."""
    row = {c: "" for c in ROW_COLUMNS}
    row.update(scene=scene.name, family=scene.family, strategy=strategy, actuator=scene.actuator)
    row["seed"] = "" if scene.seed is None else str(scene.seed)
    return row


def run_job(scene: Scene, strategy: str, lib: str) -> tuple[RunResult | None, dict[str, str]]:
    """Run one scene with one strategy; the result (None on failure) and its row."""
    row = _new_row(scene, strategy)
    try:
        scenario = scene.parsed()
        row["family"] = scenario.meta.family or scene.family
        row["actuator"] = actuator_name(scenario)
        wheels = wheels_for(scenario, lib)
        scenario, controller = controller_for(scenario, strategy, lib, wheels)
        result = simulate(scenario, controller, wheels=wheels)
        metrics = evaluate(result)
    except Exception as exc:  # any failure of one scene is its row, not the sweep's end
        row["error"] = _one_line(exc)
        return None, row
    row["steps"] = str(scenario.sim.steps + 1)
    row.update(format_metrics(metrics))
    return result, row


def _one_line(exc: BaseException) -> str:
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
        row = _new_row(scene, strategy)
        try:
            scenario = scene.parsed()
        except Exception as exc:  # as run_job: a scene's failure is its row
            row["error"] = _one_line(exc)
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
            row["error"] = _one_line(exc)
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
        failure = _one_line(exc)
    else:
        failure = ""
    if engine == "batched" and not failure:
        return run_jobs_batched(jobs, path, sha)
    outcomes = []
    for scene, strategy in jobs:
        if failure and strategy != "dwa":
            outcomes.append(_crash_row((scene, strategy), failure))
            continue
        result, row = run_job(scene, strategy, path)
        events = events_json(result) if result is not None else None
        outcomes.append(Outcome(scene.name, strategy, row, events, sha))
    return outcomes


# ------------------------------------------------------------------ runs.csv


_METRIC_TYPES = get_type_hints(Metrics)


def _well_formed(row: dict[str, str]) -> bool:
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


def read_rows(path: Path) -> list[dict[str, str]]:
    """The complete, well-formed rows of a runs.csv (a line cut short by an
    interruption, or a value that is not one of its column, is left out)."""
    if not path.is_file():
        return []
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        if tuple(reader.fieldnames or ()) != ROW_COLUMNS:
            return []
        return [r for r in reader if None not in r.values() and None not in r and _well_formed(r)]


class Row(Mapping[str, str]):
    """A row of runs.csv as a sweep keeps it until the end: its values in
    :data:`ROW_COLUMNS` order in one tuple, the repeated ones (scene,
    family, actuator, strategy, ...) shared between rows; some 0.8 kB where
    a dict takes 1.6 kB."""

    __slots__ = ("_values",)

    def __init__(self, row: Mapping[str, str]) -> None:
        self._values = tuple(sys.intern(row[c]) if c in _SHARED else row[c] for c in ROW_COLUMNS)

    def __getitem__(self, column: str) -> str:
        return self._values[_INDEX[column]]

    def __iter__(self) -> Iterator[str]:
        return iter(ROW_COLUMNS)

    def __len__(self) -> int:
        return len(ROW_COLUMNS)


_INDEX = {c: i for i, c in enumerate(ROW_COLUMNS)}
_SHARED = frozenset(("scene", "family", "actuator", "strategy", "steps", "error"))


def _row_text(row: Mapping[str, str]) -> str:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow([row[c] for c in ROW_COLUMNS])
    return buf.getvalue()


def write_rows(path: Path, rows: Iterable[Mapping[str, str]]) -> None:
    """Write runs.csv whole (through a temporary file, then renamed)."""
    tmp = path.with_suffix(".csv.tmp")
    with tmp.open("w", newline="") as f:
        f.write(",".join(ROW_COLUMNS) + "\n")
        for row in rows:
            f.write(_row_text(row))
    tmp.replace(path)


# ------------------------------------------------------------------ the sweep


def batches(
    jobs: Sequence[Job], workers: int, most: int = 16, per_worker: int = 8
) -> list[list[Job]]:
    """Cut @p jobs into batches: about @p per_worker a worker so the load
    evens out, at most @p most jobs each."""
    size = max(1, min(most, math.ceil(len(jobs) / max(1, workers * per_worker))))
    return [list(jobs[i : i + size]) for i in range(0, len(jobs), size)]


def engine_batches(
    jobs: Sequence[Job], workers: int, engine: str, batch: int = BATCH
) -> list[list[Job]]:
    """@p jobs cut for @p engine: small batches for "scene" (:func:`batches`);
    for "batched" as large as @p batch allows, about 2 a worker (the
    batched engine's cost per scene falls with the batch's size)."""
    if engine == "batched":
        return batches(jobs, workers, most=batch, per_worker=2)
    return batches(jobs, workers)


def _crash_row(job: Job, why: str) -> Outcome:
    scene, strategy = job
    row = {c: "" for c in ROW_COLUMNS}
    row.update(
        scene=scene.name, family=scene.family, actuator=scene.actuator, strategy=strategy, error=why
    )
    row["seed"] = "" if scene.seed is None else str(scene.seed)
    return Outcome(scene.name, strategy, row, None, "")


Emit = Callable[[Outcome], None]
Ship = Callable[[list[Job]], list[Job]]
"""A batch as a worker needs it (:func:`shipped`), made as it is sent."""
IN_FLIGHT = 2
"""Batches sent a worker at a time: one running, one waiting, so that a
worker never waits for the client and the client holds no more."""


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


def run_local(
    jobs: Sequence[Job],
    lib: str,
    workers: int,
    emit: Emit,
    engine: str = "scene",
    batch_size: int = BATCH,
    ship: Ship = list,
) -> None:
    """Run @p jobs on a pool of @p workers processes with @p engine, calling
    @p emit for each outcome as it comes. Workers start fresh (spawn) and
    load the library themselves; a batch is made (@p ship) and sent when
    one of the :data:`IN_FLIGHT` a worker comes back."""
    context = multiprocessing.get_context("spawn")
    pending = list(jobs)
    while pending:
        done_ids: set[int] = set()
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=context)
        try:
            cut = iter(engine_batches(pending, workers, engine, batch_size))
            futures: dict[Future[list[Outcome]], list[Job]] = {}
            broken = False
            while True:
                if not broken:
                    for b in itertools.islice(cut, workers * IN_FLIGHT - len(futures)):
                        futures[pool.submit(run_batch, ship(b), lib, engine)] = b
                if not futures:
                    break
                finished, _ = wait(futures, return_when=FIRST_COMPLETED)
                for fut in finished:
                    batch = futures.pop(fut)
                    try:
                        outcomes = fut.result()
                    except BrokenProcessPool:
                        broken = True
                        continue
                    for job, outcome in zip(batch, outcomes, strict=True):
                        done_ids.add(id(job))
                        emit(outcome)
        except BaseException:
            # Interrupted (Ctrl-C) or failed: drop the batches not started
            # rather than wait for them; --resume runs them later.
            pool.shutdown(wait=False, cancel_futures=True)
            raise
        pool.shutdown()
        if not broken:
            return
        left = [j for j in pending if id(j) not in done_ids]
        pending = _isolate(left, lib, context, emit, engine, ship)


def _isolate(
    jobs: list[Job],
    lib: str,
    context: multiprocessing.context.BaseContext,
    emit: Emit,
    engine: str,
    ship: Ship = list,
) -> list[Job]:
    """After a worker died: run @p jobs one by one on one worker until it dies
    again; the job it died on becomes an error row. Returns the jobs not run."""
    with ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
        sent: collections.deque[tuple[int, Future[list[Outcome]]]] = collections.deque()
        i = 0
        while i < len(jobs) or sent:
            while i < len(jobs) and len(sent) < IN_FLIGHT:
                sent.append((i, pool.submit(run_batch, ship([jobs[i]]), lib, engine)))
                i += 1
            index, fut = sent.popleft()
            try:
                (outcome,) = fut.result()
            except BrokenProcessPool:
                emit(_crash_row(jobs[index], "the worker process died running this scene"))
                return jobs[index + 1 :]
            emit(outcome)
    return []


def require_dask() -> None:
    """Dask's ``distributed`` is installed (the extra ``mstc[cluster]``).

    :raises DependencyError: it is not.
    """
    if importlib.util.find_spec("distributed") is None:
        raise DependencyError(
            "a Dask cluster needs Dask's distributed, which is not installed: "
            "pip install 'mstc[cluster]' (docs/sweeps.md)"
        )


SCHEDULER_TIMEOUT = 5.0
"""How long :func:`check_scheduler` waits for a scheduler's port to answer [s]."""


def check_scheduler(address: str) -> None:
    """@p address is a Dask scheduler's, and its port answers (tcp:// and
    tls://): a wrong or closed address is said at once, before anything runs,
    not after the client's 30 s of retries.

    :raises DependencyError: Dask is not installed.
    :raises UsageError: @p address is not an address.
    :raises ClusterError: nothing answers there.
    """
    require_dask()
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location) if scheme in ("tcp", "tls") else ("", 0)
    except ValueError as exc:
        raise UsageError(
            f"--scheduler {address}: {exc} (expected tcp://HOST:PORT, docs/sweeps.md)"
        ) from exc
    if not host:
        return
    try:
        socket.create_connection((host, port), timeout=SCHEDULER_TIMEOUT).close()
    except OSError as exc:
        why = exc.strerror or str(exc) or type(exc).__name__
        raise ClusterError(f"cannot reach the Dask scheduler at {address}: {why}") from exc


def run_dask(
    jobs: Sequence[Job],
    lib: str,
    scheduler: str,
    emit: Emit,
    engine: str = "scene",
    batch_size: int = BATCH,
    ship: Ship = list,
) -> None:
    """Run @p jobs with @p engine on the Dask cluster at @p scheduler
    (``tcp://host:port``): a task is a batch of jobs, made (@p ship) and
    submitted when one of the :data:`IN_FLIGHT` a worker comes back.
    Dask retries the tasks of a dead worker elsewhere; a batch that keeps
    killing workers is run again job by job, and the job that still does
    becomes an error row.

    :raises DependencyError: Dask is not installed.
    """
    require_dask()
    from distributed import Client, as_completed
    from distributed.scheduler import KilledWorker

    try:
        client = Client(scheduler, timeout="30s")
    except OSError as exc:  # distributed's TimeoutError too
        raise ClusterError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from exc
    with client:
        workers = max(1, len(client.scheduler_info()["workers"]))
        cut = iter(engine_batches(jobs, workers, engine, batch_size))
        todo = {
            client.submit(run_batch, ship(b), lib, engine, pure=False): b
            for b in itertools.islice(cut, workers * IN_FLIGHT)
        }
        queue = as_completed(list(todo))
        for fut in queue:
            batch = todo.pop(fut)
            for b in itertools.islice(cut, max(0, workers * IN_FLIGHT - len(todo))):
                new = client.submit(run_batch, ship(b), lib, engine, pure=False)
                todo[new] = b
                queue.add(new)
            try:
                outcomes = fut.result()
            except KilledWorker:
                if len(batch) == 1:
                    emit(_crash_row(batch[0], "the worker process died running this scene"))
                    continue
                for job in batch:
                    single = client.submit(run_batch, ship([job]), lib, engine, pure=False)
                    todo[single] = [job]
                    queue.add(single)
                continue
            for outcome in outcomes:
                emit(outcome)


# ------------------------------------------------------------------ orchestration


@dataclass
class SweepResult:
    """What a sweep leaves: every row in plan order, and what this call ran."""

    rows: list[Row]
    ran: int
    """Jobs run by this call (the rest came from a previous, resumed one)."""


def run_sweep(
    scenes: Sequence[Scene],
    strategies: Sequence[str],
    out: Path,
    lib: str,
    *,
    workers: int,
    scheduler: str | None = None,
    resume: bool = False,
    progress: Callable[[int, int], None] | None = None,
    engine: str = "batched",
    batch: int = BATCH,
    spool: Spool | None = None,
) -> SweepResult:
    """Run every scene with every strategy; write events.json and runs.csv
    under @p out.

    :param workers: processes of the local pool (ignored with @p scheduler).
    :param scheduler: a Dask scheduler's address, or None for the local pool.
    :param resume: keep the rows of DIR/runs.csv (and their events.json) run
        from the same scene text and library (DIR/sources.json:
        :mod:`mstc.sweep.folder`) and run only the jobs it lacks; otherwise
        start afresh.
    :param progress: called with (done, total) as jobs finish.
    :param engine: :data:`ENGINES` (the module's docstring).
    :param batch: most scenes of one batch of the batched engine.
    :param spool: where @p scenes, records without text or scenario
        (:meth:`Scene.from_scenario`), are kept parsed: each batch is read
        from it as it is sent (None: the scenes carry what a worker needs).

    :raises FirmwareError: a worker ran another firmware library than @p lib
        (different contents), so its rows would not be comparable.
    """
    out.mkdir(parents=True, exist_ok=True)
    runs = out / "runs.csv"
    # Each run's row at its place in the plan: scene order, then strategy order.
    first = {scene.name: i * len(strategies) for i, scene in enumerate(scenes)}
    column = {strategy: j for j, strategy in enumerate(strategies)}
    rows: list[Row | None] = [None] * (len(scenes) * len(strategies))
    local_sha = library_sha256(lib) if Path(lib).is_file() else ""
    texts = {scene.name: scene.digest() for scene in scenes}
    if resume:
        before = read_sources(out)
        ran_from = before.get("scenes")
        ran_from = ran_from if isinstance(ran_from, dict) else {}
        for row in read_rows(runs):
            finished = (
                bool(row["error"])
                or (out / row["strategy"] / row["scene"] / "events.json").is_file()
            )
            same = ran_from.get(row["scene"]) == texts.get(row["scene"]) and (
                row["strategy"] == "dwa" or before.get("library") == local_sha
            )
            planned = row["scene"] in first and row["strategy"] in column
            if planned and finished and same:
                rows[first[row["scene"]] + column[row["strategy"]]] = Row(row)
    write_rows(runs, (r for r in rows if r is not None))
    write_sources(out, local_sha, texts)  # after runs.csv: it holds no row from before
    todo = [
        (scene, strategy)
        for scene in scenes
        for strategy in strategies
        if rows[first[scene.name] + column[strategy]] is None
    ]
    total, done = len(rows), sum(1 for r in rows if r is not None)
    if progress:
        progress(done, total)

    with runs.open("a", newline="") as log:

        def emit(outcome: Outcome) -> None:
            nonlocal done
            if outcome.library and local_sha and outcome.library != local_sha:
                raise FirmwareError(
                    f"a worker ran a different firmware library (sha256 {outcome.library[:12]}…, "
                    f"here {local_sha[:12]}…): build the same sources on every machine"
                )
            if outcome.events is not None:
                folder = out / outcome.strategy / outcome.scene
                folder.mkdir(parents=True, exist_ok=True)
                (folder / "events.json").write_text(outcome.events)
            log.write(_row_text(outcome.row))
            log.flush()
            rows[first[outcome.scene] + column[outcome.strategy]] = Row(outcome.row)
            done += 1
            if progress:
                progress(done, total)

        ship: Ship = functools.partial(shipped, spool=spool) if spool is not None else list
        if todo and scheduler:
            run_dask(todo, lib, scheduler, emit, engine, batch, ship)
        elif todo:
            run_local(todo, lib, workers, emit, engine, batch, ship)
    ordered = [r for r in rows if r is not None]
    write_rows(runs, ordered)
    return SweepResult(ordered, len(todo))
