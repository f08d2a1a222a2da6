# SPDX-License-Identifier: MIT
"""The real-time loop (mstc.loop.realtime, mstc.loop.timing)
against the firmware library on a virtual clock: deterministic.

:class:`VirtualFirmware` is a python-can bus around the SIL firmware
(libmstc_sil.so) whose control tick (mstc_sil_fw_tick) runs every period from
a chosen phase, whose frames take chosen delays each way, and which can skip
a tick, add one, or stall the plant. It keeps its own record of what
happened: when each frame was sent, reached the firmware or reached the
plant, and when each tick ran. The expected values of these tests come from
that record (which frame was the latest to reach the firmware before each
tick), from an integration of the unicycle written here, and from
docs/safety.md, never from the plant's own bookkeeping.
"""

from __future__ import annotations

import ctypes
import heapq
import itertools
import json
import math
import random
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import can
import cantools
import pytest

from mstc.can import secoc
from mstc.can.protocol import wire_limits
from mstc.cli import main
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import simulate
from mstc.loop.realtime import RealtimeLink, simulate_realtime
from mstc.loop.result import RunResult
from mstc.plant.scenario import Scenario, load_scenario
from mstc.report.outputs import write_outputs
from mstc.report.plots import plot_timing
from mstc.report.table import format_report

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "sim" / "scenarios"
DB = cantools.database.load_file(ROOT / "firmware" / "comm" / "mstc.dbc")
ODOM_XY, STEP, WHEEL_CMD, PARAM_VALUE = 0x100, 0x104, 0x180, 0x190
PERIOD = 0.02


class _Frame(ctypes.Structure):
    """mstc_sil_frame_t (hal/sil/mstc_sil.h)."""

    _fields_ = [("id", ctypes.c_uint32), ("dlc", ctypes.c_uint8), ("data", ctypes.c_uint8 * 8)]


_TO_FW, _TICK, _TO_PLANT = 0, 1, 2  # the order of simultaneous happenings


@dataclass
class Record:
    """What happened on the virtual bus, on its clock [s]."""

    sent: list[tuple[float, can.Message]] = field(default_factory=list)
    """Frames the plant sent, when it sent them."""
    firmware: list[tuple[float, int | None]] = field(default_factory=list)
    """In the firmware's order: (time, index in ``sent``) for a frame that
    reached it, (time, None) for a tick it ran."""
    delivered: list[tuple[float, can.Message]] = field(default_factory=list)
    """The firmware's frames, when they reached the plant."""


