# SPDX-License-Identifier: MIT
"""The CAN side of the ROS 2 bridge: the firmware behind a python-can bus,
without ROS.

:class:`Board` encodes the bridge's inputs as the protocol's frames (E2E
protected, the parameters and the arm command authenticated with the key),
decodes what the firmware sends, and counts what went wrong on the way: the
frames it dropped (CRC, alive counter, length, unknown identifier), the
firmware's own drop counters (STATUS_COUNTERS), and the commands the
firmware refused (AUTH_STATUS: missing, bad MAC, stale freshness). The ROS
node (:mod:`mstc.ros.bridge`) turns its frames into topics.

Two ways to receive, by bus: the in-process firmware (``mstc-sil``) answers
each frame before ``send`` returns, so the answers are taken right after
every send, on the sender's thread; any other bus (socketcan, slcan) has a
reader thread. Either way frames are handled one at a time under one lock,
and handed to ``on_frame`` in bus order.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial

import can

from mstc.can import secoc
from mstc.can.protocol import DropReason, Frame, Protocol, wire_limits
from mstc.errors import ControllerError, FrameDropped
from mstc.loop.lockstep import (
    ACCEPTED,
    AGAIN,
    CONTESTED,
    STEP_MODULO,
    answer_despite_counter,
    contested,
    contested_error,
    decides,
    no_status,
    obstacle_frames,
    odometry_frames,
    outcome,
    reference_frames,
    step_frame,
    unauthenticated,
)
from mstc.model import Obstacle, Pose

READ_TIMEOUT = 0.1
"""How long the reader thread waits for a frame before it looks whether it
should stop [s]."""


@dataclass
class Counts:
    """What the board link counted, for the diagnostics."""

    sent: int = 0
    """Frames sent."""
    received: int = 0
    """Frames received (before the checks)."""
    send_failures: int = 0
    """Frames the bus refused to send."""
    refused_inputs: int = 0
    """Inputs not sent because a value was outside its signal's range or not finite."""
    obstacles_clamped: int = 0
    """Obstacles whose radius OBSTACLE cannot carry, sent clamped on the safe
    side (:meth:`Board.obstacles`)."""
    velocities_clamped: int = 0
    """Obstacle velocities OBSTACLE_VEL cannot carry, sent clamped in their
    direction (:meth:`Board.obstacles`)."""
    firmware_drops: dict[str, int] = field(default_factory=dict)
    """The firmware's latest STATUS_COUNTERS: frames it dropped, by reason."""
    auth_refused: int = 0
    """Authenticated commands the firmware refused (AUTH_STATUS_refused)."""
    auth_last: str = "none"
    """Why the latest command was refused (AUTH_STATUS_last)."""
    auth_unverified: int = 0
    """Status frames (AUTH_STATUS with its AUTH_CHALLENGE) whose MAC did not
    verify under the bridge's key: the firmware has another key, or a node
    on the bus forges them."""
    heartbeat: str = ""
    """The firmware's latest HEARTBEAT state."""


