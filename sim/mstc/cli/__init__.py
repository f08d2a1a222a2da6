# SPDX-License-Identifier: MIT
"""The ``mstc`` command: one subcommand per job, each with ``--help``.

Each subcommand is a module of this package with ``NAME``, ``HELP``,
``add_parser(commands)`` (which sets ``run`` as the parser's default) and
``run(args) -> int`` returning the exit status.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from mstc import __version__
from mstc.cli import export, hil, play, plot, replay, ros, sim, sweep

COMMANDS = (sim, hil, replay, play, plot, sweep, export, ros)
"""The subcommands, in the order ``mstc --help`` lists them."""


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``mstc``."""
    parser = argparse.ArgumentParser(
        prog="mstc",
        description="mstc: the plant, the CAN harness and the log tools of the mstc "
        "motor-controller firmware. `mstc COMMAND --help` describes each command.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``mstc``; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    # Everything after `mstc ros` is ROS's (--ros-args -p ...), which
    # argparse would take for options of its own.
    passed: list[str] = []
    if argv[:1] == [ros.NAME] and argv[1:2] not in (["-h"], ["--help"]):
        argv, passed = argv[:1], argv[1:]
    args = build_parser().parse_args(argv)
    if passed:
        args.ros_args = passed
    try:
        status: int = args.run(args)
    except KeyboardInterrupt:
        print("\ninterrupted", file=sys.stderr)
        return 130
    return status
