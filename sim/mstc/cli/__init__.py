# SPDX-License-Identifier: MIT
"""The ``mstc`` command: one subcommand per job, each with ``--help``.

Each subcommand is a module of this package with ``NAME``, ``HELP``,
``add_parser(commands)`` (which sets ``run`` as the parser's default) and
``run(args) -> int`` returning the exit status. A subcommand does not catch
errors to print them: every error mstc raises on purpose (:mod:`mstc.errors`)
ends in :func:`main`, which prints it as ``error: ...`` and returns its exit
status (as cantools' ``_main`` does). A subcommand whose exit status for an
error differs from the error's own sets ``exit_status`` (a mapping from error
class to status) among its parser's defaults.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping, Sequence

from mstc import __version__
from mstc.cli import barn, board, export, hil, play, plot, replay, ros, sim, sweep
from mstc.errors import EXIT_INTERRUPTED, MstcError

COMMANDS = (sim, hil, replay, play, plot, sweep, barn, export, ros, board)
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


def exit_status(exc: MstcError, args: argparse.Namespace) -> int:
    """The exit status of @p exc in the subcommand of @p args: the
    subcommand's own for that error, if it has one, else the error's."""
    own: Mapping[type[MstcError], int] = getattr(args, "exit_status", {})
    return next((status for cls, status in own.items() if isinstance(exc, cls)), exc.exit_status)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``mstc``; returns the exit status."""
    args = build_parser().parse_args(argv)
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
