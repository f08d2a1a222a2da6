# SPDX-License-Identifier: MIT
"""``mstc board``: talk to a board (or mstc-fw, or the in-process firmware)
from the shell, as odrivetool and ``cantools monitor`` do."""

from __future__ import annotations

import argparse
import difflib
import json
import os
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

import can

from mstc.can import secoc
from mstc.can.protocol import MAX_NODE_ID, Frame, Protocol
from mstc.cli import COMMANDS
from mstc.cli.common import add_bus_arguments, add_key_argument, find_library, open_args_bus
from mstc.errors import (
    EXIT_FAILED,
    EXIT_OK,
    AuthKeyError,
    ControllerError,
    FrameDropped,
    UsageError,
)
from mstc.limits import Limit, load_table
from mstc.model import Fault
from mstc.ros.board import Board, result_text

NAME = "board"
HELP = COMMANDS[NAME]

_EPILOG = """\
actions:
  status     the board's state, refreshed (mode, halt reason, wheel speeds,
             faults, E2E and authentication counters on both sides)
  get        parameters by name, with their units and limits (all by default)
  set        a parameter, authenticated with the key; a refusal with its reason
  arm        arm (authenticated); refused with the reason when not ready
  disarm     disarm: a ramped stop (authenticated)
  version    the firmware's version, build id, numeric mode, protocol, node id
  monitor    every frame on the bus, decoded with the DBC, as they come

The board's identifiers are the DBC's plus 0x100 times its node id (--node;
docs/protocol.md), so several boards share a bus, each driven by its own
`mstc board --node N`. The in-process firmware (-i mstc-sil, the default)
steps only on STEP frames: without a plant on its bus its status shows what
it answered (not armed, no STATUS yet).

exit status: 0 done; 1 the board did not answer, or refused a command (the
reason on the error line); 2 bad arguments, an unknown parameter or no key
for a command that needs one; 3 the bus cannot be opened; 130 interrupted.

examples:
  .venv/bin/mstc board version
  .venv/bin/mstc board get D_s strategy
  .venv/bin/mstc board set D_s 0.4
  .venv/bin/mstc board -i socketcan -c can0 --node 1 status
  .venv/bin/mstc board -i slcan -c /dev/ttyACM0 -b 500000 monitor
"""

ACTIONS = ("status", "get", "set", "arm", "disarm", "version", "monitor")


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc board``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Talk to the mstc firmware on a CAN bus: its status, its parameters, "
        "arm and disarm, its version, the frames on the bus.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_bus_arguments(parser, default_interface="mstc-sil")
    parser.add_argument(
        "--node",
        metavar="N",
        type=int,
        default=0,
        help=f"the board's node id, 0..{MAX_NODE_ID} (default: %(default)s)",
    )
    parser.add_argument(
        "--lib", metavar="PATH", help="mstc-sil: the firmware library (default: the build's)"
    )
    parser.add_argument(
        "--timeout",
        metavar="S",
        type=float,
        default=1.0,
        help="how long to wait for an answer [s] (default: %(default)s)",
    )
    add_key_argument(parser)
    parser.add_argument("action", choices=ACTIONS, metavar="ACTION", help=", ".join(ACTIONS))
    parser.add_argument("args", nargs="*", metavar="ARG", help="get: NAME ...; set: NAME VALUE")
    parser.add_argument(
        "-n",
        "--count",
        metavar="N",
        type=int,
        default=0,
        help="status: refresh N times; monitor: stop after N frames (default: until Ctrl-C)",
    )
    parser.add_argument(
        "--period",
        metavar="S",
        type=float,
        default=0.5,
        help="status: seconds between refreshes (default: %(default)s)",
    )
    parser.set_defaults(run=run, exit_status={ControllerError: EXIT_FAILED})


def _key(args: argparse.Namespace, needed: bool) -> bytes:
    """The key commands are signed with; a placeholder when the action
    signs nothing and there is none (its statuses then do not verify)."""
    simulated = args.interface == "mstc-sil"
    default = secoc.SIM_KEY_FILE if simulated else secoc.DEFAULT_KEY_FILE
    try:
        return secoc.load_key(args.key_file, default)
    except AuthKeyError:
        if needed:
            raise
        return bytes(secoc.KEY_LEN)


