# SPDX-License-Identifier: MIT
"""The ROS 2 bridge checks what it is told (issue 30, R1-R7), and publishes
what the wheels measured on ``joint_states`` (issue 32).

The bridge node (``mstc.ros.bridge.Bridge``) runs in this process with the
firmware in process (mstc-sil, its real library), stepping on odometry
(``step_source: odom``), and is handed real ROS 2 messages (nav_msgs/Odometry,
nav_msgs/Path, geometry_msgs/PoseStamped, visualization_msgs/MarkerArray) by
its own subscriptions' callbacks, one period at a time, as rclpy's executor
hands them; parameters go through rclpy's own ``set_parameters`` (what
``ros2 param set`` reaches). Each control step's answer (WHEEL_CMD and
STATUS) is back before the callback returns (mstc-sil answers in ``send``).
The robot is a unicycle moved with the commanded wheel speeds for one period.

Stamps are sim time from 1 s (as tests/python/ros_plant.py's), far behind the
node's clock, which is the wall clock; "ahead of the clock" is the wall clock
plus an hour.

Expected values: the firmware's halt reasons (docs/safety.md: 2 odometry,
3 reference), its parameter defaults and ranges (firmware/ctrl/ctl_params.toml:
D_s 0.35 < D_act 0.5, max_wheel_decel 125, control-law parameters refused while
armed), the frames' ranges (firmware/comm/mstc.dbc: radius 0.01..2.55 m,
velocity ±32 m/s), the filter's longest period (50 ms) and contact by
geometry: the centre within R_m + radius of the obstacle's.
"""

from __future__ import annotations

import math
import os
import random
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can
import cantools
import pytest
import rclpy
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool
from visualization_msgs.msg import Marker, MarkerArray

from conftest import ROOT
from logfiles import DBC
from mstc.can.library import Library
from mstc.can.protocol import Protocol
from mstc.errors import MstcError, UsageError
from mstc.firmware.wheels import DcWheels
from mstc.model import Params, Pose
from mstc.plant.plant import Integrator, UnicyclePlant
from mstc.ros.bridge import Bridge

PROFILE = ROOT / "tests" / "data" / "fastdds-loopback.xml"
DT = 0.02
DT_NS = 20_000_000
START_NS = 1_000_000_000
HOUR_NS = 3600 * 1_000_000_000
HALT_NONE, HALT_ODOMETRY, HALT_REFERENCE = 0, 2, 3


@pytest.fixture(scope="module")
def ros_context() -> Iterator[None]:
    """ROS 2 on localhost only, in a domain of its own."""
    os.environ["ROS_DOMAIN_ID"] = str(random.Random(os.getpid() + 30).randrange(1, 100))
    os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] = str(PROFILE)
    rclpy.init()
    yield
    rclpy.shutdown()


_nodes = iter(range(1_000_000))


def make_bridge(sil_lib: Path, **params: Any) -> Bridge:
    """A bridge in this process on the firmware in process, stepping on
    odometry, with @p params (``firmware_D_s`` for ``firmware.D_s``)."""
    values = {"can_interface": "mstc-sil", "sil_lib": str(sil_lib), "step_source": "odom"}
    values.update({k.replace("firmware_", "firmware.", 1): v for k, v in params.items()})
    overrides = [Parameter(k, value=v) for k, v in values.items()]
    return Bridge(namespace=f"t{next(_nodes)}", parameter_overrides=overrides)


@pytest.fixture
def bridges(ros_context: None) -> Iterator[list[Bridge]]:
    made: list[Bridge] = []
    yield made
    for b in made:
        b.destroy_node()


def stamp(header: Any, ns: int) -> None:
    header.stamp.sec, header.stamp.nanosec = divmod(ns, 1_000_000_000)


def odometry(pose: Pose, ns: int) -> Odometry:
    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = "odom", "base_link"
    stamp(msg.header, ns)
    msg.pose.pose.position.x, msg.pose.pose.position.y = pose.x, pose.y
    msg.pose.pose.orientation.z = math.sin(pose.theta / 2)
    msg.pose.pose.orientation.w = math.cos(pose.theta / 2)
    return msg


