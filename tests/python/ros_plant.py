# SPDX-License-Identifier: MIT
"""A small rclpy node that plays the plant of a scenario over ROS 2, in
lock-step with the bridge (``mstc ros`` with step_source odom), for
tests/python/test_ros.py.

At sim time t_k it publishes what the robot's sensors would: the obstacles
its range sensor sees (visualization_msgs/MarkerArray: DELETEALL, then a
CYLINDER per obstacle, as a perception node does) and its odometry
(nav_msgs/Odometry, odom -> base_link), both stamped t_k; it waits for the
wheel command stamped t_k on cmd_wheels (sensor_msgs/JointState), moves the
robot with it for one period (the scenario's unicycle and integrator,
mstc.plant.plant) and goes on with t_(k+1). The reference is the scenario's
virtual robot as a path (nav_msgs/Path: its poses every period), published
once. It records its poses and the bridge's events (mstc/events).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry, Path
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool
from visualization_msgs.msg import Marker, MarkerArray

from mstc.model import Pose
from mstc.plant.scenario import Scenario
from mstc.plant.world import make_world

START_NS = 1_000_000_000
"""Sim time of the first sample [ns] (a stamp of 0 reads as 'unset' to some tools)."""
PLAN_MARGIN = 2.0
"""The plan reaches this much beyond the run's duration [s]."""


@dataclass(frozen=True)
class RosEvent:
    """An event of mstc/events: the stamp of its step and its values."""

    stamp_ns: int
    name: str
    message: str
    values: dict[str, str] = field(default_factory=dict)


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _set_stamp(header: Any, ns: int) -> None:
    header.stamp.sec, header.stamp.nanosec = divmod(ns, 1_000_000_000)


def _set_yaw(orientation: Any, theta: float) -> None:
    orientation.z, orientation.w = math.sin(theta / 2), math.cos(theta / 2)


class PlantNode(Node):
    """The plant of @p scenario, stepped by the bridge's wheel commands.

    :param max_idle_steps: steps the robot may stand waiting to be armed
        before the node gives up (``failed``).
    """

    def __init__(self, scenario: Scenario, max_idle_steps: int = 3000) -> None:
        super().__init__("mstc_test_plant")
        self.scenario = scenario
        world = make_world(scenario)
        self.plant = world.plant
        self.sensor = world.sensor
        self.reference = world.reference
        self.dt = scenario.sim.dt
        self.dt_ns = round(self.dt * 1e9)
        self.steps = scenario.sim.steps
        self.max_idle_steps = max_idle_steps
        self.k = 0
        self.running_at: int | None = None
        """Stamp of the first step the firmware ran armed [ns]."""
        self.poses: list[tuple[int, Pose]] = []
        """(stamp, pose) of every sample."""
        self.events: list[RosEvent] = []
        self.done = False
        self.failed = ""
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.odom_pub = self.create_publisher(Odometry, "odom", qos)
        self.obstacles_pub = self.create_publisher(MarkerArray, "obstacles", qos)
        self.plan_pub = self.create_publisher(Path, "plan", qos)
        self.create_subscription(JointState, "cmd_wheels", self._on_cmd, qos)
        self.create_subscription(
            DiagnosticArray, "mstc/events", self._on_events, QoSProfile(depth=100)
        )
        self.arm_client = self.create_client(SetBool, "/mstc_bridge/arm")

    @property
    def t_ns(self) -> int:
        return START_NS + self.k * self.dt_ns

    def plan(self) -> Path:
        """The scenario's reference robot as a path: its pose every period
        (forward Euler or exact, as the scenario integrates)."""
        msg = Path()
        msg.header.frame_id = "odom"
        _set_stamp(msg.header, START_NS)
        ref = self.reference
        n = round((self.scenario.sim.duration + PLAN_MARGIN) / self.dt)
        for _ in range(n + 1):
            ps = PoseStamped()
            ps.header.frame_id = "odom"
            ps.pose.position.x, ps.pose.position.y = ref.pose.x, ref.pose.y
            _set_yaw(ps.pose.orientation, ref.pose.theta)
            msg.poses.append(ps)
            ref.step(self.dt)
        return msg

    def publish_sample(self) -> None:
        """Obstacles seen and odometry at t_k."""
        t_ns = self.t_ns
        robot = self.plant.pose
        markers = MarkerArray()
        clear = Marker(action=Marker.DELETEALL)
        clear.header.frame_id = "odom"
        markers.markers.append(clear)
        t_run = (t_ns - self.running_at) / 1e9 if self.running_at is not None else 0.0
        for o in self.sensor.scan(robot, t_run):
            m = Marker(type=Marker.CYLINDER, action=Marker.ADD, id=o.id, ns="obstacles")
            m.header.frame_id = "odom"
            _set_stamp(m.header, t_ns)
            m.pose.position.x, m.pose.position.y = o.x, o.y
            m.pose.orientation.w = 1.0
            m.scale.x = m.scale.y = 2 * o.radius
            m.scale.z = 0.3
            markers.markers.append(m)
        self.obstacles_pub.publish(markers)
        odom = Odometry()
        odom.header.frame_id = "odom"
        odom.child_frame_id = "base_link"
        _set_stamp(odom.header, t_ns)
        odom.pose.pose.position.x, odom.pose.pose.position.y = robot.x, robot.y
        _set_yaw(odom.pose.pose.orientation, robot.theta)
        self.odom_pub.publish(odom)
        self.poses.append((t_ns, robot))

    def _on_cmd(self, msg: JointState) -> None:
        if self.done or _stamp_ns(msg.header.stamp) != self.t_ns:
            return  # not this sample's answer
        left, right = msg.velocity
        self.plant.step(left, right, self.dt)
        self.k += 1
        end = self.scenario.sim.duration * 1e9
        if self.running_at is not None and self.t_ns - self.running_at > end + self.dt_ns / 2:
            self.done = True
            return
        if self.running_at is None and self.k > self.max_idle_steps:
            self.failed = f"not armed after {self.k} steps"
            self.done = True
            return
        self.publish_sample()

    def _on_events(self, msg: DiagnosticArray) -> None:
        stamp = _stamp_ns(msg.header.stamp)
        for s in msg.status:
            values = {kv.key: kv.value for kv in s.values}
            self.events.append(RosEvent(stamp, s.name, s.message, values))
            if s.name == "mstc: bridge" and s.message == "running" and self.running_at is None:
                self.running_at = stamp
