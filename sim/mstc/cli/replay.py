# SPDX-License-Identifier: MIT
"""``mstc replay``: a bus log through the firmware, compared bit for bit."""

from __future__ import annotations

import argparse

from mstc.can import secoc
from mstc.can.library import LIB_ENV
from mstc.cli import COMMANDS
from mstc.cli.common import add_key_argument, add_lib_argument, add_log_arguments, library, load_log
from mstc.errors import (
    EXIT_FAILED,
    EXIT_NO_TARGET,
    EXIT_OK,
    FirmwareError,
    MstcError,
    UsageError,
)
from mstc.logs.replay import format_difference, format_summary, replay
from mstc.report.progress import ProgressBar

NAME = "replay"
HELP = COMMANDS[NAME]

_EPILOG = f"""\
The frames the DBC says the firmware (node FW) receives are fed, in the log's
order, to a fresh instance of the firmware built as a shared library; after
each, the frames it sends are compared with the frames of FW's identifiers
that follow that input in the log, up to the next input. The first difference
is printed with both frames' bytes and signals; then a summary, and the
differences by message. Timing plays no part: the firmware takes its time
from STEP frames, so the replay runs as fast as it can.

Problems in the log are printed as path:line: problem. Lines that are not
frames, and remote, error and CAN FD frames, are skipped; frames with an
identifier not in the DBC are not fed; frames of the wrong length are fed (the
firmware counts and drops them, as a board does); time going backwards is
reported, the log's order kept. See docs/replay.md.

The firmware must have the key the log's commands were authenticated with
(--key-file; the committed logs: tests/data/test.key), or it refuses them and
answers otherwise than the log says: the replay then ends with `error: ...
the firmware refused N of the log's authenticated commands ...` (exit 1),
naming the key it had.

To play a log onto a bus with its timing instead (like canplayer): mstc play.

A replay that compared nothing (the log holds no frame the firmware sends,
and the firmware sent none: a log of another bus) is not called bit-exact: it
fails with exit 2, unless --allow-empty says that is expected.

exit status: 0 bit-exact; 1 the firmware's frames differ; 2 bad arguments, a
log that cannot be used (with --strict, any problem in it), or nothing
compared (without --allow-empty); 3 the firmware library cannot be loaded.

examples:
  .venv/bin/mstc replay build/sim/paper-line/bus.log
  .venv/bin/mstc replay --key-file tests/data/test.key tests/data/paper-line.log
  .venv/bin/mstc replay --lib build/host/fixed/libmstc_sil.so --key-file tests/data/test.key \\
    tests/data/paper-line.log

The library defaults to ${LIB_ENV}, else build/host/float/libmstc_sil.so
(make lib builds it).
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc replay``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Replay a CAN bus log through the firmware and compare what it sends\n"
        "with the log, bit for bit.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_log_arguments(parser)
    add_lib_argument(parser)
    parser.add_argument(
        "--allow-empty",
        action="store_true",
        help="exit 0 when nothing was compared (the log holds no frame the firmware sends)",
    )
    add_key_argument(parser)
    # The firmware that cannot be loaded or started is "no target" here.
    parser.set_defaults(run=run, exit_status={FirmwareError: EXIT_NO_TARGET})


def run(args: argparse.Namespace) -> int:
    """Replay the log and print the first difference and a summary."""
    db, log = load_log(args)
    key = secoc.load_key(args.key_file, secoc.SIM_KEY_FILE)  # the SIL library: a simulation

    def progress(total: int) -> ProgressBar:
        return ProgressBar(total, "replay", "input frames", enabled=not args.quiet)

    result = replay(log, db, library(args.lib), progress=progress, key=key)
    if result.first is not None:
        print(format_difference(result.first, log, db))
    print(format_summary(result, db))
    in_log, in_replay = result.auth_refused
    if in_replay > in_log:
        source = secoc.key_file(args.key_file, secoc.SIM_KEY_FILE) or f"${secoc.KEY_ENV}"
        raise MstcError(
            f"{args.log}: the firmware refused {in_replay - in_log} of the log's authenticated "
            f"commands (AUTH_STATUS_refused {in_replay}, the log's {in_log}): it has another key "
            f"than the log's firmware had (the key of {source}); the committed logs "
            "under tests/data are signed with tests/data/test.key: --key-file tests/data/test.key"
        )
    if result.nothing_compared and not args.allow_empty:
        raise UsageError(
            f"{args.log}: nothing compared: the log holds no frame the firmware sends and the "
            "firmware sent none for its inputs (a log of another bus?); --allow-empty accepts it"
        )
    return EXIT_OK if result.identical else EXIT_FAILED