def straight_plan(length: float) -> PathMsg:
    """A path east from the origin."""
    msg = PathMsg()
    msg.header.frame_id = "odom"
    for x in (0.0, length):
        ps = PoseStamped()
        ps.header.frame_id = "odom"
        ps.pose.position.x = x
        ps.pose.orientation.w = 1.0
        msg.poses.append(ps)
    return msg


def reference(pose: Pose, ns: int) -> PoseStamped:
    msg = PoseStamped()
    msg.header.frame_id = "odom"
    stamp(msg.header, ns)
    msg.pose.position.x, msg.pose.position.y = pose.x, pose.y
    msg.pose.orientation.z = math.sin(pose.theta / 2)
    msg.pose.orientation.w = math.cos(pose.theta / 2)
    return msg


def obstacles(*items: tuple[int, float, float, float, float, float]) -> MarkerArray:
    """(id, x, y, radius, vx, vy) each: a CYLINDER, and an ARROW when moving."""
    msg = MarkerArray()
    for i, x, y, r, vx, vy in items:
        m = Marker(type=Marker.CYLINDER, action=Marker.ADD, id=i)
        m.header.frame_id = "odom"
        m.pose.position.x, m.pose.position.y = x, y
        m.scale.x = m.scale.y = 2 * r
        msg.markers.append(m)
        if vx or vy:
            a = Marker(type=Marker.ARROW, action=Marker.ADD, id=i)
            a.header.frame_id = "odom"
            a.points = [type(m.pose.position)(), type(m.pose.position)(x=vx, y=vy)]
            msg.markers.append(a)
    return msg


class Robot:
    """A unicycle driven by the bridge's wheel commands, one period a step."""

    def __init__(self, bridge: Bridge, wheels: DcWheels | None = None) -> None:
        self.bridge = bridge
        self.pose = Pose(0.0, 0.0, 0.0)
        self.k = 0
        self.params = Params()
        self.halts: list[int] = []
        self.wheels = wheels
        """"dc" wheels the commands drive (the board's own, whose wheel loop
        it measures), instead of ideal ones."""

    @property
    def ns(self) -> int:
        return START_NS + self.k * DT_NS

    def step(self, *, odom: bool = True, gap_ns: int = DT_NS) -> int:
        """Odometry at the next stamp (@p gap_ns after the last), then move
        for that long with the command it got; the step's halt reason."""
        self.k += gap_ns // DT_NS
        before = self.bridge.board.steps
        if odom:
            self.bridge._on_odom(odometry(self.pose, self.ns))
        halt = int(self.bridge.state.status.get("halt", -1))
        if self.bridge.board.steps == before:
            halt = -1  # no step ran
        left, right = self.bridge.state.wheels
        p = self.params
        if self.wheels is not None:
            plant = UnicyclePlant(self.pose, p.wheel_radius, p.track_width, Integrator.EXACT)
            self.wheels.drive(plant, left, right, gap_ns / 1e9)
            self.pose = plant.pose
            self.halts.append(halt)
            return halt
        v = p.wheel_radius * (left + right) / 2
        w = p.wheel_radius * (right - left) / p.track_width
        dt = gap_ns / 1e9
        x, y, th = self.pose
        self.pose = Pose(x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt)
        self.halts.append(halt)
        return halt

    def arm(self) -> str:
        answer = self.bridge._on_arm(SetBool.Request(data=True), SetBool.Response())
        return str(answer.message)


def armed_robot(
    bridge: Bridge, plan: bool = True, wheels: DcWheels | None = None, start: Pose | None = None
) -> Robot:
    robot = Robot(bridge, wheels)
    if start is not None:
        robot.pose = start
    if plan:
        bridge._on_plan(straight_plan(50.0))
    for _ in range(6):
        robot.step()
    assert robot.arm() == "ok"
    return robot


