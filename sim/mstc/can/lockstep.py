# SPDX-License-Identifier: MIT
"""The firmware behind a python-can bus, in lock-step (docs/protocol.md).

:class:`CanController` implements :class:`mstc.controller.Controller` with
frames: each call sends the robot's odometry, the reference, the obstacles the
sensor reports and a STEP frame, then reads the firmware's answers up to the
WHEEL_CMD that echoes the step. The same code drives the in-process firmware
(``can.Bus(interface="mstc-sil")``), ``mstc-fw`` on SocketCAN and a board.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import can

from mstc.can.protocol import Frame, FrameDropped, Protocol
from mstc.controller import Event, EventKind, Fault, Mode, Side, Status, StepResult
from mstc.errors import ControllerError
from mstc.params import Params
from mstc.sim.plant import Pose, wrap_angle
from mstc.sim.sensor import Obstacle

STEP_MODULO = 1 << 16
"""The STEP and WHEEL_CMD step counter wraps here."""
TIME_MODULO = 1 << 32
"""STEP and EVENT times [µs] wrap here (71.6 minutes)."""

_MODES = {0: Mode.TRACK, 1: Mode.AVOID, 2: Mode.STOP}
_KINDS = {1: EventKind.DETECT, 2: EventKind.ACTIVATE, 3: EventKind.COMPLETE}
_SIDES = {0: None, 1: Side.LEFT, 2: Side.RIGHT}

PARAM_INDEX = {
    "r_m": 0,
    "r_ob": 1,
    "d_det": 2,
    "d_act": 3,
    "d_s": 4,
    "trk_k1": 5,
    "trk_k2": 6,
    "trk_k3": 7,
    "avd_k1": 8,
    "avd_k2": 9,
    "wheel_radius": 10,
    "track_width": 11,
    "max_wheel_speed": 12,
}
"""PARAM_SET / PARAM_GET indices (the DBC's value table)."""
ARM_INDEX = 128
"""PARAM_SET index of the arm command (value 1 arms, 0 disarms; docs/safety.md)."""
REARM_FRAMES = 5
"""Good frames in a row each input needs before the firmware accepts the arm
command (APP_REARM_FRAMES in firmware/app/app.h)."""


def param_values(p: Params) -> dict[str, float]:
    """Every parameter the firmware takes over the bus, by PARAM_INDEX name."""
    k = p.tracking_gains
    a = p.avoidance_gains
    return {
        "r_m": p.r_m,
        "r_ob": p.r_ob,
        "d_det": p.d_det,
        "d_act": p.d_act,
        "d_s": p.d_s,
        "trk_k1": k[0],
        "trk_k2": k[1],
        "trk_k3": k[2],
        "avd_k1": a[0],
        "avd_k2": a[1],
        "wheel_radius": p.wheel_radius,
        "track_width": p.track_width,
        "max_wheel_speed": p.max_wheel_speed,
    }


@dataclass
class Traffic:
    """What crossed the bus, for bus.log and the report."""

    frames: list[tuple[can.Message, bool]] = field(default_factory=list)
    """Every frame in bus order, with True for the ones this side sent."""
    firmware_drops: dict[str, int] = field(default_factory=dict)
    """The firmware's latest STATUS_COUNTERS."""


class CanController:
    """The firmware's control step through CAN frames, lock-step.

    :param bus: the bus the firmware is on.
    :param params: parameters, sent with PARAM_SET before the first step.
    :param timeout: how long to wait for an answer [s] (wall time).
    :param sim_time_stamps: stamp sent frames with the simulated time (for the
        in-process bus, whose answers carry the same stamp), else wall time.
    """

    def __init__(
        self,
        bus: can.BusABC,
        params: Params,
        *,
        timeout: float = 2.0,
        sim_time_stamps: bool = False,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.bus = bus
        self.params = params
        self.timeout = timeout
        self.sim_time_stamps = sim_time_stamps
        self.clock = clock
        self.proto = Protocol(node=None)
        self.traffic = Traffic()
        self._now = 0.0
        self._steps = 0
        self._armed = False
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
            except FrameDropped:
                continue  # counted in self.proto.drops
            if frame.name == "STATUS_COUNTERS":
                self.traffic.firmware_drops = dict(frame.signals)
            return frame

    def _configure(self) -> None:
        """PARAM_SET every parameter; retry the ones the firmware rejects
        because another one has not changed yet (D_s < D_act must hold at
        every moment)."""
        pending = param_values(self.params)
        while pending:
            rejected: dict[str, float] = {}
            for name, value in pending.items():
                index = PARAM_INDEX[name]
                self._send(self.proto.encode("PARAM_SET", index=index, value=value))
                answer = self._await(
                    lambda f, i=index: f.name == "PARAM_VALUE" and f.signals["index"] == i,
                    f"PARAM_VALUE {name}",
                )
                if answer.signals["result"] != 0:
                    rejected[name] = value
            if len(rejected) == len(pending):
                raise ControllerError(f"the firmware rejects the parameters {sorted(rejected)}")
            pending = rejected

    def _send_inputs(self, robot: Pose, ref: Pose, v_r: float, w_r: float) -> None:
        self._send_odometry(robot)
        self._send_reference(ref, v_r, w_r)

    def _send_odometry(self, robot: Pose) -> can.Message:
        """ODOM_XY and ODOM_THETA; returns the ODOM_XY frame."""
        xy = self.proto.encode("ODOM_XY", x=robot.x, y=robot.y)
        self._send(xy)
        self._send(self.proto.encode("ODOM_THETA", theta=wrap_angle(robot.theta)))
        return xy

    def _send_reference(self, ref: Pose, v_r: float, w_r: float) -> None:
        enc = self.proto.encode
        self._send(enc("REF_XY", x=ref.x, y=ref.y))
        self._send(enc("REF_MOTION", theta=wrap_angle(ref.theta), v=v_r, w=w_r))

    def _send_obstacles(self, obstacles: Sequence[Obstacle]) -> None:
        """One OBSTACLE frame per reported obstacle."""
        for o in obstacles:
            self._send(self.proto.encode("OBSTACLE", id=o.id, x=o.x, y=o.y, radius=o.radius))

    def _arm(self, robot: Pose, ref: Pose, v_r: float, w_r: float) -> None:
        """Arm the firmware before the first step (docs/safety.md): it starts
        halted and accepts the arm command once each input has arrived
        REARM_FRAMES times in a row. No STEP is sent, so no control step runs
        and the run's first step is still step 0 at its own time."""
        for _ in range(REARM_FRAMES):
            self._send_inputs(robot, ref, v_r, w_r)
        self._send(self.proto.encode("PARAM_SET", index=ARM_INDEX, value=1.0))
        answer = self._await(
            lambda f: f.name == "PARAM_VALUE" and f.signals["index"] == ARM_INDEX, "PARAM_VALUE arm"
        )
        if answer.signals["result"] != 0:
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
    ) -> StepResult:
        """One lock-step exchange (see :meth:`Controller.step`)."""
        self._now = t_us / 1e6
        if not self._armed:
            self._arm(robot, ref, v_r, w_r)
        step = self._steps % STEP_MODULO
        self._steps += 1
        enc = self.proto.encode
        self._send_inputs(robot, ref, v_r, w_r)
        self._send_obstacles(obstacles)
        self._send(enc("STEP", step=step, time=t_us % TIME_MODULO, raw=True))

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
                events.append(self._decode_event(frame, t_us - t_us % TIME_MODULO))
            elif frame.name == "STATUS":
                status = frame
            elif frame.name == "STATUS_TRK":
                trk = frame
            elif frame.name == "WHEEL_CMD" and s["step"] == step:
                break
        if status is None or trk is None:
            raise ControllerError(f"step {step}: WHEEL_CMD came without STATUS and STATUS_TRK")
        left, right = float(s["left"]), float(s["right"])
        return StepResult(left, right, self._decode_status(status, trk, left, right), tuple(events))

    # ------------------------------------------------------------ telemetry

    def _decode_event(self, frame: Frame, base_us: int) -> Event:
        """An EVENT frame; its 32-bit time [µs] is added to @p base_us."""
        s = frame.signals
        raw_us = round(s["time"] * 1e6)
        return Event(base_us + raw_us, _KINDS[s["kind"]], int(s["obstacle"]), _SIDES[s["side"]])

    def _decode_status(self, status: Frame, trk: Frame, left: float, right: float) -> Status:
        """A step's STATUS and STATUS_TRK, with the body velocity of its wheel
        commands [rad/s]."""
        p = self.params
        st = status.signals
        return Status(
            mode=_MODES[st["mode"]],
            active_obstacle=int(st["obstacle"]),
            side=_SIDES[st["side"]],
            faults=Fault(int(st["faults"])),
            e1=float(trk.signals["e1"]),
            e2=float(trk.signals["e2"]),
            e3=float(trk.signals["e3"]),
            e=float(st["e"]),
            v=p.wheel_radius * (left + right) / 2,
            w=p.wheel_radius * (right - left) / p.track_width,
        )
