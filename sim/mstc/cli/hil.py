# SPDX-License-Identifier: MIT
"""``mstc hil``: scenario files over a real CAN bus, against ``mstc-fw`` or a board."""

from __future__ import annotations

import argparse
import select
import subprocess
from pathlib import Path

import can

from mstc.can import secoc
from mstc.can.lockstep import CanController
from mstc.cli.common import EXIT_USAGE, add_key_argument, error, load_key, run_scenarios
from mstc.cli.sim import add_output_arguments
from mstc.errors import ControllerError, FirmwareError
from mstc.report.outputs import BusLog
from mstc.sim.run import RunResult, simulate
from mstc.sim.scenario import Scenario

NAME = "hil"
HELP = "run scenario files over SocketCAN (or another python-can bus) against mstc-fw or a board"

_EPILOG = """\
The plant runs on this machine and reaches the firmware through a python-can
bus: by default SocketCAN's vcan0, where the firmware runs as its own process
(--fw build/host/mstc-fw, started afresh for each scenario, like a board) or
on a board behind a CAN adapter. Each scenario writes DIR/<file stem>/ with
events.json, trace.csv, bus.log (every frame, candump -L) and the figures,
and prints the table of `mstc sim`.

On a host whose kernel has no CAN, `make hil` runs this inside a small VM
with vcan (docs/hil.md).

exit status: 0 done; 1 the firmware could not be started or did not answer,
or an output could not be written; 2 bad arguments or a bad scenario file.

example:
  .venv/bin/mstc hil --channel vcan0 --fw build/host/mstc-fw \\
      sim/scenarios/paper-line.toml
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
    add_key_argument(parser)
    add_output_arguments(parser, "build/hil")
    parser.set_defaults(run=run)


def start_firmware(
    exe: Path, channel: str, key_file: Path | None = None, timeout: float = 30.0
) -> subprocess.Popen[str]:
    """Start ``exe --can channel [--key-file key_file]`` and wait until it is
    on the bus (its first line on stderr says so). Without @p key_file it
    takes its key from the environment, as the tools do.

    :raises FirmwareError: it exited or said nothing in @p timeout seconds.
    """
    if not exe.is_file():
        raise FirmwareError(f"--fw {exe}: no such file (make fw builds build/host/mstc-fw)")
    cmd = [str(exe), "--can", channel]
    if key_file is not None:
        cmd += ["--key-file", str(key_file)]
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
    firmware = (
        start_firmware(args.fw, args.channel, args.key_source) if args.fw is not None else None
    )
    try:
        ctl = CanController(bus, scenario.params, sim_time_stamps=False, key=args.key)
        result = simulate(scenario, ctl)
    finally:
        bus.shutdown()
        if firmware is not None:
            stop_firmware(firmware)
    return bus.channel_info, result, BusLog(args.channel, ctl)


def run(args: argparse.Namespace) -> int:
    """Validate every scenario, run each over the bus, then write and report."""
    if args.fw is not None and args.interface != "socketcan":
        error("--fw starts mstc-fw, which runs on SocketCAN only (--interface socketcan)")
        return EXIT_USAGE
    args.key = load_key(args)
    if args.key is None:
        return EXIT_USAGE
    # mstc-fw gets the same key: the file it came from (None: from $MSTC_KEY,
    # which the process inherits).
    args.key_source = secoc.key_file(args.key_file)
    return run_scenarios(
        args.scenarios,
        args.out,
        not args.no_figures,
        lambda scenario: _run_one(args, scenario),
        (FirmwareError, ControllerError, can.CanError, OSError),
    )
