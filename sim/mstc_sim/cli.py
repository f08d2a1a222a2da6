# SPDX-License-Identifier: MIT
"""Command line: ``python -m mstc_sim run SCENARIO.toml...``."""

import argparse
import os
import select
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import can

from mstc_sim.canctl import CanController, ControllerError
from mstc_sim.firmware import LIB_ENV, FirmwareError, SilController
from mstc_sim.output import BusLog, write_outputs
from mstc_sim.report import format_report
from mstc_sim.run import RunResult, simulate
from mstc_sim.scenario import Scenario, ScenarioError, load_scenario

EXIT_OK = 0
EXIT_FAILED = 1
"""The firmware could not be loaded or run, or the outputs not written."""
EXIT_USAGE = 2
"""Bad command line or bad scenario file: nothing was run or written."""

_RUN_EPILOG = f"""\
Each scenario writes DIR/<file stem>/: events.json, trace.csv and the figures
path.png, position_error.png, angle_error.png, v.png, w.png, distance.png and
overview.png; through CAN (--bus sil or socketcan) also bus.log, every frame
in candump -L format. The table printed for each lists the switching events beside
the scenario's [[expected]] times, the difference in control steps, and the
minimum distance to each obstacle against D_s. The format of scenario files
is in docs/scenarios.md.

Every scenario is validated before any runs: a bad file prints one line
(file, key, problem) and nothing is written.

exit status: 0 done; 1 the firmware library failed or an output could not be
written; 2 bad arguments or a bad scenario file.

buses:
  sil        the firmware in process behind CAN frames: python-can's interface
             "mstc-sil" around libmstc_sil.so (default)
  memory     the firmware's control step called directly, no frames: the
             reference the frame path is compared against
  socketcan  python-can's socketcan interface on --channel, where mstc-fw or
             a board runs (see docs/hil.md)

example:
  .venv/bin/python -m mstc_sim run --lib build/host/float/libmstc_sil.so \\
      sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml

The library is built by `make lib`; without --lib it is read from {LIB_ENV}.
"""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``python -m mstc_sim``."""
    parser = argparse.ArgumentParser(
        prog="python -m mstc_sim",
        description="Kinematic plant of mstc: runs scenarios in closed loop with the "
        "firmware's controller and writes events, traces and figures.",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    run = commands.add_parser(
        "run",
        help="run scenario files against the firmware",
        description="Run scenario files in closed loop against the firmware: in process "
        "through CAN frames (default), in memory, or over SocketCAN.",
        epilog=_RUN_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run.add_argument(
        "--lib",
        metavar="PATH",
        type=Path,
        help=f"firmware shared library (default: ${LIB_ENV})",
    )
    run.add_argument(
        "--bus",
        choices=("sil", "memory", "socketcan"),
        default="sil",
        help="how the plant reaches the firmware (default: %(default)s; see below)",
    )
    run.add_argument(
        "--channel",
        metavar="IFACE",
        default="vcan0",
        help="SocketCAN interface for --bus socketcan (default: %(default)s)",
    )
    run.add_argument(
        "--fw",
        metavar="PATH",
        type=Path,
        help="with --bus socketcan: start this firmware executable (mstc-fw) on --channel "
        "before each scenario and stop it after, so each runs on a fresh firmware",
    )
    run.add_argument(
        "--no-figures",
        action="store_true",
        help="write events.json, trace.csv and bus.log but not the figures",
    )
    run.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=Path("build/sim"),
        help="output folder; each scenario writes DIR/<file stem>/ (default: %(default)s)",
    )
    run.add_argument(
        "scenarios",
        metavar="SCENARIO.toml",
        nargs="+",
        type=Path,
        help="scenario files (format: docs/scenarios.md)",
    )
    return parser


def _error(message: str) -> None:
    print(f"error: {message}", file=sys.stderr)


def _load_all(paths: Sequence[Path], out: Path) -> list[Scenario] | None:
    """Every scenario, or None after printing each problem."""
    scenarios = []
    ok = True
    for path in paths:
        try:
            scenarios.append(load_scenario(path))
        except ScenarioError as exc:
            _error(str(exc))
            ok = False
    seen: dict[str, Path] = {}
    for scenario in scenarios:
        first = seen.setdefault(scenario.name, scenario.path)
        if first != scenario.path:
            _error(f"{first} and {scenario.path} would both write {out / scenario.name}/")
            ok = False
    return scenarios if ok else None


def run_command(args: argparse.Namespace) -> int:
    """``run``: validate every scenario, run each, then write and report."""
    scenarios = _load_all(args.scenarios, args.out)
    if scenarios is None:
        return EXIT_USAGE
    results: list[tuple[RunResult, BusLog | None]] = []
    firmware = ""
    try:
        for scenario in scenarios:
            firmware, result, log = _run_one(args, scenario)
            results.append((result, log))
    except (FirmwareError, ControllerError, can.CanError) as exc:
        _error(str(exc))
        return EXIT_FAILED
    print(f"firmware: {firmware}")
    for result, log in results:
        try:
            folder = write_outputs(result, args.out, log, figures=not args.no_figures)
        except OSError as exc:
            _error(f"cannot write the outputs of {result.scenario.path}: {exc}")
            return EXIT_FAILED
        print()
        print(format_report(result, folder))
        if log is not None:
            print(f"  bus           {log.describe()}")
    return EXIT_OK


def start_firmware(exe: Path, channel: str, timeout: float = 30.0) -> subprocess.Popen[str]:
    """Start ``exe --can channel`` and wait until it is on the bus (its first
    line on stderr says so).

    :raises FirmwareError: it exited or said nothing in @p timeout seconds.
    """
    if not exe.is_file():
        raise FirmwareError(f"--fw {exe}: no such file (make fw builds build/host/mstc-fw)")
    proc = subprocess.Popen(
        [str(exe), "--can", channel], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True
    )
    assert proc.stderr is not None
    ready, _, _ = select.select([proc.stderr], [], [], timeout)
    line = proc.stderr.readline() if ready else ""
    if " mode on " not in line:
        proc.kill()
        said = (line + proc.stderr.read()).strip() or "no answer"
        raise FirmwareError(f"{exe} did not start on {channel}: {said}")
    return proc


def stop_firmware(proc: subprocess.Popen[str]) -> None:
    """Stop a firmware process started by :func:`start_firmware`."""
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _run_one(args: argparse.Namespace, scenario: Scenario) -> tuple[str, RunResult, BusLog | None]:
    """Run one scenario on the bus the arguments name."""
    if args.bus == "memory":
        controller = SilController(scenario.params, args.lib)
        return f"{controller.lib_path} ({controller.numeric})", simulate(scenario, controller), None
    if args.bus == "sil":
        lib = args.lib if args.lib is not None else os.environ.get(LIB_ENV)
        bus = can.Bus(interface="mstc-sil", channel="sil0", lib=lib)
    else:
        bus = can.Bus(interface="socketcan", channel=args.channel)
    firmware = start_firmware(args.fw, args.channel) if args.fw is not None else None
    try:
        ctl = CanController(bus, scenario.params, sim_time_stamps=args.bus == "sil")
        result = simulate(scenario, ctl)
    finally:
        bus.shutdown()
        if firmware is not None:
            stop_firmware(firmware)
    log = BusLog(args.channel if args.bus == "socketcan" else "sil0", ctl)
    return bus.channel_info, result, log


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    args = build_parser().parse_args(argv)
    if args.command == "run":
        return run_command(args)
    raise AssertionError(f"unhandled command {args.command}")
