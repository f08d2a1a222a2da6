# SPDX-License-Identifier: MIT
"""The lock-step loop: the plant's time is the firmware's.

:func:`simulate` runs a scenario in closed loop around any
:class:`~mstc.model.Controller`, one control step per period of simulated
time: the firmware's step in process (:class:`mstc.firmware.sil.SilController`),
a baseline (:class:`mstc.sweep.dwa.DwaController`), or the firmware behind a
python-can bus, :class:`CanController` (docs/protocol.md). That one
implements the step with frames: each call sends the robot's odometry, the
reference, the obstacles the sensor reports and a STEP frame, then reads the
firmware's answers up to the WHEEL_CMD that echoes the step. The same code
drives the in-process firmware (``can.Bus(interface="mstc-sil")``),
``mstc-fw`` on SocketCAN and a board. The real-time loop
(:mod:`mstc.loop.realtime`) shares all but the clock.
"""

from __future__ import annotations

import math
import os
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol as TypingProtocol

import can
import numpy as np

from mstc.can import secoc
from mstc.can.dbc import Tables, tables
from mstc.can.protocol import (
    COUNTER_MODULO,
    DropReason,
    Frame,
    Protocol,
    e2e_crc,
    wire_limits,
)
from mstc.can.silbus import SilBus
from mstc.errors import ControllerError, FrameDropped, SignalRangeError, SimulationError
from mstc.loop.result import (
    PROGRESS_UPDATES,
    TRACE_COLUMNS,
    RunResult,
    Trace,
    distances,
    fault_counts,
)
from mstc.model import (
    Controller,
    Event,
    Fault,
    Mode,
    Obstacle,
    Params,
    Pose,
    Progress,
    SignalRange,
    Status,
    StepResult,
    StepValues,
    param_values,
    wrap_angle,
)
from mstc.plant.plant import WheelDrive
from mstc.plant.scenario import Scenario
from mstc.plant.world import make_world


class BoardWheels(WheelDrive, TypingProtocol):
    """Wheels that a firmware instance measures itself: their wheel loop is
    in the firmware library, at :attr:`address`
    (:class:`mstc.firmware.wheels.DcWheels`)."""

    @property
    def address(self) -> int:
        """Where the wheel loop is, for :meth:`SilBus.attach_wheels`."""
        ...


# ------------------------------------------------------------------ the loop

StepFunction = Callable[
    [Pose, Pose, float, float, Sequence[Obstacle], int, tuple[float, float] | None], StepValues
]


def step_values(controller: Controller) -> StepFunction:
    """@p controller's step, its result as :data:`~mstc.model.StepValues`: the
    controller's own ``step_values`` when it has one (the firmware's, which
    skips building the Status and StepResult objects), else its ``step``
    with the values read from the result."""
    own: StepFunction | None = getattr(controller, "step_values", None)
    if own is not None:
        return own
    step = controller.step

    def values(
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        seen: Sequence[Obstacle],
        t_us: int,
        wheel_speeds: tuple[float, float] | None,
    ) -> StepValues:
        result = step(robot, ref, v_r, w_r, seen, t_us, wheel_speeds)
        s = result.status
        left, right = result.wheel_left, result.wheel_right
        return left, right, s.mode, int(s.faults), s.e1, s.e2, s.e3, s.e, result.events

    return values


def _not_carried(pair: tuple[SignalRange, SignalRange], x: float, y: float) -> SignalRangeError:
    """The error the frame of @p pair would raise for (@p x, @p y), one of
    which it does not carry (:func:`mstc.can.protocol.to_raw`'s)."""
    signal, value = next((s, v) for s, v in zip(pair, (x, y), strict=True) if v not in s)
    frame, name = signal.name.split(".")
    return SignalRangeError(frame, name, value, (signal.lo, signal.hi), signal.unit)


