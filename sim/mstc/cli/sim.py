# SPDX-License-Identifier: MIT
"""``mstc sim``: scenario files in closed loop against the firmware in process."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import can

from mstc.can import secoc
from mstc.can.library import LIB_ENV
from mstc.cli import COMMANDS
from mstc.cli.common import add_key_argument, add_lib_argument, library, run_scenarios
from mstc.errors import UsageError
from mstc.firmware.sil import SilController
from mstc.firmware.wheels import wheels_for
from mstc.loop.lockstep import simulate, simulate_on_sil_bus
from mstc.loop.result import RunResult
from mstc.plant.scenario import Scenario
from mstc.report.outputs import BusLog
from mstc.report.progress import ProgressBar

NAME = "sim"
HELP = COMMANDS[NAME]

_EPILOG = f"""\
Each scenario writes DIR/<file stem>/: events.json, trace.csv, run.json (when
it started, where mstc export places its bus.log) and the figures
path.png, position_error.png, angle_error.png, v.png, w.png, distance.png and
overview.png; through CAN (--bus sil) also bus.log, every frame in candump -L
format. The table printed for each lists the switching events beside the
scenario's [[expected]] times, the difference in control steps, and the
minimum distance to each obstacle against D_s. The format of scenario files
is in docs/scenarios.md.

Every scenario is validated before any runs: a bad file prints one line
(file, key, problem) and nothing is written. Values the CAN frames cannot
carry (positions beyond 128 m, speeds beyond 16, radii beyond 2.55 m or off
whole centimetres, more than 48 obstacles) and runs of more than 100,000
control steps are refused (docs/scenarios.md). A run longer than a second
shows its progress on stderr (--quiet hides it).

A rerun into the same folder replaces the earlier run: the files a run writes
(those above) are removed from DIR/<file stem>/ before the new ones are
written, so that none is left from before. A folder holding any other file,
a folder that is a symbolic link, and a file whose stem cannot name a folder
inside DIR (a file called ...toml) are refused (exit 2) and left alone.

A run that misses its scenario's [[expected]] events (one not reproduced,
further from its time than its tolerance and --tolerance, or on the other
side), touches an obstacle (COLLISION in its report) or ends halted says so
on the last line, after its outputs are written, and exits 4.

exit status: 0 done; 1 the firmware library failed or refused the scenario's
parameters, the run failed, or an output could not be written; 2 bad
arguments, a bad scenario file, or an output folder that cannot be used;
4 a run missed its scenario's expectations or touched an obstacle.

buses:
  sil     the firmware in process behind CAN frames: python-can's interface
          "mstc-sil" around libmstc_sil.so (default)
  memory  the firmware's control step called directly, no frames: the
          reference the frame path is compared against

The same scenarios over SocketCAN, with the firmware as its own process or on
a board: mstc hil.

example:
  .venv/bin/mstc sim --lib build/host/float/libmstc_sil.so \\
      sim/scenarios/paper-line.toml sim/scenarios/paper-circle.toml

The library is built by `make lib`; without --lib it is read from {LIB_ENV},
else build/host/float/libmstc_sil.so.
"""


def add_output_arguments(
    parser: argparse.ArgumentParser, default_out: str, default_tolerance: str = "0"
) -> None:
    """--no-figures, --out, --tolerance and the scenario files (shared with
    ``mstc hil``)."""
    parser.add_argument(
        "--tolerance",
        metavar="S",
        type=float,
        help="how much further than its own tolerance an [[expected]] event may be [s] "
        f"(default: {default_tolerance})",
    )
    parser.add_argument(
        "--no-figures",
        action="store_true",
        help="write events.json, trace.csv and bus.log but not the figures",
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=Path(default_out),
        help="output folder; each scenario writes DIR/<file stem>/ (default: %(default)s)",
    )
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="no progress display (long runs show one)"
    )
    parser.add_argument(
        "scenarios",
        metavar="SCENARIO.toml",
        nargs="+",
        type=Path,
        help="scenario files (format: docs/scenarios.md)",
    )


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc sim``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Run scenario files in closed loop against the firmware built as a "
        "shared library: through CAN frames (default) or in memory.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_lib_argument(parser)
    parser.add_argument(
        "--bus",
        choices=("sil", "memory"),
        default="sil",
        help="how the plant reaches the firmware (default: %(default)s; see below)",
    )
    add_key_argument(parser)
    add_output_arguments(parser, "build/sim")
    parser.set_defaults(run=run)


def _run_one(
    args: argparse.Namespace, scenario: Scenario, bar: ProgressBar
) -> tuple[str, RunResult, BusLog | None]:
    lib = library(args.lib)
    wheels = wheels_for(scenario, lib)
    if args.bus == "memory":
        controller = SilController(scenario.params, lib, wheels)
        result = simulate(scenario, controller, bar, wheels)
        return f"{controller.lib_path} ({controller.numeric})", result, None
    result, ctl, channel_info = simulate_on_sil_bus(
        scenario, lib, wheels, key=args.key, progress=bar
    )
    return channel_info, result, BusLog("sil0", ctl)


def tolerance(args: argparse.Namespace, default: float = 0.0) -> float:
    """--tolerance, or @p default [s].

    :raises UsageError: not a time >= 0.
    """
    if args.tolerance is None:
        return default
    if not 0.0 <= args.tolerance < math.inf:
        raise UsageError(f"--tolerance: expected a time >= 0 s, got {args.tolerance:g}")
    return float(args.tolerance)


def run(args: argparse.Namespace) -> int:
    """Validate every scenario, run each, then write and report."""
    slack = tolerance(args)
    # A simulation: the simulations' key by default, never a device's.
    args.key = secoc.load_key(args.key_file, secoc.SIM_KEY_FILE) if args.bus == "sil" else None
    return run_scenarios(
        args.scenarios,
        args.out,
        not args.no_figures,
        lambda scenario, bar: _run_one(args, scenario, bar),
        (can.CanError,),
        quiet=args.quiet,
        slack=slack,
    )