T = TypeVar("T")


def again(ask: Callable[[], T]) -> T:
    """@p ask, once more if it got no answer. A board that has run longer
    than this tool has followed the alive counters of an earlier `mstc
    board`; this one starts each identifier's at 0, which the board may drop
    as repeated or out of sequence (docs/safety.md, E2E), once: the board's
    receiver follows the dropped frame's counter, so the second is taken."""
    try:
        return ask()
    except ControllerError:
        return ask()


COUNTERS_FILE = "board-counters.json"
"""Under $XDG_CACHE_HOME/mstc (~/.cache/mstc): the alive counters each `mstc
board` sent last, by bus and node."""


def _counters_path() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mstc" / COUNTERS_FILE


def _bus_key(args: argparse.Namespace) -> str:
    return f"{args.interface}:{args.channel or ''}:{args.node}"


def load_counters(args: argparse.Namespace) -> dict[int, int]:
    """The alive counters the last `mstc board` on this bus and node sent.

    A board follows each identifier's counter from frame to frame, and drops
    a frame whose counter repeats the last or jumps too far (docs/safety.md,
    E2E). A tool that starts again at 0 would have its first PARAM_SET and
    PARAM_AUTH dropped; the authenticated command then cannot be signed again
    for the same challenge. So `mstc board` goes on from where the last one
    left off, as one long-running tool would. Nothing for the in-process
    firmware, which each run starts afresh.
    """
    if args.interface == "mstc-sil":
        return {}
    try:
        data = json.loads(_counters_path().read_text())
        return {int(k): int(v) for k, v in data.get(_bus_key(args), {}).items()}
    except (OSError, ValueError, AttributeError):
        return {}


def save_counters(args: argparse.Namespace, counters: dict[int, int]) -> None:
    """Keep @p counters for the next `mstc board` on this bus and node (best
    effort: a cache that cannot be written only costs a dropped first frame)."""
    if args.interface == "mstc-sil":
        return
    path = _counters_path()
    try:
        data = json.loads(path.read_text()) if path.is_file() else {}
        data[_bus_key(args)] = {str(k): v for k, v in counters.items()}
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(data))
        tmp.replace(path)
    except (OSError, ValueError):
        pass


def open_board(args: argparse.Namespace, latest: dict[str, Frame]) -> Board:
    """The board of @p args on its bus, started; frames kept by name in @p latest."""
    if not 0 <= args.node <= MAX_NODE_ID:
        raise UsageError(f"--node {args.node}: 0 to {MAX_NODE_ID}")
    key = _key(args, needed=args.action in ("set", "arm", "disarm"))
    config: dict[str, Any] = {}
    if args.interface == "mstc-sil":
        lib = args.lib or find_library(None)
        config = {"lib": str(lib) if lib else None, "node": args.node}
        # The simulated board's own key, whatever the tool signs with (as mstc ros's).
        config["key"] = secoc.load_key(None, secoc.SIM_KEY_FILE)
    bus = open_args_bus(args, **config)
    board = Board(
        bus,
        key,
        lambda f: latest.__setitem__(f.name, f),
        answers_in_send=args.interface == "mstc-sil",
        timeout=args.timeout,
        node_id=args.node,
    )
    board.proto.tx_counters = load_counters(args)
    again(board.start)
    return board


def run(args: argparse.Namespace) -> int:
    """Do the action on the board."""
    latest: dict[str, Frame] = {}
    if args.action == "monitor":
        return _monitor(args)
    board = open_board(args, latest)
    try:
        actions: dict[str, Callable[[], int]] = {
            "status": lambda: _status(args, board, latest),
            "get": lambda: _get(args, board),
            "set": lambda: _set(args, board),
            "arm": lambda: _arm(board, True),
            "disarm": lambda: _arm(board, False),
            "version": lambda: _print(version_text(again(board.version))),
        }
        return actions[args.action]()
    finally:
        save_counters(args, board.proto.tx_counters)
        board.stop()
        board.bus.shutdown()


def _print(text: str) -> int:
    print(text, flush=True)
    return EXIT_OK