class VirtualFirmware(can.BusABC):
    """The firmware library as a bus on a virtual clock.

    :param period: the firmware's control period [s].
    :param phase: its first tick [s].
    :param to_fw: delay of a plant frame to the firmware [s].
    :param from_fw: delay of a firmware frame to the plant [s], or a function
        giving it frame by frame (kept in order: a frame never overtakes).
    :param skip: ticks (by number) that do not run.
    :param extra: times [s] of ticks added to the schedule.
    :param stall: (time, length) [s]: the first time the plant waits at or
        after ``time``, it is held ``length`` more (a descheduled process).
    """

    def __init__(
        self,
        lib: Path,
        *,
        period: float = PERIOD,
        phase: float = 0.007,
        to_fw: float = 0.001,
        from_fw: float | Callable[[], float] = 0.003,
        skip: tuple[int, ...] = (),
        extra: tuple[float, ...] = (),
        stall: tuple[float, float] | None = None,
    ) -> None:
        self._lib = ctypes.CDLL(str(lib.resolve()))
        for name, args in (
            ("mstc_sil_fw_init", [ctypes.c_void_p]),
            ("mstc_sil_fw_send", [ctypes.POINTER(_Frame)]),
            ("mstc_sil_fw_recv", [ctypes.POINTER(_Frame)]),
        ):
            getattr(self._lib, name).argtypes = args
        self._lib.mstc_sil_fw_tick.argtypes = [ctypes.c_uint64]
        self._lib.mstc_sil_fw_tick.restype = None
        self._lib.mstc_sil_fw_set_key.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_uint32]
        assert self._lib.mstc_sil_fw_init(None) == 0
        key = secoc.load_key()  # the test key (conftest)
        assert self._lib.mstc_sil_fw_set_key(key, len(key), 0) == 0
        self.now = 0.0
        self.period, self.phase, self.to_fw = period, phase, to_fw
        self._from_fw = from_fw if callable(from_fw) else (lambda: from_fw)
        self._last_delivery = 0.0
        self.skip = set(skip)
        self.stall = stall
        self.record = Record()
        self._heap: list[tuple[float, int, int, object]] = []
        self._order = itertools.count()
        self._inbox: list[tuple[float, can.Message]] = []
        self._push(phase, _TICK, 0)
        for t in extra:
            self._push(t, _TICK, None)
        self.channel_info = "virtual firmware"
        super().__init__(channel="virtual0")

    def _push(self, t: float, kind: int, payload: object) -> None:
        heapq.heappush(self._heap, (t, kind, next(self._order), payload))

    def clock(self) -> float:
        """The virtual clock [s]."""
        return self.now

    def sleep(self, seconds: float) -> None:
        """Let virtual time pass."""
        self._run(self.now + max(seconds, 0.0))

    def _collect(self, t: float) -> None:
        f = _Frame()
        while self._lib.mstc_sil_fw_recv(ctypes.byref(f)) == 0:
            msg = can.Message(
                arbitration_id=f.id, is_extended_id=False, data=bytes(f.data[: f.dlc])
            )
            self._last_delivery = max(self._last_delivery, t + self._from_fw())
            self._push(self._last_delivery, _TO_PLANT, msg)

    def _run(self, until: float, stop_at_output: bool = False) -> None:
        while self._heap and self._heap[0][0] <= until:
            t, kind, _, payload = heapq.heappop(self._heap)
            self.now = max(self.now, t)
            if kind == _TO_FW:
                assert isinstance(payload, int)
                msg = self.record.sent[payload][1]
                f = _Frame(msg.arbitration_id, msg.dlc)
                f.data[: msg.dlc] = list(msg.data)
                assert self._lib.mstc_sil_fw_send(ctypes.byref(f)) == 0
                self.record.firmware.append((t, payload))
                self._collect(t)
            elif kind == _TICK:
                if payload is not None:
                    n = int(payload)  # type: ignore[call-overload]
                    self._push(self.phase + (n + 1) * self.period, _TICK, n + 1)
                if payload is None or payload not in self.skip:
                    self._lib.mstc_sil_fw_tick(round(t * 1e6))
                    self.record.firmware.append((t, None))
                    self._collect(t)
            else:
                assert isinstance(payload, can.Message)
                self._inbox.append((t, payload))
                if stop_at_output:
                    return
        self.now = max(self.now, until)

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """The frame reaches the firmware ``to_fw`` later."""
        self.record.sent.append((self.now, msg))
        self._push(self.now + self.to_fw, _TO_FW, len(self.record.sent) - 1)

    def recv(self, timeout: float | None = None) -> can.Message | None:
        """Wait on the virtual clock (python-can's recv() would time the
        wait with the real one)."""
        if self.stall is not None and self.now >= self.stall[0]:
            self._run(self.now + self.stall[1])
            self.stall = None
        if not self._inbox:
            self._run(self.now + (timeout or 0.0), stop_at_output=True)
        if not self._inbox:
            return None
        t, msg = self._inbox.pop(0)
        msg.timestamp = t
        self.record.delivered.append((t, msg))
        return msg

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        return self.recv(timeout), False


@dataclass(frozen=True)
class Run:
    """A real-time run on the virtual bus."""

    result: RunResult
    bus: VirtualFirmware
    link: RealtimeLink


def run_virtual(
    scenario: Scenario, lib: Path, stop_odometry_at: float | None = None, **bus_args: object
) -> Run:
    bus = VirtualFirmware(lib, **bus_args)  # type: ignore[arg-type]
    try:
        link = RealtimeLink(
            bus, scenario.params, clock=bus.clock, sleep=bus.sleep, stamps=lambda ts: ts
        )
        result = simulate_realtime(scenario, link, stop_odometry_at=stop_odometry_at)
    finally:
        bus.shutdown()
    return Run(result, bus, link)


def decode(msg: can.Message) -> dict[str, float]:
    return DB.decode_message(msg.arbitration_id, bytes(msg.data), decode_choices=False)