class Board:
    """The firmware on a python-can bus, for the bridge.

    :param bus: the bus the firmware is on.
    :param key: the firmware's key (authenticated commands).
    :param on_frame: called with every frame that passes the checks, in bus
        order, under the board's lock (on the sender's thread for a bus that
        answers in ``send``, else on the reader thread).
    :param answers_in_send: the bus hands the firmware's answers back before
        ``send`` returns (the in-process ``mstc-sil``): no reader thread.
    :param timeout: how long a command waits for its answer [s].
    """

    def __init__(
        self,
        bus: can.BusABC,
        key: bytes,
        on_frame: Callable[[Frame], None],
        *,
        answers_in_send: bool,
        timeout: float = 0.5,
    ) -> None:
        self.bus = bus
        self.proto = Protocol(node=None)
        self.tables = self.proto.tables
        self.wire = wire_limits()
        self.auth = secoc.Authenticator(key)
        self.on_frame = on_frame
        self.answers_in_send = answers_in_send
        self.timeout = timeout
        self.counts = Counts()
        self.steps = 0
        """STEP frames sent."""
        self._lock = threading.RLock()
        self._answer = threading.Condition(self._lock)
        self._answers: list[Frame] = []
        self._stop = threading.Event()
        self._reader: threading.Thread | None = None

    # ------------------------------------------------------------ lifetime

    def start(self) -> None:
        """Start receiving, then learn the firmware's freshness value.

        :raises ControllerError: the firmware does not answer.
        """
        if not self.answers_in_send and self._reader is None:
            self._reader = threading.Thread(target=self._read, name="mstc-can-rx", daemon=True)
            self._reader.start()
        # Present? A PARAM_GET (which changes nothing) is answered by
        # PARAM_VALUE, and by the firmware's authenticated status, which the
        # first command is signed for. A status that does not verify under
        # this key is not adopted; the bridge still runs (its diagnostics
        # count those statuses), and every command says why it cannot sign.
        seen = self.auth.status
        self.request(self.tables.arm_index, None)
        try:
            self._await_status(lambda st: st is not seen)
        except ControllerError:
            pass

    def stop(self) -> None:
        """Stop the reader thread (the bus stays open: its owner shuts it down)."""
        self._stop.set()
        if self._reader is not None:
            self._reader.join(timeout=2 * READ_TIMEOUT + 1.0)
            self._reader = None

    # ------------------------------------------------------------ sending

    def send(self, frames: Iterable[can.Message]) -> bool:
        """Send @p frames in order; then, on a bus that answers in ``send``,
        take its answers. A frame the bus refuses is counted and the rest
        still go.

        :returns: every frame went out.
        """
        ok = True
        with self._lock:
            for msg in frames:
                msg.timestamp = time.time()
                try:
                    self.bus.send(msg)
                except can.CanError:
                    self.counts.send_failures += 1
                    ok = False
                    continue
                self.counts.sent += 1
            if self.answers_in_send:
                self._drain()
        return ok

    def _encoded(self, encode: Callable[[], list[can.Message]]) -> list[can.Message]:
        """The frames @p encode gives, or none (counted) when a value cannot
        be sent: non-finite, or outside its signal's range."""
        try:
            return encode()
        except ValueError:  # SignalRangeError, and NaN on the way to an integer
            self.counts.refused_inputs += 1
            return []

    def odometry(self, robot: Pose) -> list[can.Message]:
        """ODOM_XY and ODOM_THETA (both or neither)."""
        return self._encoded(partial(odometry_frames, self.proto, robot))

    def reference(self, ref: Pose, v_r: float, w_r: float) -> list[can.Message]:
        """REF_XY and REF_MOTION (both or neither)."""
        return self._encoded(partial(reference_frames, self.proto, ref, v_r, w_r))

    def obstacles(self, obstacles: Sequence[Obstacle], robot: Pose | None) -> list[can.Message]:
        """An OBSTACLE frame for each, followed by OBSTACLE_VEL for a moving
        one, what the frames cannot carry clamped on the safe side and
        counted (:meth:`fit`); one that cannot be sent even so (a position
        beyond the frame's range, a value not finite) is left out and counted
        in ``refused_inputs``."""
        frames: list[can.Message] = []
        for o in obstacles:
            fitted = self.fit(o, robot)
            if fitted is None:
                self.counts.refused_inputs += 1
                continue
            frames += self._encoded(partial(obstacle_frames, self.proto, fitted))
        return frames

    def fit(self, o: Obstacle, robot: Pose | None) -> Obstacle | None:
        """@p o as the frames can carry it, for a robot at @p robot:

        - a radius above OBSTACLE's largest (2.55 m) becomes the largest, the
          circle moved towards the robot so that its point nearest to the
          robot is the obstacle's: the distance and the direction the
          controller sees are the true ones, at every step (a robot within
          the obstacle gets it centred on itself); a radius below the
          smallest (0.01 m) becomes the smallest;
        - a velocity beyond OBSTACLE_VEL's ±32 m/s is scaled down to what it
          carries, its direction kept; the position is sent all the same.

        None when it cannot be sent: no robot pose yet for a radius to clamp.
        """
        lo, hi = self.wire.radius.lo, self.wire.radius.hi
        if o.radius > hi:
            if robot is None:
                return None
            dx, dy = robot.x - o.x, robot.y - o.y
            d = math.hypot(dx, dy)
            if d > o.radius:
                shift = (o.radius - hi) / d
                o = replace(o, x=o.x + shift * dx, y=o.y + shift * dy, radius=hi)
            else:
                o = replace(o, x=robot.x, y=robot.y, radius=hi)
            self.counts.obstacles_clamped += 1
        elif o.radius < lo:
            o = replace(o, radius=lo)
            self.counts.obstacles_clamped += 1
        scale = 1.0
        for v, r in zip((o.vx, o.vy), self.wire.velocity, strict=True):
            if v > r.hi:
                scale = min(scale, r.hi / v)
            elif v < r.lo:
                scale = min(scale, r.lo / v)
        if scale < 1.0:
            o = replace(o, vx=o.vx * scale, vy=o.vy * scale)
            self.counts.velocities_clamped += 1
        return o

    def step(self, t_us: int) -> tuple[int, can.Message]:
        """The next STEP frame, at firmware time @p t_us; and its step number."""
        step = self.steps % STEP_MODULO
        self.steps += 1
        return step, step_frame(self.proto, step, t_us)

    # ------------------------------------------------------------ commands

    def command(self, index: int, value: float) -> Frame:
        """An authenticated PARAM_SET; the firmware's PARAM_VALUE.

        Signed for the challenge of the firmware's last authenticated status
        (asked for first when this board has signed it already); when the
        status that decided it says the challenge was used up before it came
        (stale) or the firmware restarted, signed once more for the new one,
        as :meth:`mstc.loop.lockstep.CanController.command` does.

        :raises ControllerError: no answer within the timeout, or the firmware
            refused the command (its authenticated status says why).
        """
        what = f"PARAM_SET {self.tables.param_index.name_of(index)}"
        unauth = self.tables.param_result.value("unauthenticated")
        for _ in range(2):  # once more after AGAIN
            if not self.auth.can_sign():
                self.sync()
            st0 = self.auth.status
            answer, signed = self._set(index, value)
            assert st0 is not None  # can_sign() needs a status
            st = self._await_status(decides(st0.session, signed))
            with self._lock:
                answers = list(self._answers)  # every PARAM_VALUE since it went out
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

    def sync(self) -> None:
        """Learn the firmware's session and challenge: a PARAM_GET (which
        changes nothing) is answered by PARAM_VALUE and the authenticated
        status.

        :raises ControllerError: no status verifies within the timeout.
        """
        seen = self.auth.status
        self.request(self.tables.arm_index, None)
        self._await_status(lambda st: st is not seen)

    def _await_status(self, fresh: Callable[[secoc.Status], bool]) -> secoc.Status:
        """The firmware's next status whose MAC verifies and that @p fresh
        accepts (the current one if it does).

        :raises ControllerError: none within the timeout.
        """
        deadline = time.monotonic() + self.timeout
        with self._lock:
            while True:
                if self.answers_in_send:
                    self._drain()
                st = self.auth.status
                if st is not None and fresh(st):
                    return st
                left = deadline - time.monotonic()
                if left <= 0 or self.answers_in_send:
                    raise no_status(self.auth)
                self._answer.wait(left)

    def _set(self, index: int, value: float) -> tuple[Frame, int]:
        """The signed PARAM_SET and its PARAM_AUTH; the answer and the
        freshness value signed."""
        with self._lock:
            frames = self.auth.param_set(self.proto, index, value)
            signed = self.auth.signed
            assert signed is not None  # param_set signed one
            return self._ask(index, frames), signed

    def request(self, index: int, value: float | None) -> Frame:
        """PARAM_GET of parameter @p index (@p value None), or an
        authenticated PARAM_SET of it (:meth:`command`, which also reads the
        status that decided it); the firmware's PARAM_VALUE about it.

        :raises ControllerError: no answer within the timeout.
        """
        if value is not None:
            return self.command(index, value)
        with self._lock:
            return self._ask(index, [self.proto.encode("PARAM_GET", index=index)])

    def _ask(self, index: int, frames: list[can.Message]) -> Frame:
        """Send @p frames; the firmware's PARAM_VALUE about @p index."""
        with self._lock:
            self._answers.clear()
            self.send(frames)
            deadline = time.monotonic() + self.timeout
            while True:
                for frame in self._answers:
                    if frame.signals["index"] == index:
                        return frame
                left = deadline - time.monotonic()
                if left <= 0 or self.answers_in_send:
                    name = self.tables.param_index.name_of(index) or str(index)
                    raise ControllerError(
                        f"no PARAM_VALUE {name} from the firmware within {self.timeout:g} s: "
                        f"is it on this bus ({self.bus.channel_info})?"
                    )
                self._answer.wait(left)

    # ----------------------------------------------------------- receiving

    def _read(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self.bus.recv(timeout=READ_TIMEOUT)
            except can.CanError:
                continue
            if msg is not None:
                with self._lock:
                    self._handle(msg)

    def _drain(self) -> None:
        while (msg := self.bus.recv(timeout=0.0)) is not None:
            self._handle(msg)

    def _handle(self, msg: can.Message) -> None:
        self.counts.received += 1
        try:
            frame = self.proto.decode(msg)
        except FrameDropped as dropped:  # counted in proto.drops
            # A PARAM_VALUE dropped as a repeat: a node may have answered
            # first under the firmware's next counter; the command's outcome
            # weighs it (lockstep.outcome), nothing else sees it.
            repeat = answer_despite_counter(self.proto, msg, dropped)
            if repeat is not None:
                self._answers.append(repeat)
                self._answer.notify_all()
            return
        name = frame.name
        s = frame.signals
        if name in ("AUTH_STATUS", "AUTH_CHALLENGE"):
            # Counted only from a status whose MAC verifies: a forged one
            # changes nothing (secoc.Authenticator.sync).
            st = self.auth.sync(frame)
            self.counts.auth_unverified = self.auth.forged
            if st is not None:
                self.counts.auth_refused = st.refused
                self.counts.auth_last = self._choice("AUTH_STATUS", "last", st.last)
                self._answer.notify_all()
        elif name == "STATUS_COUNTERS":
            self.counts.firmware_drops = {k: int(v) for k, v in s.items()}
        elif name == "HEARTBEAT":
            self.counts.heartbeat = self._choice("HEARTBEAT", "state", s["state"])
        elif name == "PARAM_VALUE":
            self._answers.append(frame)
            self._answer.notify_all()
        self.on_frame(frame)

    def _choice(self, message: str, signal: str, raw: float) -> str:
        """The value table's name of @p raw, else the number."""
        choices = self.proto.message(message).get_signal_by_name(f"{message}_{signal}").choices
        for number, name in (choices or {}).items():
            if number == int(raw):
                return str(name)
        return str(int(raw))

    @property
    def drops(self) -> dict[str, int]:
        """Frames this side dropped, by reason (E2E: crc, seq, len; unknown)."""
        return {r.value: self.proto.drops[r] for r in DropReason}
