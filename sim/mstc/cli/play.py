# SPDX-License-Identifier: MIT
"""``mstc play``: a bus log onto a bus with its timing, like canplayer."""

from __future__ import annotations

import argparse
import math
import sys

import can

from mstc.cli import COMMANDS
from mstc.cli.common import add_bus_arguments, add_log_arguments, load_log, open_args_bus
from mstc.errors import EXIT_OK, UsageError
from mstc.logs.candump import candump_line
from mstc.logs.play import IdFilter, Player, select
from mstc.logs.replay import firmware_ids
from mstc.report.progress import ProgressBar

NAME = "play"
HELP = COMMANDS[NAME]

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
    add_bus_arguments(parser, default_interface="socketcan", default_channel="vcan0")
    parser.add_argument(
        "-m",
        "--map",
        metavar="BUS=LOG",
        action="append",
        default=[],
        help="interface mapping, as canplayer's vcan0=can0: send the frames logged on LOG "
        "onto the bus channel BUS (repeatable; the others are not sent); without it every "
        "frame goes onto --channel",
    )
    parser.add_argument(
        "-n",
        "--count",
        metavar="N",
        type=int,
        default=0,
        help="stop after N frames sent (default: all)",
    )
    parser.add_argument(
        "-v", "--verbose", action="store_true", help="print each frame as it is sent (candump -L)"
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
    if args.count < 0:
        parser.error(f"--count must be >= 0 (0: all), got {args.count}")
    mapping: dict[str, str] = {}
    for item in args.map:
        bus_channel, sep, log_channel = item.partition("=")
        if not sep or not bus_channel or not log_channel:
            parser.error(f"--map {item!r}: BUS=LOG, e.g. vcan0=can0")
        mapping[log_channel] = bus_channel
    db, log = load_log(args)
    id_filter = IdFilter.parse(args.id_filter, db) if args.id_filter is not None else None
    inputs, _ = firmware_ids(db)
    frames = select(
        log,
        inputs=None if args.all else inputs,
        id_filter=id_filter,
        channels=mapping or None,
    )
    what = "every frame" if args.all else "the firmware's input frames"
    if not frames:
        raise UsageError(
            f"{args.log}: nothing to send ({what}, ID filter {args.id_filter or 'none'})"
        )
    buses = {ch: open_args_bus(args, channel=ch) for ch in sorted(set(mapping.values()))}
    bus = open_args_bus(args) if not buses else next(iter(buses.values()))
    total = len(frames) * loops if loops else len(frames)
    total = min(total, args.count) if args.count else total
    bar = ProgressBar(total, "play", "frames", enabled=not args.quiet and loops != 0)

    def echo(msg: can.Message) -> None:
        channel = mapping.get(str(msg.channel), args.channel) if mapping else args.channel
        print(candump_line(msg, str(channel)), flush=True)

    player = Player(
        bus,
        rate=rate,
        loops=loops,
        limit=args.count,
        echo=echo if args.verbose else None,
        route=(lambda msg: buses[mapping[str(msg.channel)]]) if mapping else None,
    )
    span = frames[-1].timestamp - frames[0].timestamp
    print(
        f"play: {args.log}: {len(frames):,} frames ({what}) over {span:.3f} s of log time, "
        f"rate {rate:g}, {'until interrupted' if loops == 0 else f'{loops} loop(s)'}, "
        f"onto {args.interface} "
        + (", ".join(f"{b} (from {c})" for c, b in mapping.items()) if mapping else args.channel)
    )
    try:
        player.play(frames, bar)
    finally:
        bar.close()
        for b in {bus, *buses.values()}:
            b.shutdown()
        # How far it came, unless interrupted: after every frame, or up to a
        # failed send (whose error main() prints).
        if not isinstance(sys.exception(), KeyboardInterrupt):
            stats = player.stats
            print(
                f"  sent {stats.sent:,} frames in {stats.loops} loop(s), {stats.seconds:.3f} s; "
                f"latest send {stats.late_max * 1e3:.3f} ms behind its time"
            )
    return EXIT_OK
