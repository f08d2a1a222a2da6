# SPDX-License-Identifier: MIT
"""Export a decoded bus log as a rosbag2 (MCAP storage), the ROS 2 tools'
format (``ros2 bag play``, rviz2, rqt, Foxglove), with rosbags: no ROS
installation needed.

Standard message types only, in REP-105 frames (``odom``, ``base_link``),
each message stamped (header and record time) with the bus time stamp of the
frame it comes from (a simulation's, which count from 0, placed at its run's
start: :attr:`mstc.logs.decode.DecodedLog.epoch_ns`); for what a control
step gives, that step's WHEEL_CMD:

=====================  ================================  =======================================
topic                  type                              messages
=====================  ================================  =======================================
``/odom``              nav_msgs/msg/Odometry             each step: the odometry the firmware
                                                         used; twist: the body velocity of the
                                                         step's wheel command
``/tf``                tf2_msgs/msg/TFMessage            each step: odom → base_link
``/reference``         geometry_msgs/msg/PoseStamped     each step: the reference
``/reference/path``    nav_msgs/msg/Path                 once, at the first step: the whole
                                                         reference path (transient local)
``/obstacles``         visualization_msgs/msg/MarkerArray each step: DELETEALL, then a CYLINDER
                                                         per obstacle the step was sent (its id
                                                         the obstacle's) and an ARROW of its
                                                         velocity (1 s) for a moving one: the
                                                         bridge's own input format
``/cmd_wheels``        sensor_msgs/msg/JointState        each step: the wheel speed commands
``/joint_states``      sensor_msgs/msg/JointState        each WHEEL_SPEED frame: the speeds the
                                                         wheels measured, as the bridge
                                                         publishes them (runs with an
                                                         ``[actuator]`` only: the ideal wheels
                                                         send none)
``/mstc/status``       diagnostic_msgs/msg/               each step: every STATUS and STATUS_TRK
                       DiagnosticArray                   signal, mode and halt as names
``/mstc/events``       diagnostic_msgs/msg/               each switching event, at its step
                       DiagnosticArray
``/can/frames``        can_msgs/msg/Frame                every frame of the log, raw
=====================  ================================  =======================================

can_msgs/msg/Frame is ros_canopen's (ROS 2 branches; ros2_socketcan uses it
too), registered in the typestore from its .msg definition, since rosbags
ships only the standard distribution's types.
"""

from __future__ import annotations

