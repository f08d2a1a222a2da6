# SPDX-License-Identifier: MIT
"""``mstc ros``: the board as a ROS 2 node (docs/ros2.md).

On one side a python-can bus with the firmware on it (a board on socketcan
or slcan, ``mstc-fw``, or the firmware in process, ``mstc-sil``); on the
other ROS 2 topics with standard types, in REP-103 units and REP-105 frames:

- in: ``odom`` (nav_msgs/Odometry) → ODOM_XY, ODOM_THETA; the reference from
  ``plan`` (nav_msgs/Path, travelled at ``plan_speed``) or ``reference``
  (geometry_msgs/PoseStamped) → REF_XY, REF_MOTION; ``obstacles``
  (visualization_msgs/MarkerArray: a CYLINDER per obstacle, an ARROW of the
  same id for its velocity) → OBSTACLE, OBSTACLE_VEL;
- out: ``cmd_wheels`` (sensor_msgs/JointState: the wheel speed commands),
  ``joint_states`` (sensor_msgs/JointState: the wheel speeds measured, each
  WHEEL_SPEED frame on the bus, ros2_control's topic),
  ``mstc/status`` (diagnostic_msgs/DiagnosticArray: mode, errors, halt,
  faults, and every E2E and authentication failure counted),
  ``mstc/events`` (DiagnosticArray: the switching events, and the bridge's
  own: running, halted), ``tf`` when ``publish_tf`` is set;
- services: ``~/arm`` (std_srvs/SetBool), and the firmware's parameters as
  the node's parameters ``firmware.<name>`` (``ros2 param set``), both sent
  as the protocol's authenticated commands with the key of ``key_file``.

Who steps the firmware is ``step_source``: ``odom`` (one control step per
odometry message a period after the last, at its stamp: a simulator that
waits for the command), ``timer`` (the bridge's timer on the node's clock,
which follows ``use_sim_time``), or ``none`` (the firmware's own timer: a
board or ``mstc-fw --realtime``; no STEP frame is sent).
"""

from __future__ import annotations

import math
import signal
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can
import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Header
from std_srvs.srv import SetBool
from visualization_msgs.msg import Marker, MarkerArray

from mstc.can import secoc
from mstc.can.protocol import Frame, wire_limits
from mstc.errors import ControllerError, DependencyError, MstcError, UsageError
from mstc.limits import Held, violation
from mstc.logs.play import open_bus as open_can_bus
from mstc.loop.lockstep import decode_event
from mstc.model import Event, Fault, Obstacle, Pose
from mstc.plant.scenario import MAX_DT
from mstc.ros import diagnostics
from mstc.ros.board import Board, result_text
from mstc.ros.parameters import (
    FIRMWARE_PREFIX,
    FUTURE_BOUND_S,
    PARAMETERS,
    RANGES,
    RUN_TIME,
    STALE_PERIODS,
    STALE_S,
    STEP_SOURCES,
    problem,
)
from mstc.ros.reference import PathReference, ReferenceSample, StampedReference

NODE_NAME = "mstc_bridge"
OBSTACLE_IDS = range(int(wire_limits().ids.lo), int(wire_limits().ids.hi) + 1)
"""The firmware's obstacle ids (OBSTACLE_id: 1..48)."""
ODOM_STEP_SLACK = 0.01
"""With step_source odom, a step runs for the first odometry at least
(1 - this) periods after the last step's."""


class Inputs:
    """The latest of each input, as the bridge will send it."""

    def __init__(self) -> None:
        self.odom: Pose | None = None
        self.odom_new = False
        """An odometry message arrived since the last one sent."""
        self.plan: PathReference | None = None
        self.plan_tau = 0.0
        """How long the reference has moved along the plan [s]."""
        self.stream = StampedReference()
        self.stream_age = 0
        """Periods the stream's sample has been sent for."""
        self.obstacles: list[Obstacle] = []
        self.obstacles_at = -math.inf
        """When the obstacles arrived [s, monotonic]."""


