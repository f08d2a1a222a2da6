# SPDX-License-Identifier: MIT
"""``mstc hil``: scenario files over a real CAN bus, against ``mstc-fw`` or a
board, in lock-step or in real time; or over a board image's serial line under
QEMU (processor in the loop)."""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass, replace
from pathlib import Path

import can

from mstc.can import secoc
from mstc.can.library import LIB_ENV
from mstc.can.vmbridge import Bridge, BridgeBus
from mstc.cli import COMMANDS
from mstc.cli.common import (
    add_bus_arguments,
    add_key_argument,
    library,
    open_args_bus,
    run_scenarios,
)
from mstc.cli.sim import add_output_arguments, tolerance
from mstc.errors import ControllerError, UsageError
from mstc.firmware.process import start_firmware, stop_firmware
from mstc.firmware.qemu import ICOUNT, PIL_TRACE_N, BoardVm, LoopStats, WheelStats
from mstc.firmware.wheels import SUBSTEP_US, DcWheels, loop_figures, wheels_for
from mstc.loop.lockstep import CanController, enter_lockstep, simulate
from mstc.loop.realtime import (
    COMM_LOSS_TAIL,
    DEFAULT_PHASE,
    DEFAULT_RATE_HZ,
    RealtimeLink,
    simulate_realtime,
)
from mstc.loop.result import RunResult
from mstc.plant.scenario import Scenario
from mstc.report.outputs import BusLog
from mstc.report.progress import ProgressBar

NAME = "hil"
HELP = COMMANDS[NAME]

_EPILOG = f"""\
The plant runs on this machine and reaches the firmware through a python-can
bus: by default SocketCAN's vcan0, where the firmware runs as its own process
(--fw build/host/mstc-fw, started afresh for each scenario, like a board) or
on a board behind a CAN adapter. Each scenario writes DIR/<file stem>/ with
events.json, trace.csv, run.json, bus.log (every frame, candump -L) and the figures,
and prints the table of `mstc sim`. Scenario limits, progress, and reruns into
the same folder are as for `mstc sim` (see its --help).

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
the firmware in a small VM with vcan and this command on the host, through the
VM's bridge (tools/vm/with-vcan --bridge, docs/hil.md); --fw then starts
mstc-fw in the VM. A real-time run raises its priority (and the VM's) to
SCHED_RR 1 while it lasts, where permitted (timing.json's "priority").

A board in the loop (--board) steps on its own timer until its first STEP
frame: one STEP goes first, before the parameters and the arming, so that
every step of the run is the plant's. A board on a USB-serial adapter
(CAN=slcan images): --interface slcan --channel /dev/ttyUSB0@460800 --board.

With --qemu, the firmware is a board image built with CAN=slcan, booted under
qemu-system-arm for each scenario, and the plant reaches it through
python-can's slcan interface on the image's USART2 (processor in the loop,
`make pil`). One STEP frame first switches the board's main loop to
lock-step; the run fails if its timer ran a step after that. Each scenario
also writes loop_stats.json: the board's steps, and the instructions per
control step and per wheel period counted under QEMU's -icount. A scenario
with `[actuator] model = "dc"` needs a PIL image (build/firmware/<board>-pil),
whose wheel loop drives simulated motors on the target: the board measures
its own wheels, the plant moves the robot with a twin of them (the library
of --lib, in the board's numeric mode), and loop_stats.json gets the wheel
loop's figures from the board's motors and wheel_trace.csv their speeds.

A run that misses its scenario's [[expected]] events, or whose firmware
ended it halted when it was not asked to (--stop-odometry-at asks, and the
events expected from then on are not judged), says so on the last line,
after its outputs are written, and exits 4. In real time an event may be
3 control periods further from its time than its tolerance (--tolerance).

exit status: 0 done; 1 the firmware could not be started, did not answer or
refused the parameters, or an output could not be written; 2 bad arguments,
a bad scenario file, or an output folder that cannot be used; 3 the bus
cannot be opened (the error says why: no SocketCAN in this kernel, no such
interface, an interface down); 4 a run missed its scenario's expectations.

examples:
  .venv/bin/mstc hil --channel vcan0 --fw build/host/mstc-fw \\
      sim/scenarios/paper-line.toml
  .venv/bin/mstc hil --realtime --channel vcan0 --fw build/host/mstc-fw \\
      sim/scenarios/paper-line.toml
  .venv/bin/mstc hil --realtime --interface socketcan --channel can0 \\
      sim/scenarios/paper-line.toml          # a board (docs/hil.md)
  .venv/bin/mstc hil --qemu build/firmware/stm32f103-pil --out build/pil/stm32f103 \\
      sim/scenarios/paper-line.toml
"""


