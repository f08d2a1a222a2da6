# SPDX-License-Identifier: MIT
"""The ``mstc`` command: one subcommand per job, each with ``--help``.

Each subcommand is a module of this package, listed with its one-line help
in :data:`COMMANDS` (so that ``mstc --help`` lists it without importing it),
with ``NAME``, ``HELP`` (its line there), ``add_parser(commands)`` (which
sets ``run`` as the parser's default) and ``run(args) -> int`` returning the
exit status. A subcommand does not catch
errors to print them: every error mstc raises on purpose (:mod:`mstc.errors`)
ends in :func:`main`, which prints it as ``error: ...`` and returns its exit
status (as cantools' ``_main`` does). A subcommand whose exit status for an
error differs from the error's own sets ``exit_status`` (a mapping from error
class to status) among its parser's defaults.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Collection, Mapping, Sequence

from mstc import __version__
from mstc.errors import EXIT_INTERRUPTED, MstcError

COMMANDS: dict[str, str] = {
    "sim": "run scenario files against the firmware in process",
    "hil": "run scenario files over SocketCAN (or another python-can bus) against mstc-fw or "
    "a board",
    "replay": "feed a bus log through the firmware and compare what it sends, bit for bit",
    "play": "play a bus log onto a bus with its original timing, like canplayer",
    "plot": "decode a bus log: events, status, trace and the paper's figures",
    "sweep": "run scenario files or suites for several strategies, on all cores or a Dask cluster",
    "barn": "run BARN's 300 worlds (the benchmark's Jackal, its protocol and score)",
    "export": "write a run or a bus log as an MCAP file (Foxglove) or a rosbag2 (ROS 2 tools)",
    "ros": "bridge a CAN bus with the firmware on it to ROS 2 topics (a node Nav2 can drive)",
    "board": "talk to a board on a CAN bus: status, parameters, arm, version, frames",
}
"""The subcommands (each the module ``mstc.cli.NAME``) and their one-line
help, in the order ``mstc --help`` lists them."""


def build_parser(commands: Collection[str] = tuple(COMMANDS)) -> argparse.ArgumentParser:
    """The argument parser of ``mstc``, whole for the subcommands @p commands;
    the others are listed with their help alone and their modules left
    unimported (:func:`main` builds the one it runs: a command then starts
    without every other's imports, e.g. a sweep's client without ROS's and
    matplotlib's)."""
    parser = argparse.ArgumentParser(
        prog="mstc",
        description="mstc: the plant, the CAN harness and the log tools of the mstc "
        "motor-controller firmware. `mstc COMMAND --help` describes each command.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, text in COMMANDS.items():
        if name in commands:
            importlib.import_module(f"mstc.cli.{name}").add_parser(subparsers)
        else:
            subparsers.add_parser(name, help=text)
    return parser


def _command(argv: Sequence[str]) -> str | None:
    """The subcommand @p argv names: its first word that is not an option
    (``mstc`` has no option taking a value)."""
    return next((word for word in argv if not word.startswith("-")), None)


def exit_status(exc: MstcError, args: argparse.Namespace) -> int:
    """The exit status of @p exc in the subcommand of @p args: the
    subcommand's own for that error, if it has one, else the error's."""
    own: Mapping[type[MstcError], int] = getattr(args, "exit_status", {})
    return next((status for cls, status in own.items() if isinstance(exc, cls)), exc.exit_status)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``mstc``; returns the exit status."""
    words = sys.argv[1:] if argv is None else argv
    named = _command(words)
    args = build_parser([named] if named in COMMANDS else []).parse_args(words)
    try:
        status: int = args.run(args)
    except MstcError as exc:
        for line in str(exc).splitlines():
            print(f"error: {line}", file=sys.stderr)
        return exit_status(exc, args)
    except KeyboardInterrupt:
        print("\ninterrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return status