def firmware_value(bridge: Bridge, name: str) -> float:
    tables = bridge.board.tables
    return float(bridge.board.request(tables.param_index.value(name), None).signals["value"])


def sent_frames(bridge: Bridge) -> list[can.Message]:
    """Record every frame the bridge sends from now on."""
    sent: list[can.Message] = []
    bus = bridge.bus
    send = bus.send

    def record(msg: can.Message, timeout: float | None = None) -> None:
        sent.append(msg)
        send(msg, timeout)

    bus.send = record  # type: ignore[method-assign]
    return sent


def status(bridge: Bridge) -> dict[str, str]:
    """The values of the mstc/status message the bridge publishes now."""
    got: list[Any] = []
    publish = bridge.status_pub.publish
    bridge.status_pub.publish = got.append  # type: ignore[method-assign]
    try:
        bridge._publish_status()
    finally:
        bridge.status_pub.publish = publish  # type: ignore[method-assign]
    return {kv.key: kv.value for kv in got[0].status[0].values}


def decoded(frames: list[can.Message], name: str) -> list[dict[str, float]]:
    proto = Protocol(node=None)
    message = proto.message(name)
    out = []
    for m in frames:
        if m.arbitration_id == message.frame_id:
            signals = message.decode(bytes(m.data), decode_choices=False)
            out.append({k.removeprefix(f"{name}_"): float(v) for k, v in signals.items()})
    return out


# ------------------------------------------------------------- R2, R4 start


@pytest.mark.parametrize("value", [0.0, -1.0, math.nan])
def test_obstacle_timeout_must_be_positive_at_start_and_on_set(
    value: float, bridges: list[Bridge], sil_lib: Path
) -> None:
    """R2: 0, negative or NaN sent no obstacle ever again."""
    with pytest.raises(UsageError) as refused:
        bridges.append(make_bridge(sil_lib, obstacle_timeout=value))
    assert str(refused.value).startswith(f"obstacle_timeout {value!r}: a positive number")
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    result = bridge.set_parameters([Parameter("obstacle_timeout", value=value)])[0]
    assert not result.successful
    assert "obstacle_timeout" in result.reason and "positive" in result.reason
    assert bridge.get_parameter("obstacle_timeout").value == 1.0
    # Obstacles still reach the firmware.
    sent = sent_frames(bridge)
    robot = Robot(bridge)
    bridge._on_plan(straight_plan(10.0))
    bridge._on_obstacles(obstacles((1, 3.0, 0.0, 0.2, 0.0, 0.0)))
    robot.step()
    assert len(decoded(sent, "OBSTACLE")) == 1


@pytest.mark.parametrize(("rate", "source"), [(5.0, "odom"), (19.0, "timer"), (10.0, "none")])
def test_a_control_period_longer_than_the_filter_allows_is_refused_at_start(
    rate: float, source: str, bridges: list[Bridge], sil_lib: Path
) -> None:
    """R4: the "mstc" safety filter's guarantee needs a period of 50 ms at
    most (alpha dt <= 1 with alpha = 20/s); rate_hz below 20 is refused, as
    the scenario loader refuses sim.dt above 0.05 s."""
    with pytest.raises(UsageError) as refused:
        bridges.append(make_bridge(sil_lib, rate_hz=rate, step_source=source))
    assert str(refused.value).startswith(f"rate_hz {rate!r}: at least 20 Hz"), refused.value


# ----------------------------------------------------------------- R4 runtime


