# SPDX-License-Identifier: MIT
"""What every subcommand of ``mstc`` shares: exit statuses, the error line,
the firmware library's default, and loading scenario files."""

from __future__ import annotations

import argparse
import os
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path

from cantools.database.can import Database

from mstc.can import secoc
from mstc.can.protocol import DBC_PATH, load_database
from mstc.errors import FirmwareError, LogError, ScenarioError
from mstc.firmware import LIB_ENV
from mstc.logs.read import FORMATS, FrameLog, read_log
from mstc.report.outputs import BusLog, write_outputs
from mstc.report.table import format_report
from mstc.sim.run import RunResult
from mstc.sim.scenario import Scenario, load_scenario

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
DEFAULT_LIB = ROOT / "build" / "host" / "float" / "libmstc_sil.so"
"""The float build (``make lib``), when neither --lib nor $MSTC_SIL_LIB names one."""


def error(message: str) -> None:
    """Print one ``error: ...`` line on stderr."""
    print(f"error: {message}", file=sys.stderr)


def library(given: Path | None) -> Path:
    """The firmware library: @p given, else $MSTC_SIL_LIB, else :data:`DEFAULT_LIB`.

    :raises FirmwareError: none given and the default does not exist.
    """
    if given is not None:
        return Path(given)
    env = os.environ.get(LIB_ENV)
    if env:
        return Path(env)
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
    """Every scenario, or None after printing each problem (and any two that
    would write the same output folder)."""
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
    return scenarios if ok else None


RunOne = Callable[[Scenario], tuple[str, RunResult, "BusLog | None"]]
"""Runs one scenario: (what firmware ran, the result, the bus log if any)."""


def run_scenarios(
    paths: Sequence[Path],
    out: Path,
    figures: bool,
    run_one: RunOne,
    failures: tuple[type[BaseException], ...],
) -> int:
    """Validate every scenario file, run each with @p run_one, then write each
    run's outputs under @p out and print its table. An exception of
    @p failures ends the command with one error line (EXIT_FAILED)."""
    scenarios = load_all(paths, out)
    if scenarios is None:
        return EXIT_USAGE
    results: list[tuple[RunResult, BusLog | None]] = []
    firmware = ""
    try:
        for scenario in scenarios:
            firmware, result, log = run_one(scenario)
            results.append((result, log))
    except failures as exc:
        error(str(exc))
        return EXIT_FAILED
    print(f"firmware: {firmware}")
    for result, log in results:
        try:
            folder = write_outputs(result, out, log, figures=figures)
        except OSError as exc:
            error(f"cannot write the outputs of {result.scenario.path}: {exc}")
            return EXIT_FAILED
        print()
        print(format_report(result, folder))
        if log is not None:
            print(f"  bus           {log.describe()}")
    return EXIT_OK


# -------------------------------------------------------------- bus logs


def add_log_arguments(parser: argparse.ArgumentParser) -> None:
    """The log and how to read it (``mstc replay``, ``play``, ``plot``)."""
    parser.add_argument("log", metavar="LOG", type=Path, help="the bus log")
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
        help="the protocol's DBC (default: firmware/comm/mstc.dbc)",
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


def load_log(args: argparse.Namespace) -> tuple[Database, FrameLog] | int:
    """The DBC and the log, with its problems printed; or an exit status."""
    try:
        db = load_database(args.dbc)
    except Exception as exc:  # cantools raises several kinds on a bad DBC
        error(f"cannot load the DBC {args.dbc}: {exc}")
        return EXIT_USAGE
    try:
        log = read_log(args.log, db, args.format)
    except LogError as exc:
        error(str(exc))
        return EXIT_USAGE
    problems = log.problems
    for problem in problems[: max(args.max_problems, 0)]:
        print(problem, file=sys.stderr)
    rest = len(problems) - max(args.max_problems, 0)
    if rest > 0:
        kinds = Counter(p.kind.value for p in problems)
        counts = ", ".join(f"{n} {kind}" for kind, n in kinds.items())
        print(f"{args.log}: ... and {rest} more problems ({counts} in all)", file=sys.stderr)
    if problems and args.strict:
        error(f"{args.log}: {len(problems)} problems in the log (--strict)")
        return EXIT_USAGE
    return db, log
