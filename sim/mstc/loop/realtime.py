# SPDX-License-Identifier: MIT
"""The real-time loop: the closed loop on the wall clock, against a firmware on
its own timer (docs/hil.md, "Real time").

Beside the lock-step loop (:func:`mstc.loop.lockstep.simulate`), sharing
everything but the clock: the scenario, the plant, the reference, the sensor,
the result (:class:`~mstc.loop.result.RunResult`, with its outputs and
report). Here nothing waits for the firmware: the plant samples its state at
a fixed rate and sends odometry, reference and obstacles; the firmware steps
on its own timer with whatever arrived last; each wheel command acts on the
plant from the moment it arrives, so the pose is integrated piecewise between
arrivals.

The frames go through :class:`RealtimeLink`:
:class:`~mstc.loop.lockstep.CanController` without the STEP frame (the same
parameters, frames, E2E protection and telemetry decoding), but the frames go
out when the plant's clock says so and the firmware's come in as its timer
produces them. It stamps every frame, sent or received, with the plant's
clock, records every ODOM_XY frame it sent and assembles each control step
the firmware reports (STATUS, STATUS_TRK, then WHEEL_CMD) into a
:class:`~mstc.loop.timing.FirmwareStep`, with the ODOM_XY frame the step used,
found from the counter the firmware echoes in STATUS_TRK_odom_counter. The
clock, the sleep and the bus are the link's, so a test can run the loop on a
clock of its own; :mod:`mstc.loop.timing` measures the run.
"""

from __future__ import annotations

import gc
import math
import os
import statistics
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace

import can
import numpy as np

from mstc.can.protocol import COUNTER_MODULO, Frame
from mstc.errors import ControllerError, FrameDropped, SimulationError
from mstc.loop.lockstep import REARM_FRAMES, CanController, decode_event, unauthenticated
from mstc.loop.result import PROGRESS_UPDATES, RunResult, Trace, distances, fault_counts
from mstc.loop.timing import FirmwareStep, OdomSent, analyse
from mstc.model import Event, Mode, Obstacle, Params, Pose, Progress
from mstc.plant.plant import integrate
from mstc.plant.reference import ReferenceRobot
from mstc.plant.scenario import Scenario
from mstc.plant.world import make_world

# ------------------------------------------------------------------ the link

ODOM_XY_ID = 0x100
"""The ODOM_XY frame's identifier (mstc.dbc)."""
STATUS_STEP_MODULO = 8
"""STATUS_step holds the low 3 bits of the step."""
STAMP_TRUST = 10.0
"""A received frame's time stamp older than this [s], or in the future, is
taken as not on the plant's clock (an interface that stamps otherwise)."""


def _epoch_offset(clock: Callable[[], float], tries: int = 7) -> float:
    """time.time() - clock(), read so that a descheduling between the two
    readings (milliseconds, in a loaded VM) cannot bias it: the reading
    bracketed most tightly by two of the clock's."""
    best = (math.inf, 0.0)
    for _ in range(tries):
        a = clock()
        wall = time.time()
        b = clock()
        best = min(best, (b - a, wall - (a + b) / 2))
    return best[1]


