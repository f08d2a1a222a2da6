# SPDX-License-Identifier: MIT
"""``mstc play``: a bus log onto a bus with its timing, like canplayer."""

from __future__ import annotations

import argparse
import errno
import math
import sys

import can

from mstc.cli.common import (
    EXIT_FAILED,
    EXIT_INTERRUPTED,
    EXIT_NO_TARGET,
    EXIT_OK,
    EXIT_USAGE,
    add_log_arguments,
    error,
    load_log,
)
from mstc.errors import SendError
from mstc.logs.play import IdFilter, Player, PlayStats, select
from mstc.logs.replay import firmware_ids
from mstc.report.progress import Progress

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


_ERRNO_HINTS = {
    errno.EAFNOSUPPORT: "this kernel has no SocketCAN (modules can, can-raw); "
    "docs/hil.md runs it in a VM",
    errno.ENODEV: "no such interface; a virtual one is made with "
    "`ip link add dev {channel} type vcan && ip link set up {channel}`",
    errno.ENETDOWN: "the interface is down: `ip link set up {channel}`",
    errno.EPERM: "not permitted: run as a user allowed to open CAN sockets",
}


def open_bus(interface: str, channel: str) -> can.BusABC | str:
    """The bus, or why it cannot be opened."""
    try:
        return can.Bus(interface=interface, channel=channel)
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        text = f"cannot open {interface} bus {channel!r}: {exc}"
        code = getattr(exc, "errno", None) or getattr(exc, "error_code", None)
        hint = _ERRNO_HINTS.get(code) if isinstance(code, int) else None
        if hint is None and isinstance(exc.__cause__, OSError):
            hint = _ERRNO_HINTS.get(exc.__cause__.errno or 0)
        if hint is not None:
            text += f" ({hint.format(channel=channel)})"
        return text


def run(args: argparse.Namespace) -> int:
    """Play the log onto the bus."""
    parser: argparse.ArgumentParser = args.parser
    rate, loops = args.rate, args.loop
    if not (rate > 0 and not math.isnan(rate)):
        parser.error(f"--rate must be > 0 (inf: back to back), got {args.rate}")
    if loops < 0:
        parser.error(f"--loop must be >= 0 (0: until interrupted), got {loops}")
    loaded = load_log(args)
    if isinstance(loaded, int):
        return loaded
    db, log = loaded
    id_filter = None
    if args.id_filter is not None:
        try:
            id_filter = IdFilter.parse(args.id_filter, db)
        except ValueError as exc:
            parser.error(str(exc))
    inputs, _ = firmware_ids(db)
    frames = select(log, inputs=None if args.all else inputs, id_filter=id_filter)
    what = "every frame" if args.all else "the firmware's input frames"
    if not frames:
        error(f"{args.log}: nothing to send ({what}, ID filter {args.id_filter or 'none'})")
        return EXIT_USAGE
    bus = open_bus(args.interface, args.channel)
    if isinstance(bus, str):
        error(bus)
        return EXIT_NO_TARGET
    total = len(frames) * loops if loops else len(frames)
    bar = Progress(total, "play", "frames", enabled=not args.quiet and loops != 0)
    player = Player(bus, rate=rate, loops=loops)
    span = frames[-1].timestamp - frames[0].timestamp
    print(
        f"play: {args.log}: {len(frames):,} frames ({what}) over {span:.3f} s of log time, "
        f"rate {rate:g}, {'until interrupted' if loops == 0 else f'{loops} loop(s)'}, "
        f"onto {args.interface} {args.channel}"
    )
    status = EXIT_OK
    stats: PlayStats
    try:
        stats = player.play(frames, bar)
    except SendError as exc:
        error(str(exc))
        stats, status = exc.stats, EXIT_FAILED
    except KeyboardInterrupt:
        stats, status = PlayStats(), EXIT_INTERRUPTED
        print("\ninterrupted", file=sys.stderr)
    finally:
        bar.close()
        bus.shutdown()
    if status != EXIT_INTERRUPTED:
        print(
            f"  sent {stats.sent:,} frames in {stats.loops} loop(s), {stats.seconds:.3f} s; "
            f"latest send {stats.late_max * 1e3:.3f} ms behind its time"
        )
    return status