def run_start(rec: Record) -> float:
    """The run's first sample, from the bus alone: the first ODOM_XY sent
    after the first WHEEL_CMD that followed the accepted arm command."""
    armed = False
    first_cmd = None
    for t, msg in rec.delivered:
        if msg.arbitration_id == PARAM_VALUE:
            v = decode(msg)
            # The answer to PARAM_SET arm = 1 (PARAM_GET arm, which learns
            # the freshness first, is answered with value 0).
            armed = armed or (
                v["PARAM_VALUE_index"] == 128
                and v["PARAM_VALUE_result"] == 0
                and v["PARAM_VALUE_value"] == 1
            )
        elif msg.arbitration_id == WHEEL_CMD and armed:
            first_cmd = t
            break
    assert first_cmd is not None
    return next(t for t, m in rec.sent if m.arbitration_id == ODOM_XY and t > first_cmd)


@dataclass(frozen=True)
class Truth:
    """From the firmware's side of the record: which ODOM_XY frame (index in
    ``sent``) each tick used, and when its wheel command reached the plant."""

    ticks: list[tuple[float, int | None]]
    """(tick time, the latest ODOM_XY frame to reach the firmware before it)."""
    arrivals: list[float]
    """Each tick's WHEEL_CMD at the plant."""


def truth(run: Run) -> Truth:
    rec = run.bus.record
    latest: int | None = None
    ticks = []
    for t, index in rec.firmware:
        if index is None:
            ticks.append((t, latest))
        elif rec.sent[index][1].arbitration_id == ODOM_XY:
            latest = index
    arrivals = [t for t, m in rec.delivered if m.arbitration_id == WHEEL_CMD]
    # Ticks after the end of the run have no arrival: the bus stopped.
    return Truth(ticks[: len(arrivals)], arrivals)


def run_window(run: Run, tr: Truth) -> tuple[float, float]:
    """[first sample, arrival of the command computed from the last one]."""
    rec = run.bus.record
    start = run_start(rec)
    last = max(i for i, (_, m) in enumerate(rec.sent) if m.arbitration_id == ODOM_XY)
    end = next(a for (_, used), a in zip(tr.ticks, tr.arrivals, strict=True) if used == last)
    return start, end


@pytest.fixture(scope="module")
def short(tmp_path_factory: pytest.TempPathFactory) -> Scenario:
    """3 s with a turning reference and an obstacle in the way, integrated
    exactly, so that a piecewise integration written here can match it."""
    path = tmp_path_factory.mktemp("rt") / "short.toml"
    path.write_text(
        "[robot]\npose = [0.0, 0.0, 0.0]\n"
        "[reference]\npose = [0.1, 0.2, 0.3]\nv = 0.5\nw = 0.3\n"
        "[[obstacles]]\nposition = [1.3, 0.6]\n"
        '[sim]\nduration = 3.0\ndt = 0.02\nintegrator = "exact"\n'
    )
    return load_scenario(path, wire_limits())


def _arc(x: float, y: float, th: float, v: float, w: float, dt: float) -> tuple[float, ...]:
    """The unicycle over dt at constant (v, w), from the arc's closed form."""
    if abs(w) < 1e-12:
        return x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th
    return (
        x + v / w * (math.sin(th + w * dt) - math.sin(th)),
        y - v / w * (math.cos(th + w * dt) - math.cos(th)),
        th + w * dt,
    )


# ------------------------------------------------------------ the plant's own timing


def test_the_plant_sends_its_inputs_at_the_rate_and_never_a_step(
    sil_lib: Path, short: Scenario
) -> None:
    run = run_virtual(short, sil_lib)
    rec = run.bus.record
    start = run_start(rec)
    odom = [t for t, m in rec.sent if m.arbitration_id == ODOM_XY and t >= start]
    assert len(odom) == round(short.sim.duration / PERIOD) + 1
    assert all(abs((b - a) - PERIOD) < 1e-9 for a, b in zip(odom, odom[1:], strict=False))
    assert not any(m.arbitration_id == STEP for _, m in rec.sent)
    # Each sample: odometry, reference, then the obstacle while in range.
    ids = [m.arbitration_id for t, m in rec.sent if t >= start]
    assert ids[:4] == [0x100, 0x101, 0x102, 0x103]
    assert ids.count(0x102) == ids.count(0x100) == ids.count(0x103)
    assert len(run.result.trace.values) == len(odom)
    assert [round(t, 9) for t in run.result.trace["t"]] == [round(t - start, 9) for t in odom]