@dataclass
class StepState:
    """The bridge's view of the firmware's control steps."""

    stamps: dict[int, Time] = field(default_factory=dict)
    """Stamp of each step sent, by step number (the last few)."""
    origin_ns: int | None = None
    """Node time of the first step [ns] (its firmware time is 0)."""
    last_ns: int | None = None
    """Node time of the last step [ns]."""
    t_us: int = 0
    """Firmware time of the last step [µs]."""
    offset_us: int = 0
    """Added to the firmware's time since the first step: late steps move it
    on by at least the firmware's timeout."""
    status: dict[str, float | int] = field(default_factory=dict)
    trk: dict[str, float | int] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)
    last_step: int | None = None
    """Number of the last STEP sent."""
    running: bool | None = None
    """The firmware's latest step ran (STATUS_halt none)."""
    wheels: tuple[float, float] = (0.0, 0.0)


def _time(ns: int) -> Time:
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def _ns(stamp: Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _yaw(q: Any) -> float:
    """Heading of a quaternion about z (REP-103: counter-clockwise)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def open_bus(interface: str, channel: str, bitrate: int, lib: str) -> can.BusABC:
    """The python-can bus of the parameters. The firmware in process
    (mstc-sil) is a simulation and has the key a simulated board has:
    $MSTC_KEY, $MSTC_KEY_FILE or keys/sim.key, whatever the bridge's key_file.

    :raises UsageError: a channel is needed and not given.
    :raises BusError: it cannot be opened (:func:`mstc.logs.play.open_bus`
        says why, with a hint for the usual SocketCAN causes).
    """
    config: dict[str, Any] = {}
    if interface == "mstc-sil":
        config["lib"] = lib or None
        config["key"] = secoc.load_key(None, secoc.SIM_KEY_FILE)
    elif not channel:
        raise UsageError(f"can_interface {interface} needs can_channel (can0, /dev/ttyACM0, ...)")
    elif interface == "slcan":
        config["bitrate"] = bitrate
    return open_can_bus(interface, channel or None, **config)


class Bridge(Node):
    """The bridge node; see the module's description.

    :raises UsageError: a parameter the bridge cannot use.
    :raises AuthKeyError: no key in key_file (or the default's places).
    :raises BusError: the bus cannot be opened.
    :raises ControllerError: the firmware does not answer on it.
    """

    def __init__(self, **node_kwargs: Any) -> None:
        super().__init__(NODE_NAME, **node_kwargs)
        for name, (default, text) in PARAMETERS.items():
            try:
                self.declare_parameter(name, default, ParameterDescriptor(description=text))
            except ParameterException as exc:  # given with another type than the default's
                raise UsageError(str(exc)) from exc
        p = self._param
        for name in RANGES:
            why = problem(name, p(name))
            if why is not None:
                raise UsageError(why)
        interface = str(p("can_interface"))
        step_source = str(p("step_source")) or ("timer" if interface == "mstc-sil" else "none")
        if step_source not in STEP_SOURCES:
            raise UsageError(f"step_source {step_source!r}: one of {', '.join(STEP_SOURCES)}")
        reference_source = str(p("reference_source"))
        if reference_source not in ("plan", "reference"):
            raise UsageError(f"reference_source {reference_source!r}: plan or reference")
        reliability = str(p("qos_reliability"))
        if reliability not in ("reliable", "best_effort"):
            raise UsageError(f"qos_reliability {reliability!r}: reliable or best_effort")
        key_path = str(p("key_file"))
        # The firmware in process is a simulation: the simulations' key by
        # default (keys/sim.key, which make sim writes), as mstc sim's.
        simulated = interface == "mstc-sil"
        default = secoc.SIM_KEY_FILE if simulated else secoc.DEFAULT_KEY_FILE
        key = secoc.load_key(Path(key_path) if key_path else None, default)
        self.bus = open_bus(
            interface, str(p("can_channel")), int(p("can_bitrate")), str(p("sil_lib"))
        )
        self.step_source = step_source
        self.reference_source = reference_source
        self.period = 1.0 / float(p("rate_hz"))
        self.frames = {k: str(p(k)) for k in ("world_frame", "base_frame", "reference_frame")}
        self.joints = [str(p("left_wheel_joint")), str(p("right_wheel_joint"))]
        self.inputs = Inputs()
        self.state = StepState()
        self.late_steps = 0
        """Control steps more than MAX_DT after the last (or before it)."""
        self.dropped_inputs: dict[str, int] = {}
        """Messages not used, by reason (wrong frame, bad value, ...)."""
        self.board = Board(
            self.bus,
            key,
            self._on_frame,
            answers_in_send=interface == "mstc-sil",
            timeout=float(p("command_timeout")),
        )

        depth = int(p("qos_depth"))
        qin = QoSProfile(
            depth=depth,
            reliability=ReliabilityPolicy.RELIABLE
            if reliability == "reliable"
            else ReliabilityPolicy.BEST_EFFORT,
        )
        qout = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)
        events_qos = QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE
        )
        self.cmd_pub = self.create_publisher(JointState, "cmd_wheels", qout)
        self.joint_pub = self.create_publisher(JointState, "joint_states", qout)
        self.status_pub = self.create_publisher(DiagnosticArray, "mstc/status", qout)
        self.events_pub = self.create_publisher(DiagnosticArray, "mstc/events", events_qos)
        self.tf_pub: Any = None
        if bool(p("publish_tf")):
            try:
                from tf2_msgs.msg import TFMessage
            except ImportError as exc:
                raise DependencyError(
                    "publish_tf needs tf2_msgs, which this ROS 2 installation lacks "
                    "(a ROS 2 desktop install has it; the PyPI wheels do not)"
                ) from exc
            self.tf_pub = self.create_publisher(TFMessage, "tf", qout)
        self.create_subscription(PathMsg, "plan", self._on_plan, qin)
        self.create_subscription(PoseStamped, "reference", self._on_reference, qin)
        self.create_subscription(MarkerArray, "obstacles", self._on_obstacles, qin)
        # Odometry last: rclpy's executor takes a node's ready messages in the
        # order of its subscriptions, so obstacles that arrived with the
        # odometry that steps the firmware (step_source odom) go with that step.
        self.create_subscription(Odometry, "odom", self._on_odom, qin)
        self.create_service(SetBool, "~/arm", self._on_arm)

        self.board.start()
        self._firmware_parameters()
        self.add_on_set_parameters_callback(self._on_set_parameters)
        if step_source != "odom":
            self.create_timer(self.period, self._on_tick)
        self.create_timer(1.0 / float(p("status_rate_hz")), self._publish_status)
        self.get_logger().info(
            f"mstc bridge on {self.bus.channel_info}: steps from {step_source}, "
            f"reference from {reference_source}, {1 / self.period:g} Hz"
        )

    def _param(self, name: str) -> Any:
        return self.get_parameter(name).value

    def destroy_node(self) -> None:
        """Stop the CAN side, then the node (also of a node whose start
        failed half-way: rclpy's shutdown destroys it too)."""
        board: Board | None = getattr(self, "board", None)
        if board is not None:
            board.stop()
        bus: can.BusABC | None = getattr(self, "bus", None)
        if bus is not None:
            bus.shutdown()
            self.bus = None  # type: ignore[assignment]  # shut down once
        super().destroy_node()

    # ------------------------------------------------------- parameters

    def _firmware_parameters(self) -> None:
        """``firmware.<name>`` for every parameter of the DBC: the values
        given at start (a parameters file, ``-p``) are sent to the firmware as
        one set (:meth:`_set_firmware`); the others are read from it.

        :raises UsageError: a value given that the parameter table refuses.
        :raises ControllerError: one the firmware refuses, or no answer.
        """
        tables = self.board.tables
        self._syncing = True
        try:
            given: dict[str, Any] = {}
            held: dict[str, float] = {}
            for raw, name in tables.param_index.entries.items():
                if raw == tables.arm_index:
                    continue
                full = FIRMWARE_PREFIX + name
                text = f"the firmware's parameter {name} (PARAM_SET index {raw})"
                if name == "strategy":
                    text += ": " + " or ".join(tables.strategy.entries.values())
                value = self.declare_parameter(
                    full, None, ParameterDescriptor(description=text, dynamic_typing=True)
                ).value
                if value is not None:
                    given[name] = value
                answer = self.board.request(raw, None)
                if answer.signals["result"] != tables.param_ok:
                    continue  # not readable: left unset
                held[name] = float(answer.signals["value"])
                if value is None:
                    shown: Any = held[name]
                    if name == "strategy":
                        shown = tables.strategy.name_of(round(held[name])) or held[name]
                    self.set_parameters([Parameter(full, value=shown)])
            if given:
                self._set_firmware(given, held)
        finally:
            self._syncing = False

    def _firmware_number(self, name: str, value: Any) -> float:
        """@p value of firmware parameter @p name as PARAM_SET sends it.

        :raises UsageError: not a number (nor a strategy's name).
        """
        tables = self.board.tables
        if name == "strategy" and isinstance(value, str):
            return float(tables.strategy.value(value))
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise UsageError(f"firmware.{name}: a number, not {value!r}")
        return float(value)

    def _firmware_held(self) -> dict[str, float]:
        """What the firmware holds, as the node's ``firmware.*`` parameters
        show it (read at start, then set only through :meth:`_set_firmware`)."""
        held = {}
        for raw, name in self.board.tables.param_index.entries.items():
            if raw == self.board.tables.arm_index:
                continue
            value = self.get_parameter(FIRMWARE_PREFIX + name).value
            if value is not None:
                held[name] = self._firmware_number(name, value)
        return held

    def _set_firmware(self, values: dict[str, Any], held: dict[str, float]) -> None:
        """Send @p values to the firmware as one set, or none of them: checked
        as a whole against the parameter table (:func:`mstc.limits.violation`,
        the firmware's own check) with the values it @p held, then sent one by
        one in an order that keeps the firmware's set valid at every step;
        when the firmware refuses one all the same (armed, not authenticated,
        no answer), those already sent are set back.

        :raises UsageError: the table refuses the set.
        :raises ControllerError: the firmware refused a value (the others
            set back, or the error says which could not be).
        """
        tables = self.board.tables
        new = {name: self._firmware_number(name, v) for name, v in values.items()}
        for name in new:
            if name not in tables.param_index.entries.values() or name == "arm":
                raise UsageError(f"firmware.{name}: no such parameter of the firmware")
        ways = (Held.FLOAT, Held.FIXED_FRAME)  # as a frame's float32 reaches either build
        wrong = violation({**held, **new}, ways)
        if wrong is not None:
            names = ", ".join(FIRMWARE_PREFIX + n for n in wrong.names if n in new) or "the set"
            raise UsageError(f"{names}: {wrong.problem}")
        now = dict(held)
        pending = dict(new)
        done: list[tuple[str, float | None]] = []  # sent, with the value before
        while pending:
            ready = [n for n, v in pending.items() if violation({**now, n: v}, ways) is None]
            if not ready:  # cannot happen for a set the table accepts but by rounding
                ready = list(pending)[:1]
            name = ready[0]
            value = pending.pop(name)
            why = self._send_firmware(name, value)
            if why is not None:
                raise ControllerError(why + self._undo(done))
            done.append((name, now.get(name)))
            now[name] = value

    def _send_firmware(self, name: str, value: float) -> str | None:
        """Send one parameter; None when the firmware accepted it, else why not."""
        tables = self.board.tables
        try:
            answer = self.board.command(tables.param_index.value(name), value)
        except MstcError as exc:  # no answer, not authenticated, a forged answer
            return str(exc)
        if answer.signals["result"] != tables.param_ok:
            result = tables.param_result.name_of(int(answer.signals["result"]))
            return f"the firmware answers {result} to {name} = {value:g}"
        return None

    def _undo(self, done: list[tuple[str, float | None]]) -> str:
        """Set back the parameters of @p done (sent, with their values
        before), the last first; what to add to the error."""
        if not done:
            return ""
        failed = []
        for name, before in reversed(done):
            if before is None or self._send_firmware(name, before) is not None:
                failed.append(name)
        if failed:
            return f"; the firmware keeps the new {', '.join(failed)}: set it again"
        return f"; {', '.join(n for n, _ in done)} set back"

    def _on_set_parameters(self, params: list[Parameter[Any]]) -> SetParametersResult:
        if self._syncing:
            return SetParametersResult(successful=True)
        firmware: dict[str, Any] = {}
        for param in params:
            if param.name.startswith(FIRMWARE_PREFIX):
                firmware[param.name.removeprefix(FIRMWARE_PREFIX)] = param.value
            elif param.name in PARAMETERS and param.name not in RUN_TIME:
                return SetParametersResult(
                    successful=False, reason=f"{param.name} is read at start: restart the bridge"
                )
            elif (why := problem(param.name, param.value)) is not None:
                return SetParametersResult(successful=False, reason=why)
        if firmware:
            try:
                self._set_firmware(firmware, self._firmware_held())
            except MstcError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _on_arm(self, request: Any, response: Any) -> Any:
        """``~/arm``: the authenticated arm (true) or disarm (false) command."""
        tables = self.board.tables
        try:
            answer = self.board.command(tables.arm_index, 1.0 if request.data else 0.0)
        except MstcError as exc:  # no answer, not authenticated
            response.success, response.message = False, str(exc)
            return response
        response.success = answer.signals["result"] == tables.param_ok
        response.message = result_text(tables, tables.arm_index, int(answer.signals["result"]))
        return response

    # ------------------------------------------------------------ inputs

    def _drop(self, why: str) -> None:
        self.dropped_inputs[why] = self.dropped_inputs.get(why, 0) + 1
        if self.dropped_inputs[why] == 1:
            self.get_logger().warning(f"input not used: {why} (counted in mstc/status)")

    def _in_world(self, frame_id: str, topic: str) -> bool:
        if frame_id and frame_id != self.frames["world_frame"]:
            self._drop(f"{topic} in frame {frame_id}, not {self.frames['world_frame']}")
            return False
        return True

    def _on_odom(self, msg: Odometry) -> None:
        if not self._in_world(msg.header.frame_id, "odom"):
            return
        base = self.frames["base_frame"]
        if msg.child_frame_id and msg.child_frame_id != base:
            self._drop(f"odom of {msg.child_frame_id}, not {base}")
            return
        stamp = _ns(msg.header.stamp)
        if self.step_source == "odom" and self._ahead(stamp, "odom"):
            return
        p = msg.pose.pose
        self.inputs.odom = Pose(p.position.x, p.position.y, _yaw(p.orientation))
        self.inputs.odom_new = True
        if self.step_source == "none":
            self._send_odometry()
            return
        if self.step_source == "odom":
            last = self.state.last_ns
            # A stamp before the last step's is a clock that jumped back (a
            # bag played in a loop, a restarted simulator): a step, which
            # _control_step takes as late.
            if (
                last is None
                or stamp < last
                or stamp - last >= (1 - ODOM_STEP_SLACK) * self.period * 1e9
            ):
                self._control_step(stamp)

    def _ahead(self, stamp_ns: int, topic: str) -> bool:
        """A stamp more than FUTURE_BOUND_S ahead of the node's clock: the
        message is not used, and counted."""
        if stamp_ns - self.get_clock().now().nanoseconds > FUTURE_BOUND_S * 1e9:
            self._drop(f"{topic} stamped more than {FUTURE_BOUND_S:g} s ahead of the clock")
            return True
        return False

    def _on_plan(self, msg: PathMsg) -> None:
        if not self._in_world(msg.header.frame_id, "plan"):
            return
        points = [(ps.pose.position.x, ps.pose.position.y) for ps in msg.poses]
        try:
            speed = float(self._param("plan_speed"))
            # On its clock (at(τ)): the bridge has no goal to wait for the robot at.
            self.inputs.plan = PathReference(points, speed, self.period, wait=False)
        except ValueError as exc:
            self._drop(f"plan: {exc}")
            return
        self.inputs.plan_tau = 0.0

    def _on_reference(self, msg: PoseStamped) -> None:
        if not self._in_world(msg.header.frame_id, "reference"):
            return
        stamp = _ns(msg.header.stamp)
        if self._ahead(stamp, "reference"):
            return
        p = msg.pose
        pose = Pose(p.position.x, p.position.y, _yaw(p.orientation))
        if self.inputs.stream.add(stamp, pose):
            self.inputs.stream_age = 0

    def _on_obstacles(self, msg: MarkerArray) -> None:
        cylinders: dict[int, Marker] = {}
        arrows: dict[int, Marker] = {}
        for m in msg.markers:
            if m.action != Marker.ADD or not self._in_world(m.header.frame_id, "obstacles"):
                continue
            if m.id not in OBSTACLE_IDS:
                self._drop(
                    f"obstacle marker id {m.id} outside {OBSTACLE_IDS[0]}..{OBSTACLE_IDS[-1]}"
                )
                continue
            if m.type == Marker.CYLINDER:
                cylinders[m.id] = m
            elif m.type == Marker.ARROW and len(m.points) == 2:
                arrows[m.id] = m
        obstacles = []
        for i, m in sorted(cylinders.items()):
            vx = vy = 0.0
            if i in arrows:
                a, b = arrows[i].points
                vx, vy = b.x - a.x, b.y - a.y
            radius = max(m.scale.x, m.scale.y) / 2
            obstacles.append(Obstacle(i, m.pose.position.x, m.pose.position.y, radius, vx, vy))
        self.inputs.obstacles = obstacles
        self.inputs.obstacles_at = time.monotonic()

    # ------------------------------------------------------------- steps

    def _reference(self) -> ReferenceSample | None:
        if self.reference_source == "plan":
            plan = self.inputs.plan
            return plan.at(self.inputs.plan_tau) if plan is not None else None
        return self.inputs.stream.sample

    def _send_odometry(self) -> list[can.Message]:
        odom = self.inputs.odom
        if odom is None or not self.inputs.odom_new:
            return []
        self.inputs.odom_new = False
        frames = self.board.odometry(odom)
        if self.step_source == "none":
            self.board.send(frames)
        return frames

    def _inputs(self, dt: float) -> list[can.Message]:
        """Reference and obstacles of a period @p dt [s] after the last. The
        reference moves on along the plan only after a step the firmware ran:
        halted, it waits at its place."""
        frames: list[can.Message] = []
        if self.state.running:
            self.inputs.plan_tau += dt
        ref = self._reference()
        if self.reference_source == "reference" and ref is not None:
            # A sample is sent for STALE_PERIODS periods, then no more: the
            # firmware halts (reference) when the stream stops, as it would
            # on the bus.
            if self.inputs.stream_age >= STALE_PERIODS:
                self._drop(f"reference older than {STALE_PERIODS} periods (not sent)")
                ref = None
            self.inputs.stream_age += 1
        if ref is not None:
            frames += self.board.reference(ref.pose, ref.v, ref.w)
        timeout = float(self._param("obstacle_timeout"))
        if time.monotonic() - self.inputs.obstacles_at <= timeout:
            frames += self.board.obstacles(self.inputs.obstacles, self.inputs.odom)
        return frames

    def _on_tick(self) -> None:
        if self.step_source == "timer":
            self._control_step(self.get_clock().now().nanoseconds)
        else:
            self.board.send(self._inputs(self.period))

    def _control_step(self, stamp_ns: int) -> None:
        """One lock-step control step at node time @p stamp_ns: odometry (if
        new), reference, obstacles, STEP.

        A step more than the filter's longest period (MAX_DT) after the last,
        or before it (the clock jumped back), is late: the controller must not
        run over such a gap. It goes without its odometry and at least the
        firmware's timeout (STALE_S) after the last on the firmware's clock,
        so that the firmware halts (odometry), as it does when the bus is
        lost; counted (``late_steps``)."""
        st = self.state
        if st.origin_ns is None:
            st.origin_ns = stamp_ns
        t_us = (stamp_ns - st.origin_ns) // 1000 + st.offset_us
        late = st.last_ns is not None and not (
            0 <= stamp_ns - st.last_ns <= MAX_DT * (1 + ODOM_STEP_SLACK) * 1e9
        )
        if late:
            self.late_steps += 1
            if self.late_steps == 1:
                self.get_logger().warning(
                    f"a control step {(stamp_ns - (st.last_ns or 0)) / 1e9:g} s after the last: "
                    f"more than {MAX_DT:g} s, sent without odometry so that the firmware halts "
                    "(counted in mstc/status, late_steps)"
                )
            least = st.t_us + round(STALE_S * 1e6)
            if t_us < least:
                st.offset_us += least - t_us
                t_us = least
        dt = (t_us - st.t_us) / 1e6 if st.last_ns is not None else 0.0
        st.last_ns = stamp_ns
        st.t_us = t_us
        frames = ([] if late else self._send_odometry()) + self._inputs(dt)
        step, msg = self.board.step(t_us)
        st.stamps[step] = _time(stamp_ns)
        st.stamps.pop(step - 8, None)
        st.last_step = step
        self.board.send([*frames, msg])

    # ----------------------------------------------------------- outputs

    def _on_frame(self, frame: Frame) -> None:
        """A frame from the firmware (under the board's lock)."""
        st = self.state
        name = frame.name
        if name == "EVENT":
            try:
                st.events.append(decode_event(self.board.tables, frame, 0))
            except KeyError:  # a kind or side this DBC does not name: another firmware's
                self._drop(f"EVENT of unknown kind {frame.signals['kind']} or side")
        elif name == "STATUS":
            st.status = frame.signals
        elif name == "STATUS_TRK":
            st.trk = frame.signals
        elif name == "WHEEL_SPEED":
            # What the wheels measured: the board's own encoders (it sends
            # them at the step, before WHEEL_CMD) or the motor drivers'.
            # Stamped with the last step's time in lock-step, else on arrival.
            stamp = st.stamps.get(st.last_step) if st.last_step is not None else None
            if stamp is None:
                stamp = self.get_clock().now().to_msg()
            joints = JointState()
            joints.header.stamp = stamp
            joints.header.frame_id = self.frames["base_frame"]
            joints.name = list(self.joints)
            joints.velocity = [float(frame.signals["left"]), float(frame.signals["right"])]
            self.joint_pub.publish(joints)
        elif name == "WHEEL_CMD":
            step = int(frame.signals["step"])
            stamp = st.stamps.pop(step, None)
            if stamp is None:
                stamp = self.get_clock().now().to_msg()
            left, right = float(frame.signals["left"]), float(frame.signals["right"])
            st.wheels = (left, right)
            cmd = JointState()
            cmd.header.stamp = stamp
            cmd.header.frame_id = self.frames["base_frame"]
            cmd.name = list(self.joints)
            cmd.velocity = [left, right]
            self.cmd_pub.publish(cmd)
            self._step_done(stamp)

    def _step_done(self, stamp: Time) -> None:
        """After a step's WHEEL_CMD: its events, a change of running, /tf."""
        st = self.state
        tables = self.board.tables
        statuses = []
        for event in st.events:
            text, values = diagnostics.event_status(event)
            statuses.append(self._status(diagnostics.EVENT, diagnostics.OK, text, values))
        st.events = []
        if st.status:
            halt = int(st.status["halt"])
            running = halt == 0
            if running != st.running:
                reason = tables.halt.name_of(halt) or str(halt)
                text = "running" if running else f"halted: {reason}"
                level = diagnostics.OK if running else diagnostics.WARN
                statuses.append(self._status(diagnostics.BRIDGE, level, text, [("halt", reason)]))
                st.running = running
        if statuses:
            self.events_pub.publish(DiagnosticArray(header=self._header(stamp), status=statuses))
        if self.tf_pub is not None:
            self._publish_tf(stamp)

    def _header(self, stamp: Time) -> Header:
        return Header(stamp=stamp, frame_id=self.frames["base_frame"])

    def _status(
        self, name: str, level: int, message: str, values: Sequence[tuple[str, object]]
    ) -> DiagnosticStatus:
        return DiagnosticStatus(
            level=bytes([level]),  # a byte field: rclpy wants bytes
            name=name,
            message=message,
            hardware_id=str(self.bus.channel_info),
            values=[KeyValue(key=k, value=str(v)) for k, v in values],
        )

    def _publish_tf(self, stamp: Time) -> None:
        from geometry_msgs.msg import TransformStamped
        from tf2_msgs.msg import TFMessage

        transforms = []
        ref = self._reference()
        poses = (
            (self.frames["base_frame"], self.inputs.odom),
            (self.frames["reference_frame"], ref.pose if ref is not None else None),
        )
        for child, pose in poses:
            if pose is None:
                continue
            t = TransformStamped()
            t.header.stamp = stamp
            t.header.frame_id = self.frames["world_frame"]
            t.child_frame_id = child
            t.transform.translation.x, t.transform.translation.y = pose.x, pose.y
            t.transform.rotation.z = math.sin(pose.theta / 2)
            t.transform.rotation.w = math.cos(pose.theta / 2)
            transforms.append(t)
        self.tf_pub.publish(TFMessage(transforms=transforms))

    def _publish_status(self) -> None:
        """mstc/status: the firmware's latest step and every counter."""
        tables = self.board.tables
        st = self.state
        counts = self.board.counts
        values: list[tuple[str, object]] = []
        level, message = diagnostics.STALE, "no control step yet"
        if st.status:
            s = st.status
            mode = tables.mode.get(int(s["mode"]))
            halt = tables.halt.name_of(int(s["halt"])) or str(s["halt"])
            faults = Fault(int(s["faults"]))
            side = tables.side.get(int(s["side"]))
            values += [
                ("mode", mode),
                ("halt", halt),
                ("side", side or ""),
                ("obstacle", int(s["obstacle"])),
                ("faults", "|".join(str(f.name).lower() for f in Fault if f in faults)),
                ("e", f"{float(s['e']):.4f}"),
                ("distance", f"{float(s['distance']):.3f}"),
            ]
            values += [(k, f"{float(st.trk[k]):.4f}") for k in ("e1", "e2", "e3") if st.trk]
            values += [("wheel_left", st.wheels[0]), ("wheel_right", st.wheels[1])]
            level, message = diagnostics.controller_level(str(mode), halt)
        values += [("heartbeat", counts.heartbeat)]
        # E2E failures: frames the bridge dropped, and those the firmware did.
        values += [(f"bridge_dropped_{k}", v) for k, v in self.board.drops.items()]
        values += [(f"firmware_dropped_{k}", v) for k, v in counts.firmware_drops.items()]
        # MAC failures: authenticated commands the firmware refused, and the
        # firmware's statuses that did not verify under the bridge's key.
        values += [("auth_refused", counts.auth_refused), ("auth_last", counts.auth_last)]
        values += [("auth_unverified", counts.auth_unverified)]
        values += [
            ("frames_sent", counts.sent),
            ("frames_received", counts.received),
            ("send_failures", counts.send_failures),
            ("inputs_refused", counts.refused_inputs),
            ("late_steps", self.late_steps),
            ("obstacles_clamped", counts.obstacles_clamped),
            ("velocities_clamped", counts.velocities_clamped),
        ]
        values += [(f"input_dropped: {k}", v) for k, v in self.dropped_inputs.items()]
        now = self.get_clock().now().to_msg()
        status = self._status(diagnostics.CONTROLLER, level, message, values)
        self.status_pub.publish(DiagnosticArray(header=self._header(now), status=[status]))


def run(args: Sequence[str]) -> int:
    """Run the bridge until interrupted; @p args are ROS's (``--ros-args ...``).

    :raises MstcError: the bridge cannot start (see :class:`Bridge`).
    """
    # Ctrl-C and SIGTERM both end spin with KeyboardInterrupt, Python's own
    # way, at any point of the start (rclpy's handlers shut the context
    # down under a starting executor, which then fails with a traceback).
    # SIGINT too is set here: Python leaves it ignored when the process
    # starts with it ignored (a shell's background job, `cmd &` in a
    # script), and the bridge then ran on after Ctrl-C or `kill -INT`.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        rclpy.init(args=["mstc-ros", *args], signal_handler_options=SignalHandlerOptions.NO)
    except RuntimeError as exc:  # rclpy's RCLError: arguments rcl cannot parse
        why = str(exc).removeprefix("failed to initialize rcl: ").split(". Error:")[0]
        raise UsageError(f"ROS arguments {' '.join(args)}: {why}") from exc
    node: Bridge | None = None
    try:
        node = Bridge()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):  # Ctrl-C, SIGTERM
        pass
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
