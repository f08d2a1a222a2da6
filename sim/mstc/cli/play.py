# SPDX-License-Identifier: MIT
"""``mstc play``: a bus log onto a bus with its timing, like canplayer."""

from __future__ import annotations

import argparse
import math
import sys

from mstc.cli.common import add_log_arguments, load_log
from mstc.errors import EXIT_OK, UsageError
from mstc.logs.play import IdFilter, Player, open_bus, select
from mstc.logs.replay import firmware_ids
from mstc.report.progress import ProgressBar

NAME = "play"
HELP = "play a bus log onto a bus with its original timing, like canplayer"

_EPILOG = """\
Like canplayer: the frames are sent with the log's timing, scaled by --rate,
--loop times; by default only the firmware's input frames (those the DBC
says node FW receives), so that a board or mstc-fw on the bus answers them.
Problems in the log are printed as path:line: problem (docs/replay.md).

exit status: 0 every frame sent; 1 a send failed; 2 bad arguments, or a log
that cannot be used (with --strict, any problem in it), or nothing to send;
3 the bus cannot be opened; 130 interrupted.

examples:
  .venv/bin/mstc play --interface socketcan --channel vcan0 bench.log
  .venv/bin/mstc play --channel can0 --rate 0.5 --loop 3 --id-filter 0x100-0x104 bench.log
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc play``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Play a CAN bus log onto a bus with its original timing, like canplayer.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_log_arguments(parser)
    parser.add_argument(
        "--interface",
        default="socketcan",
        help="python-can interface to play the log onto (socketcan, virtual, ...; "
        "default: %(default)s)",
    )
    parser.add_argument(
        "--channel", default="vcan0", help="the interface's channel (default: %(default)s)"
    )
    parser.add_argument(
        "--rate",
        metavar="FACTOR",
        type=float,
        default=1.0,
        help="time scale: 2 twice as fast as recorded, 0.5 half as fast, inf back to back "
        "(default: %(default)s)",
    )
    parser.add_argument(
        "--loop",
        metavar="N",
        type=int,
        default=1,
        help="play the log N times, 0 until interrupted (default: %(default)s)",
    )
    parser.add_argument(
        "--id-filter",
        metavar="IDS",
        help="send only these identifiers: hex, ranges and message names, "
        "e.g. 0x100,0x104-0x110,STEP",
    )
    parser.add_argument(
        "--all",
        action="store_true",
        help="send every frame of the log, not only the firmware's inputs",
    )
    parser.set_defaults(run=run, parser=parser)


def run(args: argparse.Namespace) -> int:
    """Play the log onto the bus."""
    parser: argparse.ArgumentParser = args.parser
    rate, loops = args.rate, args.loop
    if not (rate > 0 and not math.isnan(rate)):
        parser.error(f"--rate must be > 0 (inf: back to back), got {args.rate}")
    if loops < 0:
        parser.error(f"--loop must be >= 0 (0: until interrupted), got {loops}")
    db, log = load_log(args)
    id_filter = IdFilter.parse(args.id_filter, db) if args.id_filter is not None else None
    inputs, _ = firmware_ids(db)
    frames = select(log, inputs=None if args.all else inputs, id_filter=id_filter)
    what = "every frame" if args.all else "the firmware's input frames"
    if not frames:
        raise UsageError(
            f"{args.log}: nothing to send ({what}, ID filter {args.id_filter or 'none'})"
        )
    bus = open_bus(args.interface, args.channel)
    total = len(frames) * loops if loops else len(frames)
    bar = ProgressBar(total, "play", "frames", enabled=not args.quiet and loops != 0)
    player = Player(bus, rate=rate, loops=loops)
    span = frames[-1].timestamp - frames[0].timestamp
    print(
        f"play: {args.log}: {len(frames):,} frames ({what}) over {span:.3f} s of log time, "
        f"rate {rate:g}, {'until interrupted' if loops == 0 else f'{loops} loop(s)'}, "
        f"onto {args.interface} {args.channel}"
    )
    try:
        player.play(frames, bar)
    finally:
        bar.close()
        bus.shutdown()
        # How far it came, unless interrupted: after every frame, or up to a
        # failed send (whose error main() prints).
        if not isinstance(sys.exception(), KeyboardInterrupt):
            stats = player.stats
            print(
                f"  sent {stats.sent:,} frames in {stats.loops} loop(s), {stats.seconds:.3f} s; "
                f"latest send {stats.late_max * 1e3:.3f} ms behind its time"
            )
    return EXIT_OK
