# SPDX-License-Identifier: MIT
"""Command lines of the bus-log tools: ``tools/replay`` and ``tools/logplot``.

Both read a log with :mod:`mstc_sim.logread` and print its problems as
``path:line: problem``; docs/replay.md describes them whole.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import can
from cantools.database.can import Database

from mstc_sim.logdecode import (
    decode_log,
    format_events,
    write_events_json,
    write_status_csv,
    write_trace_csv,
)
from mstc_sim.logread import FORMATS, FrameLog, LogError, read_log
from mstc_sim.player import IdFilter, Player, PlayStats, SendError, select
from mstc_sim.plots import plot_all
from mstc_sim.progress import Progress
from mstc_sim.protocol import DBC_PATH, load_database
from mstc_sim.replay import (
    FirmwareError,
    firmware_ids,
    format_difference,
    format_summary,
    replay,
)
from mstc_sim.scenario import ScenarioError, load_scenario
from mstc_sim.silbus import LIB_ENV

ROOT = Path(__file__).resolve().parents[2]
"""The repository."""
DEFAULT_LIB = ROOT / "build" / "host" / "float" / "libmstc_sil.so"
"""The float build, when neither --lib nor $MSTC_SIL_LIB names one."""

EXIT_OK = 0
EXIT_DIFFERENT = 1
"""replay: the firmware's frames differ from the log's, or a send failed;
logplot: an output could not be written."""
EXIT_BAD_INPUT = 2
"""Bad arguments, or a log that cannot be used (with --strict: any problem)."""
EXIT_NO_TARGET = 3
"""The firmware library cannot be loaded, or the bus cannot be opened."""
EXIT_INTERRUPTED = 130


def _error(message: str) -> None:
    print(f"error: {message}", file=sys.stderr)


def _add_log_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", metavar="LOG", type=Path, help="the bus log")
    parser.add_argument(
        "--format",
        choices=FORMATS,
        help="log format (default: by extension: .log candump -L, .asc, .blf)",
    )
    parser.add_argument(
        "--dbc",
        metavar="PATH",
        type=Path,
        default=DBC_PATH,
        help="the protocol's DBC (default: firmware/comm/mstc.dbc)",
    )
    parser.add_argument(
        "--strict",
        action="store_true",
        help="any problem in the log is fatal (exit 2), not only a warning",
    )
    parser.add_argument(
        "--max-problems",
        metavar="N",
        type=int,
        default=20,
        help="print at most N problems of the log, then count the rest (default: %(default)s)",
    )


def _load(args: argparse.Namespace) -> tuple[Database, FrameLog] | int:
    """The DBC and the log, with its problems printed; or an exit status."""
    try:
        db = load_database(args.dbc)
    except Exception as exc:  # cantools raises several kinds on a bad DBC
        _error(f"cannot load the DBC {args.dbc}: {exc}")
        return EXIT_BAD_INPUT
    try:
        log = read_log(args.log, db, args.format)
    except LogError as exc:
        _error(str(exc))
        return EXIT_BAD_INPUT
    problems = log.problems
    for problem in problems[: max(args.max_problems, 0)]:
        print(problem, file=sys.stderr)
    rest = len(problems) - max(args.max_problems, 0)
    if rest > 0:
        kinds = Counter(p.kind.value for p in problems)
        counts = ", ".join(f"{n} {kind}" for kind, n in kinds.items())
        print(f"{args.log}: ... and {rest} more problems ({counts} in all)", file=sys.stderr)
    if problems and args.strict:
        _error(f"{args.log}: {len(problems)} problems in the log (--strict)")
        return EXIT_BAD_INPUT
    return db, log


# ------------------------------------------------------------------- replay

_REPLAY_EPILOG = f"""\
Compare (default): the frames the DBC says the firmware (node FW) receives are
fed, in the log's order, to a fresh instance of the firmware built as a
shared library; after each, the frames it sends are compared with the frames
of FW's identifiers that follow that input in the log, up to the next input.
The first difference is printed with both frames' bytes and signals; then a
summary, and the differences by message. Timing plays no part: the firmware
takes its time from STEP frames, so the replay runs as fast as it can.

Onto a bus (--to-bus INTERFACE): like canplayer, the frames are sent with the
log's timing, scaled by --rate, --loop times; by default only the firmware's
input frames, so that a board on the bus answers them.

Problems in the log are printed as path:line: problem. Lines that are not
frames, and remote, error and CAN FD frames, are skipped; frames with an
identifier not in the DBC are not fed; frames of the wrong length are fed (the
firmware counts and drops them, as a board does); time going backwards is
reported, the log's order kept. See docs/replay.md.