def test_each_wheel_command_acts_from_its_arrival(sil_lib: Path, short: Scenario) -> None:
    """The plant's poses at its samples are those of a robot whose wheel
    speeds change exactly when each WHEEL_CMD reaches it, between samples."""
    jitter = random.Random(15)
    run = run_virtual(short, sil_lib, phase=0.0131, from_fw=lambda: jitter.uniform(0.0005, 0.009))
    rec = run.bus.record
    start = run_start(rec)
    p = short.params
    cmds = []
    for t, m in rec.delivered:
        if m.arbitration_id == WHEEL_CMD:
            s = decode(m)
            left, right = s["WHEEL_CMD_left"], s["WHEEL_CMD_right"]
            v = p.wheel_radius * (left + right) / 2
            w = p.wheel_radius * (right - left) / p.track_width
            cmds.append((t, v, w))
    samples = [t for t, m in rec.sent if m.arbitration_id == ODOM_XY and t >= start]

    def poses(effective: Callable[[float], float]) -> list[tuple[float, ...]]:
        """The robot at each sample when each command takes effect at
        effective(its arrival)."""
        x, y, th = short.robot
        t_now = start
        _, v, w = [c for c in cmds if c[0] <= start][-1]
        changes = sorted((effective(t), cv, cw) for t, cv, cw in cmds if t > start)
        out = []
        for ts in samples:
            while changes and changes[0][0] <= ts:
                te, nv, nw = changes.pop(0)
                x, y, th = _arc(x, y, th, v, w, te - t_now)
                t_now, v, w = te, nv, nw
            x, y, th = _arc(x, y, th, v, w, ts - t_now)
            t_now = ts
            out.append((x, y, th))
        return out

    def error(a: list[tuple[float, ...]], b: list[tuple[float, ...]]) -> float:
        return max(
            abs(u - v) for pa, pb in zip(a, b, strict=True) for u, v in zip(pa, pb, strict=True)
        )

    trace = run.result.trace
    got = list(zip(trace["x"], trace["y"], trace["theta"], strict=True))
    assert len(got) == len(samples)
    assert error(got, poses(lambda t: t)) < 1e-9
    # The test can tell: holding each command until the next sample is off.
    next_sample = lambda t: next((ts for ts in samples if ts >= t), math.inf)  # noqa: E731
    assert error(got, poses(next_sample)) > 1e-4
    # The reference is taken at the same instants, exactly.
    xr, yr, thr = short.reference.pose
    rows = zip(samples, trace["x_r"], trace["y_r"], trace["theta_r"], strict=True)
    for t_s, row_x, row_y, row_th in rows:
        want_r = _arc(xr, yr, thr, short.reference.v, short.reference.w, t_s - start)
        assert abs(row_x - want_r[0]) < 1e-9 and abs(row_y - want_r[1]) < 1e-9
        assert abs(row_th - want_r[2]) < 1e-9


def _latencies(run: Run, tr: Truth) -> dict[float, float]:
    """Send time → latency [ms] of every ODOM_XY frame of the run that a tick
    used, from the firmware's side of the record (relative to the run's start)."""
    rec = run.bus.record
    start, end = run_window(run, tr)
    out: dict[float, float] = {}
    for (_, used), arrival in zip(tr.ticks, tr.arrivals, strict=True):
        if used is None or arrival > end:
            continue
        sent = rec.sent[used][0]
        if sent >= start and round(sent - start, 9) not in out:
            out[round(sent - start, 9)] = (arrival - sent) * 1e3
    return out


