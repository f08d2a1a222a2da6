# SPDX-License-Identifier: MIT
"""A sweep's plan: its runs numbered, cut into slices that workers make, run
and summarise themselves.

A sweep runs every scene of its inputs with every strategy. Its *plan* lists
them in *blocks*, in the order of the inputs: a suite gives a block per family
and actuator profile (the family's scenes under that profile, in index
order), scenario files a block of their scenes. Each run has a *position*:
its block's first position, plus the scene's index times the number of
strategies, plus the strategy's; runs.csv holds the rows in that order
(:class:`mstc.sweep.rows.RowFile`).

The plan is cut into *slices* (:class:`Slice`: parts of one or more blocks,
in plan order, each a block's scenes from one index to another or some of
their runs), which :func:`mstc.sweep.jobs.run_tasks` sends to the workers.
A suite's scene is a pure function of the suite, family, actuator profile
and index (:func:`mstc.sweep.suite.scene_doc`): a
slice of a suite carries the suite's few numbers and the range of indices,
and the worker makes each scene's document and parses it (no text is written
or read), runs them (:func:`mstc.sweep.engine.run_batch`) and sends back the
rows, as runs.csv's fields, never a scene. Scenario files are read and
validated by the client; their slices carry them, pickled. A worker also
sends back, to be written by the client, the scene file and events.json of
each *failure* (an error row, a contact), so that every run summary.md
reports can be run alone from its row, and with ``--write-scenes`` and
``--write-events`` those of every run.

What a suite's block is run from is the sha256 of its definition (the
suite's period and integrator, the family's kind, seed and ranges, the
profile's wheels), of the generator's code and of its first scene's text
(:meth:`Plan.add_suite`); ``--resume`` keeps a row when that of its block, or
of its scenario file's text, and the library are what they were
(``DIR/sources.json``).

The first slices are small (an eighth, a quarter, a half of a full one) so
the first rows reach runs.csv within seconds; a full slice is ``batch`` runs,
spread so that every worker gets two at least.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mstc.can.protocol import wire_limits
from mstc.errors import FirmwareError, ScenarioError, SuiteError
from mstc.loop.result import RunResult
from mstc.plant.scenario import parse_scenario
from mstc.report.outputs import events_json
from mstc.sweep import suite as suite_module
from mstc.sweep.engine import (
    BATCH,
    ROW_COLUMNS,
    Job,
    Outcome,
    Scene,
    crash_row,
    library_sha256,
    new_row,
    one_line,
    run_batch,
    run_job,
    shipped,
    well_formed,
)
from mstc.sweep.folder import read_sources, write_sources
from mstc.sweep.jobs import run_tasks
from mstc.sweep.rows import Fields, Keep, RowFile
from mstc.sweep.spool import Spool
from mstc.sweep.suite import (
    IDEAL,
    ActuatorProfile,
    Family,
    Suite,
    scene_doc,
    text_of,
)

_GENERATOR = hashlib.sha256(Path(suite_module.__file__).read_bytes()).hexdigest()
"""The suite generator's code: a block made by another is another block."""