class RealtimeLink(CanController):
    """Frames of a real-time run, on the plant's clock.

    :param bus: the bus the firmware is on.
    :param params: parameters, sent with PARAM_SET when the link is made.
    :param clock: the plant's clock [s], monotonic.
    :param sleep: waits [s] on that clock (for buses whose ``recv`` does not).
    :param stamps: turns a received frame's time stamp into the plant's
        clock. A frame's arrival is its stamp when the interface gives one
        (SocketCAN's kernel stamps it as it arrives, whatever the plant
        process was doing), else when ``recv`` returned it. Default: stamps on
        the epoch, as SocketCAN's and python-can's are; a stamp off by more
        than a second, or in the future, is not used.
    :param timeout: how long to wait for a PARAM_VALUE answer [s].
    :param key: the firmware's key; default: :func:`mstc.can.secoc.load_key`.
    """

    def __init__(
        self,
        bus: can.BusABC,
        params: Params,
        *,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        stamps: Callable[[float], float] | None = None,
        timeout: float = 2.0,
        key: bytes | None = None,
    ) -> None:
        self.now = clock
        self.sleep = sleep
        # bus.log's time stamps: the plant's clock, shifted to the epoch as
        # candump's (and SocketCAN's kernel stamps) are.
        self._epoch = _epoch_offset(clock)
        self._stamps = stamps if stamps is not None else (lambda ts: ts - self._epoch)
        self.odometry: list[OdomSent] = []
        """Every ODOM_XY frame sent, with the plant clock's time."""
        self.steps: list[FirmwareStep] = []
        """Every firmware step received, with the plant clock's time."""
        self.answers: list[Frame] = []
        """PARAM_VALUE frames received while running."""
        self.send_failures = 0
        self.last_t = 0.0
        """When the last frame was sent, or the last frame received arrived
        [s, plant clock]."""
        self._xy_t = 0.0
        self._last_arrival = -math.inf
        self._pending_events: list[Event] = []
        self._pending_status: Frame | None = None
        self._pending_trk: Frame | None = None
        super().__init__(bus, params, timeout=timeout, clock=lambda: self.stamp(clock()), key=key)

    def stamp(self, t: float) -> float:
        """The time stamp in bus.log of time @p t on the plant's clock."""
        return self._epoch + t

    # ------------------------------------------------------------ sending

    def _send(self, msg: can.Message) -> None:
        """Stamp with the plant's clock and send (raises on failure)."""
        self.last_t = self.now()
        msg.timestamp = self.stamp(self.last_t)
        if msg.arbitration_id == ODOM_XY_ID:
            self._xy_t = self.last_t
        self.bus.send(msg)
        self.traffic.frames.append((msg, True))

    def _post(self, send: Callable[[], object]) -> bool:
        """Run a send while the loop runs: a frame that cannot go out is
        counted and the run goes on, as on a board."""
        try:
            send()
        except can.CanError:
            self.send_failures += 1
            return False
        return True

    def send_sample(
        self,
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        obstacles: Sequence[Obstacle],
        sample: int | None,
        *,
        odometry: bool = True,
    ) -> None:
        """One sample's frames: odometry (unless @p odometry is False: a
        comm-loss trial), reference, and the obstacles the sensor reports.

        :param sample: the plant sample; None while arming.
        """
        if odometry:
            sent: list[can.Message] = []
            if self._post(lambda: sent.append(self._send_odometry(robot))):
                # Its own time, not that of ODOM_THETA, sent after it.
                self.odometry.append(OdomSent(self._xy_t, sent[0].data[1] & 0x0F, sample))
        self._post(lambda: self._send_reference(ref, v_r, w_r))
        self._post(lambda: self._send_obstacles(obstacles))

    def send_arm(self, value: float) -> bool:
        """The arm command, authenticated: 1 arms, 0 disarms (docs/safety.md),
        signed for the challenge of the firmware's last authenticated status
        (:meth:`take` adopts them; one comes every 100 ms and after each
        answer). When that challenge was signed already, a PARAM_GET asks for
        a new status instead.

        :returns: whether the command went out.
        """
        if not self.auth.can_sign():
            self._post(
                lambda: self._send(self.proto.encode("PARAM_GET", index=self.tables.arm_index))
            )
            return False
        frames = self.auth.param_set(self.proto, self.tables.arm_index, value)
        return self._post(lambda: self._send_all(frames))

    def _send_all(self, frames: Sequence[can.Message]) -> None:
        for msg in frames:
            self._send(msg)

    # ---------------------------------------------------------- receiving

    def take(self, timeout: float) -> Frame | None:
        """Wait at most @p timeout [s] for one frame; handle it if it passes
        the E2E checks (else it is counted in ``proto.drops``).

        :returns: the frame, or None (nothing came, or it was dropped).
        """
        msg = self.bus.recv(timeout=max(timeout, 0.0))
        if msg is None:
            return None
        now = self.now()
        arrived = self._stamps(msg.timestamp) if msg.timestamp else now
        if not now - STAMP_TRUST <= arrived <= now:
            arrived = now
        # Frames arrive in order: never before the one taken before.
        self.last_t = max(arrived, self._last_arrival)
        self._last_arrival = self.last_t
        msg.timestamp = self.stamp(self.last_t)
        self.traffic.frames.append((msg, False))
        try:
            frame = self.proto.decode(msg)
        except FrameDropped:
            return None
        name = frame.name
        if name == "EVENT":
            self._pending_events.append(decode_event(self.tables, frame, 0))
        elif name == "STATUS":
            self._pending_status = frame
        elif name == "STATUS_TRK":
            self._pending_trk = frame
        elif name == "WHEEL_CMD":
            self.steps.append(self._step(frame))
        elif name == "PARAM_VALUE":
            self.answers.append(frame)
        elif name == "STATUS_COUNTERS":
            self.traffic.firmware_drops = {k: int(v) for k, v in frame.signals.items()}
        elif name in ("AUTH_STATUS", "AUTH_CHALLENGE"):
            self.auth.sync(frame)  # adopted when AUTH_CHALLENGE's MAC verifies
        return frame

    def _step(self, wheel_cmd: Frame) -> FirmwareStep:
        """A WHEEL_CMD with the telemetry that came before it; that telemetry
        is the same step's when STATUS_step matches."""
        s = wheel_cmd.signals
        step = int(s["step"])
        left, right = float(s["left"]), float(s["right"])
        status, trk = self._pending_status, self._pending_trk
        if status is not None and int(status.signals["step"]) != step % STATUS_STEP_MODULO:
            status = None  # an earlier step's
        result = FirmwareStep(
            t=self.last_t,
            step=step,
            left=left,
            right=right,
            status=self._decode_status(status, trk, left, right) if status and trk else None,
            halt=int(status.signals["halt"]) if status else None,
            odom=self._echoed(int(trk.signals["odom_counter"]), self.last_t) if trk else None,
            events=tuple(self._pending_events),
        )
        self._pending_events, self._pending_status, self._pending_trk = [], None, None
        return result

    def _echoed(self, counter: int, arrived: float) -> int | None:
        """The ODOM_XY frame a step used: the latest sent before its answer
        arrived (not before the plant got round to it: a busy plant may have
        sent 16 more since) with the counter it echoes. Each counter value
        comes back every 16 frames, so this holds while the latency stays
        under 16 periods."""
        odometry = self.odometry
        i = len(odometry) - 1
        while i >= 0 and odometry[i].t > arrived:
            i -= 1
        for j in range(i, max(i - COUNTER_MODULO, -1), -1):
            if odometry[j].counter == counter:
                return j
        return None


