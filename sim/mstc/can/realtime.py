# SPDX-License-Identifier: MIT
"""The firmware on its own timer behind a python-can bus: the plant's side of a
real-time run (docs/hil.md, "Real time").

:class:`RealtimeLink` is :class:`~mstc.can.lockstep.CanController` without
the STEP frame: the same parameters, frames, E2E protection and telemetry
decoding, but the frames go out when the plant's clock says so and the
firmware's come in as its timer produces them. It stamps every frame, sent
or received, with the plant's clock, records every ODOM_XY frame it sent and
assembles each control step the firmware reports (STATUS, STATUS_TRK, then
WHEEL_CMD) into a :class:`~mstc.sim.timing.FirmwareStep`, with the ODOM_XY
frame the step used, found from the counter the firmware echoes in
STATUS_TRK_odom_counter. The loop that drives it is
:func:`mstc.sim.realtime.simulate_realtime`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import can

from mstc.can.lockstep import CanController
from mstc.can.protocol import COUNTER_MODULO, Frame, FrameDropped
from mstc.controller import Event
from mstc.params import Params
from mstc.sim.plant import Pose
from mstc.sim.sensor import Obstacle
from mstc.sim.timing import FirmwareStep, OdomSent

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

    def send_arm(self, value: float) -> None:
        """The arm command, authenticated: 1 arms, 0 disarms (docs/safety.md).
        Its answers come in through :meth:`take`, which keeps the freshness
        value in step with the firmware's AUTH_STATUS."""
        frames = self.auth.param_set(self.proto, self.tables.arm_index, value)
        self._post(lambda: self._send_all(frames))

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
            self._pending_events.append(self._decode_event(frame, 0))
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
        elif name == "AUTH_STATUS":
            self.auth.sync(frame)
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