@dataclass(frozen=True)
class Block:
    """Runs of one source, contiguous in the plan (the module's docstring)."""

    base: int
    """The position of its first run."""
    scenes: int
    """Its scenes."""
    suite: Suite | None = None
    """A suite's block: the suite with this family and profile alone."""
    origin: str = ""
    """The suite file, as the user named it (error messages)."""
    digest: str = ""
    """What a suite's block is run from (sources.json)."""
    records: tuple[Scene, ...] = ()
    """A block of scenario files: their records (:meth:`Scene.from_scenario`)."""

    @property
    def family(self) -> Family:
        assert self.suite is not None
        return self.suite.families[0]

    @property
    def profile(self) -> ActuatorProfile:
        assert self.suite is not None
        return self.suite.actuators[0]

    @property
    def key(self) -> str:
        """A suite block's name in sources.json: ``family/profile``."""
        return f"{self.family.name}/{self.profile.name}"

    def name(self, index: int) -> str:
        """The name of scene @p index (a file's stem)."""
        if self.suite is None:
            return self.records[index].name
        return self.suite.scene_name(self.family, index, self.profile)

    def wheels(self) -> ActuatorProfile | None:
        """The profile a scene's document names: None for the ideal wheels of
        a suite without profiles (no ``[meta] actuator``, as before profiles)."""
        return None if self.profile == ActuatorProfile(IDEAL, {}) else self.profile

    def doc(self, index: int) -> dict[str, object]:
        """Scene @p index's document (:func:`mstc.sweep.suite.scene_doc`)."""
        assert self.suite is not None
        return scene_doc(self.suite, self.family, index, actuator=self.wheels())

    def text(self, index: int, doc: Mapping[str, object] | None = None) -> str:
        """Scene @p index's file (of its document @p doc, when made already)."""
        assert self.suite is not None
        return text_of(self.suite, self.family, index, self.doc(index) if doc is None else doc)

    def path(self, index: int) -> str:
        """Where scene @p index's file goes, under DIR (``mstc sweep
        --generate-only`` writes every one there)."""
        return f"scenes/{self.family.name}/{self.name(index)}.toml"

    def make(self, index: int, folder: str, doc: Mapping[str, object] | None = None) -> Scene:
        """Scene @p index (of its document @p doc, when made already),
        parsed, as a worker runs it; its file named as under @p folder.

        :raises SuiteError: the loader refuses it (named with its suite and
            family, since the suite is what to change).
        """
        path = f"{folder}/{self.path(index)}"
        try:
            scenario = parse_scenario(self.doc(index) if doc is None else doc, path, wire_limits())
        except ScenarioError as exc:
            where = f"scene {self.name(index)}"
            where += f": {exc.key}" if exc.key else ""
            problem = f"{where}: {exc.problem}"
            raise SuiteError(self.origin, f"family.{self.family.name}", problem) from exc
        family = self.family
        return Scene(
            self.name(index),
            path,
            "",
            family.name,
            family.scene_seed(index),
            scenario.meta.actuator,
            scenario=scenario,
        )


@dataclass(frozen=True)
class Part:
    """A block's scenes ``start`` to ``stop`` (exclusive) under every
    strategy, or only the runs named."""

    block: Block
    """Its block, without the records of a block of files."""
    start: int
    stop: int
    runs: tuple[int, ...] | None = None
    """The runs to make, numbered from the part's first (scene ``start``
    under the first strategy); None: all of them."""
    records: tuple[Scene, ...] = ()
    """A block of files: the scenes ``start`` to ``stop``, pickled."""


@dataclass(frozen=True)
class Slice:
    """What a worker makes and runs in one batch (the module's docstring):
    parts of one or more blocks, in plan order."""

    parts: tuple[Part, ...]
    strategies: tuple[str, ...]
    folder: str = ""
    """DIR (a scene's file name)."""
    texts: bool = False
    """Send back every scene's file (--write-scenes)."""
    events: bool = False
    """Send back every run's events.json (--write-events)."""

    def runs(self) -> list[tuple[int, int]]:
        """The runs to make: (part, the run's number in it), in order."""
        width = len(self.strategies)
        out = []
        for k, part in enumerate(self.parts):
            numbers = range((part.stop - part.start) * width) if part.runs is None else part.runs
            out += [(k, n) for n in numbers]
        return out

    def only(self, runs: Sequence[tuple[int, int]]) -> Slice:
        """This slice with only @p runs (some of :meth:`runs`, in order)."""
        numbers: dict[int, list[int]] = {}
        for k, n in runs:
            numbers.setdefault(k, []).append(n)
        parts = tuple(dataclasses.replace(self.parts[k], runs=tuple(n)) for k, n in numbers.items())
        return dataclasses.replace(self, parts=parts)

    def run(self, k: int, number: int) -> tuple[int, int, str]:
        """Run @p number of part @p k: its position, scene index and strategy."""
        part, width = self.parts[k], len(self.strategies)
        position = part.block.base + part.start * width + number
        return position, part.start + number // width, self.strategies[number % width]