# ------------------------------------------------------------------ the loop

DEFAULT_RATE_HZ = 50.0
"""The control rate: the DBC's cycle time of the inputs, 20 ms."""
DEFAULT_PHASE = 0.25
"""Where the plant samples within the firmware's period: a quarter of a
period after a wheel command arrives. The tick before has run by then, and
the plant can only be late, never early: its frames have three quarters of a
period to reach the next tick."""
COMM_LOSS_TAIL = 1.0
"""How long a comm-loss trial runs after the odometry stops [s]."""
ARM_TIMEOUT = 10.0
"""How long arming may take before the run gives up [s]."""
BACKLOG = 4
"""At most this many queued frames are taken before a due send: a machine
that handles frames slower than they come must still send (the firmware
halts without odometry); the rest wait for the next pause."""
DRAIN_PERIODS = 2
"""Periods the loop keeps receiving after the last sample, so that the last
frames' wheel commands are seen."""
ARM_REFUSALS = 3
"""Arm commands refused as unauthenticated in a row that end the run: one
can meet a challenge that expired on its way (a race), three cannot."""


def _arm(
    link: RealtimeLink,
    robot: Pose,
    ref: Pose,
    v_r: float,
    w_r: float,
    period: float,
    phase: float | None,
) -> FirmwareStep:
    """Arm the firmware and return its first step armed.

    The firmware steps on its own timer, so the inputs must keep coming at
    the rate, not in one burst as in lock-step: every period the initial
    state goes out. The firmware accepts the arm command after 5 good frames
    of each input in a row (docs/safety.md), and a tick that finds no new
    frame breaks the row, so the command goes once its last REARM_FRAMES
    steps each echoed a new ODOM_XY frame, and again while refused. The
    firmware steps (halted) before it is armed too, so with @p phase each
    send is put that fraction of a period after its latest wheel command,
    where a late frame still reaches the next tick. The first step after the
    accepting answer computes the wheel command of the initial state, the
    run's step 0.

    :raises ControllerError: not armed within ARM_TIMEOUT, or its first step
        halted.
    """
    clock = link.now
    tables = link.tables
    start = clock()
    next_send = start
    fresh = 0  # steps in a row that took a new odometry frame
    asked: float | None = None
    armed = False
    refusals = 0
    unauthenticated_in_a_row = 0

    def handle(frame: Frame) -> FirmwareStep | None:
        """Note the arm command's answer, and which steps found new
        odometry; the first step armed, if this is it."""
        nonlocal armed, refusals, asked, next_send, fresh, unauthenticated_in_a_row
        if frame.name == "PARAM_VALUE" and frame.signals["index"] == tables.arm_index:
            if frame.signals["result"] == tables.param_result.value("unauthenticated"):
                # Sent again 3 periods later for the next challenge (one
                # that expired on the way is a race, not an attack); the
                # third refusal in a row ends the run, with the reason the
                # authenticated status gives.
                unauthenticated_in_a_row += 1
                if unauthenticated_in_a_row >= ARM_REFUSALS:
                    raise unauthenticated("the arm command", link.auth)
            else:
                unauthenticated_in_a_row = 0
            armed = frame.signals["result"] == tables.param_ok
            refusals += not armed
            asked = asked if armed else None
        elif frame.name == "WHEEL_CMD":
            if armed:
                return link.steps[-1]
            steps = link.steps
            new = len(steps) > 1 and steps[-1].odom is not None and steps[-1].odom != steps[-2].odom
            fresh = fresh + 1 if new else 0
            if phase is not None and link.last_t + phase * period > clock():
                next_send = link.last_t + phase * period
        return None

    while True:
        now = clock()
        if now - start > ARM_TIMEOUT:
            if not link.steps:
                why = "ran no control step: is it in real-time mode (mstc-fw --realtime)?"
            elif armed:
                why = "accepted the arm command but ran no step after it"
            else:
                why = f"did not arm ({refusals} refusals, {len(link.steps)} control steps seen)"
            raise ControllerError(f"within {ARM_TIMEOUT:g} s the firmware {why}")
        if now >= next_send:
            link.send_sample(robot, ref, v_r, w_r, (), None)
            # The arm command once the firmware's last steps each found a new
            # frame (its receivers then count a run of good frames), and again
            # if refused or unanswered for 3 periods.
            if not armed and fresh >= REARM_FRAMES and (asked is None or now - asked > 3 * period):
                link.send_arm(1.0)
                asked = now
            next_send += period * (1 + math.floor((now - next_send) / period))
        # Every frame already queued, then one more until the next send is
        # due: on a slow machine the sends must not starve the receive side.
        first = None
        for _ in range(BACKLOG):
            frame = link.take(0.0)
            if frame is None or (first := handle(frame)) is not None:
                break
        if first is None and (left := next_send - clock()) > 0:
            frame = link.take(left)
            if frame is None:
                _idle(link, next_send)
            else:
                first = handle(frame)
        if first is not None:
            if first.halt not in (0, None):
                raise ControllerError(
                    f"the firmware halted at its first step armed (STATUS_halt {first.halt})"
                )
            return first


