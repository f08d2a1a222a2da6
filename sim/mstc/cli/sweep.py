# SPDX-License-Identifier: MIT
"""``mstc sweep``: many scenes, several strategies, on every core or a Dask
cluster (docs/sweeps.md)."""

from __future__ import annotations

import argparse
import os
import sys
import time
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

from mstc.can.library import LIB_ENV
from mstc.can.protocol import wire_limits
from mstc.cli.common import find_library, library
from mstc.errors import EXIT_OK, ScenarioError, SuiteError, UsageError, writing
from mstc.firmware.sil import SilController
from mstc.loop.result import RunResult
from mstc.model import Params, WireLimits
from mstc.plant.scenario import Scenario, load_scenario, parse_scenario
from mstc.report.progress import ProgressBar
from mstc.sweep.engine import (
    BATCH,
    ENGINES,
    STRATEGIES,
    Scene,
    check_scheduler,
    run_job,
    run_sweep,
    shipped,
)
from mstc.sweep.folder import locked, text_sha256
from mstc.sweep.spool import Spool
from mstc.sweep.suite import MAX_COUNT, Family, Suite, generate, is_suite, load_suite
from mstc.sweep.summary import runs_of, write_summary

NAME = "sweep"
HELP = "run scenario files or suites for several strategies, on all cores or a Dask cluster"

