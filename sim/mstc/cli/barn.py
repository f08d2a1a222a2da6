# SPDX-License-Identifier: MIT
"""``mstc barn``: BARN's 300 worlds (or any file of worlds in its format)
for several strategies, references, speeds and actuator profiles, on all
cores or a Dask cluster (docs/barn.md)."""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Sequence
from contextlib import closing
from pathlib import Path

from mstc.barn.run import (
    COLUMNS,
    FIRMWARE,
    IDEAL,
    REFERENCES,
    STRATEGIES,
    BarnWork,
    Task,
    plan,
    tasks,
    tracks,
)
from mstc.barn.summary import gallery, lines, picked_runs, table, worst
from mstc.barn.worlds import WORLDS, load_worlds, pick, published_dwa
from mstc.can.library import LIB_ENV
from mstc.cli import COMMANDS
from mstc.cli.common import ROOT, add_lib_argument, library
from mstc.errors import EXIT_OK, SuiteError, UsageError, writing
from mstc.report.progress import ProgressBar
from mstc.sweep.folder import locked
from mstc.sweep.jobs import check_scheduler, run_tasks
from mstc.sweep.rows import RowFile
from mstc.sweep.suite import load_suite

NAME = "barn"
HELP = COMMANDS[NAME]
PROFILES = ROOT / "sim" / "suites" / "standard.toml"
"""The suite whose [actuator.<name>] tables are the actuator profiles."""
ACTUATORS = ("ideal", "gearmotor", "sluggish")
"""The profiles of the standard suite, for --help."""