PHASE_STEPS = 25
"""Steps whose arrivals place the samples (:func:`_arrival`)."""


def _arrival(steps: Sequence[FirmwareStep], period: float) -> float:
    """When the last of @p steps would have arrived on the firmware's grid:
    the median, over the last PHASE_STEPS steps, of each arrival moved to the
    last step by its step count. A single arrival is early or late by the
    scheduling of the emulated side and of the bridge (milliseconds, under
    load); samples placed after the first armed step alone would sit that
    much off the intended phase for the whole run. (statistics.median, not
    numpy's: numpy's first call in a process takes some 14 ms, which made
    the first run's sample 0 that late, and its first step stale.)"""
    last = steps[-1]
    moved = [
        s.t + ((last.step - s.step) % (1 << 16)) * period
        for s in steps[-PHASE_STEPS:]
        if (last.step - s.step) % (1 << 16) < 2 * PHASE_STEPS
    ]
    return statistics.median(moved)


def _drift(
    steps: Sequence[FirmwareStep], t0: float, period: float, phase: float | None, last: float
) -> float:
    """How far the firmware's grid has moved from the samples' grid (t0 +
    k·period) since the run began [s], the nearest to @p last (the previous
    estimate: it moves by microseconds a period): the samples follow it. Two
    clocks never run at quite the same rate (a VM's, calibrated
    at its boot on a busy host, was some 400 ppm off: 8 ms in a 20 s run);
    samples on a fixed grid would slide towards the firmware's ticks until
    their frames came after them."""
    if phase is None or not steps:
        return last
    want = _arrival(steps, period) + phase * period - t0 - last
    return float(last + (want + period / 2) % period - period / 2)


