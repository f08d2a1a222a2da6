# SPDX-License-Identifier: MIT
"""What every subcommand of ``mstc`` shares: exit statuses, the error line,
the firmware library's default, and loading scenario files."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from cantools.database.can import Database

from mstc.can import secoc
from mstc.can.dbc import tables
from mstc.can.protocol import DBC_PATH, load_database
from mstc.errors import (
    ControllerError,
    DbcError,
    FirmwareError,
    LogError,
    MstcError,
    ScenarioError,
)
from mstc.firmware import LIB_ENV
from mstc.logs.decode import DecodedLog, decode_log
from mstc.logs.read import FORMATS, FrameLog, ProblemList, read_log
from mstc.report.outputs import RUN_FILES, BusLog, OutputError, output_folder, write_outputs
from mstc.report.progress import Progress
from mstc.report.table import format_report
from mstc.sim.run import RunResult
from mstc.sim.scenario import Scenario, changed_params, load_scenario

EXIT_OK = 0
EXIT_FAILED = 1
"""The run failed: the firmware could not be run, its frames differ from a
log's, a send failed, or an output could not be written."""
EXIT_USAGE = 2
"""Bad arguments or bad input (a scenario file, a log): nothing was run."""
EXIT_NO_TARGET = 3
"""The firmware library cannot be loaded, or the bus cannot be opened."""
EXIT_INTERRUPTED = 130
"""Interrupted (Ctrl-C)."""

ROOT = Path(__file__).resolve().parents[3]
"""The repository, when the package runs from its source tree."""
DEFAULT_LIB: Path | None = (
    ROOT / "build" / "host" / "float" / "libmstc_sil.so"
    if (ROOT / "hal" / "sil" / "mstc_sil.h").is_file()
    else None
)
"""The float build (``make lib``), when neither --lib nor $MSTC_SIL_LIB names
one; None when the package is installed outside its source tree (no build
to default to)."""


def error(message: str) -> None:
    """Print one ``error: ...`` line on stderr."""
    print(f"error: {message}", file=sys.stderr)


def library(given: Path | None) -> Path:
    """The firmware library: @p given, else $MSTC_SIL_LIB, else :data:`DEFAULT_LIB`.

    :raises FirmwareError: none given and there is no default, or it does not exist.
    """
    if given is not None:
        return Path(given)
    env = os.environ.get(LIB_ENV)
    if env:
        return Path(env)
    if DEFAULT_LIB is None:
        raise FirmwareError(
            "no firmware library: this mstc is installed outside its source tree, so there "
            f"is no default build; name one with --lib PATH or {LIB_ENV} (`make lib` in the "
            "source tree builds build/host/float/libmstc_sil.so)"
        )
    if not DEFAULT_LIB.is_file():
        raise FirmwareError(
            f"no firmware library: {DEFAULT_LIB} does not exist; build it with `make lib`, "
            f"or name one with --lib PATH or {LIB_ENV}"
        )
    return DEFAULT_LIB


def add_key_argument(parser: argparse.ArgumentParser) -> None:
    """``--key-file``: the firmware's key for authenticated commands."""
    parser.add_argument(
        "--key-file",
        metavar="PATH",
        type=Path,
        help=f"the firmware's key, 32 hex digits (default: ${secoc.KEY_ENV} as hex digits, "
        f"else the file ${secoc.KEY_FILE_ENV}, else keys/device.key, which `make key` "
        "generates; docs/safety.md)",
    )


def load_key(args: argparse.Namespace) -> bytes | None:
    """The key ``--key-file`` or the defaults name; None after an error line."""
    try:
        return secoc.load_key(args.key_file)
    except secoc.AuthKeyError as exc:
        error(str(exc))
        return None


def load_all(paths: Sequence[Path], out: Path) -> list[Scenario] | None:
    """Every scenario, or None after printing each problem: a bad file, any two
    that would write the same output folder, a folder that cannot be written
    (:func:`~mstc.report.outputs.output_folder`)."""
    scenarios = []
    ok = True
    for path in paths:
        try:
            scenarios.append(load_scenario(path))
        except ScenarioError as exc:
            error(str(exc))
            ok = False
    seen: dict[str, Path] = {}
    for scenario in scenarios:
        first = seen.setdefault(scenario.name, scenario.path)
        if first != scenario.path:
            error(f"{first} and {scenario.path} would both write {out / scenario.name}/")
            ok = False
            continue
        try:
            output_folder(out, scenario.name, RUN_FILES)
        except OutputError as exc:
            error(f"{scenario.path}: {exc}")
            ok = False
    return scenarios if ok else None


def run_failure(scenario: Scenario, exc: BaseException) -> str:
    """The error line of a run that failed: the file first, and, when the
    firmware refused the parameters, the settings of the file's [params]."""
    text = f"{scenario.path}: {exc}"
    if isinstance(exc, FirmwareError | ControllerError) and "parameters" in str(exc):
        settings = changed_params(scenario.params)
        text += f" (the file sets {', '.join(settings)})" if settings else ""
    return text