import math
import shutil
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from cantools.database.can import Database
from rosbags.interfaces import (
    Nodetype,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from mstc.can.dbc import numeric_values
from mstc.errors import WriteError, writing
from mstc.logs.decode import DecodedLog
from mstc.logs.export import OBSTACLE_HEIGHT, ExportSummary
from mstc.ros import diagnostics
from mstc.ros.parameters import PARAMETERS

CAN_FRAME_TYPE = "can_msgs/msg/Frame"
CAN_FRAME_MSG = """\
std_msgs/Header header
uint32 id
bool is_rtr
bool is_extended
bool is_error
uint8 dlc
uint8[8] data
"""
"""can_msgs/msg/Frame (ros-industrial/ros_canopen, BSD; ROS 2 branches)."""
STORE = Stores.ROS2_KILTED
DISTRO = "kilted"
"""The ROS 2 distribution of STORE, named in the bag's metadata.yaml."""
"""The type definitions written into the bag (Kilted's; the standard
messages used here are the same from Humble on)."""
WORLD = str(PARAMETERS["world_frame"][0])
"""The frame of odometry, reference and obstacles: the bridge's default (odom)."""
BASE = str(PARAMETERS["base_frame"][0])
"""The robot's frame: the bridge's default (base_link)."""
JOINTS = (str(PARAMETERS["left_wheel_joint"][0]), str(PARAMETERS["right_wheel_joint"][0]))
"""The wheels' JointState names: the bridge's defaults."""

_NUMPY = {
    "bool": np.bool_,
    "byte": np.uint8,
    "char": np.uint8,
    "octet": np.uint8,
    "uint8": np.uint8,
    "int8": np.int8,
    "uint16": np.uint16,
    "int16": np.int16,
    "uint32": np.uint32,
    "int32": np.int32,
    "uint64": np.uint64,
    "int64": np.int64,
    "float32": np.float32,
    "float64": np.float64,
}


def typestore() -> Typestore:
    """Kilted's types with can_msgs/msg/Frame."""
    store = get_typestore(STORE)
    store.register(get_types_from_msg(CAN_FRAME_MSG, CAN_FRAME_TYPE))
    return store


class _Messages:
    """Builds messages of a typestore, every field not given at its default
    (zero, empty), as rclpy's constructors do."""

    def __init__(self, store: Typestore) -> None:
        self.store = store

    def _default(self, node: tuple[Any, Any]) -> Any:
        kind, detail = node
        if kind == Nodetype.BASE:
            name = detail[0]
            if name == "string":
                return ""
            if name == "bool":
                return False
            return 0.0 if name.startswith("float") else 0
        if kind == Nodetype.NAME:
            return self.make(detail)
        sub, length = detail
        if kind == Nodetype.ARRAY:
            if sub[0] == Nodetype.BASE and sub[1][0] in _NUMPY:
                return np.zeros(length, dtype=_NUMPY[sub[1][0]])
            return [self._default(sub) for _ in range(length)]
        if sub[0] == Nodetype.BASE and sub[1][0] in _NUMPY:
            return np.zeros(0, dtype=_NUMPY[sub[1][0]])
        return []

    def make(self, msgtype: str, **values: Any) -> Any:
        _, fields = self.store.fielddefs[msgtype]
        args = {
            name: values[name] if name in values else self._default(node) for name, node in fields
        }
        unknown = set(values) - set(args)
        if unknown:
            raise KeyError(f"{msgtype} has no field {sorted(unknown)}")
        return self.store.types[msgtype](**args)

    def header(self, ns: int, frame_id: str) -> Any:
        stamp = self.make("builtin_interfaces/msg/Time", sec=ns // 10**9, nanosec=ns % 10**9)
        return self.make("std_msgs/msg/Header", stamp=stamp, frame_id=frame_id)

    def pose(self, x: float, y: float, theta: float, z: float = 0.0) -> Any:
        return self.make(
            "geometry_msgs/msg/Pose",
            position=self.make("geometry_msgs/msg/Point", x=x, y=y, z=z),
            orientation=self.make(
                "geometry_msgs/msg/Quaternion", z=math.sin(theta / 2), w=math.cos(theta / 2)
            ),
        )

    def vector(self, x: float, y: float, z: float = 0.0) -> Any:
        return self.make("geometry_msgs/msg/Vector3", x=x, y=y, z=z)

    def kv(self, key: str, value: object) -> Any:
        return self.make("diagnostic_msgs/msg/KeyValue", key=key, value=str(value))


_LATCHED = [
    # rosbag2 plays a transient-local topic back as such (a latched path).
    Qos(
        history=QosHistory.KEEP_LAST,
        depth=1,
        reliability=QosReliability.RELIABLE,
        durability=QosDurability.TRANSIENT_LOCAL,
        deadline=QosTime(sec=0x7FFFFFFF, nsec=0xFFFFFFFF),
        lifespan=QosTime(sec=0x7FFFFFFF, nsec=0xFFFFFFFF),
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=QosTime(sec=0x7FFFFFFF, nsec=0xFFFFFFFF),
        avoid_ros_namespace_conventions=False,
    )
]
"""The offered QoS of a latched topic (forever: the largest duration)."""


class _Bag:
    """Messages by topic, held, then written in time order."""

    def __init__(self, store: Typestore) -> None:
        self.store = store
        self.types: dict[str, str] = {}
        """Message type of each topic, in the order they came."""
        self.latched: set[str] = set()
        self.pending: list[tuple[int, int, str, Any]] = []

    def add(self, topic: str, ns: int, msg: Any, *, latched: bool = False) -> None:
        self.types.setdefault(topic, msg.__msgtype__)
        if latched:
            self.latched.add(topic)
        self.pending.append((ns, len(self.pending), topic, msg))

    def write(self, out: Path, summary: ExportSummary) -> None:
        """Write the bag folder @p out; count its messages into @p summary.

        :raises WriteError: @p out cannot be written, or exists and is not a
            rosbag2 folder (an earlier bag there is replaced).
        """
        with writing(str(out)):
            out.parent.mkdir(parents=True, exist_ok=True)
            replace_bag(out)
            try:
                writer = Writer(
                    out, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP
                )
                writer.open()
            except WriterError as exc:
                raise WriteError(f"cannot write {out}: {exc}") from exc
            connections = {
                topic: writer.add_connection(
                    topic,
                    msgtype,
                    typestore=self.store,
                    offered_qos_profiles=_LATCHED if topic in self.latched else [],
                )
                for topic, msgtype in self.types.items()
            }
            counts: Counter[str] = Counter()
            for ns, _, topic, msg in sorted(self.pending, key=lambda m: (m[0], m[1])):
                data = self.store.serialize_cdr(msg, msg.__msgtype__)
                writer.write(connections[topic], ns, data)
                counts[topic] += 1
            writer.close()
            # The distribution whose definitions the bag holds, which rosbags
            # leaves as its own name ("rosbags"): ros2 bag info shows it.
            meta = out / "metadata.yaml"
            text = meta.read_text().replace("ros_distro: rosbags", f"ros_distro: {DISTRO}")
            meta.write_text(text)
        summary.messages = dict(counts)
        if self.pending:
            summary.start_ns = min(m[0] for m in self.pending)
            summary.end_ns = max(m[0] for m in self.pending)


def replace_bag(out: Path) -> None:
    """Remove the bag an earlier export wrote at @p out, so that an export
    replaces it, as the MCAP export replaces its file and `mstc sim` its
    run (rosbag2's writer refuses a folder that exists).

    :raises WriteError: @p out exists and is not a rosbag2 folder (no
        metadata.yaml): left alone.
    """
    if not out.exists() and not out.is_symlink():
        return
    if out.is_symlink() or not (out / "metadata.yaml").is_file():
        raise WriteError(f"{out} exists and is not a rosbag2 folder: left alone")
    shutil.rmtree(out)


def _obstacle_reports(decoded: DecodedLog, db: Database) -> dict[int, list[tuple[int, ...]]]:
    """The OBSTACLE (and OBSTACLE_VEL) frames of each step, by the log row of
    its WHEEL_CMD: (id, x, y, radius, vx, vy) for each, as the firmware got them."""
    log = decoded.log
    ids = {m.name: m for m in db.messages}
    obstacle, velocity, wheel = ids["OBSTACLE"], ids["OBSTACLE_VEL"], ids["WHEEL_CMD"]
    reports: dict[int, list[tuple[Any, ...]]] = {}
    pending: dict[int, list[float]] = {}
    for row in range(len(log)):
        if log.extended[row]:
            continue
        fid = int(log.frame_id[row])
        if fid not in (obstacle.frame_id, velocity.frame_id, wheel.frame_id):
            continue
        if fid == wheel.frame_id:
            reports[row] = [tuple(v) for v in pending.values()]
            pending = {}
            continue
        message = obstacle if fid == obstacle.frame_id else velocity
        try:
            s = numeric_values(message, log.data[row, : int(log.dlc[row])].tobytes())
        except Exception:  # cantools raises several kinds on bad data
            continue
        if message is obstacle:
            pending[int(s["id"])] = [int(s["id"]), s["x"], s["y"], s["radius"], 0.0, 0.0]
        elif int(s["id"]) in pending:
            pending[int(s["id"])][4:6] = [s["vx"], s["vy"]]
    return reports


def _measured_speeds(decoded: DecodedLog, db: Database) -> list[tuple[int, float, float]]:
    """(bus time [ns], left, right [rad/s]) of each WHEEL_SPEED frame of the
    log that decodes (a frame cantools cannot read is left out, as
    :func:`_obstacle_reports` does)."""
    log = decoded.log
    message = db.get_message_by_name("WHEEL_SPEED")
    speeds = []
    for row in np.flatnonzero((log.frame_id == message.frame_id) & ~log.extended):
        try:
            s = numeric_values(message, log.data[row, : int(log.dlc[row])].tobytes())
        except Exception:  # cantools raises several kinds on bad data
            continue
        speeds.append((decoded.ns(float(log.time[row])), float(s["left"]), float(s["right"])))
    return speeds


def export_rosbag2(decoded: DecodedLog, db: Database, out: Path) -> ExportSummary:
    """Write @p decoded (and its log's raw frames) as a rosbag2 folder @p out.

    :raises WriteError: @p out cannot be written, or exists and is not a
        rosbag2 folder (an earlier bag there is replaced).
    """
    store = typestore()
    m = _Messages(store)
    summary = ExportSummary(out)
    bag = _Bag(store)
    log = decoded.log

    for row in range(len(log)):
        n = int(log.dlc[row])
        data = np.zeros(8, dtype=np.uint8)
        data[:n] = log.data[row, :n]
        ns = decoded.ns(float(log.time[row]))
        frame = m.make(
            CAN_FRAME_TYPE,
            header=m.header(ns, log.channel[row]),
            id=int(log.frame_id[row]),
            is_extended=bool(log.extended[row]),
            dlc=n,
            data=data,
        )
        bag.add("/can/frames", ns, frame)

    trace = decoded.trace
    stamps = [decoded.ns(float(s)) for s in decoded.stamps]
    columns = [decoded.status_columns.index(c) for c in ("wheel_left", "wheel_right")]
    trace_wheels = np.array([[row[i] for i in columns] for row in decoded.status_rows], dtype=float)
    path_poses = []
    for k, ns in enumerate(stamps):
        x, y, th = (float(trace[c][k]) for c in ("x", "y", "theta"))
        xr, yr, thr = (float(trace[c][k]) for c in ("x_r", "y_r", "theta_r"))
        if all(map(math.isfinite, (x, y, th))):
            odom = m.make(
                "nav_msgs/msg/Odometry",
                header=m.header(ns, WORLD),
                child_frame_id=BASE,
                pose=m.make("geometry_msgs/msg/PoseWithCovariance", pose=m.pose(x, y, th)),
                twist=m.make(
                    "geometry_msgs/msg/TwistWithCovariance",
                    twist=m.make(
                        "geometry_msgs/msg/Twist",
                        linear=m.vector(float(trace["v"][k]), 0.0),
                        angular=m.vector(0.0, 0.0, float(trace["w"][k])),
                    ),
                ),
            )
            bag.add("/odom", ns, odom)
            transform = m.make(
                "geometry_msgs/msg/TransformStamped",
                header=m.header(ns, WORLD),
                child_frame_id=BASE,
                transform=m.make(
                    "geometry_msgs/msg/Transform",
                    translation=m.vector(x, y),
                    rotation=m.pose(x, y, th).orientation,
                ),
            )
            bag.add("/tf", ns, m.make("tf2_msgs/msg/TFMessage", transforms=[transform]))
        if all(map(math.isfinite, (xr, yr, thr))):
            ref = m.make(
                "geometry_msgs/msg/PoseStamped",
                header=m.header(ns, WORLD),
                pose=m.pose(xr, yr, thr),
            )
            bag.add("/reference", ns, ref)
            path_poses.append(ref)
        wheels = [float(trace_wheels[k, 0]), float(trace_wheels[k, 1])]
        cmd = m.make(
            "sensor_msgs/msg/JointState",
            header=m.header(ns, BASE),
            name=list(JOINTS),
            velocity=np.array(wheels, dtype=np.float64),
        )
        bag.add("/cmd_wheels", ns, cmd)
        bag.add("/mstc/status", ns, _status(m, decoded, k, ns))
    if path_poses:
        first = decoded.ns(float(decoded.stamps[0]))
        path = m.make("nav_msgs/msg/Path", header=m.header(first, WORLD), poses=path_poses)
        bag.add("/reference/path", first, path, latched=True)

    for ns, left, right in _measured_speeds(decoded, db):
        measured = m.make(
            "sensor_msgs/msg/JointState",
            header=m.header(ns, BASE),
            name=list(JOINTS),
            velocity=np.array([left, right], dtype=np.float64),
        )
        bag.add("/joint_states", ns, measured)

    reports = _obstacle_reports(decoded, db)
    for row, obstacles in sorted(reports.items()):
        ns = decoded.ns(float(log.time[row]))
        markers = [m.make("visualization_msgs/msg/Marker", header=m.header(ns, WORLD), action=3)]
        for oid, x, y, r, vx, vy in obstacles:
            markers.append(
                m.make(
                    "visualization_msgs/msg/Marker",
                    header=m.header(ns, WORLD),
                    ns="obstacles",
                    id=int(oid),
                    type=3,  # CYLINDER
                    action=0,  # ADD
                    pose=m.pose(x, y, 0.0, OBSTACLE_HEIGHT / 2),
                    scale=m.vector(2 * r, 2 * r, OBSTACLE_HEIGHT),
                    color=m.make("std_msgs/msg/ColorRGBA", r=0.84, g=0.15, b=0.16, a=0.8),
                )
            )
            if vx or vy:
                points = [
                    m.make("geometry_msgs/msg/Point", x=x, y=y),
                    m.make("geometry_msgs/msg/Point", x=x + vx, y=y + vy),
                ]
                markers.append(
                    m.make(
                        "visualization_msgs/msg/Marker",
                        header=m.header(ns, WORLD),
                        ns="obstacles/velocity",
                        id=int(oid),
                        type=0,  # ARROW
                        action=0,
                        points=points,
                        scale=m.vector(0.03, 0.06, 0.0),
                        color=m.make("std_msgs/msg/ColorRGBA", r=0.84, g=0.15, b=0.16, a=1.0),
                    )
                )
        bag.add("/obstacles", ns, m.make("visualization_msgs/msg/MarkerArray", markers=markers))

    # An event is stamped like the step that emitted it (as mstc export --mcap).
    step_us = np.round(trace["t"] * 1e6)
    for event in decoded.events:
        k = min(int(np.searchsorted(step_us, event.t_us)), len(step_us) - 1)
        ns = stamps[k]
        message, values = diagnostics.event_status(event)
        status = m.make(
            "diagnostic_msgs/msg/DiagnosticStatus",
            level=diagnostics.OK,
            name=diagnostics.EVENT,
            message=message,
            hardware_id=log.channel[0] if log.channel else "",
            values=[m.kv(k, v) for k, v in values],
        )
        array = m.make(
            "diagnostic_msgs/msg/DiagnosticArray", header=m.header(ns, BASE), status=[status]
        )
        bag.add("/mstc/events", ns, array)
    bag.write(out, summary)
    return summary


def _status(m: _Messages, decoded: DecodedLog, k: int, ns: int) -> Any:
    """One step's STATUS and STATUS_TRK as a DiagnosticArray, its level and
    message as the bridge's (:func:`mstc.ros.diagnostics.controller_level`);
    STALE for a step before the first STATUS."""
    row = decoded.status_rows[k]
    values = dict(zip(decoded.status_columns, row, strict=True))
    halt = str(values.get("halt", ""))
    level, message = diagnostics.STALE, "no STATUS yet"
    if halt:
        level, message = diagnostics.controller_level(str(decoded.trace.mode[k]), halt)
    skip = {"t", "step"}
    status = m.make(
        "diagnostic_msgs/msg/DiagnosticStatus",
        level=level,
        name=diagnostics.CONTROLLER,
        message=message,
        hardware_id=decoded.log.channel[0] if decoded.log.channel else "",
        values=[m.kv(c, v) for c, v in values.items() if c not in skip],
    )
    return m.make("diagnostic_msgs/msg/DiagnosticArray", header=m.header(ns, BASE), status=[status])