def _idle(link: RealtimeLink, until: float) -> None:
    """A bus whose ``recv`` returned before its timeout: wait a little on the
    clock, not in a busy loop."""
    left = until - link.now()
    if left > 0:
        link.sleep(min(left, 0.001))


def simulate_realtime(
    scenario: Scenario,
    link: RealtimeLink,
    *,
    rate_hz: float = DEFAULT_RATE_HZ,
    phase: float | None = DEFAULT_PHASE,
    stop_odometry_at: float | None = None,
    progress: Progress | None = None,
    boost: Sequence[int] = (),
) -> RunResult:
    """Run a scenario in real time against a firmware on its own timer.

    After arming (:func:`_arm`), sample k = 0..N (N = duration · rate) is
    taken at t0 + k/rate on the link's clock, t0 being @p phase of a period
    after the first armed step's wheel command arrived (or the next send
    time, when @p phase is None). At each sample the plant is integrated to
    the present with the wheel command in force, the reference is taken at
    the same instant (its grid pose at k/rate, advanced by the loop's
    lateness), and ODOM_XY, ODOM_THETA, REF_XY, REF_MOTION and an OBSTACLE
    frame for each obstacle in range go out; the row is recorded. Between
    samples every WHEEL_CMD that arrives takes effect at once. A sample the
    loop is a whole period late for is skipped (counted), not sent in a
    burst. No STEP frame is ever sent.

    Rows are stamped with the time the sample was actually taken; events
    with the time of the odometry the step that raised them used (found
    through the echo in STATUS_TRK), which is the lock-step time of a
    timely run; errors and mode come from the firmware's latest step.

    :param stop_odometry_at: a comm-loss trial: from the first sample at or
        after this time [s], ODOM_XY and ODOM_THETA are no longer sent (the
        reference and obstacles still are); the run ends COMM_LOSS_TAIL later.
    :param progress: told how many samples are done, now and then, and closed
        when the run ends.
    :param boost: threads that run at the real-time priority with the loop
        (:func:`real_time_priority`): the vcan VM's.

    The scenario's odometry noise is added to the pose sent, with the same
    stream as in lock-step, and the sensor's imperfections apply; its
    ``delay`` does not (the latency here is the bus's and the firmware's).
    An ``[actuator]`` is simulated in lock-step only: the wheels here follow
    WHEEL_CMD at once.

    :returns: the run, with its :class:`~mstc.loop.timing.Timing`.
    :raises ControllerError: the firmware could not be armed.
    :raises SimulationError: the scenario has an ``[actuator]``, or a path
        reference (``[reference] path``).
    """
    if scenario.actuator.model != "ideal":
        raise SimulationError(
            f"{scenario.path}: [actuator]: the real-time plant has ideal wheels; run the "
            "scenario in lock-step (mstc sim, mstc hil without --realtime)"
        )
    if scenario.reference.path:
        raise SimulationError(
            f"{scenario.path}: [reference] path: the real-time plant follows time-parameterised "
            "references only (a path's target waits for the robot and ends the run at its goal "
            "in lock-step); run the scenario in lock-step (mstc sim, mstc hil without --realtime)"
        )
    period = 1.0 / rate_hz
    last_k = round(scenario.sim.duration * rate_hz)
    if stop_odometry_at is not None:
        last_k = min(last_k, math.ceil((stop_odometry_at + COMM_LOSS_TAIL) * rate_hz - 1e-9))
    drops_before = dict(link.traffic.firmware_drops)
    try:
        # On a clock of its own (a test's) a run needs no priority.
        wall = link.now is time.monotonic
        cpu_before = _host_cpu()
        with _no_gc_pauses(), real_time_priority(boost, enabled=wall) as priority:
            result = _run(
                scenario, link, period, phase, stop_odometry_at, last_k, drops_before, progress
            )
        cpu_after = _host_cpu()
    finally:
        if progress is not None:
            progress.close()
    assert result.timing is not None
    extra = {**result.timing.extra, "priority": priority, "host": _host(cpu_before, cpu_after)}
    return replace(result, timing=replace(result.timing, extra=extra))


