# SPDX-License-Identifier: MIT
"""What every subcommand of ``mstc`` shares: the firmware library's default,
the key, loading scenario files and bus logs, and running scenarios."""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import can
from cantools.database.can import Database

from mstc.can import secoc
from mstc.can.dbc import tables
from mstc.can.library import LIB_ENV
from mstc.can.protocol import DBC_PATH, load_database, wire_limits
from mstc.can.vmbridge import Bridge
from mstc.errors import (
    EXIT_OK,
    BusError,
    ControllerError,
    ExpectationError,
    FirmwareError,
    LogError,
    MstcError,
    RunError,
    UsageError,
)
from mstc.logs.decode import DecodedLog, decode_log, log_epoch
from mstc.logs.framelog import FrameLog, ProblemList
from mstc.logs.play import open_bus
from mstc.logs.read import FORMATS, read_log
from mstc.loop.result import RunResult
from mstc.plant.scenario import Scenario, changed_params, load_scenarios
from mstc.report.outputs import RUN_FILES, BusLog, folder_problem, write_outputs
from mstc.report.progress import ProgressBar
from mstc.report.table import format_report, missed

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


def find_library(given: Path | None) -> Path | None:
    """The firmware library: @p given, else $MSTC_SIL_LIB, else :data:`DEFAULT_LIB`
    when it exists; None when none of them names one."""
    if given is not None:
        return Path(given)
    env = os.environ.get(LIB_ENV)
    if env:
        return Path(env)
    if DEFAULT_LIB is not None and DEFAULT_LIB.is_file():
        return DEFAULT_LIB
    return None


def library(given: Path | None) -> Path:
    """The firmware library (:func:`find_library`).

    :raises FirmwareError: none given and there is no default, or it does not exist.
    """
    found = find_library(given)
    if found is not None:
        return found
    if DEFAULT_LIB is None:
        raise FirmwareError(
            "no firmware library: this mstc is installed outside its source tree, so there "
            f"is no default build; name one with --lib PATH or {LIB_ENV} (`make lib` in the "
            "source tree builds build/host/float/libmstc_sil.so)"
        )
    raise FirmwareError(
        f"no firmware library: {DEFAULT_LIB} does not exist; build it with `make lib`, "
        f"or name one with --lib PATH or {LIB_ENV}"
    )


def add_lib_argument(parser: argparse.ArgumentParser) -> None:
    """``--lib``: the firmware built as a shared library (:func:`library`)."""
    parser.add_argument(
        "--lib",
        metavar="PATH",
        type=Path,
        help=f"firmware shared library (default: ${LIB_ENV}, else build/host/float/libmstc_sil.so)",
    )


def add_bus_arguments(
    parser: argparse.ArgumentParser, default_interface: str, default_channel: str | None = None
) -> None:
    """The bus options python-can's and can-utils' users type: ``-i``/
    ``--interface``, ``-c``/``--channel``, ``-b``/``--bitrate`` (as
    python-can's ``can.player`` and ``can.logger`` take them)."""
    parser.add_argument(
        "-i",
        "--interface",
        default=default_interface,
        help="python-can interface: mstc-sil (the firmware in process), socketcan, slcan, "
        "virtual, ... (default: %(default)s)",
    )
    parser.add_argument(
        "-c",
        "--channel",
        default=default_channel,
        help="the interface's channel: vcan0, can0, /dev/ttyACM0, ... (default: "
        + (f"{default_channel})" if default_channel else "the interface's own)"),
    )
    parser.add_argument(
        "-b",
        "--bitrate",
        metavar="BIT/S",
        type=int,
        help="bit rate, for interfaces that set it (slcan, pcan, ...; socketcan takes the "
        "link's: `ip link set can0 type can bitrate 500000`)",
    )


def open_args_bus(
    args: argparse.Namespace, channel: str | None = None, **config: Any
) -> can.BusABC:
    """The bus of :func:`add_bus_arguments`' options (on @p channel instead
    of --channel when given), with the interface's other settings @p config.

    :raises BusError: it cannot be opened (says why).
    """
    if args.bitrate is not None:
        if args.bitrate <= 0:
            raise UsageError(f"--bitrate {args.bitrate}: a positive number of bit/s")
        config["bitrate"] = args.bitrate
    channel = channel or args.channel
    # Under tools/vm/with-vcan --bridge the vcan interface is the VM's,
    # reached through the bridge it made (docs/hil.md).
    bridge = Bridge.from_env(channel) if args.interface == "socketcan" else None
    if bridge is not None:
        return bridge.open_bus()
    return open_bus(args.interface, channel, **config)


def add_key_argument(parser: argparse.ArgumentParser) -> None:
    """``--key-file``: the firmware's key for authenticated commands."""
    parser.add_argument(
        "--key-file",
        metavar="PATH",
        type=Path,
        help=f"the firmware's key, 32 hex digits (default: ${secoc.KEY_ENV} as hex digits, "
        f"else the file ${secoc.KEY_FILE_ENV}, else keys/sim.key for a simulation (mstc "
        "sim, replay, hil --fw/--qemu) and keys/device.key for a board, which `make key` "
        "generates; docs/safety.md)",
    )


def load_all(paths: Sequence[Path], out: Path) -> list[Scenario]:
    """Every scenario, checked to be runnable: a valid file, no two that would
    write the same output folder, a folder that can be written
    (:func:`~mstc.report.outputs.output_folder`).

    :raises UsageError: one line per problem.
    """
    scenarios, problems = load_scenarios(paths, wire_limits())
    seen: dict[str, Path] = {}
    for scenario in scenarios:
        first = seen.setdefault(scenario.name, scenario.path)
        if first != scenario.path:
            problems.append(f"{first} and {scenario.path} would both write {out / scenario.name}/")
            continue
        problem = folder_problem(out, scenario.name, RUN_FILES)
        if problem is not None:
            problems.append(f"{scenario.path}: {problem}")
    if problems:
        raise UsageError("\n".join(problems))
    return scenarios