def version_text(frame: Frame) -> str:
    """FW_VERSION as a line: ``node 0: mstc firmware 0.1.0 (build e1396e8), float, protocol 1``."""
    s = {k: int(v) for k, v in frame.signals.items()}
    build = f"build {s['build']:07x}" if s["build"] else "built outside git"
    dirty = ", changes not committed" if s["dirty"] else ""
    numeric = "fixed (Q16.16)" if s["numeric"] else "float"
    return (
        f"node {s['node']}: mstc firmware {s['major']}.{s['minor']}.{s['patch']} "
        f"({build}{dirty}), {numeric}, protocol {s['protocol']}"
    )


# ------------------------------------------------------------- parameters


def _params() -> dict[str, Limit]:
    return {p.name: p for p in load_table().params}


def _param(name: str) -> Limit:
    """The parameter called @p name.

    :raises UsageError: there is none (with the closest names).
    """
    params = _params()
    if name in params:
        return params[name]
    close = difflib.get_close_matches(name, [*params, "arm"], n=3, cutoff=0.5)
    hint = f": did you mean {', '.join(close)}?" if close else f" (known: {', '.join(params)})"
    raise UsageError(f"no parameter {name!r}{hint}")


def _value_text(p: Limit, value: float) -> str:
    if p.choices:
        i = int(value)
        return p.choices[i] if 0 <= i < len(p.choices) else f"{value:g}"
    return f"{value:.6g}"


def _get(args: argparse.Namespace, board: Board) -> int:
    names = args.args or list(_params())
    limits = [_param(n) for n in names]
    width = max(len(n) for n in names)
    for p in limits:
        answer = again(partial(board.request, p.index, None))
        value = _value_text(p, float(answer.signals["value"]))
        if p.choices:
            limits_text = f"one of {', '.join(p.choices)}"
        else:
            limits_text = f"[{p.minimum:g} .. {p.maximum:g}]"
        law = "  (control law: set only while disarmed)" if p.control_law else ""
        print(f"{p.name:<{width}}  {value:>10} {p.unit:<8} {limits_text}{law}")
    return EXIT_OK


def _set(args: argparse.Namespace, board: Board) -> int:
    if len(args.args) != 2:
        raise UsageError("set takes NAME VALUE, e.g. `mstc board set D_s 0.4`")
    name, text = args.args
    p = _param(name)
    if p.choices and text in p.choices:
        value = float(p.choices.index(text))
    else:
        try:
            value = float(text)
        except ValueError:
            raise UsageError(f"set {name}: {text!r} is not a number") from None
    answer = again(partial(board.command, p.index, value))
    result = int(answer.signals["result"])
    held = _value_text(p, float(answer.signals["value"]))
    if result != board.tables.param_ok:
        raise ControllerError(
            f"set {name} {text}: {result_text(board.tables, p.index, result)} "
            f"(value in force: {held} {p.unit})"
        )
    return _print(f"{name} = {held} {p.unit}")


def _arm(board: Board, arm: bool) -> int:
    answer = again(partial(board.command, board.tables.arm_index, 1.0 if arm else 0.0))
    result = int(answer.signals["result"])
    what = "arm" if arm else "disarm"
    if result != board.tables.param_ok:
        reason = result_text(board.tables, board.tables.arm_index, result)
        raise ControllerError(f"{what}: {reason}")
    return _print("armed" if arm else "disarmed (a ramped stop)")


# ----------------------------------------------------------------- status