def _host_cpu() -> list[int] | None:
    """The host's CPU time by kind (/proc/stat's first line: user, nice,
    system, idle, iowait, irq, softirq, steal) [clock ticks]; None where
    there is no such file."""
    try:
        with open("/proc/stat", encoding="ascii") as f:
            return [int(x) for x in f.readline().split()[1:9]]
    except (OSError, ValueError):
        return None


def _host(before: list[int] | None, after: list[int] | None) -> dict[str, object]:
    """What else the host did over a run, for timing.json's ``host``: the
    CPU its hypervisor took from it (steal) and the time its cores spent
    waiting for the disk (iowait) [ms], which no priority here can give
    back, and the load average at the end."""
    doc: dict[str, object] = {"load": round(os.getloadavg()[0], 2)}
    if before is not None and after is not None and len(before) == len(after) == 8:
        ms = 1e3 / os.sysconf("SC_CLK_TCK")
        doc["steal_ms"] = round((after[7] - before[7]) * ms, 1)
        doc["iowait_ms"] = round((after[4] - before[4]) * ms, 1)
    return doc


RT_PRIORITY = 1
"""The SCHED_RR priority of a real-time run: the lowest, above every ordinary
process; nothing of the run needs more."""


@contextmanager
def real_time_priority(threads: Sequence[int] = (), *, enabled: bool = True) -> Iterator[str]:
    """This process, and the threads @p threads (the vcan VM's), at the
    real-time priority SCHED_RR RT_PRIORITY while the run lasts, as a HIL
    rig runs its real-time parts; back to the normal policy after. Each
    needs a few milliseconds of CPU per 20 ms period (docs/hil.md, "Load"),
    and gets them at once however busy the host's cores are with ordinary
    work. Where this user may not (no root, no CAP_SYS_NICE), they run as they
    are.

    :returns: (as the context) what was done, for timing.json: ``"SCHED_RR
        1"`` or why not.
    """
    raised: list[int] = []
    why = f"SCHED_RR {RT_PRIORITY}"
    for tid in (0, *threads) if enabled else ():
        try:
            os.sched_setscheduler(tid, os.SCHED_RR, os.sched_param(RT_PRIORITY))
            raised.append(tid)
        except PermissionError:
            why = "normal (not permitted to raise it)"
            break
        except ProcessLookupError:
            continue
    try:
        yield why if raised else ("normal (not permitted to raise it)" if enabled else "normal")
    finally:
        for tid in raised:
            try:
                os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
            except (PermissionError, ProcessLookupError):
                pass