_EPILOG = f"""\
INPUT is a suite file (a TOML file with [family.<name>] tables: its scenes
are generated into DIR/scenes/<family>/ first), a scenario file, or a folder
of scenario files (every *.toml below it). Formats: docs/sweeps.md (suites),
docs/scenarios.md (scenarios).

Writes under DIR:
  <strategy>/<scene>/events.json  exactly as `mstc sim` writes it
  runs.csv                        one row per scene and strategy (columns:
                                  docs/sweeps.md); appended as runs finish,
                                  rewritten in order at the end
  summary.md                      rates with 95 % Wilson intervals and
                                  medians per family and strategy, histograms
                                  (clearance.png, tracking_error.png) and the
                                  runs of smallest clearance (gallery/)
  sources.json                    the sha256 of each scene's text and of the
                                  library the rows were run with (--resume)

strategies:
  paper   the paper's switch strategy in the firmware (in memory, C step)
  mstc    mstc's own strategy in the firmware
  dwa     the Dynamic Window Approach baseline (Python, mstc.sweep.dwa)

engines (the firmware's strategies; dwa always runs scene by scene):
  batched the default: a batch of scenes steps together, the plant (ideal
          or "lag" wheels) as numpy arrays, the firmware's step for all of
          them in one call (mstc_sil_step_batch); the metrics are computed as
          the runs go; scenes on "dc" wheels run scene by scene
  scene   each scene alone through the lock-step loop, judged from its trace:
          the reference the batched engine is compared with (docs/sweeps.md)

A scene that fails (an exception, a non-finite state, a worker that dies) is
a row with its error, never the end of the sweep. Interrupted, the sweep goes
on where it stopped with --resume (same DIR and inputs): it keeps the rows run
from the same scene files and library (DIR/sources.json) and runs the rest.
One sweep at a time writes DIR (a lock on DIR/.lock): another is refused.
Every scene is validated before anything runs; parsed, it waits on disk (an
unnamed file in DIR, gone when the sweep ends) until its batch is sent, so
the sweep holds a small record a scene, not the scenes (docs/sweeps.md,
"Memory").

exit status: 0 done (error rows included); 1 the firmware library could not
be loaded or differs between workers, the Dask scheduler cannot be reached,
or an output could not be written; 2 bad arguments, a bad suite or scenario
file, or DIR in use by another sweep.

examples:
  .venv/bin/mstc sweep --strategy paper,dwa --out build/sweep/standard \\
      sim/suites/standard.toml
  .venv/bin/mstc sweep --count 20 --family cluster sim/suites/standard.toml
  .venv/bin/mstc sweep --scheduler tcp://10.0.0.5:8786 sim/suites/standard.toml

The library is built by `make lib`; without --lib it is read from {LIB_ENV},
else build/host/float/libmstc_sil.so. Every worker loads it itself (on a
cluster: the same path, or the worker's own {LIB_ENV}; its contents must be
the same, which the sweep checks).
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc sweep``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Run many scenes through the firmware's control step in memory (and the "
        "DWA baseline), in parallel, and summarise how often each strategy touches an "
        "obstacle, keeps D_s, rejoins its reference or is blocked.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "inputs", metavar="INPUT", nargs="+", type=Path, help="suite, scenario or folder"
    )
    parser.add_argument(
        "--strategy",
        default=",".join(STRATEGIES),
        help="comma-separated strategies to run each scene with (default: %(default)s)",
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=Path("build/sweep"),
        help="output folder (default: %(default)s)",
    )
    parser.add_argument(
        "--lib",
        metavar="PATH",
        type=Path,
        help=f"firmware shared library (default: ${LIB_ENV}, else build/host/float/libmstc_sil.so)",
    )
    parser.add_argument(
        "--jobs",
        metavar="N",
        type=int,
        default=os.cpu_count() or 1,
        help="worker processes of the local pool (default: every core, %(default)s)",
    )
    parser.add_argument(
        "--engine",
        choices=ENGINES,
        default=ENGINES[0],
        help="how the firmware's strategies run (default: %(default)s; see below)",
    )
    parser.add_argument(
        "--batch",
        metavar="N",
        type=int,
        default=BATCH,
        help="most runs (a scene under one strategy each) a batch of the batched engine "
        "steps together; a worker's memory "
        "grows with it, not with the scenes' length, and so does the client's, which sends "
        "two batches a worker at a time (default: %(default)s)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run on the Dask cluster of this scheduler instead of the local pool",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="keep DIR/runs.csv's finished runs and run only the rest",
    )
    parser.add_argument(
        "--generate-only",
        action="store_true",
        help="write the suites' scene files into DIR/scenes/ and stop",
    )
    parser.add_argument(
        "--family",
        metavar="NAME",
        action="append",
        help="only this family of the suites (repeatable)",
    )
    parser.add_argument(
        "--actuator",
        metavar="NAME",
        action="append",
        help="only this actuator profile of the suites (repeatable; default: all)",
    )
    parser.add_argument(
        "--count",
        metavar="N",
        type=int,
        help=f"scenes per family instead of the suite's counts (1 to {MAX_COUNT:,})",
    )
    parser.add_argument(
        "--gallery",
        metavar="N",
        type=int,
        default=6,
        help="path figures of the N runs of smallest clearance per strategy (default: %(default)s)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    parser.set_defaults(run=run)


Origins = dict[Path, tuple[Path, str]]
"""A generated scene file -> its suite file and family."""


def _scene_files(args: argparse.Namespace) -> tuple[list[Path], list[Suite], Origins]:
    """The scenario files to run (suites generated first), and where the
    generated ones come from.

    :raises UsageError: a folder without scenario files, an unknown family,
        with --generate-only an input that is not a suite.
    :raises SuiteError: a bad suite file.
    :raises WriteError: the scene files cannot be written.
    """
    files: list[Path] = []
    suites: list[Suite] = []
    origins: Origins = {}
    for path in args.inputs:
        if path.is_dir():
            found = sorted(p for p in path.rglob("*.toml") if p.is_file())
            if not found:
                raise UsageError(f"{path}: no scenario files (*.toml) in this folder")
            files += found
        elif path.is_file() and is_suite(path):
            suite = load_suite(path)
            if args.count is not None:
                suite = replace(
                    suite, families=tuple(_with_count(f, args.count) for f in suite.families)
                )
            known = {f.name for f in suite.families}
            for name in args.family or ():
                if name not in known:
                    families = ", ".join(sorted(known))
                    raise UsageError(f"{path}: no family {name!r} (families: {families})")
            profiles = {a.name for a in suite.actuators}
            for name in args.actuator or ():
                if name not in profiles:
                    names = ", ".join(sorted(profiles))
                    raise UsageError(f"{path}: no actuator {name!r} (actuators: {names})")
            wanted = tuple(args.family) if args.family else None
            chosen = tuple(args.actuator) if args.actuator else None
            with writing("the scene files"):
                scenes = generate(suite, args.out / "scenes", wanted, chosen)
            files += [f.path for f in scenes]
            origins.update((f.path, (path, f.family)) for f in scenes)
            suites.append(suite)
        elif args.generate_only:
            raise UsageError(
                f"{path}: not a suite file (no [family.<name>] table): --generate-only "
                "writes the scenes of suites"
            )
        else:
            files.append(path)
    return files, suites, origins


def _load(files: list[Path], origins: Origins, spool: Spool) -> tuple[list[Scene], list[str]]:
    """Every scene validated (each file read and parsed once), and the
    problem of each that is not: a generated scene's named with its suite and
    family (docs/sweeps.md), since the suite is what to change. A valid
    scene's parsed scenario goes into @p spool; the scene is its record
    (:meth:`Scene.from_scenario`)."""
    wire = wire_limits()
    scenes, problems = [], []
    for path in files:
        try:
            text, scenario = _read(path, wire)
        except ScenarioError as exc:
            if path not in origins:
                problems.append(str(exc))
                continue
            suite, family = origins[path]
            where = f"scene {path.stem}: {exc.key}" if exc.key else f"scene {path.stem}"
            problems.append(
                str(SuiteError(str(suite), f"family.{family}", f"{where}: {exc.problem}"))
            )
            continue
        # The text as Path.read_text gives it (universal newlines), the
        # digest DIR/sources.json has always held.
        lines = text.replace("\r\n", "\n").replace("\r", "\n")
        scene = Scene.from_scenario(scenario, text_sha256(lines))
        if scene.name not in spool:
            spool.add(scene.name, scenario)
        scenes.append(scene)
    return scenes, problems


def _read(path: Path, wire: WireLimits) -> tuple[str, Scenario]:
    """A scenario file's text and the text parsed.

    :raises ScenarioError: the file cannot be read, is not TOML or not a
        valid scenario (:func:`load_scenario`'s words).
    """
    try:
        text = path.read_bytes().decode("utf-8")
        data = tomllib.loads(text)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        load_scenario(path, wire)  # says what is wrong, in its words
        raise ScenarioError(str(path), None, f"changed while read ({exc})") from exc
    return text, parse_scenario(data, str(path), wire)


def _with_count(family: Family, count: int) -> Family:
    return replace(family, count=count)


def run(args: argparse.Namespace) -> int:
    """Generate, validate, run, summarise."""
    strategies = [s.strip() for s in args.strategy.split(",") if s.strip()]
    unknown = [s for s in strategies if s not in STRATEGIES]
    if unknown or not strategies:
        raise UsageError(
            f"--strategy: unknown {', '.join(unknown) or '(none)'} (known: {', '.join(STRATEGIES)})"
        )
    if args.jobs < 1:
        raise UsageError("--jobs must be at least 1")
    if args.batch < 1:
        raise UsageError("--batch must be at least 1")
    if args.count is not None and not 1 <= args.count <= MAX_COUNT:
        raise UsageError(f"--count: expected 1 to {MAX_COUNT:,} scenes a family, got {args.count}")
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    with locked(args.out):  # one sweep at a time in a folder
        return _sweep(args, strategies)


def _sweep(args: argparse.Namespace, strategies: list[str]) -> int:
    if args.generate_only:
        files, _, _ = _scene_files(args)
        print(f"{len(files)} scene files in {args.out / 'scenes'}/")
        return EXIT_OK
    with writing("the sweep's spool"):
        spool = Spool(args.out)
    with spool:
        scenes, suites = _validated(args, spool)
        return _run(args, strategies, scenes, suites, spool)


def _validated(args: argparse.Namespace, spool: Spool) -> tuple[list[Scene], list[Suite]]:
    """Every scene of the inputs validated here, before anything runs, like
    `mstc sim`; parsed, it waits in @p spool until its batch is sent. The
    scenes' records and the suites.

    :raises UsageError: a scene is not valid, or two would write one folder
        (every problem, one a line).
    """
    files, suites, origins = _scene_files(args)
    scenes, problems = _load(files, origins, spool)
    seen: dict[str, str] = {}
    for scene in scenes:
        first = seen.setdefault(scene.name, scene.source)
        if first != scene.source:
            problems.append(
                f"{first} and {scene.source} would both write {args.out}/<strategy>/{scene.name}/"
            )
    if problems:
        raise UsageError("\n".join(problems))
    return scenes, suites


def _run(
    args: argparse.Namespace,
    strategies: list[str],
    scenes: list[Scene],
    suites: list[Suite],
    spool: Spool,
) -> int:
    """Run the validated @p scenes (records; their scenarios in @p spool)."""

    # The DWA baseline alone needs no firmware library.
    given = library(args.lib) if set(strategies) != {"dwa"} else find_library(args.lib)
    if given is not None:
        # Absolute: workers (and a cluster's) may run in another directory.
        lib = str(given.resolve())
        firmware = f"{given} ({SilController(Params(), lib).numeric})"
    else:
        lib, firmware = str(args.lib or ""), "none (dwa only)"

    where = args.scheduler or f"{args.jobs} local processes"
    print(
        f"sweep: {len(scenes)} scenes × {', '.join(strategies)} on {where}, engine "
        f"{args.engine}; firmware {firmware}"
    )
    bar = ProgressBar(
        len(scenes) * len(strategies), "sweep", "runs", delay=0.5, enabled=not args.quiet
    )
    start = time.monotonic()
    try:
        with writing("the outputs"):
            result = run_sweep(
                scenes,
                strategies,
                args.out,
                lib,
                workers=args.jobs,
                scheduler=args.scheduler,
                resume=args.resume,
                progress=lambda done, total: bar.update(done),
                engine=args.engine,
                batch=args.batch,
                spool=spool,
            )
    finally:
        bar.close()
    elapsed = time.monotonic() - start

    by_name = {s.name: s for s in scenes}

    def rerun(row: Mapping[str, str]) -> RunResult | None:
        ((scene, strategy),) = shipped([(by_name[row["scene"]], row["strategy"])], spool)
        return run_job(scene, strategy, lib)[0]

    title = ", ".join(s.name for s in suites) or ", ".join(str(p) for p in args.inputs)
    with writing("the summary"):
        summary = write_summary(
            result.rows,
            strategies,
            args.out,
            title=title,
            firmware=firmware,
            gallery=args.gallery,
            rerun=rerun,
        )
    _print_table(result.rows, strategies)
    errors = sum(1 for r in result.rows if r["error"])
    print(
        f"{len(result.rows)} runs ({result.ran} run now, {len(result.rows) - result.ran} resumed) "
        f"in {elapsed:.1f} s; {errors} error rows"
    )
    print(f"output: {args.out}/runs.csv, {summary}")
    return EXIT_OK


def _print_table(rows: Sequence[Mapping[str, str]], strategies: list[str]) -> None:
    groups = list(dict.fromkeys((r["family"] or "(none)", r["actuator"] or "ideal") for r in rows))
    line = "  {:<16} {:<10} {:<9} {:>5} {:>8} {:>9} {:>9} {:>8} {:>7}"
    print(
        line.format(
            "family",
            "actuator",
            "strategy",
            "runs",
            "contact",
            "D_s kept",
            "rejoined",
            "blocked",
            "errors",
        )
    )
    for family, actuator in groups:
        for strategy in strategies:
            mine = runs_of(rows, family, actuator, strategy)
            if not mine:
                continue
            ok = [r for r in mine if not r["error"]]

            def count(column: str, rows: list[Mapping[str, str]] = ok) -> int:
                return sum(1 for r in rows if r[column] == "1")

            free = [r for r in ok if r["blocked"] == "0" and r["rejoined"] != ""]
            print(
                line.format(
                    family,
                    actuator,
                    strategy,
                    len(mine),
                    count("contact"),
                    count("ds_kept"),
                    f"{count('rejoined', free)}/{len(free)}",
                    count("blocked"),
                    len(mine) - len(ok),
                )
            )
    sys.stdout.flush()