def status_text(board: Board, latest: dict[str, Frame], armed: bool | None) -> str:
    """The board's state from the frames it sent last (what is missing said so)."""
    t = board.tables
    c = board.counts
    lines = [f"node {board.proto.node_id} on {board.bus.channel_info}"]
    heartbeat = c.heartbeat or "(no HEARTBEAT yet)"
    armed_text = "unknown" if armed is None else ("yes" if armed else "no")
    lines.append(f"  state      {heartbeat}, armed {armed_text}")
    st = latest.get("STATUS")
    if st is None:
        lines.append("  mode       (no STATUS yet: the firmware steps on STEP frames or its timer)")
    else:
        s = st.signals
        mode = t.mode.get(int(s["mode"]))
        halt = t.halt.name_of(int(s["halt"])) or str(int(s["halt"]))
        faults = Fault(int(s["faults"]))
        names = "|".join(str(f.name).lower() for f in Fault if f in faults) or "none"
        side = t.side.get(int(s["side"]))
        lines.append(f"  mode       {mode}, halt {halt}, faults {names}")
        if int(s["obstacle"]):
            lines.append(
                f"  obstacle   O{int(s['obstacle'])} side {side or 'none'}, "
                f"distance {float(s['distance']):.3f} m, heading error {float(s['e']):.4f} rad"
            )
        else:
            lines.append("  obstacle   none in range")
    cmd = latest.get("WHEEL_CMD")
    if cmd is not None:
        left, right = float(cmd.signals["left"]), float(cmd.signals["right"])
        lines.append(f"  wheels     left {left:.3f} rad/s, right {right:.3f} rad/s (WHEEL_CMD)")
    mine = " ".join(f"{k} {v}" for k, v in board.drops.items())
    lines.append(f"  this side  sent {c.sent}, received {c.received}, dropped: {mine}")
    if c.firmware_drops:
        theirs = " ".join(
            f"{k.removesuffix('_errors').removesuffix('_ids')} {v}"
            for k, v in c.firmware_drops.items()
        )
        lines.append(f"  firmware   dropped: {theirs} (STATUS_COUNTERS)")
    lines.append(f"  auth       refused {c.auth_refused}, last {c.auth_last}")
    return "\n".join(lines)


def _status(args: argparse.Namespace, board: Board, latest: dict[str, Frame]) -> int:
    tty = sys.stdout.isatty()
    n = 0
    while True:
        armed = again(partial(board.request, board.tables.arm_index, None)).signals["value"] == 1.0
        text = status_text(board, latest, armed)
        print(("\x1b[H\x1b[J" if tty else "") + text, flush=True)
        n += 1
        if args.count and n >= args.count:
            return EXIT_OK
        time.sleep(args.period)


# ---------------------------------------------------------------- monitor


def frame_line(protos: dict[int, Protocol], msg: can.Message) -> str:
    """One received frame, decoded with the DBC under the node id its
    identifier belongs to: ``12.345678  0x181 STATUS  mode=track ...``
    (``node 1`` before the name for node 1's); a frame of no node, or one
    the E2E checks drop, with its bytes and why."""
    head = f"{msg.timestamp:17.6f}  0x{msg.arbitration_id:03X}"
    node = protos[0].node_of(msg)
    if node is None:
        return f"{head}  {bytes(msg.data).hex(' ').upper()}  (not in the DBC)"
    proto = protos.setdefault(node, Protocol(node=None, node_id=node))
    try:
        frame = proto.decode(msg)
    except FrameDropped as exc:
        return f"{head}  {bytes(msg.data).hex(' ').upper()}  (dropped: {exc})"
    message = proto.message(frame.name)
    parts = []
    for name, value in frame.signals.items():
        signal = message.get_signal_by_name(f"{frame.name}_{name}")
        choices: dict[int, object] = dict(signal.choices or {})
        choice = choices.get(int(value))
        if choice is not None:
            text = str(choice)
        else:
            text = str(int(value)) if float(value).is_integer() else f"{value:.6g}"
        parts.append(f"{name}={text}{signal.unit or ''}")
    where = f"node {node} " if node else ""
    return f"{head}  {where}{frame.name:<15} {' '.join(parts)}"


def _monitor(args: argparse.Namespace) -> int:
    config: dict[str, Any] = {}
    if args.interface == "mstc-sil":
        lib = args.lib or find_library(None)
        config = {"lib": str(lib) if lib else None, "node": args.node}
    bus = open_args_bus(args, **config)
    protos = {0: Protocol(node=None)}
    n = 0
    try:
        while not args.count or n < args.count:
            msg = bus.recv(timeout=0.5)
            if msg is None:
                if args.interface == "mstc-sil":
                    break  # the in-process firmware sends nothing unless it is sent frames
                continue
            print(frame_line(protos, msg), flush=True)
            n += 1
    finally:
        bus.shutdown()
    return EXIT_OK