@dataclass
class SliceResult:
    """What a worker sends back for a slice."""

    rows: list[tuple[int, Fields]]
    """(position, runs.csv's fields), in position order."""
    files: list[tuple[str, str]] = field(default_factory=list)
    """(path under DIR, text) to write: scene files and events.json."""
    library: str = ""
    """sha256 of the firmware library it ran ("" for none)."""
    make_cpu: float = 0.0
    """CPU time making (suites) or unpickling (files) its scenes [s]."""
    run_cpu: float = 0.0
    """CPU time running them [s]."""


def _fields(outcome: Outcome) -> list[str]:
    return [outcome.row[c] for c in ROW_COLUMNS]


def _events_path(strategy: str, scene: str) -> str:
    return f"{strategy}/{scene}/events.json"


@dataclass(frozen=True)
class SweepWork:
    """A sweep's work on a worker (:class:`mstc.sweep.jobs.Work`): a slice's
    scenes made, run with the library @p lib and the engine @p engine."""

    lib: str
    engine: str = "batched"

    def __call__(self, task: Slice) -> SliceResult:
        c0 = time.process_time()
        wanted = task.runs()
        scenes: dict[tuple[int, int], Scene] = {}
        docs: dict[tuple[int, int], Mapping[str, object]] = {}
        errors: dict[tuple[int, int], str] = {}
        jobs: list[tuple[int, Job]] = []
        outcomes: dict[int, Outcome] = {}
        for i, (k, number) in enumerate(wanted):
            _, index, strategy = task.run(k, number)
            key = (k, index)
            if key not in scenes and key not in errors:
                _make(task, key, scenes, docs, errors)
            scene = scenes.get(key)
            if scene is None:
                outcomes[i] = _failed(task.parts[k].block, index, strategy, errors[key])
            else:
                jobs.append((i, (scene, strategy)))
        c1 = time.process_time()
        ran = run_batch([job for _, job in jobs], self.lib, self.engine)
        c2 = time.process_time()
        outcomes.update((i, o) for (i, _), o in zip(jobs, ran, strict=True))
        result = SliceResult([], library=next((o.library for o in ran if o.library), ""))
        written: set[tuple[int, int]] = set()
        for i, (k, number) in enumerate(wanted):
            position, index, _ = task.run(k, number)
            outcome = outcomes[i]
            result.rows.append((position, _fields(outcome)))
            failure = bool(outcome.row["error"]) or outcome.row["contact"] == "1"
            key = (k, index)
            if (task.texts or failure) and key in docs and key not in written:
                written.add(key)
                block = task.parts[k].block
                result.files.append((block.path(index), block.text(index, docs[key])))
            if outcome.events is not None and (task.events or failure):
                result.files.append((_events_path(outcome.strategy, outcome.scene), outcome.events))
        result.make_cpu, result.run_cpu = c1 - c0, c2 - c1
        return result

    def split(self, task: Slice) -> list[Slice]:
        """Halves of @p task's runs; [] for one run."""
        runs = task.runs()
        if len(runs) < 2:
            return []
        half = len(runs) // 2
        return [task.only(runs[:half]), task.only(runs[half:])]

    def crashed(self, task: Slice, why: str) -> SliceResult:
        """The error row of @p task's one run."""
        ((k, number),) = task.runs()
        position, index, strategy = task.run(k, number)
        part = task.parts[k]
        if part.block.suite is None:
            outcome = crash_row((part.records[index - part.start], strategy), why)
        else:
            outcome = _failed(part.block, index, strategy, why)
        return SliceResult([(position, _fields(outcome))])


