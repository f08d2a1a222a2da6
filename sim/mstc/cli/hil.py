# SPDX-License-Identifier: MIT
"""``mstc hil``: scenario files over a real CAN bus, against ``mstc-fw`` or a
board, in lock-step or in real time."""

from __future__ import annotations

import argparse
import select
import subprocess
from pathlib import Path

import can

from mstc.can.lockstep import CanController
from mstc.can.realtime import RealtimeLink
from mstc.cli.common import EXIT_USAGE, error, run_scenarios
from mstc.cli.sim import add_output_arguments
from mstc.errors import ControllerError, FirmwareError
from mstc.report.outputs import BusLog
from mstc.sim.realtime import COMM_LOSS_TAIL, DEFAULT_PHASE, DEFAULT_RATE_HZ, simulate_realtime
from mstc.sim.run import RunResult, simulate
from mstc.sim.scenario import Scenario

NAME = "hil"
HELP = "run scenario files over SocketCAN (or another python-can bus) against mstc-fw or a board"

_EPILOG = f"""\
The plant runs on this machine and reaches the firmware through a python-can
bus: by default SocketCAN's vcan0, where the firmware runs as its own process
(--fw build/host/mstc-fw, started afresh for each scenario, like a board) or
on a board behind a CAN adapter. Each scenario writes DIR/<file stem>/ with
events.json, trace.csv, bus.log (every frame, candump -L) and the figures,
and prints the table of `mstc sim`.

With --realtime the plant runs on the wall clock instead: it sends odometry,
reference and obstacles at --rate-hz, never STEP, and applies each wheel
command from the moment it arrives, while the firmware steps on its own timer
(mstc-fw --realtime, or a board). Each scenario then also writes timing.json
(wheel-command period, latency from odometry to wheel command, missed and
doubled periods, dropped frames) and timing.png, and the table gains a timing
line. --stop-odometry-at S is a comm-loss trial: odometry stops at S seconds,
the firmware must halt within 3 control periods and ramp the wheels down
(docs/safety.md); the run ends {COMM_LOSS_TAIL:g} s later.

On a host whose kernel has no CAN, `make hil` (REALTIME=1 for real time) runs
this inside a small VM with vcan (docs/hil.md).

exit status: 0 done; 1 the firmware could not be started or did not answer,
or an output could not be written; 2 bad arguments or a bad scenario file.

examples:
  .venv/bin/mstc hil --channel vcan0 --fw build/host/mstc-fw \\
      sim/scenarios/paper-line.toml
  .venv/bin/mstc hil --realtime --channel vcan0 --fw build/host/mstc-fw \\
      sim/scenarios/paper-line.toml
  .venv/bin/mstc hil --realtime --interface socketcan --channel can0 \\
      sim/scenarios/paper-line.toml          # a board (docs/hil.md)
"""


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Register ``mstc hil``."""
    parser = commands.add_parser(
        NAME,
        help=HELP,
        description="Run scenario files in closed loop over a CAN bus, against the firmware "
        "as its own process (mstc-fw) or on a board.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--interface",
        default="socketcan",
        help="python-can interface (default: %(default)s)",
    )
    parser.add_argument(
        "--channel",
        metavar="NAME",
        default="vcan0",
        help="the interface's channel (default: %(default)s)",
    )
    parser.add_argument(
        "--fw",
        metavar="PATH",
        type=Path,
        help="start this firmware executable (mstc-fw) on --channel before each scenario "
        "and stop it after, so each runs on a fresh firmware (SocketCAN only)",
    )
    timing = parser.add_argument_group("real time")
    timing.add_argument(
        "--realtime",
        action="store_true",
        help="run the plant on the wall clock against a firmware on its own timer "
        "(--fw starts mstc-fw --realtime)",
    )
    timing.add_argument(
        "--rate-hz",
        metavar="HZ",
        type=float,
        default=DEFAULT_RATE_HZ,
        help="the plant's sample rate, which must be the firmware's control rate "
        "(default: %(default)g; with --fw, 1000/HZ must be a whole number of ms)",
    )
    timing.add_argument(
        "--free-phase",
        action="store_true",
        help="sample on the plant's own schedule; by default the samples are put "
        f"{DEFAULT_PHASE:g} of a period after the firmware's wheel commands, so that a "
        "late sample still reaches the next tick",
    )
    timing.add_argument(
        "--stop-odometry-at",
        metavar="S",
        type=float,
        help=f"comm-loss trial: stop sending odometry at S seconds; the run ends "
        f"{COMM_LOSS_TAIL:g} s later",
    )
    add_output_arguments(parser, "build/hil")
    parser.set_defaults(run=run)


def start_firmware(
    exe: Path, channel: str, timeout: float = 30.0, *, period_ms: int | None = None
) -> subprocess.Popen[str]:
    """Start ``exe --can channel`` (with ``--realtime --period-ms`` when
    @p period_ms is given) and wait until it is on the bus (its first line on
    stderr says so).

    :raises FirmwareError: it exited or said nothing in @p timeout seconds.
    """
    if not exe.is_file():
        raise FirmwareError(f"--fw {exe}: no such file (make fw builds build/host/mstc-fw)")
    cmd = [str(exe), "--can", channel]
    if period_ms is not None:
        cmd += ["--realtime", "--period-ms", str(period_ms)]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    assert proc.stderr is not None
    ready, _, _ = select.select([proc.stderr], [], [], timeout)
    line = proc.stderr.readline() if ready else ""
    if " mode on " not in line:
        proc.kill()
        said = (line + proc.stderr.read()).strip() or "no answer"
        raise FirmwareError(f"{exe} did not start on {channel}: {said}")
    return proc


def stop_firmware(proc: subprocess.Popen[str]) -> None:
    """Stop a firmware process started by :func:`start_firmware`."""
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def _run_one(args: argparse.Namespace, scenario: Scenario) -> tuple[str, RunResult, BusLog]:
    bus = can.Bus(interface=args.interface, channel=args.channel)
    period_ms = round(1000.0 / args.rate_hz) if args.realtime else None
    firmware = (
        start_firmware(args.fw, args.channel, period_ms=period_ms) if args.fw is not None else None
    )
    ctl: CanController
    try:
        if args.realtime:
            ctl = RealtimeLink(bus, scenario.params)
            result = simulate_realtime(
                scenario,
                ctl,
                rate_hz=args.rate_hz,
                phase=None if args.free_phase else DEFAULT_PHASE,
                stop_odometry_at=args.stop_odometry_at,
            )
        else:
            ctl = CanController(bus, scenario.params, sim_time_stamps=False)
            result = simulate(scenario, ctl)
    finally:
        bus.shutdown()
        if firmware is not None:
            stop_firmware(firmware)
    return bus.channel_info, result, BusLog(args.channel, ctl)


def _check_realtime(args: argparse.Namespace) -> str | None:
    """The problem with the real-time options, if any."""
    realtime_only = args.free_phase or args.stop_odometry_at is not None
    if not args.realtime:
        return "--free-phase and --stop-odometry-at need --realtime" if realtime_only else None
    if not 1.0 <= args.rate_hz <= 1000.0:
        return f"--rate-hz: expected 1 to 1000, got {args.rate_hz:g}"
    period_ms = 1000.0 / args.rate_hz
    if args.fw is not None and abs(period_ms - round(period_ms)) > 1e-9:
        return (
            f"--rate-hz {args.rate_hz:g}: mstc-fw's period is whole milliseconds "
            f"(--period-ms), and 1000/{args.rate_hz:g} = {period_ms:g}"
        )
    if args.stop_odometry_at is not None and not args.stop_odometry_at >= 0.0:
        return f"--stop-odometry-at: expected a time >= 0 s, got {args.stop_odometry_at:g}"
    return None


def run(args: argparse.Namespace) -> int:
    """Validate every scenario, run each over the bus, then write and report."""
    if args.fw is not None and args.interface != "socketcan":
        error("--fw starts mstc-fw, which runs on SocketCAN only (--interface socketcan)")
        return EXIT_USAGE
    problem = _check_realtime(args)
    if problem is not None:
        error(problem)
        return EXIT_USAGE
    return run_scenarios(
        args.scenarios,
        args.out,
        not args.no_figures,
        lambda scenario: _run_one(args, scenario),
        (FirmwareError, ControllerError, can.CanError, OSError),
    )
