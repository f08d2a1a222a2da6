# SPDX-License-Identifier: MIT
"""``mstc sweep``: many scenes, several strategies, on every core or a Dask
cluster (docs/sweeps.md)."""

from __future__ import annotations

import argparse
import os
import resource
import time
import tomllib
from dataclasses import replace
from pathlib import Path

from mstc.can.library import LIB_ENV
from mstc.can.protocol import wire_limits
from mstc.cli import COMMANDS
from mstc.cli.common import add_lib_argument, find_library, library
from mstc.errors import EXIT_OK, ScenarioError, UsageError, writing
from mstc.firmware.sil import SilController
from mstc.model import Params, WireLimits
from mstc.plant.scenario import Scenario, load_scenario, parse_scenario
from mstc.report.progress import ProgressBar
from mstc.sweep.engine import BATCH, ENGINES, STRATEGIES, Scene
from mstc.sweep.folder import clear, locked, text_sha256
from mstc.sweep.jobs import check_scheduler
from mstc.sweep.plan import Plan, rerun, run_sweep
from mstc.sweep.spool import Spool
from mstc.sweep.suite import MAX_COUNT, Suite, generate, is_suite, load_suite
from mstc.sweep.summary import Tally

NAME = "sweep"
HELP = COMMANDS[NAME]