exit status: 0 bit-exact (or all frames sent); 1 the firmware's frames differ
(or a send failed); 2 bad arguments, or a log that cannot be used (with
--strict, any problem in it); 3 the firmware library cannot be loaded, or the
bus cannot be opened.

examples:
  tools/replay tests/data/paper-line.log
  tools/replay --lib build/host/fixed/libmstc_sil.so tests/data/paper-line.log
  tools/replay --to-bus socketcan --channel vcan0 --rate 2 --loop 3 \\
      --id-filter 0x100-0x104 bench.log

The library defaults to ${LIB_ENV}, else build/host/float/libmstc_sil.so
(make lib builds it).
"""


def build_replay_parser() -> argparse.ArgumentParser:
    """The argument parser of ``tools/replay``."""
    parser = argparse.ArgumentParser(
        prog="replay",
        description="Replay a CAN bus log through the firmware and compare what it sends\n"
        "with the log, bit for bit; or play the log onto a bus with its timing.",
        epilog=_REPLAY_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_log_arguments(parser)
    parser.add_argument(
        "--lib",
        metavar="PATH",
        type=Path,
        help=f"firmware shared library (default: ${LIB_ENV}, else build/host/float/libmstc_sil.so)",
    )
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="no progress display (long runs show one)"
    )
    bus = parser.add_argument_group("onto a bus, like canplayer")
    bus.add_argument(
        "--to-bus",
        metavar="INTERFACE",
        help="python-can interface to play the log onto (socketcan, virtual, ...)",
    )
    bus.add_argument("--channel", help="the interface's channel (default: vcan0)")
    bus.add_argument(
        "--rate",
        metavar="FACTOR",
        type=float,
        help="time scale: 2 twice as fast as recorded, 0.5 half as fast, inf back to back "
        "(default: 1)",
    )
    bus.add_argument(
        "--loop",
        metavar="N",
        type=int,
        help="play the log N times, 0 until interrupted (default: 1)",
    )
    bus.add_argument(
        "--id-filter",
        metavar="IDS",
        help="send only these identifiers: hex, ranges and message names, "
        "e.g. 0x100,0x104-0x110,STEP",
    )
    bus.add_argument(
        "--all",
        action="store_true",
        help="send every frame of the log, not only the firmware's inputs",
    )
    return parser


def _library(args: argparse.Namespace) -> Path:
    if args.lib is not None:
        return Path(args.lib)
    env = os.environ.get(LIB_ENV)
    return Path(env) if env else DEFAULT_LIB


def replay_main(argv: Sequence[str] | None = None) -> int:
    """``tools/replay``; returns the exit status."""
    parser = build_replay_parser()
    args = parser.parse_args(argv)
    bus_only = {
        "--channel": args.channel,
        "--rate": args.rate,
        "--loop": args.loop,
        "--id-filter": args.id_filter,
        "--all": args.all or None,
    }
    if args.to_bus is None:
        given = [name for name, value in bus_only.items() if value is not None]
        if given:
            parser.error(f"{', '.join(given)} only with --to-bus")
    elif args.lib is not None:
        parser.error("--lib is for comparing with the firmware, not with --to-bus")
    loaded = _load(args)
    if isinstance(loaded, int):
        return loaded
    db, log = loaded
    if args.to_bus is not None:
        return _play(args, parser, db, log)
    lib = _library(args)

    def progress(total: int) -> Progress:
        return Progress(total, "replay", "input frames", enabled=not args.quiet)

    try:
        result = replay(log, db, lib, progress=progress)
    except FirmwareError as exc:
        _error(str(exc))
        return EXIT_NO_TARGET
    except KeyboardInterrupt:
        print("\ninterrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    if result.first is not None:
        print(format_difference(result.first, log, db))
    print(format_summary(result, db))
    return EXIT_OK if result.identical else EXIT_DIFFERENT


_ERRNO_HINTS = {
    errno.EAFNOSUPPORT: "this kernel has no SocketCAN (modules can, can-raw); "
    "docs/hil.md runs it in a VM",
    errno.ENODEV: "no such interface; a virtual one is made with "
    "`ip link add dev {channel} type vcan && ip link set up {channel}`",
    errno.ENETDOWN: "the interface is down: `ip link set up {channel}`",
    errno.EPERM: "not permitted: run as a user allowed to open CAN sockets",
}


def _open_bus(interface: str, channel: str) -> can.BusABC | str:
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


def _play(
    args: argparse.Namespace, parser: argparse.ArgumentParser, db: Database, log: FrameLog
) -> int:
    rate = 1.0 if args.rate is None else args.rate
    loops = 1 if args.loop is None else args.loop
    if not (rate > 0 and not math.isnan(rate)):
        parser.error(f"--rate must be > 0 (inf: back to back), got {args.rate}")
    if loops < 0:
        parser.error(f"--loop must be >= 0 (0: until interrupted), got {loops}")
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
        _error(f"{args.log}: nothing to send ({what}, ID filter {args.id_filter or 'none'})")
        return EXIT_BAD_INPUT
    channel = args.channel or "vcan0"
    bus = _open_bus(args.to_bus, channel)
    if isinstance(bus, str):
        _error(bus)
        return EXIT_NO_TARGET
    total = len(frames) * loops if loops else len(frames)
    bar = Progress(total, "play", "frames", enabled=not args.quiet and loops != 0)
    player = Player(bus, rate=rate, loops=loops)
    span = frames[-1].timestamp - frames[0].timestamp
    print(
        f"play: {args.log}: {len(frames):,} frames ({what}) over {span:.3f} s of log time, "
        f"rate {rate:g}, {'until interrupted' if loops == 0 else f'{loops} loop(s)'}, "
        f"onto {args.to_bus} {channel}"
    )
    status = EXIT_OK
    stats: PlayStats
    try:
        stats = player.play(frames, bar)
    except SendError as exc:
        _error(str(exc))
        stats, status = exc.stats, EXIT_DIFFERENT
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


# ------------------------------------------------------------------ logplot

_LOGPLOT_EPILOG = """\
Writes DIR/<log file stem>/ (for a run's bus.log, its folder's name):
events.json and trace.csv in the formats of
make sim (docs/scenarios.md), status.csv (one row per control step: the
inputs, the wheel speeds and v, w, every STATUS and STATUS_TRK signal, the
distance to each obstacle), and the figures of the paper's Figures 5 and 6:
path.png, position_error.png, angle_error.png, v.png, w.png, distance.png and
overview.png. Prints the events table of make sim, beside the [[expected]]
events of --scenario when given.