def test_odometry_later_than_the_filter_allows_halts_the_firmware(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R4 at run time: odometry at 5 Hz after a good start. The step at the
    late stamp does not run the controller over 200 ms: the firmware halts
    with reason 2 (odometry: its timeout, as on a lost bus), and the late
    step is counted."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    robot = armed_robot(bridge)
    for _ in range(5):
        assert robot.step() == HALT_NONE
    assert robot.step(gap_ns=10 * DT_NS) == HALT_ODOMETRY
    for _ in range(3):
        assert robot.step(gap_ns=10 * DT_NS) == HALT_ODOMETRY
    assert int(status(bridge)["late_steps"]) == 4


# ------------------------------------------------------------------------ R6


def test_odometry_stamped_ahead_of_the_clock_is_refused_and_counted(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R6: one odometry message stamped an hour ahead of the node's clock
    stopped every later step, silently. It is refused and counted; the steps
    go on."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    robot = armed_robot(bridge)
    ahead = bridge.get_clock().now().nanoseconds + HOUR_NS
    bridge._on_odom(odometry(robot.pose, ahead))
    for _ in range(10):
        assert robot.step() == HALT_NONE
    dropped = status(bridge)
    assert any("ahead of the clock" in k and v == "1" for k, v in dropped.items()), dropped


# ------------------------------------------------------------------------ R5


def test_a_reference_stream_that_stops_halts_the_firmware(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R5: with reference_source reference, the last sample was sent for
    ever; now for three periods (the firmware's staleness limit), so the
    firmware halts with reason 3 within six periods of the last sample."""
    bridge = make_bridge(sil_lib, reference_source="reference")
    bridges.append(bridge)
    robot = Robot(bridge)
    ref = Pose(1.0, 0.0, 0.0)

    def step_with_reference() -> int:
        nonlocal ref
        bridge._on_reference(reference(ref, robot.ns + DT_NS))
        ref = Pose(ref.x + 0.5 * DT, 0.0, 0.0)
        return robot.step()

    for _ in range(6):
        step_with_reference()
    assert robot.arm() == "ok"
    for _ in range(5):
        assert step_with_reference() == HALT_NONE
    halts = [robot.step() for _ in range(8)]
    assert HALT_REFERENCE in halts[:6], halts


def test_a_reference_stamped_ahead_of_the_clock_is_refused_and_counted(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R5: one PoseStamped stamped an hour ahead froze the reference for good
    (every later sample is older). It is refused and counted, and the stream
    goes on."""
    bridge = make_bridge(sil_lib, reference_source="reference")
    bridges.append(bridge)
    robot = Robot(bridge)
    ref = Pose(1.0, 0.0, 0.0)
    for _ in range(6):
        bridge._on_reference(reference(ref, robot.ns))
        robot.step()
    assert robot.arm() == "ok"
    ahead = bridge.get_clock().now().nanoseconds + HOUR_NS
    bridge._on_reference(reference(Pose(40.0, 0.0, 0.0), ahead))
    for _ in range(20):
        ref = Pose(ref.x + 0.5 * DT, 0.0, 0.0)
        bridge._on_reference(reference(ref, robot.ns + DT_NS))
        assert robot.step() == HALT_NONE
    sample = bridge.inputs.stream.sample
    assert sample is not None and sample.pose.x == pytest.approx(ref.x)
    dropped = status(bridge)
    assert any("ahead of the clock" in k and v == "1" for k, v in dropped.items()), dropped


# ------------------------------------------------------------------------ R3


def run_at(bridge: Bridge, obstacle: tuple[float, float, float], seconds: float) -> float:
    """Drive along the plan east for @p seconds with a static obstacle
    (x, y, radius) reported every step; the least clearance between the
    robot's disc and the obstacle's [m]."""
    robot = armed_robot(bridge)
    x, y, r = obstacle
    clearance = math.inf
    for _ in range(round(seconds / DT)):
        bridge._on_obstacles(obstacles((1, x, y, r, 0.0, 0.0)))
        robot.step()
        d = math.hypot(robot.pose.x - x, robot.pose.y - y) - r - robot.params.r_m
        clearance = min(clearance, d)
    return clearance


def test_an_obstacle_larger_than_the_frame_carries_is_avoided(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R3: a radius of 3.0 m (OBSTACLE carries up to 2.55 m) on the path
    was left out whole and the robot drove through it (clearance -3.0 m).
    It is sent as the largest radius at its nearest point to the robot, the
    robot keeps clear, and mstc/status counts it."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    sent = sent_frames(bridge)
    clearance = run_at(bridge, (6.0, 0.0, 3.0), 16.0)
    radii = {round(o["radius"] / 0.01) for o in decoded(sent, "OBSTACLE")}
    assert radii == {255}, radii  # raw: the 8-bit radius at its largest, 2.55 m
    print(f"\n3.0 m obstacle on the path: least clearance {clearance:.3f} m")
    assert clearance > 0.0, f"clearance {clearance:.3f} m"
    assert int(status(bridge)["obstacles_clamped"]) > 0


def test_an_obstacle_velocity_beyond_the_frame_keeps_its_position(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R3: an obstacle of 0.5 m reported with a velocity of 40 m/s
    (OBSTACLE_VEL carries ±32 m/s) was left out whole, position and all. Its
    OBSTACLE goes out, its velocity clamped to what the frame carries in
    the same direction, and mstc/status counts it."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    sent = sent_frames(bridge)
    robot = armed_robot(bridge)
    bridge._on_obstacles(obstacles((2, 3.0, 0.5, 0.5, -40.0, 0.0)))
    robot.step()
    assert [(o["id"], o["x"], o["y"]) for o in decoded(sent, "OBSTACLE")] == [(2, 3.0, 0.5)]
    vel = decoded(sent, "OBSTACLE_VEL")
    assert len(vel) == 1 and vel[0]["vx"] == -32.0 and vel[0]["vy"] == 0.0, vel
    assert int(status(bridge)["velocities_clamped"]) == 1


# --------------------------------------------------------------- R1 and R7


def test_a_firmware_parameter_refused_at_start_stops_the_bridge(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R1: D_s 0.6 against D_act 0.5 (D_s < D_act, ctl_params.toml) was
    shown as set while the firmware kept 0.35. The bridge does not start,
    and says why in the table's words."""
    with pytest.raises(MstcError) as refused:
        bridges.append(make_bridge(sil_lib, firmware_D_s=0.6))
    assert "D_s" in str(refused.value) and "D_act" in str(refused.value), refused.value
    assert "\n" not in str(refused.value)


def test_an_atomic_set_valid_only_together_reaches_the_firmware_whole(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R7: D_s 0.6 and D_act 0.7 hold together (D_s < D_act) but D_s 0.6 does
    not with the D_act in force: sent in the given order, the first was
    refused. The set is accepted, and the firmware holds both."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    result = bridge.set_parameters_atomically(
        [Parameter("firmware.D_s", value=0.6), Parameter("firmware.D_act", value=0.7)]
    )
    assert result.successful, result.reason
    assert firmware_value(bridge, "D_s") == pytest.approx(0.6)
    assert firmware_value(bridge, "D_act") == pytest.approx(0.7)


def test_an_atomic_set_the_table_refuses_sends_nothing(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R7, the issue's case: D_s 0.45 and D_act 0.4 together break D_s <
    D_act; D_s went out alone and stayed (firmware 0.45, node 0.35)."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    result = bridge.set_parameters_atomically(
        [Parameter("firmware.D_s", value=0.45), Parameter("firmware.D_act", value=0.4)]
    )
    assert not result.successful
    assert firmware_value(bridge, "D_s") == pytest.approx(0.35)
    assert firmware_value(bridge, "D_act") == pytest.approx(0.5)
    assert bridge.get_parameter("firmware.D_s").value == pytest.approx(0.35)


def test_an_atomic_set_whose_second_value_the_firmware_refuses_is_undone(
    bridges: list[Bridge], sil_lib: Path
) -> None:
    """R7: while armed, max_wheel_decel (accepted while armed) then D_s (a
    control-law parameter: refused, armed). The firmware ends with neither:
    max_wheel_decel back at 125."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    armed_robot(bridge)
    result = bridge.set_parameters_atomically(
        [Parameter("firmware.max_wheel_decel", value=200.0), Parameter("firmware.D_s", value=0.4)]
    )
    assert not result.successful
    assert "armed" in result.reason
    assert firmware_value(bridge, "max_wheel_decel") == pytest.approx(125.0)
    assert firmware_value(bridge, "D_s") == pytest.approx(0.35)


# ------------------------------------------------------------ joint_states


def test_joint_states_are_the_wheel_speed_frames_on_the_bus(
    bridges: list[Bridge], sil_lib: Path, tmp_path: Path
) -> None:
    """The firmware in process as an integrated board: its own wheel loop on
    two "dc" motors (attached to mstc-sil's firmware, driven by its commands)
    sends WHEEL_SPEED at every step. Every frame on the bus goes to a candump
    log (python-can's writer); ``joint_states``, received by a subscriber of
    its own, holds each WHEEL_SPEED of that log, in order, with the speeds
    cantools decodes from it (the DBC read here, not by the bridge), the
    joints' names and the step's stamp."""
    bridge = make_bridge(sil_lib)
    bridges.append(bridge)
    wheels = DcWheels(Library.open(sil_lib))
    bridge.bus.attach_wheels(wheels.loop.address)  # type: ignore[attr-defined]  # a SilBus
    log_path = tmp_path / "bus.log"
    log = can.Logger(str(log_path))
    bus = bridge.bus
    send, recv = bus.send, bus.recv

    def logged_send(msg: can.Message, timeout: float | None = None) -> None:
        send(msg, timeout)
        log(msg)

    def logged_recv(timeout: float | None = None) -> can.Message | None:
        msg = recv(timeout)
        if msg is not None:
            log(msg)
        return msg

    bus.send = logged_send  # type: ignore[method-assign]
    bus.recv = logged_recv  # type: ignore[method-assign]
    listener = rclpy.create_node(f"joint_states_listener_{next(_nodes)}")
    got: list[JointState] = []
    listener.create_subscription(
        JointState, f"/{bridge.get_namespace().strip('/')}/joint_states", got.append, 100
    )
    executor = SingleThreadedExecutor()
    executor.add_node(listener)
    try:
        for _ in range(100):  # discovery: the publisher sees the subscriber
            if bridge.joint_pub.get_subscription_count() > 0:
                break
            executor.spin_once(timeout_sec=0.1)
        assert bridge.joint_pub.get_subscription_count() > 0
        # 0.2 m left of the plan: the robot turns back to it, its wheels
        # at different speeds.
        robot = armed_robot(bridge, wheels=wheels, start=Pose(0.0, 0.2, 0.0))
        stamps = []
        for _ in range(50):
            assert robot.step() == HALT_NONE
            stamps.append(robot.ns)
            executor.spin_once(timeout_sec=0.0)
        for _ in range(50):  # what is still on its way
            executor.spin_once(timeout_sec=0.05)
    finally:
        log.stop()
        executor.shutdown()
        listener.destroy_node()
    db = cantools.database.load_file(str(DBC))
    message = db.get_message_by_name("WHEEL_SPEED")
    want = [
        message.decode(bytes(m.data))
        for m in can.LogReader(str(log_path))
        if m.arbitration_id == message.frame_id
    ]
    # One a step the firmware ran: the 6 before arming and the 50 after.
    assert len(want) == 56
    assert max(abs(w["WHEEL_SPEED_left"]) for w in want) > 5.0  # the wheels did turn
    assert max(abs(w["WHEEL_SPEED_left"] - w["WHEEL_SPEED_right"]) for w in want) > 1.0
    assert len(got) == len(want)
    for js, w in zip(got, want, strict=True):
        assert list(js.name) == ["left_wheel_joint", "right_wheel_joint"]
        assert list(js.velocity) == [w["WHEEL_SPEED_left"], w["WHEEL_SPEED_right"]]
        assert w["WHEEL_SPEED_faults"] == 0
    # Stamped with their step's time: the last 50 with the odometry stamps
    # that ran them.
    got_ns = [js.header.stamp.sec * 1_000_000_000 + js.header.stamp.nanosec for js in got]
    assert got_ns[-50:] == stamps