def test_latency_comes_from_the_echo_even_when_frames_take_over_a_period(
    sil_lib: Path, short: Scenario
) -> None:
    """Frames take 25 ms to reach the firmware: each tick uses a frame sent
    more than a period before, not the latest one sent. Only the echo of
    STATUS_TRK_odom_counter can tell which."""
    run = run_virtual(short, sil_lib, to_fw=0.025, phase=0.0113)
    tr = truth(run)
    want = _latencies(run, tr)
    timing = run.result.timing
    assert timing is not None
    got = {round(t, 9): ms for t, ms in timing.latency_series}
    assert got.keys() == want.keys()
    assert max(abs(got[t] - want[t]) for t in want) < 1e-6
    assert min(want.values()) > 1e3 * PERIOD  # really over a period
    # The naive pairing, with the last frame sent before the tick, is not it.
    assert timing.latency.p50 == pytest.approx(sorted(want.values())[len(want) // 2], abs=1e-6)


def test_missed_doubled_and_stale_periods_are_counted(sil_lib: Path, short: Scenario) -> None:
    """Two ticks skipped, one added 5 ms after another, and the plant held up
    for 33 ms once: the counts are those of the firmware's side of the record,
    and of the schedule worked out by hand."""
    run = run_virtual(
        short, sil_lib, skip=(40, 90), extra=(0.007 + 60 * PERIOD + 0.005,), stall=(1.5, 0.033)
    )
    tr = truth(run)
    start, end = run_window(run, tr)
    in_run = [
        (t, used) for (t, used), a in zip(tr.ticks, tr.arrivals, strict=True) if start <= a <= end
    ]
    ran = {round(t, 9) for t, _ in in_run}
    missed = sum(
        1
        for n in (40, 90)
        if start < 0.007 + n * PERIOD < end and round(0.007 + n * PERIOD, 9) not in ran
    )
    stale = sum(1 for (_, a), (_, b) in zip(in_run, in_run[1:], strict=False) if a == b)
    rec = run.bus.record
    odom = [i for i, (t, m) in enumerate(rec.sent) if m.arbitration_id == ODOM_XY and t >= start]
    used = {u for _, u in in_run}
    unused = sum(1 for i in odom if i not in used and i < max(used))
    timing = run.result.timing
    assert timing is not None
    # By hand: ticks at 7 + 20n ms, their wheel commands at the plant 3 ms
    # later, samples a quarter period after that (15 + 20n ms, from 0.195 s),
    # each reaching the firmware 1 ms later. A skipped tick leaves its frame
    # unused (the next tick has a newer one); the extra tick at 1.212 s finds
    # nothing new (stale). The stall catches the plant waiting after its
    # 1.495 s sample and holds it to 1.543 s: the 1.515 s sample is skipped
    # (plant missed), the 1.535 one goes at 1.543 s; the tick at 1.527 s is
    # stale and the one at 1.547 s takes the late frame.
    assert (missed, stale, unused) == (2, 2, 2)
    assert timing.missed == missed
    assert timing.doubled == 1
    assert timing.stale == stale
    assert timing.unused == unused
    assert timing.plant_missed == 1
    assert timing.wheel_cmd_lost == 0
    assert timing.steps == len(in_run)


def test_the_samples_follow_a_firmware_whose_clock_runs_slow(
    sil_lib: Path, short: Scenario
) -> None:
    """A firmware whose period is 20.1 ms on the plant's clock (0.5 % slow:
    a VM's clock calibrated on a busy host was 400 ppm off) drifts 15 ms
    over this 3 s run. Samples on a fixed 20 ms grid would meet its ticks
    twice in some periods and none in others; following its grid, every tick
    takes a new frame and none is passed over. From the firmware's side of
    the record, not from the plant's bookkeeping."""
    run = run_virtual(short, sil_lib, period=0.0201)
    tr = truth(run)
    start, end = run_window(run, tr)
    in_run = [used for (_, used), a in zip(tr.ticks, tr.arrivals, strict=True) if start <= a <= end]
    stale = sum(1 for a, b in zip(in_run, in_run[1:], strict=False) if a == b)
    rec = run.bus.record
    odom = [i for i, (t, m) in enumerate(rec.sent) if m.arbitration_id == ODOM_XY and t >= start]
    unused = sum(1 for i in odom if i not in set(in_run) and i < max(in_run))
    assert (stale, unused) == (0, 0)
    timing = run.result.timing
    assert timing is not None
    assert (timing.stale, timing.unused, timing.plant_missed) == (0, 0, 0)


def check_ramp(ramp: list[tuple[float, float, float]], decel_step: float, lsb: float) -> None:
    """docs/safety.md: each step the faster wheel loses max_wheel_decel·dt
    (@p decel_step for one nominal period, or a whole multiple of it when
    periods were skipped), the other is scaled by the same factor, down to
    zero. @p ramp starts with the last command before the halt; the wire
    carries speeds to @p lsb."""
    assert ramp[-1][1:] == (0.0, 0.0), ramp
    (_, l0, r0) = ramp[0]
    for (_, la, ra), (_, lb, rb) in zip(ramp, ramp[1:], strict=False):
        top_a, top_b = max(abs(la), abs(ra)), max(abs(lb), abs(rb))
        if top_b == 0.0:
            assert top_a <= 3 * decel_step + 2 * lsb, ramp  # the last step may be short
            continue
        periods = (top_a - top_b) / decel_step
        assert periods > 0.5 and abs(periods - round(periods)) * decel_step < 2 * lsb, ramp
        # The same curvature: the wheels keep their ratio.
        assert abs(lb * r0 - rb * l0) <= 2 * lsb * (abs(l0) + abs(r0)), ramp


def test_comm_loss_halts_within_three_periods_and_ramps_down(sil_lib: Path) -> None:
    scenario = load_scenario(SCENARIOS / "paper-line.toml", wire_limits())
    run = run_virtual(scenario, sil_lib, stop_odometry_at=1.0)
    rec = run.bus.record
    start = run_start(rec)
    odom = [t - start for t, m in rec.sent if m.arbitration_id == ODOM_XY and t >= start]
    assert odom[-1] < 1.0 <= odom[-1] + PERIOD + 1e-9  # none sent from 1.0 s on
    timing = run.result.timing
    assert timing is not None and timing.comm_loss is not None
    loss = timing.comm_loss
    assert loss.stopped_at == pytest.approx(1.0, abs=1e-9)
    # docs/safety.md: the halt comes at the 3rd step without fresh odometry
    # (k_last < k <= k_last + 3), i.e. 3 periods after the last step on it.
    assert loss.halt_after_steps == 3
    assert loss.halt_after == pytest.approx(3 * PERIOD, abs=1e-9)
    assert loss.halt_reason == 2  # odometry
    # From the bus alone: STATUS_halt and the wheel commands after the cut.
    halts, wheels = [], []
    status = None
    for t, m in rec.delivered:
        if m.arbitration_id == 0x181:
            status = decode(m)
        elif m.arbitration_id == WHEEL_CMD:
            s = decode(m)
            wheels.append((t - start, s["WHEEL_CMD_left"], s["WHEEL_CMD_right"]))
            halts.append(status["STATUS_halt"] if status else None)
    k_halt = halts.index(2)
    assert wheels[k_halt][0] == pytest.approx(loss.halt_t, abs=1e-9)
    ramp = wheels[k_halt - 1 :]
    ramp = ramp[: next(i for i, w in enumerate(ramp) if w[1:] == (0.0, 0.0)) + 1]
    assert [w[1:] for w in ramp] == [w[1:] for w in loss.ramp[-len(ramp) :]]
    decel = 125.0  # rad/s², PARAM max_wheel_decel's default (docs/safety.md)
    check_ramp(ramp, decel * PERIOD, 2**-10)
    # The plant stops the robot: no velocity in its last rows.
    assert run.result.trace["v"][-1] == 0.0 and run.result.trace["w"][-1] == 0.0


@pytest.fixture(scope="module")
def lockstep(sil_lib: Path) -> dict[str, RunResult]:
    out = {}
    for name in ("paper-line", "paper-circle"):
        scenario = load_scenario(SCENARIOS / f"{name}.toml", wire_limits())
        out[name] = simulate(scenario, SilController(scenario.params, sil_lib))
    return out


@pytest.mark.parametrize("name", ["paper-line", "paper-circle"])
def test_paper_scenarios_in_real_time_keep_the_lock_step_events(
    sil_lib: Path, lockstep: dict[str, RunResult], name: str
) -> None:
    """With the delays of a loaded machine (1 to 12 ms back, jittered), the
    events are those of lock-step within ±3 control periods and no obstacle
    comes closer than D_s."""
    scenario = load_scenario(SCENARIOS / f"{name}.toml", wire_limits())
    jitter = random.Random(name)
    run = run_virtual(scenario, sil_lib, phase=0.0037, from_fw=lambda: jitter.uniform(0.001, 0.012))
    got, want = run.result.events, lockstep[name].events
    assert [(e.kind, e.obstacle, e.side) for e in got] == [
        (e.kind, e.obstacle, e.side) for e in want
    ]
    assert all(abs(a.t - b.t) <= 3 * PERIOD + 1e-9 for a, b in zip(got, want, strict=True))
    p = scenario.params
    for o, d in zip(scenario.obstacles, run.result.min_distance, strict=True):
        assert d >= p.safe_distance(o.radius) > p.r_m + o.radius  # no contact
    timing = run.result.timing
    assert timing is not None
    # The jitter (11 ms at most) spreads single intervals, not their mean.
    assert timing.period.mean == pytest.approx(1e3 * PERIOD, abs=11.0 / timing.period.n)
    assert timing.missed == timing.doubled == timing.plant_missed == 0


def test_a_real_time_run_writes_timing_json_its_figure_and_a_report_line(
    sil_lib: Path, short: Scenario, tmp_path: Path
) -> None:
    run = run_virtual(short, sil_lib)
    folder = write_outputs(run.result, tmp_path, figures=False)  # the paper's figures: test_cli.py
    assert run.result.timing is not None
    plot_timing(run.result.timing, "short", folder / "timing.png")
    doc = json.loads((folder / "timing.json").read_text())
    assert doc["rate_hz"] == 50.0 and doc["period_ms"] == 20.0
    for key in ("wheel_cmd_period_ms", "latency_ms"):
        assert set(doc[key]) == {"n", "mean", "p50", "p99", "max", "min"}
    # By construction: sampled 3 + 5 ms after a tick, taken by the next, 20 ms
    # after it, whose wheel command takes 3 ms: 20 - 8 + 3 = 15 ms.
    assert doc["latency_ms"]["p50"] == pytest.approx(15.0, abs=1e-3)
    assert doc["firmware"]["missed_periods"] == 0 and doc["plant"]["samples"] == 151
    assert len(doc["series"]["latency"]) == doc["latency_ms"]["n"]
    assert (folder / "timing.png").stat().st_size > 10_000
    report = format_report(run.result, folder)
    assert "  timing        WHEEL_CMD every 20.00 ms" in report
    assert "latency odometry→command 15.00 ms p50" in report
    # A lock-step run in the same folder leaves no stale timing.json behind.
    write_outputs(simulate(short, SilController(short.params, sil_lib)), tmp_path, figures=False)
    assert not (folder / "timing.json").exists()


def test_a_firmware_that_never_ticks_is_a_clear_error(sil_lib: Path, short: Scenario) -> None:
    from mstc.errors import ControllerError

    with pytest.raises(ControllerError, match=r"mstc-fw --realtime"):
        run_virtual(short, sil_lib, phase=math.inf)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--stop-odometry-at", "1"], "need --realtime"),
        (["--realtime", "--rate-hz", "30", "--fw", "mstc-fw"], "whole milliseconds"),
        (["--realtime", "--rate-hz", "0"], "expected 1 to 1000"),
        (["--realtime", "--stop-odometry-at", "-1"], "expected a time >= 0 s"),
    ],
)
def test_mstc_hil_refuses_bad_real_time_options(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["hil", *args, str(SCENARIOS / "paper-line.toml")]) == 2
    assert message in capsys.readouterr().err


def test_a_path_reference_is_refused_in_real_time(tmp_path: Path) -> None:
    # A path's target waits for the robot and ends the run at the goal: the
    # lock-step loop's; the real-time loop says so before it touches the link.
    from mstc.errors import SimulationError

    path = tmp_path / "path.toml"
    path.write_text(
        "[robot]\npose = [0.0, 0.0, 0.0]\n"
        "[reference]\npath = [[0.0, 0.0], [2.0, 0.0]]\nspeed = 0.5\n"
        '[sim]\nduration = 3.0\ndt = 0.02\nintegrator = "euler"\n'
    )
    scenario = load_scenario(path, wire_limits())
    with pytest.raises(SimulationError, match=r"\[reference\] path: the real-time plant"):
        simulate_realtime(scenario, None)  # type: ignore[arg-type]  # never reached
