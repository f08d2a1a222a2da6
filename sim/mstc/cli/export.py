# SPDX-License-Identifier: MIT
"""``mstc export``: a run or a bus log as an MCAP file, for Foxglove."""

from __future__ import annotations

import argparse
from pathlib import Path

from mstc.cli.common import add_log_arguments, load_decoded
from mstc.errors import EXIT_OK
from mstc.logs.export import export_mcap, format_summary

NAME = "export"
HELP = "write a run or a bus log as an MCAP file (Foxglove: 3D path, plots, CAN signals)"

_EPILOG = """\
RUN_DIR is a folder mstc sim or mstc hil wrote (its bus.log is read); LOG is
any bus log mstc replay reads. The file holds every CAN frame decoded with the
DBC on /can/<MESSAGE> (JSON), the robot's and the reference's poses and paths,
the obstacles and the switching events as Foxglove schemas (protobuf), each
stamped with the log's time. Open it in Foxglove: its 3D panel shows the
paths and obstacles in the frame "world"; a Plot panel takes any signal, e.g.
/can/STATUS.e. See docs/replay.md.

exit status: 0 written; 1 the file cannot be written; 2 bad arguments, or a
log that cannot be used (with --strict, any problem in it).

examples:
  .venv/bin/mstc export tests/data/paper-line.log --mcap build/paper-line.mcap
  .venv/bin/mstc export build/sim/paper-line --mcap build/sim/paper-line/run.mcap
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc export``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Export a run folder or a CAN bus log to MCAP, decoded with the DBC.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_log_arguments(parser, "RUN_DIR|LOG", "a run's folder (its bus.log is read), or a bus log")
    parser.add_argument(
        "--mcap", metavar="OUT", type=Path, required=True, help="the MCAP file to write"
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Decode the log and write the MCAP file."""
    source = args.log
    db, decoded = load_decoded(args)
    summary = export_mcap(decoded, db, args.mcap)
    print(format_summary(summary, source))
    return EXIT_OK