REALTIME_SLACK = 3
"""Control periods an event of a real-time run may be off its expected time
beyond its tolerance: the plant's and the firmware's clocks are not one, so an
event moves by about a period (docs/hil.md); test_hil allows 3."""


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
    add_bus_arguments(parser, default_interface="socketcan", default_channel="vcan0")
    parser.add_argument(
        "--fw",
        metavar="PATH",
        type=Path,
        help="start this firmware executable (mstc-fw) on --channel before each scenario "
        "and stop it after, so each runs on a fresh firmware (SocketCAN only)",
    )
    parser.add_argument(
        "--board",
        action="store_true",
        help="the firmware is a board image, which steps on its own timer until its first "
        "STEP frame: send one first (docs/hil.md); implied by --qemu",
    )
    parser.add_argument(
        "--qemu",
        metavar="IMAGE_DIR",
        type=Path,
        help="boot this board image (build/firmware/<board>-pil or <board>-slcan) under QEMU "
        "for each scenario and run it over its serial line with python-can's slcan interface",
    )
    parser.add_argument(
        "--lib",
        metavar="PATH",
        type=Path,
        help='with --qemu and a "dc" scenario: the firmware library whose wheel loop is '
        f"the plant's twin of the board's wheels (default: ${LIB_ENV}, else "
        "build/host/float/libmstc_sil.so)",
    )
    add_key_argument(parser)
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
    add_output_arguments(parser, "build/hil", f"0; {REALTIME_SLACK:g} control periods in real time")
    parser.set_defaults(run=run)


def _run_one(
    args: argparse.Namespace, scenario: Scenario, bar: ProgressBar
) -> tuple[str, RunResult, BusLog]:
    # The vcan VM's bridge (with-vcan --bridge): the bus through it, the
    # firmware started in the VM, and what crossed it counted.
    bridge = Bridge.from_env(args.channel) if args.interface == "socketcan" else None
    bus = bridge.open_bus() if bridge is not None else open_args_bus(args)
    before = bridge.counters() if bridge is not None else {}
    period_ms = round(1000.0 / args.rate_hz) if args.realtime else None
    firmware = (
        start_firmware(
            args.fw,
            args.channel,
            args.key_source,
            period_ms=period_ms,
            prefix=bridge.runner() if bridge is not None else (),
        )
        if args.fw is not None
        else None
    )
    ctl: CanController
    crossed: dict[str, int] | None = None
    try:
        if args.realtime:
            ctl = RealtimeLink(bus, scenario.params, key=args.key)
            result = simulate_realtime(
                scenario,
                ctl,
                rate_hz=args.rate_hz,
                phase=None if args.free_phase else DEFAULT_PHASE,
                stop_odometry_at=args.stop_odometry_at,
                progress=bar,
                boost=bridge.vm_threads() if bridge is not None else (),
            )
        else:
            primer = enter_lockstep(bus) if args.board else []
            ctl = CanController(bus, scenario.params, sim_time_stamps=False, key=args.key)
            ctl.traffic.frames[:0] = primer
            result = simulate(scenario, ctl, bar)
    finally:
        # The firmware first: the bridge's count is complete once it is quiet.
        if firmware is not None:
            stop_firmware(firmware)
        try:
            if bridge is not None and isinstance(bus, BridgeBus):
                crossed = bridge.tally(bus, before)
        finally:
            bus.shutdown()
    if crossed is not None:
        result = _with_bridge(result, crossed)
    return bus.channel_info, result, BusLog(args.channel, ctl)


def _with_bridge(result: RunResult, crossed: dict[str, int]) -> RunResult:
    """The bridge's count in the run's timing (real time); a lock-step run,
    which waits for every answer, cannot have lost a frame without failing,
    but a frame lost both ways is still an error worth its own message."""
    lost = crossed["dropped_to_vcan"] + crossed["dropped_to_plant"]
    if result.timing is None:
        if lost:
            raise ControllerError(f"the vcan VM's bridge lost frames: {crossed}")
        return result
    return replace(
        result, timing=replace(result.timing, extra={**result.timing.extra, "bridge": crossed})
    )


# ------------------------------------------------------------ under QEMU

SLCAN_BITRATE = 500000
"""The S code python-can asks for (S6): nominal, a serial line has no bit rate."""