Wheel radius and track width (for v and w), D_s and D_act come from the
PARAM_VALUE frames in the log, else Table 1 of the paper; the obstacles from
the OBSTACLE frames.

exit status: 0 done; 1 an output could not be written; 2 bad arguments, a log
that cannot be used (with --strict, any problem in it) or one without
control steps.

example:
  tools/logplot --scenario sim/scenarios/paper-line.toml tests/data/paper-line.log
"""


def build_logplot_parser() -> argparse.ArgumentParser:
    """The argument parser of ``tools/logplot``."""
    parser = argparse.ArgumentParser(
        prog="logplot",
        description="Decode a CAN bus log with the DBC: events, status over time, and the\n"
        "figures of the paper's Figures 5 and 6, as make sim draws them.",
        epilog=_LOGPLOT_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_log_arguments(parser)
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
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="no progress display (long runs show one)"
    )
    return parser


def logplot_main(argv: Sequence[str] | None = None) -> int:
    """``tools/logplot``; returns the exit status."""
    args = build_logplot_parser().parse_args(argv)
    expected = ()
    if args.scenario is not None:
        try:
            expected = load_scenario(args.scenario).expected
        except ScenarioError as exc:
            _error(str(exc))
            return EXIT_BAD_INPUT
    loaded = _load(args)
    if isinstance(loaded, int):
        return loaded
    db, log = loaded
    try:
        bar = Progress(len(log), "decode", "frames", enabled=not args.quiet)
        decoded = decode_log(log, db, bar)
    except ValueError as exc:
        _error(str(exc))
        return EXIT_BAD_INPUT
    for problem in decoded.problems[: max(args.max_problems, 0)]:
        print(problem, file=sys.stderr)
    if decoded.problems and args.strict:
        _error(f"{args.log}: {len(decoded.problems)} frames not decoded (--strict)")
        return EXIT_BAD_INPUT
    folder = args.out / decoded.name
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_events_json(decoded, folder / "events.json")
        write_trace_csv(decoded, folder / "trace.csv")
        write_status_csv(decoded, folder / "status.csv")
        if not args.no_figures:
            plot_all(decoded.plot_data(), folder)
    except OSError as exc:
        _error(f"cannot write the outputs into {folder}: {exc}")
        return EXIT_DIFFERENT
    print(format_events(decoded, expected, folder))
    return EXIT_OK
