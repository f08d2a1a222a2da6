# SPDX-License-Identifier: MIT
"""``mstc plot``: events, status and the paper's figures from a bus log alone."""

from __future__ import annotations

import argparse
from pathlib import Path

from mstc.can.protocol import wire_limits
from mstc.cli import COMMANDS
from mstc.cli.common import add_log_arguments, load_decoded, run_log
from mstc.errors import EXIT_OK
from mstc.logs.decode import output_name
from mstc.plant.scenario import ExpectedEvent, load_scenario
from mstc.report.logplot import PLOT_FILES, format_events, write_log_outputs
from mstc.report.outputs import output_folder

NAME = "plot"
HELP = COMMANDS[NAME]

_EPILOG = """\
LOG is a bus log, or a run's folder (mstc sim or mstc hil wrote it), whose
bus.log is read. Writes DIR/<log file stem>/ (for a run's bus.log, its
folder's name):
events.json and trace.csv in the formats of make sim (docs/scenarios.md),
status.csv (one row per control step: the inputs, the wheel speeds and v, w,
every STATUS and STATUS_TRK signal, the distance to each obstacle), and the
figures of the paper's Figures 5 and 6: path.png, position_error.png,
angle_error.png, v.png, w.png, distance.png and overview.png. Prints the
events table of make sim, beside the [[expected]] events of --scenario when
given.

A rerun into the same folder replaces the earlier outputs (as mstc sim does):
the files above are removed first. A folder holding other files, a folder
that is a symbolic link, and a log whose name cannot name a folder inside
DIR (a file called ...log) are refused (exit 2).

Wheel radius and track width (for v and w), D_s and D_act come from the
PARAM_VALUE frames in the log, else Table 1 of the paper; the obstacles from
the OBSTACLE frames.

exit status: 0 done; 1 an output could not be written; 2 bad arguments, a log
that cannot be used (with --strict, any problem in it), one without control
steps, or an output folder that cannot be used.

example:
  .venv/bin/mstc plot --scenario sim/scenarios/paper-line.toml tests/data/paper-line.log
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc plot``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Decode a CAN bus log with the DBC: events, status over time, and the\n"
        "figures of the paper's Figures 5 and 6, as mstc sim draws them.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_log_arguments(parser)
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=Path("build/logplot"),
        help="output folder; writes DIR/<log stem>/, or DIR/<folder>/ for a bus.log "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--scenario",
        metavar="TOML",
        type=Path,
        help="a scenario file whose [[expected]] events the log's are compared with",
    )
    parser.add_argument("--no-figures", action="store_true", help="only the tables")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Decode the log, write the tables and figures, print the events."""
    expected: tuple[ExpectedEvent, ...] = ()
    if args.scenario is not None:
        expected = load_scenario(args.scenario, wire_limits()).expected
    args.log = run_log(args.log)
    output_folder(args.out, output_name(args.log), PLOT_FILES, source=str(args.log))
    _, decoded = load_decoded(args)
    folder = write_log_outputs(decoded, args.out, figures=not args.no_figures)
    print(format_events(decoded, expected, folder))
    return EXIT_OK