def simulate(
    scenario: Scenario,
    controller: Controller,
    progress: Progress | None = None,
    wheels: WheelDrive | None = None,
    *,
    stop_on_contact: bool = False,
) -> RunResult:
    """Run a scenario in closed loop.

    For k = 0..N (N = round(duration/dt)), at t = k·dt: the sensor scans from
    the robot's pose at the start of the period (obstacles where they are at
    t); the controller steps on that pose (with odometry noise, when the
    scenario has some), the reference pose and the scan; the row is
    recorded; then robot and reference are integrated over dt, the robot with
    the wheel speeds commanded ``delay`` periods earlier (standing still
    before the first), or, with an ``[actuator]`` of model "lag", by its
    wheels in substeps (:mod:`mstc.plant.actuator`), whose drivers' measured
    speeds go to the next step (``wheel_speeds``, the WHEEL_SPEED frame: the
    external drives' topology), or by @p wheels, a board's own (the
    integrated board: no WHEEL_SPEED; the controller takes their measurement
    itself, docs/wheel.md). The run ends with the row of step N, so the trace
    spans t = 0 to the duration and the minimum distances include the final
    state.

    The trace is written into an array of the run's size, taken once: a run of
    N steps holds about (15 + obstacles) × 8 bytes per step, whatever the
    controller (the scenario loader bounds N, :data:`~mstc.plant.scenario.MAX_STEPS`).

    :param scenario: the scenario.
    :param controller: a freshly initialised controller for its parameters.
    :param progress: told how many steps are done, now and then, and closed
        when the run ends.
    :param wheels: wheels with dynamics of their own (the scenario's
        ``[actuator]``, :class:`mstc.firmware.wheels.DcWheels`) that move the
        robot instead of the ideal ones: the board's own, which its
        controller measures itself (``SilController(wheels=...)``,
        ``SilBus.attach_wheels()``, or a board image's own wheel loop).

    :returns: The trace, the events and the minimum distance to each obstacle;
        the firmware's halt state at the end when the controller keeps one
        (its ``halt``: :class:`CanController`).

    Whatever the controller, the pose and the obstacles it is given are
    checked against the ranges of the frames that carry them (ODOM_XY,
    OBSTACLE), as the frames themselves check them: a noisy pose or report, or
    a robot, beyond them stops the run with the frame's own error, so that a
    scenario gives the same result in memory and through CAN
    (docs/scenarios.md).

    :raises SimulationError: the plant's state became non-finite.
    :raises SignalRangeError: a pose or an obstacle the frames do not carry.
    """
    sim = scenario.sim
    imp = scenario.imperfections
    world = make_world(scenario)
    plant, ref, obstacles, sensor = world.plant, world.reference, world.obstacles, world.sensor
    odometry_rng = world.odometry_rng
    moving = any(o.moving for o in obstacles)
    sample_ref = ref.sample
    goal = scenario.reference.goal_radius
    r_m = scenario.params.r_m
    goal_x, goal_y = scenario.reference.path[-1] if goal is not None else (0.0, 0.0)
    steps = sim.steps
    ended = steps
    odometry_noise = None
    if imp.position_noise or imp.heading_noise:
        sigma = np.array([imp.position_noise, imp.position_noise, imp.heading_noise])
        odometry_noise = (odometry_rng.standard_normal((steps + 1, 3)) * sigma).tolist()
    pending: deque[tuple[float, float]] = deque([(0.0, 0.0)] * imp.delay)
    actuator = world.actuator
    measured_wheels: tuple[float, float] | None = None
    if actuator is not None:
        measured_wheels = (0.0, 0.0)

    values = np.empty((steps + 1, len(TRACE_COLUMNS)), dtype=float)
    modes: list[Mode] = []
    events: list[Event] = []
    fault_masks: list[int] = []
    clock = time.perf_counter_ns
    spent = 0
    step = step_values(controller)
    body_velocity = plant.body_velocity
    scan, ref_step = sensor.scan, ref.step
    plant_step: Callable[[float, float, float], object] = plant.step
    if wheels is not None:
        drive = wheels.drive

        def driven(left: float, right: float, dt: float) -> object:
            drive(plant, left, right, dt)
            return None

        plant_step = driven

    dt, dt_us = sim.dt, sim.dt_us
    tick = max((steps + 1) // PROGRESS_UPDATES, 1)
    wire = wire_limits()
    (x_lo, x_hi), (y_lo, y_hi) = ((r.lo, r.hi) for r in wire.robot)
    (ox_lo, ox_hi), (oy_lo, oy_hi) = ((r.lo, r.hi) for r in wire.obstacle)
    roaming = moving or bool(imp.obstacle_noise)  # the loader checked the others
    try:
        for k in range(steps + 1):
            t_us = k * dt_us
            t = t_us / 1e6
            robot = plant.pose
            seen = scan(robot, t)
            measured = robot
            if odometry_noise is not None:
                nx, ny, nt = odometry_noise[k]
                measured = Pose(robot.x + nx, robot.y + ny, robot.theta + nt)
            if not (x_lo <= measured.x <= x_hi and y_lo <= measured.y <= y_hi):
                if not np.isfinite(robot).all():
                    raise SimulationError(
                        f"{scenario.path}: the plant's state became non-finite at t = {t:g} s"
                    )
                raise _not_carried(wire.robot, measured.x, measured.y)
            for o in seen if roaming else ():
                if not (ox_lo <= o.x <= ox_hi and oy_lo <= o.y <= oy_hi):
                    raise _not_carried(wire.obstacle, o.x, o.y)
            sample = sample_ref(measured)
            reference, v_r, w_r = sample.pose, sample.v, sample.w
            start = clock()
            left, right, mode, faults, e1, e2, e3, e, emitted = step(
                measured, reference, v_r, w_r, seen, t_us, measured_wheels
            )
            spent += clock() - start
            v, w = body_velocity(left, right)
            values[k] = (t, *robot, *reference, v, w, v_r, w_r, e1, e2, e3, e)
            modes.append(mode)
            if emitted:
                events.extend(emitted)
            if faults:
                fault_masks.append(faults)
            if goal is not None and math.hypot(robot.x - goal_x, robot.y - goal_y) <= goal:
                ended = k  # within the goal radius: the run ends here
                break
            if stop_on_contact and any(
                math.hypot(o.x - robot.x, o.y - robot.y) <= r_m + o.radius for o in sensor.world(t)
            ):
                ended = k  # touched: the run ends here
                break
            if k < steps:
                if actuator is not None:
                    measured_wheels = actuator.step(left, right)
                else:
                    if pending:
                        pending.append((left, right))
                        left, right = pending.popleft()
                    plant_step(left, right, dt)
                ref_step(dt)
            if progress is not None and (k + 1) % tick == 0:
                progress.update(k + 1)
    finally:
        if progress is not None:
            progress.close()

    values = values[: ended + 1]
    if not np.isfinite(values[:, 1:7]).all():
        k = int(np.argmin(np.isfinite(values[:, 1:7]).all(axis=1)))
        raise SimulationError(
            f"{scenario.path}: the plant's state became non-finite at t = {values[k, 0]:g} s"
        )
    distance, obstacle_xy = distances(values, obstacles, moving)
    return RunResult(
        scenario=scenario,
        trace=Trace(values, tuple(modes), distance, obstacle_xy),
        events=tuple(events),
        min_distance=tuple(float(d) for d in distance.min(axis=0)) if len(obstacles) else (),
        faults=fault_counts(fault_masks),
        step_time=spent / 1e9 / (ended + 1),
        halt=getattr(controller, "halt", None),
        unreported=getattr(sensor, "unreported", 0),
    )


# ------------------------------------------------------------------ through CAN

STEP_MODULO = 1 << 16
"""The STEP and WHEEL_CMD step counter wraps here."""
TIME_MODULO = 1 << 32
"""STEP and EVENT times [µs] wrap here (71.6 minutes)."""

ARM_INDEX = tables().arm_index
"""PARAM_SET index of the arm command in the package's DBC (value 1 arms, 0
disarms; docs/safety.md). A controller uses its own DBC's."""
REARM_FRAMES = 5
"""Good frames in a row each input needs before the firmware accepts the arm
command (APP_REARM_FRAMES in firmware/app/app.h)."""


def _param_value(index: int) -> Callable[[Frame], bool]:
    """Matches the firmware's PARAM_VALUE answer about parameter @p index."""
    return lambda f: f.name == "PARAM_VALUE" and f.signals["index"] == index


@dataclass
class Traffic:
    """What crossed the bus, for bus.log and the report."""

    frames: list[tuple[can.Message, bool]] = field(default_factory=list)
    """Every frame in bus order, with True for the ones this side sent."""
    firmware_drops: dict[str, int] = field(default_factory=dict)
    """The firmware's latest STATUS_COUNTERS."""


def odometry_frames(proto: Protocol, robot: Pose) -> list[can.Message]:
    """ODOM_XY and ODOM_THETA of @p robot, its heading wrapped.

    :raises SignalRangeError: a value the frames cannot carry (non-finite too).
    """
    return [
        proto.encode("ODOM_XY", x=robot.x, y=robot.y),
        proto.encode("ODOM_THETA", theta=wrap_angle(robot.theta)),
    ]


def reference_frames(proto: Protocol, ref: Pose, v_r: float, w_r: float) -> list[can.Message]:
    """REF_XY and REF_MOTION of the reference @p ref moving at (@p v_r, @p w_r).

    :raises SignalRangeError: a value the frames cannot carry.
    """
    return [
        proto.encode("REF_XY", x=ref.x, y=ref.y),
        proto.encode("REF_MOTION", theta=wrap_angle(ref.theta), v=v_r, w=w_r),
    ]


def obstacle_frames(proto: Protocol, obstacle: Obstacle) -> list[can.Message]:
    """The OBSTACLE frame of a reported obstacle; right after it, for a moving
    obstacle only, its OBSTACLE_VEL (docs/protocol.md: the firmware keeps 0
    for the others).

    :raises SignalRangeError: a value the frames cannot carry.
    """
    o = obstacle
    frames = [proto.encode("OBSTACLE", id=o.id, x=o.x, y=o.y, radius=o.radius)]
    if o.moving:
        frames.append(proto.encode("OBSTACLE_VEL", id=o.id, vx=o.vx, vy=o.vy))
    return frames


def step_frame(proto: Protocol, step: int, t_us: int) -> can.Message:
    """The STEP frame of control step @p step (its number taken modulo
    :data:`STEP_MODULO`) at firmware time @p t_us (modulo :data:`TIME_MODULO`)."""
    return proto.encode("STEP", step=step % STEP_MODULO, time=t_us % TIME_MODULO, raw=True)


def decode_event(tables: Tables, frame: Frame, base_us: int) -> Event:
    """An EVENT frame as an :class:`~mstc.model.Event`; its 32-bit time [µs]
    is added to @p base_us."""
    s = frame.signals
    return Event(
        base_us + round(s["time"] * 1e6),
        tables.event_kind[int(s["kind"])],
        int(s["obstacle"]),
        tables.side[int(s["side"])],
    )


def unauthenticated(what: str, auth: secoc.Authenticator) -> ControllerError:
    """The error of a command the firmware refused as unauthenticated, with
    the reason its last authenticated status gives (a forged frame cannot
    change the advice: the tools adopt no status whose MAC fails)."""
    st = auth.status
    if st is None:
        return no_status(auth)
    why = secoc.OUTCOMES.get(st.last, f"AUTH_STATUS last = {st.last}")
    if st.last == 0:
        # Its authenticated status says the challenge was accepted: the
        # refusal came from a frame no firmware sent.
        why = "its status says the command was accepted: a node on the bus forges PARAM_VALUE"
    return ControllerError(
        f"the firmware refuses {what}: {why}; docs/safety.md, 'Authenticated commands'"
    )


def decides(session: int, signed: int) -> Callable[[secoc.Status], bool]:
    """Matches a status that decided the command signed for @p signed in
    @p session, or a later one (another session: the firmware restarted).

    Not the expiry of that challenge (last = expired): a housekeeping
    replaced it while the command was on its way, so no command decided it,
    and the command, when it comes, is refused as stale under the next
    challenge, whose status is the one that decides it. Taken for the
    decision, the expiry had a tool sign again for that next challenge, which
    the late command then used up, and each retry was one challenge behind
    (`mstc board set` on the vcan VM's bridge: refused four times in a row)."""
    return lambda s: (
        s.session != session
        or s.freshness > signed
        or (s.freshness == signed and s.last != secoc.EXPIRED)
    )


ACCEPTED, AGAIN, REFUSED, CONTESTED = "accepted", "again", "refused", "contested"
"""What :func:`outcome` says of a signed command."""


def outcome(
    before: secoc.Status, signed: int, after: secoc.Status, refused: bool, contested: bool = False
) -> str:
    """A command signed for @p signed under the status @p before, decided by
    the status @p after: :data:`ACCEPTED` when that status says it was the
    one used and its PARAM_VALUE is not @p refused as unauthenticated;
    :data:`CONTESTED` when it was the one used but PARAM_VALUE came in more
    than one version (@p contested: a node without the key answered too, and
    which answer is the firmware's cannot be told); :data:`AGAIN` when the
    firmware restarted or the challenge was used up before the command came
    (stale): signed once more for the new one; else :data:`REFUSED`.

    Only the status is authenticated: it says whether the firmware used the
    command, and PARAM_VALUE, which carries no MAC, only what it did with
    it. So a command is never taken as done on a PARAM_VALUE alone, and
    every PARAM_VALUE about it counts, those the E2E receiver dropped as
    repeats included (:func:`answer_despite_counter`): a forged answer sent
    first under the firmware's next counter makes the firmware's own a
    "repeat"."""
    restarted = after.session != before.session
    if not restarted and after.freshness == signed and after.last == 0:
        if contested:
            return CONTESTED
        return REFUSED if refused else ACCEPTED
    return AGAIN if restarted or after.last == secoc.STALE else REFUSED


def answer_despite_counter(
    proto: Protocol, msg: can.Message, dropped: FrameDropped
) -> Frame | None:
    """@p msg as a PARAM_VALUE when the E2E receiver of @p proto dropped it
    for its alive counter alone (its identifier known, its length and CRC
    good): read for the outcome of a command (:func:`outcome`), never as an
    input; None for any other frame or reason."""
    message = proto.message("PARAM_VALUE")
    if dropped.reason is not DropReason.SEQUENCE or msg.arbitration_id != (
        message.frame_id + proto.offset
    ):
        return None
    decoded = message.decode(bytes(msg.data), decode_choices=False)
    assert isinstance(decoded, dict)  # a message of single signals, choices not decoded
    signals = {k.removeprefix("PARAM_VALUE_"): v for k, v in decoded.items()}
    values = {
        k: v
        for k, v in signals.items()
        if k not in ("CRC", "Counter") and isinstance(v, int | float)
    }
    return Frame(message.name, message.frame_id, msg.data[1] & 0x0F, values, msg.timestamp)


def contested(answers: Sequence[Frame], index: int) -> bool:
    """More than one version of the PARAM_VALUE about parameter @p index
    among @p answers."""
    seen = {
        (int(a.signals["result"]), float(a.signals["value"]))
        for a in answers
        if a.signals["index"] == index
    }
    return len(seen) > 1


def contested_error(
    what: str, answers: Sequence[Frame], index: int, tables: Tables
) -> ControllerError:
    """The error of a command whose PARAM_VALUE came in several versions."""
    versions = sorted(
        {
            f"{tables.param_result.name_of(int(a.signals['result']))} {float(a.signals['value']):g}"
            for a in answers
            if a.signals["index"] == index
        }
    )
    return ControllerError(
        f"{what}: the firmware used the command (its authenticated status says so), but "
        f"PARAM_VALUE came as {' and as '.join(versions)}: a node on the bus forges PARAM_VALUE, "
        "and which is the firmware's cannot be told; read the value back (PARAM_GET) once the "
        "bus is clean. docs/safety.md, 'Authenticated commands'"
    )


def no_status(auth: secoc.Authenticator) -> ControllerError:
    """The error when no status of the firmware verified under the tools' key."""
    if auth.forged:
        return ControllerError(
            f"the firmware's status does not verify under the key the tools use "
            f"({auth.forged} status frames refused): does the firmware have that key "
            f"(--key-file, ${secoc.KEY_FILE_ENV}; keys/sim.key for simulations, "
            "keys/device.key for a board)? docs/safety.md, 'The key'"
        )
    return ControllerError(
        "no AUTH_STATUS and AUTH_CHALLENGE (the firmware's authenticated status) from the firmware"
    )


class CanController:
    """The firmware's control step through CAN frames, lock-step (a
    :class:`~mstc.model.Controller`).

    :param bus: the bus the firmware is on.
    :param params: parameters, sent with PARAM_SET before the first step.
    :param timeout: how long to wait for an answer [s] (wall time).
    :param sim_time_stamps: stamp sent frames with the simulated time (for the
        in-process bus, whose answers carry the same stamp), else wall time.
    :param protocol: the protocol side to use (its DBC gives the parameter
        indexes and value tables); default: the package's DBC.
    :param key: the firmware's key; default: :func:`mstc.can.secoc.load_key`.
    :raises DbcError: the DBC lacks an entry the controller names.
    """

    def __init__(
        self,
        bus: can.BusABC,
        params: Params,
        *,
        timeout: float = 2.0,
        sim_time_stamps: bool = False,
        clock: Callable[[], float] = time.time,
        protocol: Protocol | None = None,
        key: bytes | None = None,
    ) -> None:
        self.bus = bus
        self.params = params
        self.timeout = timeout
        self.sim_time_stamps = sim_time_stamps
        self.clock = clock
        self.proto = protocol if protocol is not None else Protocol(node=None)
        self.tables = self.proto.tables
        self.auth = secoc.Authenticator(secoc.load_key() if key is None else key)
        self.traffic = Traffic()
        self._now = 0.0
        self._steps = 0
        self._armed = False
        self._answers: list[Frame] = []
        """Every PARAM_VALUE since the last command went out (repeats too)."""
        self.halt: int | None = None
        """STATUS_halt of the latest step (0 running), None before the first."""
        self._configure()

    # ------------------------------------------------------------ the bus

    def _send(self, msg: can.Message) -> None:
        msg.timestamp = self._now if self.sim_time_stamps else self.clock()
        self.bus.send(msg)
        self.traffic.frames.append((msg, True))

    def _recv(self, deadline: float) -> Frame | None:
        """The next frame that passes the E2E checks, or None at the deadline."""
        while True:
            left = deadline - time.monotonic()
            msg = self.bus.recv(timeout=max(left, 0.0))
            if msg is None:
                if left <= 0:
                    return None
                continue
            self.traffic.frames.append((msg, False))
            try:
                frame = self.proto.decode(msg)
            except FrameDropped as dropped:  # counted in self.proto.drops
                repeat = answer_despite_counter(self.proto, msg, dropped)
                if repeat is not None:
                    self._answers.append(repeat)
                continue
            if frame.name == "PARAM_VALUE":
                self._answers.append(frame)
            if frame.name == "STATUS_COUNTERS":
                self.traffic.firmware_drops = {k: int(v) for k, v in frame.signals.items()}
            self.auth.sync(frame)
            return frame

    def _sync(self) -> None:
        """Learn the firmware's session and challenge: a PARAM_GET (which
        changes nothing) is answered by PARAM_VALUE and the status. Asked
        twice at most: a status dropped by the E2E checks (a node on the bus
        that sent frames under the firmware's identifiers) is followed by the
        next."""
        arm = self.tables.arm_index
        for attempt in range(2):
            self._send(self.proto.encode("PARAM_GET", index=arm))
            try:
                # Its PARAM_VALUE first: read later, it would come among the
                # answers to the next command about the arm, which outcome()
                # weighs all (a status left unread by another reader of the
                # bus would otherwise end the wait before it).
                try:
                    self._await(_param_value(arm), "PARAM_VALUE arm")
                except ControllerError:
                    pass  # none: the status's wait says why, with the key's advice
                self._await_status(lambda st: True)
                return
            except ControllerError:
                if attempt == 1:
                    raise

    def _await_status(self, fresh: Callable[[secoc.Status], bool]) -> secoc.Status:
        """Read frames up to the next status whose MAC verifies and that
        @p fresh accepts.

        :raises ControllerError: none within the timeout (the advice says
            whether statuses came that did not verify).
        """
        deadline = time.monotonic() + self.timeout
        seen = self.auth.status
        while (frame := self._recv(deadline)) is not None:
            st = self.auth.status
            if frame.name == "AUTH_CHALLENGE" and st is not None and st is not seen:
                seen = st
                if fresh(st):
                    return st
        raise no_status(self.auth)

    def command(self, index: int, value: float, what: str) -> Frame:
        """An authenticated PARAM_SET; the firmware's PARAM_VALUE.

        Signed for the challenge of the firmware's last authenticated status.
        When the status that decided it says the challenge was used up before
        it came (stale: another command, a refusal or the 0.5 s expiry came
        first) or the firmware restarted, it is signed once more for the new
        challenge.

        :raises ControllerError: no answer, or the firmware refused it (its
            authenticated status says why).
        """
        unauth = self.tables.param_result.value("unauthenticated")
        for _ in range(2):  # once more after AGAIN
            if not self.auth.can_sign():
                self._sync()  # no challenge left unsigned: ask for the status
            msgs = self.auth.param_set(self.proto, index, value)
            st0 = self.auth.status
            signed = self.auth.signed
            assert st0 is not None and signed is not None  # param_set needs both
            self._answers = []
            for msg in msgs:
                self._send(msg)
            answer = self._await(_param_value(index), f"PARAM_VALUE {what}")
            # The status follows every PARAM_VALUE: read the one that decided
            # this command (also so that the log keeps the bus's order).
            st = self._await_status(decides(st0.session, signed))
            answers = self._answers
            verdict = outcome(
                st0, signed, st, answer.signals["result"] == unauth, contested(answers, index)
            )
            if verdict == CONTESTED:
                raise contested_error(what, answers, index, self.tables)
            if verdict == ACCEPTED:
                return answer
            if verdict != AGAIN:
                break
        raise unauthenticated(what, self.auth)

    def _configure(self) -> None:
        """PARAM_SET every parameter; retry the ones the firmware rejects
        because another one has not changed yet (D_s < D_act must hold at
        every moment)."""
        self._sync()
        pending = param_values(self.params)
        pending["strategy"] = float(self.tables.strategy.value(str(self.params.strategy)))
        while pending:
            rejected: dict[str, float] = {}
            for name, value in pending.items():
                index = self.tables.param_index.value(name)
                answer = self.command(index, value, f"PARAM_SET {name}")
                if answer.signals["result"] != self.tables.param_ok:
                    rejected[name] = value
            if len(rejected) == len(pending):
                raise ControllerError(f"the firmware rejects the parameters {sorted(rejected)}")
            pending = rejected

    def _send_inputs(self, robot: Pose, ref: Pose, v_r: float, w_r: float) -> None:
        self._send_odometry(robot)
        self._send_reference(ref, v_r, w_r)

    def _send_odometry(self, robot: Pose) -> can.Message:
        """ODOM_XY and ODOM_THETA; returns the ODOM_XY frame."""
        xy, theta = odometry_frames(self.proto, robot)
        self._send(xy)
        self._send(theta)
        return xy

    def _send_reference(self, ref: Pose, v_r: float, w_r: float) -> None:
        for msg in reference_frames(self.proto, ref, v_r, w_r):
            self._send(msg)

    def _send_obstacles(self, obstacles: Sequence[Obstacle]) -> None:
        """Each reported obstacle's frames (:func:`obstacle_frames`)."""
        for o in obstacles:
            for msg in obstacle_frames(self.proto, o):
                self._send(msg)

    def _arm(self, robot: Pose, ref: Pose, v_r: float, w_r: float) -> None:
        """Arm the firmware before the first step (docs/safety.md): it starts
        halted and accepts the arm command once each input has arrived
        REARM_FRAMES times in a row. No STEP is sent, so no control step runs
        and the run's first step is still step 0 at its own time."""
        for _ in range(REARM_FRAMES):
            self._send_inputs(robot, ref, v_r, w_r)
        answer = self.command(self.tables.arm_index, 1.0, "the arm command")
        if answer.signals["result"] != self.tables.param_ok:
            raise ControllerError(
                f"the firmware refuses to arm (result {answer.signals['result']})"
            )
        self._armed = True

    def _await(self, match: Callable[[Frame], bool], what: str) -> Frame:
        deadline = time.monotonic() + self.timeout
        while (frame := self._recv(deadline)) is not None:
            if match(frame):
                return frame
        raise ControllerError(f"no {what} from the firmware within {self.timeout} s")

    # ------------------------------------------------------------ a step

    def step(
        self,
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        obstacles: Sequence[Obstacle],
        t_us: int,
        wheel_speeds: tuple[float, float] | None = None,
    ) -> StepResult:
        """One lock-step exchange (see :meth:`mstc.model.Controller.step`)."""
        self._now = t_us / 1e6
        if not self._armed:
            self._arm(robot, ref, v_r, w_r)
        step = self._steps % STEP_MODULO
        self._steps += 1
        self._send_inputs(robot, ref, v_r, w_r)
        if wheel_speeds is not None:
            self._send(
                self.proto.encode(
                    "WHEEL_SPEED", left=wheel_speeds[0], right=wheel_speeds[1], faults=0
                )
            )
        self._send_obstacles(obstacles)
        self._send(step_frame(self.proto, step, t_us))

        events: list[Event] = []
        status: Frame | None = None
        trk: Frame | None = None
        deadline = time.monotonic() + self.timeout
        while True:
            frame = self._recv(deadline)
            if frame is None:
                raise ControllerError(
                    f"no WHEEL_CMD for step {step} (t = {t_us / 1e6:.6f} s) within {self.timeout} s"
                )
            s = frame.signals
            if frame.name == "EVENT":
                events.append(decode_event(self.tables, frame, t_us - t_us % TIME_MODULO))
            elif frame.name == "STATUS":
                status = frame
            elif frame.name == "STATUS_TRK":
                trk = frame
            elif frame.name == "WHEEL_CMD" and s["step"] == step:
                break
        if status is None or trk is None:
            raise ControllerError(f"step {step}: WHEEL_CMD came without STATUS and STATUS_TRK")
        self.halt = int(status.signals["halt"])
        left, right = float(s["left"]), float(s["right"])
        return StepResult(left, right, self._decode_status(status, trk, left, right), tuple(events))

    # ------------------------------------------------------------ telemetry

    def _decode_status(self, status: Frame, trk: Frame, left: float, right: float) -> Status:
        """A step's STATUS and STATUS_TRK, with the body velocity of its wheel
        commands [rad/s]."""
        p = self.params
        st = status.signals
        return Status(
            mode=self.tables.mode[int(st["mode"])],
            active_obstacle=int(st["obstacle"]),
            side=self.tables.side[int(st["side"])],
            faults=Fault(int(st["faults"])),
            e1=float(trk.signals["e1"]),
            e2=float(trk.signals["e2"]),
            e3=float(trk.signals["e3"]),
            e=float(st["e"]),
            v=p.wheel_radius * (left + right) / 2,
            w=p.wheel_radius * (right - left) / p.track_width,
        )


PRIME_STEP = STEP_MODULO - 1
"""Step number of the STEP frame that :func:`enter_lockstep` sends."""


def simulate_on_sil_bus(
    scenario: Scenario,
    lib: str | os.PathLike[str],
    wheels: BoardWheels | None = None,
    *,
    key: bytes | None = None,
    progress: Progress | None = None,
    wrap: Callable[[CanController], Controller] | None = None,
) -> tuple[RunResult, CanController, str]:
    """Run @p scenario through CAN frames to the firmware library @p lib in
    process (:class:`mstc.can.silbus.SilBus`, channel "sil0").

    :param wheels: the scenario's "dc" wheels
        (:func:`mstc.firmware.wheels.wheels_for`): attached to the bus's
        firmware, whose wheel loop measures them (the integrated board:
        docs/wheel.md, "Two topologies"); None: ideal wheels, or the external
        drives' WHEEL_SPEED of an ``[actuator]`` "lag".
    :param key: the firmware's key, for the bus and the controller.
    :param progress: as :func:`simulate`'s.
    :param wrap: what stands between the loop and the controller (a test's
        stand-in that alters its inputs), given the controller.
    :returns: the run, the controller (its traffic, its halt) and the bus's
        channel_info.
    """
    bus = SilBus(channel="sil0", lib=lib, key=key)
    if wheels is not None:
        bus.attach_wheels(wheels.address)
    try:
        ctl = CanController(bus, scenario.params, sim_time_stamps=True, key=key)
        result = simulate(scenario, ctl if wrap is None else wrap(ctl), progress, wheels)
    finally:
        bus.shutdown()
    return result, ctl, bus.channel_info


def enter_lockstep(bus: can.BusABC, timeout: float = 2.0) -> list[tuple[can.Message, bool]]:
    """Switch a board's main loop (hal/stm32/main.c) to lock-step before a
    :class:`CanController` takes the bus.

    A board steps on its own timer until the first STEP frame; from then on
    only STEP frames run steps (docs/hil.md). Left in real-time mode during
    the configuration and the arming, its timer would run steps of its own
    between the plant's frames, and a step with the arm accepted but before
    the plant's first STEP. So one STEP goes first: step PRIME_STEP at time
    0, answered like any (the application is not armed yet: it stands
    still). Its alive counter is 15, the one before the 0 of a fresh
    CanController's first STEP, so the board's E2E receiver sees one
    unbroken STEP sequence; the plant's step 0 then finds the same state as
    in the host builds, which have no timer.

    :returns: every frame that crossed the bus meanwhile (True: sent), for
        the bus log.
    :raises ControllerError: no WHEEL_CMD for that STEP within @p timeout.
    """
    proto = Protocol(node=None)
    msg = proto.encode("STEP", step=PRIME_STEP, time=0, raw=True)
    data = bytearray(msg.data)
    data[1] = (data[1] & 0xF0) | (COUNTER_MODULO - 1)
    data[0] = e2e_crc(proto.data_id(msg.arbitration_id), data)
    msg.data = data
    msg.timestamp = time.time()
    bus.send(msg)
    frames: list[tuple[can.Message, bool]] = [(msg, True)]
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        got = bus.recv(timeout=left)
        if got is None:
            continue
        frames.append((got, False))
        try:
            frame = proto.decode(got)
        except FrameDropped:
            continue
        if frame.name == "WHEEL_CMD" and frame.signals["step"] == PRIME_STEP:
            return frames
    raise ControllerError(f"no WHEEL_CMD for the STEP that starts lock-step within {timeout} s")