@dataclass(frozen=True)
class BoardBusLog(BusLog):
    """The bus log of a run on a board image, and the board's own account."""

    board: str = ""
    loop_stats: str = ""
    """loop_stats.json: the board's steps and instructions per step."""
    wheel_trace: str = ""
    """wheel_trace.csv of a PIL image's simulated wheels, when it has them."""

    @property
    def files(self) -> dict[str, str]:
        files = {"loop_stats.json": self.loop_stats}
        if self.wheel_trace:
            files["wheel_trace.csv"] = self.wheel_trace
        return files

    def describe(self) -> str:
        return f"{super().describe()}\n  board         {self.board}"


def settled_stats(vm: BoardVm, start: LoopStats, steps: int, timeout: float = 2.0) -> LoopStats:
    """The board's loop statistics once they count the @p steps on STEP
    frames the plant saw since @p start, or at @p timeout. The main loop
    counts a step after the application has sent its WHEEL_CMD, so the plant
    may read the memory before the last one is counted. Each copy is
    consistent (:meth:`LoopStats.read`): a step counted in ``frame_steps`` is
    counted in ``steps`` too."""
    deadline = time.monotonic() + timeout
    end = vm.stats()
    while end.frame_steps - start.frame_steps < steps and time.monotonic() < deadline:
        time.sleep(0.01)
        end = vm.stats()
    return end


def check_lockstep(start: LoopStats, end: LoopStats, steps: int) -> None:
    """The board ran exactly one control step per STEP frame between
    @p start and @p end, and none on its timer.

    :raises ControllerError: it did not.
    """
    by_frames = end.frame_steps - start.frame_steps
    timer = (end.steps - start.steps) - by_frames
    if not end.lockstep or by_frames != steps or timer != 0:
        raise ControllerError(
            f"the board ran {by_frames} steps on {steps} STEP frames and {timer} on its timer "
            "(lock-step needs one per STEP and none on the timer)"
        )


def loop_record(
    vm: BoardVm,
    start: LoopStats,
    end: LoopStats,
    wheels: tuple[WheelStats, WheelStats] | None = None,
) -> dict[str, object]:
    """loop_stats.json: the board's steps and their cost during the run, and
    with @p wheels (its wheel loop's statistics at the start and the end) the
    wheel periods and their cost.

    Cycles are SysTick counts at the core clock QEMU models; under -icount
    shift=0 one instruction takes 1 ns of virtual time, so a count is
    10⁹ / core_hz instructions (mstc.firmware.qemu). The mean is over the run's
    steps; the maximum over every lock-step step (the one before arming too).
    A wheel period's are the firmware's: encoders to motors, a simulated
    motor's own cycles excluded (hal/stm32/pil_wheels.c); its maximum over
    every period since start.
    """
    n = end.frame_steps - start.frame_steps
    core_hz = vm.core_hz()
    per_count = 1e9 / core_hz
    mean = (end.step_cycles_sum - start.step_cycles_sum) / n if n else 0.0
    record: dict[str, object] = {
        "board": vm.board,
        "image": str(vm.image_dir),
        "machine": vm.machine,
        "icount": ICOUNT,
        "qemu_core_hz": core_hz,
        "steps": n,
        "timer_steps": (end.steps - start.steps) - n,
        "cycles_per_step": {"mean": round(mean, 1), "max": end.step_cycles_max},
        "instructions_per_step": {
            "mean": round(mean * per_count),
            "max": round(end.step_cycles_max * per_count),
        },
    }
    if wheels is not None:
        w0, w1 = wheels
        periods = w1.periods - w0.periods
        w_mean = (w1.cycles_sum - w0.cycles_sum) / periods if periods else 0.0
        record["wheel_loop"] = {
            "periods": periods,
            "periods_on_steps": w1.step_periods - w0.step_periods,
            "closed_loop": w1.closed_loop,
            "faults": w1.faults,
            "instructions_per_period": {
                "mean": round(w_mean * per_count),
                "max": round(w1.cycles_max * per_count),
            },
        }
    return record


PIL_TRACE_COLUMNS = "t,board_left,board_right,plant_left,plant_right,cmd_left,cmd_right"
"""wheel_trace.csv: per wheel period, the board's simulated wheels' true speeds,
the plant's twin's and the command in force [rad/s]."""