def _make(
    task: Slice,
    key: tuple[int, int],
    scenes: dict[tuple[int, int], Scene],
    docs: dict[tuple[int, int], Mapping[str, object]],
    errors: dict[tuple[int, int], str],
) -> None:
    """Make scene @p key (part, index) of @p task into @p scenes (a suite's
    document into @p docs), or say in @p errors why it cannot be: its rows'
    error."""
    k, index = key
    part = task.parts[k]
    block = part.block
    if block.suite is None:
        scene = part.records[index - part.start]
        if scene.pickled is not None:
            try:
                scene = dataclasses.replace(scene, scenario=scene.parsed(), pickled=None)
            except Exception:  # left pickled: run_batch makes it each run's error row
                pass
        scenes[key] = scene
        return
    try:
        docs[key] = block.doc(index)
        scenes[key] = block.make(index, task.folder, docs[key])
    except Exception as exc:  # a scene that cannot be made is its rows' error
        errors[key] = one_line(exc)


def _failed(block: Block, index: int, strategy: str, error: str) -> Outcome:
    """The error row of scene @p index of a suite's @p block under @p strategy."""
    family = block.family
    scene = Scene(block.name(index), "", "", family.name, family.scene_seed(index))
    row = new_row(scene, strategy)
    row["actuator"] = block.profile.name
    row["error"] = error
    return Outcome(scene.name, strategy, row, None, "")