RunOne = Callable[[Scenario, Progress], tuple[str, RunResult, "BusLog | None"]]
"""Runs one scenario, telling the progress display how far it is: (what
firmware ran, the result, the bus log if any)."""


def run_scenarios(
    paths: Sequence[Path],
    out: Path,
    figures: bool,
    run_one: RunOne,
    failures: tuple[type[BaseException], ...],
    *,
    quiet: bool = False,
) -> int:
    """Validate every scenario file, run each with @p run_one, then write each
    run's outputs under @p out and print its table. An :class:`MstcError` or
    an exception of @p failures ends the command with one error line naming
    the scenario's file (EXIT_FAILED).

    :param quiet: no progress display (a run longer than a second shows one).
    """
    scenarios = load_all(paths, out)
    if scenarios is None:
        return EXIT_USAGE
    results: list[tuple[RunResult, BusLog | None]] = []
    firmware = ""
    caught: tuple[type[BaseException], ...] = (MstcError, *failures)
    for scenario in scenarios:
        bar = Progress(scenario.sim.steps + 1, scenario.name, "steps", enabled=not quiet)
        try:
            firmware, result, log = run_one(scenario, bar)
        except caught as exc:
            error(run_failure(scenario, exc))
            return EXIT_FAILED
        results.append((result, log))
    print(f"firmware: {firmware}")
    for result, log in results:
        try:
            folder = write_outputs(result, out, log, figures=figures)
        except (OSError, OutputError) as exc:
            error(f"cannot write the outputs of {result.scenario.path}: {exc}")
            return EXIT_FAILED
        print()
        print(format_report(result, folder))
        if log is not None:
            print(f"  bus           {log.describe()}")
    return EXIT_OK


# -------------------------------------------------------------- bus logs


def add_log_arguments(
    parser: argparse.ArgumentParser, metavar: str = "LOG", what: str = "the bus log"
) -> None:
    """The log and how to read it (``mstc replay``, ``play``, ``plot``, ``export``)."""
    parser.add_argument("log", metavar=metavar, type=Path, help=what)
    parser.add_argument(
        "--format",
        choices=FORMATS,
        help="log format (default: by extension: .log candump -L, .asc, .blf)",
    )
    parser.add_argument(
        "--dbc",
        metavar="PATH",
        type=Path,
        default=DBC_PATH,
        help="the protocol's DBC (default: the one shipped in the package, firmware/comm/mstc.dbc)",
    )
    parser.add_argument(
        "--strict",
        action="store_true",
        help="any problem in the log is fatal (exit 2), not only a warning",
    )
    parser.add_argument(
        "--max-problems",
        metavar="N",
        type=int,
        default=20,
        help="print at most N problems of the log, then count the rest (default: %(default)s)",
    )
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="no progress display (long runs show one)"
    )


def load_decoded(args: argparse.Namespace) -> tuple[Database, DecodedLog] | int:
    """The DBC and the log, decoded (``mstc plot``, ``export``), with the
    problems of both printed; or an exit status."""
    loaded = load_log(args)
    if isinstance(loaded, int):
        return loaded
    db, log = loaded
    try:
        bar = Progress(len(log), "decode", "frames", enabled=not args.quiet)
        decoded = decode_log(log, db, bar, max_problems=max(args.max_problems, 0))
    except ValueError as exc:
        error(str(exc))
        return EXIT_USAGE
    print_problems(decoded.problems, args.log)
    if decoded.problems.total and args.strict:
        error(f"{args.log}: {decoded.problems.total:,} frames not decoded (--strict)")
        return EXIT_USAGE
    return db, decoded


def load_log(args: argparse.Namespace) -> tuple[Database, FrameLog] | int:
    """The DBC and the log, with its problems printed; or an exit status."""
    try:
        db = load_database(args.dbc)
    except Exception as exc:  # cantools raises several kinds on a bad DBC
        error(f"cannot load the DBC {args.dbc}: {exc}")
        return EXIT_USAGE
    try:
        tables(db)  # it names everything the Python side names (mstc.can.dbc)
    except DbcError as exc:
        error(str(exc))
        return EXIT_USAGE
    try:
        log = read_log(args.log, db, args.format, max_problems=max(args.max_problems, 0))
    except LogError as exc:
        error(str(exc))
        return EXIT_USAGE
    print_problems(log.problems, args.log)
    if log.problems.total and args.strict:
        error(f"{args.log}: {log.problems.total:,} problems in the log (--strict)")
        return EXIT_USAGE
    return db, log


def print_problems(problems: ProblemList, log: Path) -> None:
    """The problems kept, one a line on stderr, then how many more there are
    of each kind."""
    for problem in problems:
        print(problem, file=sys.stderr)
    rest = problems.total - len(problems)
    if rest > 0:
        counts = ", ".join(f"{n:,} {kind.value}" for kind, n in problems.counts.items())
        print(f"{log}: ... and {rest:,} more problems ({counts} in all)", file=sys.stderr)