_EPILOG = f"""\
The worlds: BARN, the Benchmark for Autonomous Robot Navigation (Perille et
al., SSRR 2020; the BARN Challenge at ICRA), its 300 static worlds, which the
package carries with their licence notice; or --worlds FILE, one world a
line in the same JSON format (docs/barn.md). Each run starts the Jackal at
the world's start, follows the reference at --speed, waiting for the robot,
and ends within the goal radius (success), at the first contact (collision)
or after 100 s (timeout). Score: success × OT / clip(time, 2·OT, 8·OT), OT
the length of start, A* path, goal at 2 m/s.

references:
  line    the straight line from start to goal: no map (the paper's setting)
  path    the start, the world's A* path (the benchmark's map), the goal

strategies:
  paper   the paper's switch strategy in the firmware (batched engine)
  mstc    mstc's own strategy in the firmware (batched engine)
  dwa     the project's Dynamic Window Approach (Python, run by run: slow)

Writes under DIR:
  runs.csv      one row per world, strategy, reference, speed and actuator:
                status (success, collision, timeout; error when it could not
                run), time [s], score, clearance [m], unreported periods
  summary.md    rates and mean score per configuration, beside the published
                move_base DWA run; the gallery of the worst runs
  gallery/      the robot's path over the world, worst runs first, per strategy

exit status: 0 done (error rows included); 1 the firmware library could not
be loaded, the Dask scheduler cannot be reached, or an output could not be
written; 2 bad arguments, a bad worlds file or actuator profile, or DIR in
use by another run.

examples:
  .venv/bin/mstc barn --strategy paper,mstc --reference line,path --out build/barn
  .venv/bin/mstc barn --strategy mstc --only 0-9 --speed 0.5,1.0 --out build/barn-10
  .venv/bin/mstc barn --strategy mstc --sample 30 --seed 1 --actuator gearmotor
  .venv/bin/mstc barn --strategy dwa --reference line --scheduler tcp://10.0.0.5:8786

The library is built by `make lib`; without --lib it is read from {LIB_ENV},
else build/host/float/libmstc_sil.so.
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc barn``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Run BARN's worlds (or a file of worlds in its format) with the "
        "firmware's strategies and the DWA baseline, judge each run as the benchmark does, "
        "and summarise success, collision, timeout and score.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--worlds",
        metavar="FILE",
        type=Path,
        default=WORLDS,
        help="JSON-lines file of worlds (default: BARN's 300, carried by the package)",
    )
    parser.add_argument("--only", metavar="LIST", help="only these world numbers, e.g. 0,7,10-19")
    parser.add_argument(
        "--sample",
        metavar="N",
        type=int,
        help="N of the worlds (of --only's, if given), drawn with --seed",
    )
    parser.add_argument(
        "--seed", metavar="S", type=int, default=0, help="seed of --sample (default: %(default)s)"
    )
    parser.add_argument(
        "--strategy",
        default="paper,mstc",
        help=f"comma-separated, of {', '.join(STRATEGIES)} (default: %(default)s)",
    )
    parser.add_argument(
        "--reference",
        default=",".join(REFERENCES),
        help=f"comma-separated, of {', '.join(REFERENCES)} (default: %(default)s)",
    )
    parser.add_argument(
        "--speed",
        default="0.5",
        help="comma-separated reference speeds [m/s] (default: %(default)s)",
    )
    parser.add_argument(
        "--actuator",
        default=IDEAL,
        help="comma-separated actuator profiles of --profiles, e.g. "
        f"{', '.join(ACTUATORS)} (default: %(default)s)",
    )
    parser.add_argument(
        "--profiles",
        metavar="SUITE",
        type=Path,
        default=PROFILES,
        help="the suite whose [actuator.<name>] tables define the profiles "
        "(default: sim/suites/standard.toml of the source tree)",
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=Path("build/barn"),
        help="output folder (default: %(default)s)",
    )
    add_lib_argument(parser)
    parser.add_argument(
        "--workers",
        metavar="N",
        type=int,
        default=os.cpu_count() or 1,
        help="worker processes of the local pool (default: every core, %(default)s)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run on the Dask cluster of this scheduler instead of the local pool",
    )
    parser.add_argument(
        "--gallery",
        metavar="N",
        type=int,
        default=4,
        help="path figures of the N worst runs per strategy (default: %(default)s; 0: none)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    parser.set_defaults(run=run)


def _names(flag: str, text: str, known: Sequence[str]) -> list[str]:
    """The comma-separated names of @p flag, each one of @p known.

    :raises UsageError: none, or one not known.
    """
    names = list(dict.fromkeys(s.strip() for s in text.split(",") if s.strip()))
    unknown = [s for s in names if s not in known]
    if unknown or not names:
        raise UsageError(
            f"{flag}: unknown {', '.join(unknown) or '(none)'} (known: {', '.join(known)})"
        )
    return names


def _speeds(text: str) -> list[float]:
    """--speed's values.

    :raises UsageError: one that is not a speed > 0 (at most the Jackal's 2 m/s).
    """
    speeds = []
    for part in (p.strip() for p in text.split(",")):
        try:
            value = float(part)
        except ValueError:
            raise UsageError(f"--speed: {part!r} is not a number") from None
        if not 0.0 < value <= 2.0:
            raise UsageError(f"--speed: {part} is outside (0, 2] m/s (the Jackal's top speed)")
        speeds.append(value)
    return list(dict.fromkeys(speeds))


def _profiles(args: argparse.Namespace) -> dict[str, dict[str, float | int]]:
    """The [actuator] table of each profile of --actuator ("ideal" alone needs
    no suite).

    :raises UsageError: a profile the suite does not define, or a suite that
        cannot be read.
    """
    names = [s.strip() for s in args.actuator.split(",") if s.strip()]
    if not names:
        raise UsageError("--actuator: no profile named")
    if names == [IDEAL]:
        return {IDEAL: {}}
    try:
        suite = load_suite(args.profiles)
    except SuiteError as exc:
        raise UsageError(f"--profiles: {exc}") from exc
    known = {a.name: dict(a.values) for a in suite.actuators}
    known.setdefault(IDEAL, {})
    unknown = [n for n in names if n not in known]
    if unknown:
        raise UsageError(
            f"--actuator: no profile {', '.join(unknown)} in {args.profiles} "
            f"(profiles: {', '.join(sorted(known))})"
        )
    return {n: known[n] for n in dict.fromkeys(names)}


def run(args: argparse.Namespace) -> int:
    """Check the arguments, run, summarise."""
    strategies = _names("--strategy", args.strategy, STRATEGIES)
    references = _names("--reference", args.reference, REFERENCES)
    speeds = _speeds(args.speed)
    profiles = _profiles(args)
    if args.workers < 1:
        raise UsageError("--workers must be at least 1")
    if args.gallery < 0:
        raise UsageError("--gallery must be 0 or more")
    worlds = pick(load_worlds(args.worlds), args.only, args.sample, args.seed)
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    uses_firmware = any(s in FIRMWARE for s in strategies)
    lib = str(library(args.lib).resolve()) if uses_firmware else str(args.lib or "")
    planned = plan(worlds, strategies, references, speeds, list(profiles))
    work = BarnWork(lib, profiles)
    where = args.scheduler or f"{args.workers} local processes"
    print(
        f"barn: {len(worlds)} worlds of {args.worlds.name} × {', '.join(strategies)} × "
        f"{', '.join(references)} × {', '.join(f'{s:g}' for s in speeds)} m/s × "
        f"{', '.join(profiles)}: {len(planned):,} runs on {where}",
        flush=True,
    )
    with locked(args.out):
        rows: list[list[str]] = []
        bar = ProgressBar(len(planned), "barn", "runs", delay=0.5, enabled=not args.quiet)
        start = time.monotonic()
        with writing("runs.csv"):
            out = RowFile(args.out / "runs.csv", COLUMNS)
        with closing(out):

            def emit(task: Task, result: list[list[str]]) -> None:
                with writing("runs.csv"):
                    out.write((task.first + i, fields) for i, fields in enumerate(result))
                rows.extend(result)
                bar.update(len(rows))

            try:
                run_tasks(
                    lambda workers: tasks(planned, workers),
                    work,
                    emit,
                    workers=args.workers,
                    scheduler=args.scheduler,
                )
            finally:
                bar.close()
        elapsed = time.monotonic() - start
        by_index = {w.index: w for w in worlds}

        found = lines(rows)
        text = [
            f"# BARN: {len(worlds)} worlds of {args.worlds.name}",
            "",
            f"{len(rows):,} runs in {elapsed:.1f} s of wall time on {where}; firmware "
            f"{lib or 'none (dwa only)'}. Columns of runs.csv and the protocol: docs/barn.md.",
            "",
            *table(found, published_dwa()),
        ]
        with writing("the gallery"):
            picked = worst(rows, args.gallery)
            paths = tracks(picked_runs(picked, by_index), profiles, lib)
            shown = gallery(args.out, picked, by_index, paths)
        if shown:
            text += ["", f"## The {args.gallery} worst runs of each strategy", "", *shown]
        with writing("summary.md"):
            (args.out / "summary.md").write_text("\n".join(text) + "\n", encoding="utf-8")
    print("\n".join(table(found, None)))
    errors = sum(line.counts["error"] for line in found)
    print(f"{len(rows):,} runs in {elapsed:.1f} s; {errors} error rows")
    print(f"output: {args.out}/runs.csv, {args.out}/summary.md")
    return EXIT_OK