_EPILOG = f"""\
INPUT is a suite file (a TOML file with [family.<name>] tables), a scenario
file, or a folder of scenario files (every *.toml below it). Formats:
docs/sweeps.md (suites), docs/scenarios.md (scenarios). A suite's scenes are
made where they run, by the workers, from the suite's numbers; the client
sends slices of them and gets rows back.

Writes under DIR, as the rows come:
  runs.csv          one row per scene and strategy (columns: docs/sweeps.md),
                    in plan order (scene, then strategy)
  summary.md        rates with 95 % Wilson intervals and medians per family,
                    actuator and strategy, histograms (clearance.png,
                    tracking_error.png) and the runs of smallest clearance
                    (gallery/); while the sweep runs, its counts so far
  scenes/<family>/<scene>.toml and <strategy>/<scene>/events.json
                    of every failure (an error row, a contact) and every
                    gallery run, so that each can be run alone; of every
                    run with --write-scenes and --write-events
  sources.json      what the rows were run from (--resume)

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
from the same suites, scene files and library (DIR/sources.json) and runs the
rest. Without --resume (and --generate-only), what an earlier sweep wrote
into DIR (the files above, the strategies' folders) is removed first, so that DIR holds one
sweep; other files are left alone. One sweep at a time writes DIR (a lock on
DIR/.lock): another is refused. Every scenario file, and the first scene of each family of a suite,
is validated before anything runs.

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
    add_lib_argument(parser)
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
        help="most runs (a scene under one strategy each) of a slice, which a worker makes "
        "and, with the batched engine, steps together; a worker's memory grows with it, not "
        "with the scenes' length (default: %(default)s)",
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
        "--write-scenes",
        action="store_true",
        help="write every scene file of the suites into DIR/scenes/ as it runs (by default "
        "only those of the failures and of the gallery)",
    )
    parser.add_argument(
        "--write-events",
        action="store_true",
        help="write every run's DIR/<strategy>/<scene>/events.json (by default only those "
        "of the failures and of the gallery)",
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


def _suite(path: Path, args: argparse.Namespace) -> Suite:
    """The suite file @p path with --count, its --family and --actuator
    names checked.

    :raises UsageError: an unknown family or actuator profile.
    :raises SuiteError: a bad suite file.
    """
    suite = load_suite(path)
    if args.count is not None:
        suite = replace(suite, families=tuple(replace(f, count=args.count) for f in suite.families))
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
    return suite


def _generate(args: argparse.Namespace) -> int:
    """--generate-only: write the suites' scene files.

    :raises UsageError: an input that is not a suite.
    """
    written = 0
    for path in args.inputs:
        if path.is_dir() or not (path.is_file() and is_suite(path)):
            raise UsageError(
                f"{path}: not a suite file (no [family.<name>] table): --generate-only "
                "writes the scenes of suites"
            )
        suite = _suite(path, args)
        wanted = tuple(args.family) if args.family else None
        chosen = tuple(args.actuator) if args.actuator else None
        with writing("the scene files"):
            written += len(generate(suite, args.out / "scenes", wanted, chosen))
    print(f"{written} scene files in {args.out / 'scenes'}/")
    return EXIT_OK


def _plan(args: argparse.Namespace, strategies: list[str], spool: Spool) -> tuple[Plan, list[str]]:
    """The sweep's plan from the inputs, in order: a suite's blocks (the
    first scene of each made and checked here), scenario files read, parsed
    and validated (into @p spool); and the suites' names.

    :raises UsageError: a folder without scenario files, a scene that is not
        valid, names two scenes would share (every problem, one a line).
    :raises SuiteError: a bad suite file.
    """
    plan = Plan(strategies, spool)
    problems: list[str] = []
    suites: list[str] = []
    files: list[Path] = []

    def add_files() -> None:
        records, bad = _load(files, spool)
        problems.extend(bad)
        problems.extend(plan.add_scenes(records))
        files.clear()

    for path in args.inputs:
        if path.is_dir():
            found = sorted(p for p in path.rglob("*.toml") if p.is_file())
            if not found:
                raise UsageError(f"{path}: no scenario files (*.toml) in this folder")
            files += found
        elif path.is_file() and is_suite(path):
            add_files()
            suite = _suite(path, args)
            suites.append(suite.name)
            wanted = tuple(args.family) if args.family else None
            chosen = tuple(args.actuator) if args.actuator else None
            problems += plan.add_suite(suite, str(path), wanted, chosen)
        else:
            files.append(path)
    add_files()
    problems += plan.problems()
    if problems:
        raise UsageError("\n".join(problems))
    return plan, suites


def _load(files: list[Path], spool: Spool) -> tuple[list[Scene], list[str]]:
    """Every scenario file validated (each read and parsed once), and the
    problem of each that is not. A valid scene's parsed scenario goes into
    @p spool; the scene is its record (:meth:`Scene.from_scenario`)."""
    wire = wire_limits()
    scenes, problems = [], []
    for path in files:
        try:
            text, scenario = _read(path, wire)
        except ScenarioError as exc:
            problems.append(str(exc))
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


def run(args: argparse.Namespace) -> int:
    """Plan, run, summarise."""
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
        if args.generate_only:
            return _generate(args)
        if not args.resume:  # the folder holds this sweep alone, none of an earlier one's
            clear(args.out, STRATEGIES)
        with writing("the sweep's spool"):
            spool = Spool(args.out)
        with spool:
            plan, suites = _plan(args, strategies, spool)
            return _run(args, plan, suites)


def _run(args: argparse.Namespace, plan: Plan, suites: list[str]) -> int:
    """Run @p plan, write the summary, print the counts."""
    strategies = list(plan.strategies)
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
        f"sweep: {plan.scenes:,} scenes × {', '.join(strategies)} on {where}, engine "
        f"{args.engine}; firmware {firmware}",
        flush=True,
    )
    title = ", ".join(suites) or ", ".join(str(p) for p in args.inputs)
    tally = Tally(strategies, args.gallery)

    def report() -> None:
        tally.write(args.out, title=title, firmware=firmware, total=plan.runs)

    bar = ProgressBar(plan.runs, "sweep", "runs", delay=0.5, enabled=not args.quiet)
    start, cpu = time.monotonic(), time.process_time()
    try:
        with writing("the outputs"):
            result = run_sweep(
                plan,
                args.out,
                lib,
                workers=args.jobs,
                scheduler=args.scheduler,
                resume=args.resume,
                engine=args.engine,
                batch=args.batch,
                texts=args.write_scenes,
                events=args.write_events,
                rows=tally.add,
                progress=lambda done, total: bar.update(done),
                report=report,
            )
    finally:
        bar.close()
    elapsed = time.monotonic() - start
    with writing("the summary"):
        tally.finish(args.out / "runs.csv")
        summary = tally.write(
            args.out, title=title, firmware=firmware, rerun=rerun(plan, lib, args.out)
        )
    print("\n".join(tally.table()))
    print(
        f"{result.runs} runs ({result.ran} run now, {result.runs - result.ran} resumed) "
        f"in {elapsed:.1f} s; {tally.error_count} error rows"
    )
    here = time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(
        f"CPU: {result.make_cpu:.1f} s making scenes and {result.run_cpu:.1f} s running them "
        f"(the workers), {here:.1f} s writing the outputs and the summary (this process, "
        f"whose peak resident memory was {peak:.0f} MiB)"
    )
    print(f"output: {args.out}/runs.csv, {summary}")
    return EXIT_OK