def run_failure(scenario: Scenario, exc: BaseException) -> str:
    """The error line of a run that failed: the file first, and, when the
    firmware refused the parameters, the settings of the file's [params]."""
    text = f"{scenario.path}: {exc}"
    if isinstance(exc, FirmwareError | ControllerError) and "parameters" in str(exc):
        settings = changed_params(scenario.params)
        text += f" (the file sets {', '.join(settings)})" if settings else ""
    return text


RunOne = Callable[[Scenario, ProgressBar], tuple[str, RunResult, "BusLog | None"]]
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
    slack: float = 0.0,
    stop_at: float | None = None,
) -> int:
    """Validate every scenario file, run each with @p run_one, then write each
    run's outputs under @p out and print its table; then judge each run
    against its scenario's expectations (:func:`~mstc.report.table.missed`).

    :param quiet: no progress display (a run longer than a second shows one).
    :param slack: how much further than its tolerance [s] an expected event
        may be (real time).
    :param stop_at: a comm-loss trial's time [s] (see
        :func:`~mstc.report.table.missed`).
    :raises UsageError: a scenario cannot be run (:func:`load_all`).
    :raises BusError: @p run_one could not open its bus.
    :raises RunError: a run failed with an :class:`MstcError` or an exception
        of @p failures: the error, named with the scenario's file.
    :raises WriteError: an output could not be written.
    :raises ExpectationError: a run missed its expectations (its outputs are
        written): one line per such run, naming its file.
    """
    scenarios = load_all(paths, out)
    results: list[tuple[RunResult, BusLog | None, int]] = []
    firmware = ""
    caught: tuple[type[BaseException], ...] = (MstcError, *failures)
    for scenario in scenarios:
        bar = ProgressBar(scenario.sim.steps + 1, scenario.name, "steps", enabled=not quiet)
        started = time.time_ns()
        try:
            firmware, result, log = run_one(scenario, bar)
        except BusError:
            raise  # the bus's fault, not the scenario's: it names the bus
        except caught as exc:  # named with its scenario, for main's one error line
            raise RunError(run_failure(scenario, exc)) from exc
        results.append((result, log, started))
    print(f"firmware: {firmware}")
    for result, log, started in results:
        folder = write_outputs(result, out, log, figures=figures, started_ns=started)
        print()
        print(format_report(result, folder))
        if log is not None:
            print(f"  bus           {log.describe()}")
    misses = [
        f"{result.scenario.path}: missed its expectations: {'; '.join(problems)}"
        for result, _, _ in results
        if (problems := missed(result, slack, stop_at))
    ]
    if misses:
        raise ExpectationError("\n".join(misses))
    return EXIT_OK


# -------------------------------------------------------------- bus logs


def add_log_arguments(
    parser: argparse.ArgumentParser,
    metavar: str = "LOG",
    what: str = "the bus log, or a run's folder (its bus.log is read)",
) -> None:
    """The log and how to read it (``mstc replay``, ``play``, ``plot``, ``export``):
    a bus log, or a run's folder, whose bus.log is read (:func:`run_log`)."""
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


def run_log(path: Path) -> Path:
    """The bus log @p path names: itself, or for a run's folder (what ``mstc
    sim`` and ``mstc hil`` write) the ``bus.log`` in it.

    :raises UsageError: a folder without a bus.log.
    """
    if not path.is_dir():
        return path
    if not (path / "bus.log").is_file():
        raise UsageError(f"{path} is a directory without a bus.log: not a run folder")
    return path / "bus.log"


def load_decoded(args: argparse.Namespace) -> tuple[Database, DecodedLog]:
    """The DBC and the log, decoded (``mstc plot``, ``export``), with the
    problems of both printed.

    :raises MstcError: see :func:`load_log`; :class:`LogError` also for a log
        without a control step, and with ``--strict`` for one with frames not
        decoded.
    """
    db, log = load_log(args)
    bar = ProgressBar(len(log), "decode", "frames", enabled=not args.quiet)
    decoded = decode_log(log, db, bar, max_problems=max(args.max_problems, 0))
    if len(log):
        decoded.epoch_ns = log_epoch(args.log, float(log.time[0]))
    print_problems(decoded.problems, args.log)
    if decoded.problems.total and args.strict:
        raise LogError(f"{args.log}: {decoded.problems.total:,} frames not decoded (--strict)")
    return db, decoded


def load_log(args: argparse.Namespace) -> tuple[Database, FrameLog]:
    """The DBC and the log, with its problems printed.

    :raises DbcLoadError: the DBC cannot be loaded.
    :raises DbcError: it lacks a name the Python side uses (:mod:`mstc.can.dbc`).
    :raises LogError: the log cannot be used, or with ``--strict`` has problems.
    :raises UsageError: a folder without a bus.log (:func:`run_log`).
    """
    args.log = run_log(args.log)
    db = load_database(args.dbc)
    tables(db)  # it names everything the Python side names (mstc.can.dbc)
    log = read_log(args.log, db, args.format, max_problems=max(args.max_problems, 0))
    print_problems(log.problems, args.log)
    if log.problems.total and args.strict:
        raise LogError(f"{args.log}: {log.problems.total:,} problems in the log (--strict)")
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