def _wheel_trace(
    board: list[tuple[float, float]], twin: DcWheels, per_step: int, period_s: float
) -> str:
    lines = [PIL_TRACE_COLUMNS]
    for i, (b, p) in enumerate(zip(board, twin.speeds, strict=False)):
        c = twin.commands[i // per_step]
        t = (i + 1) * period_s
        lines.append(f"{t:.3f},{b[0]:.4f},{b[1]:.4f},{p[0]:.4f},{p[1]:.4f},{c[0]:.4f},{c[1]:.4f}")
    return "\n".join(lines) + "\n"


def _run_on_qemu(
    args: argparse.Namespace, scenario: Scenario, bar: ProgressBar
) -> tuple[str, RunResult, BusLog]:
    # "dc": the board's wheels are its own, simulated on the target; the
    # plant moves the robot with a twin of them, recording the start.
    twin = wheels_for(scenario, library(args.lib)) if scenario.actuator.model == "dc" else None
    if twin is not None:
        twin.record = PIL_TRACE_N
    with BoardVm(args.qemu, serial=True) as vm:
        bus = can.Bus(
            interface="slcan", channel=vm.channel, bitrate=SLCAN_BITRATE, sleep_after_open=0
        )
        try:
            before = vm.stats()
            wheels_before = vm.wheel_stats()
            primer = enter_lockstep(bus)
            # The primer's step, once counted: the board counts a step after
            # its WHEEL_CMD, which the plant may see first.
            start = settled_stats(vm, before, 1)
            ctl = CanController(bus, scenario.params, sim_time_stamps=False, key=args.key)
            ctl.traffic.frames[:0] = primer
            result = simulate(scenario, ctl, bar, twin)
            end = settled_stats(vm, start, len(result.trace.values))
            wheels_after = vm.wheel_stats()
            board_trace = vm.pil_trace() if twin is not None else []
        finally:
            bus.shutdown()
        check_lockstep(start, end, len(result.trace.values))
        record = loop_record(vm, start, end, (wheels_before, wheels_after))
    trace = ""
    if twin is not None:
        # The loop's period is the twin's substep and the board's wheel
        # period: 1 ms (wheel_rate is not a scenario's parameter).
        per_step = round(scenario.sim.dt_us / SUBSTEP_US)
        accel = scenario.params.wheel_accel
        figures = {
            "board": loop_figures(board_trace, twin.commands, per_step, accel),
            "plant": loop_figures(twin.speeds, twin.commands, per_step, accel),
        }
        wheel_loop = record["wheel_loop"]
        assert isinstance(wheel_loop, dict)
        wheel_loop["figures"] = {k: v.as_dict() for k, v in figures.items()}
        wheel_loop["trace_periods"] = len(board_trace)
        trace = _wheel_trace(board_trace, twin, per_step, SUBSTEP_US * 1e-6)
    ins = record["instructions_per_step"]
    assert isinstance(ins, dict)
    board = (
        f"{args.qemu.name} on qemu-system-arm -M {record['machine']}: {record['steps']} steps, "
        f"one per STEP; {ins['mean']} instructions per step (mean), {ins['max']} (max)"
    )
    stats = json.dumps(record, indent=2) + "\n"
    return (
        f"{args.qemu}/mstc.elf under QEMU",
        result,
        BoardBusLog("slcan0", ctl, board, stats, trace),
    )


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
        raise UsageError(
            "--fw starts mstc-fw, which runs on SocketCAN only (--interface socketcan)"
        )
    if args.qemu is not None and args.fw is not None:
        raise UsageError("--qemu runs a board image, --fw a process: one or the other")
    if args.qemu is not None and args.realtime:
        raise UsageError("--qemu runs a board image in lock-step: --realtime needs --fw or a board")
    problem = _check_realtime(args)
    if problem is not None:
        raise UsageError(problem)
    # mstc-fw (--fw) and QEMU (--qemu) are simulations: the simulations' key
    # by default, never a device's; a board holds the device key.
    simulated = args.fw is not None or args.qemu is not None
    default = secoc.SIM_KEY_FILE if simulated else secoc.DEFAULT_KEY_FILE
    args.key = secoc.load_key(args.key_file, default)
    # mstc-fw gets the same key: the file it came from (None: from $MSTC_KEY,
    # which the process inherits).
    args.key_source = secoc.key_file(args.key_file, default)
    run_one = _run_on_qemu if args.qemu is not None else _run_one

    def run_checked(scenario: Scenario, bar: ProgressBar) -> tuple[str, RunResult, BusLog]:
        if scenario.actuator.model == "dc" and args.qemu is None:
            raise UsageError(
                f'{scenario.path}: [actuator] model = "dc" runs the wheel loop in the '
                "plant's process (mstc sim, mstc sweep) or on a PIL image's simulated motors "
                "(--qemu build/firmware/<board>-pil); mstc-fw and a board have no such motors"
            )
        return run_one(args, scenario, bar)

    return run_scenarios(
        args.scenarios,
        args.out,
        not args.no_figures,
        run_checked,
        (can.CanError, OSError),
        quiet=args.quiet,
        slack=tolerance(args, REALTIME_SLACK / args.rate_hz if args.realtime else 0.0),
        stop_at=args.stop_odometry_at,
    )