class Plan:
    """A sweep's runs (the module's docstring): @p strategies on the scenes of
    the blocks added, in order."""

    def __init__(self, strategies: Sequence[str], spool: Spool | None = None) -> None:
        self.strategies = tuple(strategies)
        self.blocks: list[Block] = []
        self.spool = spool
        """Where the records of scenario files keep their parsed scenarios."""
        self._names: dict[str, Block] = {}
        """A suite block's scene names, less their index: ``family`` or
        ``family-profile``."""
        self._files: dict[str, tuple[Block, int]] = {}
        self._total = 0

    @property
    def runs(self) -> int:
        """The runs of the plan."""
        return self._total

    @property
    def scenes(self) -> int:
        return self._total // max(1, len(self.strategies))

    def _append(self, block: Block) -> Block:
        block = dataclasses.replace(block, base=self._total)
        self.blocks.append(block)
        self._total += block.scenes * len(self.strategies)
        return block

    def add_suite(
        self,
        suite: Suite,
        origin: str,
        families: Sequence[str] | None = None,
        actuators: Sequence[str] | None = None,
    ) -> list[str]:
        """Add a block per family and actuator profile of @p suite (only
        @p families and @p actuators when given), family by family. The
        first scene of each is made and parsed here, so a suite whose scenes
        the loader refuses is said before anything runs: the problems, one a
        line (nothing is added then)."""
        problems: list[str] = []
        blocks = []
        for family in suite.families:
            if families is not None and family.name not in families:
                continue
            if family.name in {b.family.name for b in self.blocks if b.suite is not None}:
                problems.append(
                    f"{origin}: family {family.name}: another suite has a family of that name, "
                    "whose scenes would have the same names"
                )
                continue
            for profile in suite.actuators:
                if actuators is not None and profile.name not in actuators:
                    continue
                one = dataclasses.replace(suite, families=(family,), actuators=(profile,))
                block = Block(0, family.count, one, origin)
                if not family.count:
                    continue
                try:
                    doc = block.doc(0)
                    block.make(0, "")
                except SuiteError as exc:
                    problems.append(str(exc))
                    break
                text = block.text(0, doc)
                blocks.append(dataclasses.replace(block, digest=_digest(one, text)))
        if problems:
            return problems
        for block in blocks:
            block = self._append(block)
            self._names[block.name(0).rsplit("-", 1)[0]] = block
        return []

    def add_scenes(self, records: Sequence[Scene]) -> list[str]:
        """Add a block of scenario files (records, their scenarios in the
        plan's spool); the problems of names two scenes would share, one a line."""
        problems = []
        mine: list[Scene] = []
        for scene in records:
            twin = self._files.get(scene.name)
            if twin is not None:
                first = twin[0].records[twin[1]].source
                problems.append(f"{first} and {scene.source} would both be named {scene.name}")
                continue
            self._files[scene.name] = (Block(0, 0), len(mine))
            mine.append(scene)
        if problems or not mine:
            return problems
        block = self._append(Block(0, len(mine), records=tuple(mine)))
        for i, scene in enumerate(mine):
            self._files[scene.name] = (block, i)
        return []

    def _suite_scene(self, name: str) -> tuple[Block, int] | None:
        """The suite block and index of the scene named @p name, if it is one."""
        prefix, _, digits = name.rpartition("-")
        block = self._names.get(prefix)
        if block is None or not digits.isdigit():
            return None
        index = int(digits)
        if index >= block.scenes or block.name(index) != name:
            return None
        return block, index

    def problems(self) -> list[str]:
        """A scenario file named as a scene of a suite of the plan would
        write over its files: each such file, one a line."""
        return [
            f"{block.records[i].source} has the name of a scene of a suite: {name}"
            for name, (block, i) in self._files.items()
            if self._suite_scene(name) is not None
        ]

    def sources(self, library: str) -> dict[str, object]:
        """What the rows are run from (sources.json: folder.py)."""
        return {
            "library": library,
            "blocks": {b.key: b.digest for b in self.blocks if b.suite is not None},
            "scenes": {s.name: s.digest() for b in self.blocks for s in b.records},
        }

    def keep(self, before: Mapping[str, object], library: str) -> Keep:
        """Which rows of an earlier sweep into the same folder (whose
        sources.json was @p before) to keep: the position of a well-formed
        row of a run of the plan from the same source and library."""
        old_blocks = before.get("blocks")
        old_blocks = old_blocks if isinstance(old_blocks, dict) else {}
        old_scenes = before.get("scenes")
        old_scenes = old_scenes if isinstance(old_scenes, dict) else {}
        same_library = before.get("library") == library
        column = {s: j for j, s in enumerate(self.strategies)}
        width = len(self.strategies)

        def keep(row: Mapping[str, str]) -> int | None:
            j = column.get(row["strategy"])
            if j is None or not (same_library or row["strategy"] == "dwa"):
                return None
            found = self._suite_scene(row["scene"])
            if found is not None:
                block, index = found
                family = block.family
                if (
                    old_blocks.get(block.key) != block.digest
                    or row["family"] != family.name
                    or row["actuator"] != block.profile.name
                    or row["seed"] != str(family.scene_seed(index))
                ):
                    return None
            else:
                found = self._files.get(row["scene"])
                if found is None:
                    return None
                block, index = found
                if old_scenes.get(row["scene"]) != block.records[index].digest():
                    return None
            if not well_formed(row):
                return None
            return block.base + index * width + j

        return keep

    def slices(
        self,
        workers: int,
        kept: np.ndarray,
        *,
        batch: int = BATCH,
        engine: str = "batched",
        folder: str = "",
        texts: bool = False,
        events: bool = False,
    ) -> Iterator[Slice]:
        """The slices of the runs not in @p kept (sorted positions), in order
        (the module's docstring), for @p workers."""
        width = len(self.strategies)
        spread = 2 if engine == "batched" else 8  # slices a worker at least
        most = batch if engine == "batched" else 16
        full = max(1, min(max(1, most // width), math.ceil(self.scenes / (workers * spread))))
        sizes = iter([max(1, full // d) for d in (8, 4, 2) for _ in range(workers)])
        parts: list[Part] = []
        room = next(sizes, full)
        for block in self.blocks:
            start = 0
            while start < block.scenes:
                stop = min(block.scenes, start + room)
                part = self._part(block, start, stop, kept)
                if part is not None:
                    parts.append(part)
                room -= stop - start
                start = stop
                if not room:
                    if parts:
                        yield Slice(tuple(parts), self.strategies, folder, texts, events)
                    parts = []
                    room = next(sizes, full)
        if parts:
            yield Slice(tuple(parts), self.strategies, folder, texts, events)

    def _part(self, block: Block, start: int, stop: int, kept: np.ndarray) -> Part | None:
        """Scenes @p start to @p stop of @p block, less the runs @p kept;
        None when every run is."""
        width = len(self.strategies)
        lo, hi = block.base + start * width, block.base + stop * width
        done = kept[np.searchsorted(kept, lo) : np.searchsorted(kept, hi)]
        if len(done) == hi - lo:
            return None
        runs = None
        if len(done):
            runs = tuple(np.setdiff1d(np.arange(hi - lo), done - lo).tolist())
        records: tuple[Scene, ...] = ()
        if block.suite is None:
            jobs: list[Job] = [(s, "") for s in block.records[start:stop]]
            if self.spool is not None:
                jobs = shipped(jobs, self.spool)
            records = tuple(s for s, _ in jobs)
        return Part(dataclasses.replace(block, records=()), start, stop, runs, records)

    def scene(self, row: Sequence[str]) -> Scene:
        """The scene of a row (runs.csv's fields), ready to run again.

        :raises KeyError: no scene of the plan has its name.
        """
        name = row[ROW_COLUMNS.index("scene")]
        found = self._suite_scene(name)
        if found is not None:
            block, index = found
            return block.make(index, "")
        block, index = self._files[name]
        scene = block.records[index]
        if self.spool is None:
            return scene
        ((shipped_scene, _),) = shipped([(scene, "")], self.spool)
        return shipped_scene

    def file_of(self, row: Sequence[str]) -> tuple[str, str] | None:
        """Where the scene file of a suite's row goes under DIR, and its
        text; None for a scenario file's row."""
        found = self._suite_scene(row[ROW_COLUMNS.index("scene")])
        if found is None:
            return None
        block, index = found
        return block.path(index), block.text(index)


def _digest(suite: Suite, first: str) -> str:
    """What a suite's block (@p suite with one family and profile) is run
    from: its definition, the generator's code and its first scene @p first."""
    family, profile = suite.families[0], suite.actuators[0]
    definition = {
        "suite": [suite.name, suite.path.name, suite.dt, str(suite.integrator)],
        "family": [
            family.name,
            family.kind,
            family.seed,
            {k: list(v) if isinstance(v, tuple) else v for k, v in family.draws.items()},
            {k: list(v) for k, v in family.imperfections.items()},
        ],
        "actuator": [profile.name, dict(profile.values)],
        "generator": _GENERATOR,
        "first": hashlib.sha256(first.encode()).hexdigest(),
    }
    return hashlib.sha256(json.dumps(definition, sort_keys=True).encode()).hexdigest()


@dataclass
class SweepResult:
    """What a sweep did."""

    runs: int
    """Rows in runs.csv."""
    ran: int
    """Runs made by this call (the rest were kept from a resumed one)."""
    make_cpu: float = 0.0
    """The workers' CPU time making (or unpickling) scenes [s]."""
    run_cpu: float = 0.0
    """The workers' CPU time running them [s]."""


REPORT_EVERY = 30.0
"""Seconds between two summaries written while a sweep runs."""


def run_sweep(
    plan: Plan,
    out: Path,
    lib: str,
    *,
    workers: int = 1,
    scheduler: str | None = None,
    resume: bool = False,
    engine: str = "batched",
    batch: int = BATCH,
    texts: bool = False,
    events: bool = False,
    rows: Callable[[list[Fields]], None] | None = None,
    progress: Callable[[int, int], None] | None = None,
    report: Callable[[], None] | None = None,
) -> SweepResult:
    """Run @p plan; write runs.csv (and the failures' scene files and
    events.json) under @p out as the rows come.

    :param workers: processes of the local pool (ignored with @p scheduler,
        but for the size of the slices).
    :param scheduler: a Dask scheduler's address, or None for the local pool.
    :param resume: keep the rows of DIR/runs.csv run from the same sources
        (DIR/sources.json, :meth:`Plan.keep`) and run only the others;
        otherwise start afresh.
    :param engine: :data:`mstc.sweep.engine.ENGINES`.
    :param batch: most runs a slice holds.
    :param texts: write every scene file of a suite (--write-scenes).
    :param events: write every run's events.json (--write-events).
    :param rows: called with the rows written, in order, as they are (the
        summary's :meth:`mstc.sweep.summary.Tally.add`).
    :param progress: called with (runs written, runs of the plan).
    :param report: called every :data:`REPORT_EVERY` seconds while it runs.

    :raises FirmwareError: a worker ran another firmware library than @p lib
        (different contents), so its rows would not be comparable.
    """
    out.mkdir(parents=True, exist_ok=True)
    local_sha = library_sha256(lib) if Path(lib).is_file() else ""
    keep = plan.keep(read_sources(out), local_sha) if resume else None
    result = SweepResult(plan.runs, 0)
    made: set[Path] = set()
    done = 0
    last_report = time.monotonic()

    def take(written: list[list[str]] | list[Fields]) -> None:
        nonlocal done
        if written and rows is not None:
            rows(list(written))
        done += len(written)

    with closing(RowFile(out / "runs.csv", ROW_COLUMNS, keep)) as table:
        # sources.json after runs.csv starts afresh: the rows kept are those
        # of the sources of now.
        write_sources(out, plan.sources(local_sha))
        result.ran = plan.runs - len(table.kept)
        # The rows kept before the first run to make: at once.
        missing = np.flatnonzero(table.kept != np.arange(len(table.kept)))
        take(table.copy_kept(int(missing[0]) if len(missing) else len(table.kept)))
        if progress:
            progress(done, plan.runs)

        def emit(task: Slice, got: SliceResult) -> None:
            nonlocal last_report
            if got.library and local_sha and got.library != local_sha:
                raise FirmwareError(
                    f"a worker ran a different firmware library (sha256 {got.library[:12]}…, "
                    f"here {local_sha[:12]}…): build the same sources on every machine"
                )
            for relative, text in got.files:
                path = out / relative
                if path.parent not in made:
                    path.parent.mkdir(parents=True, exist_ok=True)
                    made.add(path.parent)
                path.write_text(text)
            take(table.write(got.rows))
            take([fields for _, fields in got.rows])
            result.make_cpu += got.make_cpu
            result.run_cpu += got.run_cpu
            if progress:
                progress(done, plan.runs)
            if report is not None and time.monotonic() - last_report >= REPORT_EVERY:
                report()
                last_report = time.monotonic()

        def tasks(n: int) -> Iterator[Slice]:
            return plan.slices(
                n,
                table.kept,
                batch=batch,
                engine=engine,
                folder=str(out),
                texts=texts,
                events=events,
            )

        run_tasks(
            tasks,
            SweepWork(lib, engine),
            emit,
            workers=workers,
            scheduler=scheduler,
        )
        take(table.finish())
        if progress:
            progress(done, plan.runs)
    return result


def rerun(plan: Plan, lib: str, out: Path) -> Callable[[Sequence[str]], RunResult | None]:
    """Runs a row's scene again for the gallery (same scene, strategy and
    library) and writes its scene file (a suite's) and events.json under
    @p out: every run summary.md shows can be run alone."""

    def again(row: Sequence[str]) -> RunResult | None:
        scene = plan.scene(row)
        strategy = row[ROW_COLUMNS.index("strategy")]
        result = run_job(scene, strategy, lib)[0]
        where = plan.file_of(row)
        if where is not None:
            path = out / where[0]
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(where[1])
        if result is not None:
            path = out / _events_path(strategy, scene.name)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(events_json(result))
        return result

    return again