@contextmanager
def _no_gc_pauses() -> Iterator[None]:
    """Python's cycle collector off while the loop runs. Its full passes
    over everything the run keeps (every frame, for bus.log) took some 50 ms
    on the host and over a second under emulation: far more than a period,
    and the firmware halts when odometry stops for 3 periods. The loop makes
    no reference cycles, so reference counting frees what it drops."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _run(
    scenario: Scenario,
    link: RealtimeLink,
    period: float,
    phase: float | None,
    stop_odometry_at: float | None,
    last_k: int,
    drops_before: dict[str, int],
    progress: Progress | None,
) -> RunResult:
    """The run of :func:`simulate_realtime`, from arming on."""
    rate_hz = 1.0 / period
    sim = scenario.sim
    world = make_world(scenario)
    plant, ref, obstacles, sensor = world.plant, world.reference, world.obstacles, world.sensor
    # simulate_realtime refused path references: the reference is a clock.
    assert isinstance(ref, ReferenceRobot), "a path reference in the real-time loop"
    v_r, w_r = ref.v, ref.w
    imp = scenario.imperfections
    noise = None
    if imp.position_noise or imp.heading_noise:
        sigma = np.array([imp.position_noise, imp.position_noise, imp.heading_noise])
        noise = (world.odometry_rng.standard_normal((last_k + 1, 3)) * sigma).tolist()
    moving = any(o.moving for o in obstacles)
    tick = max((last_k + 1) // PROGRESS_UPDATES, 1)
    first = _arm(link, plant.pose, ref.pose, v_r, w_r, period, phase)
    clock = link.now
    t0 = _arrival(link.steps, period) + phase * period if phase is not None else clock()
    wheels = (first.left, first.right)
    integrated = t0  # the plant's pose is its pose at this time

    def advance(t: float) -> None:
        nonlocal integrated
        if t > integrated:
            plant.step(wheels[0], wheels[1], t - integrated)
            integrated = t

    rows: list[tuple[float, ...]] = []
    modes: list[Mode] = []
    plant_missed = 0
    stopped_at: float | None = None
    latest = first
    k = 0
    deadline = t0
    shift = 0.0  # the firmware's grid against the samples' (_drift)
    cpu = time.process_time()

    def receive(timeout: float) -> bool:
        """Take a frame; a wheel command acts from its arrival."""
        nonlocal latest, wheels
        frame = link.take(timeout)
        if frame is not None and frame.name == "WHEEL_CMD":
            advance(link.last_t)
            latest = link.steps[-1]
            wheels = (latest.left, latest.right)
        return frame is not None

    while k <= last_k:
        now = clock()
        if now < deadline:
            if not receive(deadline - now):
                _idle(link, deadline)
            continue
        # Due: first every frame already queued, so that a command that came
        # while the loop was busy acts from its arrival, not from now.
        for _ in range(BACKLOG):
            if not receive(0.0):
                break
        now = clock()
        late = math.floor((now - deadline) / period)
        if late:  # the loop was held up for whole periods: skip those samples
            plant_missed += late
            for _ in range(late):
                ref.step(period)
            k += late
            if k > last_k:
                break
        grid = k * period
        advance(now)
        robot = plant.pose
        reference = integrate(ref.pose, v_r, w_r, now - t0 - grid, sim.integrator)
        odometry = stop_odometry_at is None or grid < stop_odometry_at - 1e-9
        if not odometry and stopped_at is None:
            stopped_at = now - t0
        measured = robot
        if noise is not None:
            nx, ny, nt = noise[k]
            measured = Pose(robot.x + nx, robot.y + ny, robot.theta + nt)
        seen = sensor.scan(robot, now - t0)
        link.send_sample(measured, reference, v_r, w_r, seen, k, odometry=odometry)
        v, w = plant.body_velocity(*wheels)
        s = latest.status
        errors = (s.e1, s.e2, s.e3, s.e) if s is not None else (0.0, 0.0, 0.0, 0.0)
        rows.append((now - t0, *robot, *reference, v, w, v_r, w_r, *errors))
        modes.append(s.mode if s is not None else Mode.STOP)
        ref.step(period)
        k += 1
        shift = _drift(link.steps, t0, period, phase, shift)
        deadline = t0 + k * period + shift
        if progress is not None and k % tick == 0:
            progress.update(k)

    cpu = time.process_time() - cpu
    end = clock() + DRAIN_PERIODS * period
    while (now := clock()) < end:
        if link.take(end - now) is None:
            _idle(link, end)
    link.send_arm(0.0)  # a deliberate, ramped stop rather than a timeout

    odometry_sent = [replace(o, t=o.t - t0) for o in link.odometry]
    steps = [replace(s, t=s.t - t0) for s in link.steps if s.t >= first.t]
    timing = analyse(
        rate_hz,
        odometry_sent,
        steps,
        samples=len(rows),
        plant_missed=plant_missed,
        send_failures=link.send_failures,
        dropped_by_firmware=_drops_since(drops_before, link.traffic.firmware_drops),
        dropped_by_plant={r.value: n for r, n in link.proto.drops.items() if n},
        odometry_stopped_at=stopped_at,
        phase=phase,
    )
    # The plant's own CPU time per sample: what it asks of the machine.
    cpu_ms = round(1e3 * cpu / max(len(rows), 1), 3)
    extra: dict[str, object] = {
        "start_stamp": round(link.stamp(t0), 6),
        "plant_cpu_ms_per_sample": cpu_ms,
    }
    timing = replace(timing, extra=extra)
    values = np.array(rows, dtype=float).reshape(len(rows), 15)
    distance, obstacle_xy = distances(values, obstacles, moving)
    return RunResult(
        scenario=scenario,
        trace=Trace(values, tuple(modes), distance, obstacle_xy),
        events=_events(steps, odometry_sent),
        min_distance=tuple(float(d) for d in distance.min(axis=0)) if len(obstacles) else (),
        faults=fault_counts(s.status.faults for s in steps if s.status is not None),
        timing=timing,
        halt=latest.halt,
    )


def _events(steps: list[FirmwareStep], odometry: list[OdomSent]) -> tuple[Event, ...]:
    """Every step's events, stamped with the time of the pose the step used:
    the sample's (0 for the initial state sent while arming), or the step's
    arrival when the echo was lost."""
    events: list[Event] = []
    for s in steps:
        if not s.events:
            continue
        if s.odom is not None:
            o = odometry[s.odom]
            t = o.t if o.sample is not None else 0.0
        else:
            t = s.t
        events += [replace(e, t_us=round(t * 1e6)) for e in s.events]
    return tuple(events)


def _drops_since(before: dict[str, int], after: dict[str, int]) -> dict[str, int]:
    """The firmware's drop counters over the run (they count from its start)."""
    return {k: int(v) - int(before.get(k, 0)) for k, v in after.items() if v != before.get(k, 0)}
