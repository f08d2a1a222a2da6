# SPDX-License-Identifier: MIT
"""Export a decoded bus log to MCAP, the file format Foxglove and other
robotics tools open.

Every message is stamped with the log's time stamp of the frame it comes
from (for a control step: its WHEEL_CMD), in nanoseconds, as both its log
and publish time; a simulation's log, which counts from 0, is placed at its
run's start (the run.json beside it). Topics:

=====================  ========  ======================  =====================================
topic                  encoding  schema                  messages
=====================  ========  ======================  =====================================
``/can/<MESSAGE>``     json      ``mstc.can.<MESSAGE>``  every frame of that DBC message,
                                 (from the DBC)          decoded: each signal by its short
                                                         name, value-table entries by name
``/robot/pose``        protobuf  foxglove.PoseInFrame    the robot's pose at each step
``/reference/pose``    protobuf  foxglove.PoseInFrame    the reference's pose at each step
``/tf``                protobuf  foxglove.FrameTransform ``world`` to ``robot`` and to
                                                         ``reference`` at each step
``/robot/path``        protobuf  foxglove.PosesInFrame   once, at the first step: the whole path
``/reference/path``    protobuf  foxglove.PosesInFrame   the same for the reference
``/scene``             protobuf  foxglove.SceneUpdate    once: each obstacle (a cylinder) with
                                                         its D_s circle, and both paths as lines
``/events``            protobuf  foxglove.Log            each switching event
=====================  ========  ======================  =====================================

The paths are published whole at the start so that the 3D panel shows them
for the entire playback; the poses and transforms move along them. Frames
are exported as recorded (a frame with a bad CRC is exported too, with its
CRC and counter, which are signals like the others); frames whose identifier
is not in the DBC, or that cantools cannot decode, are counted and left out.
Steps whose pose is unknown (before the first odometry frame) have no pose.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from cantools.database.can import Database, Message, Signal
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.CylinderPrimitive_pb2 import CylinderPrimitive
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.message import Message as ProtoMessage
from google.protobuf.timestamp_pb2 import Timestamp
from mcap.writer import Writer
from mcap_protobuf.schema import register_schema

from mstc.can.dbc import short_name, signal_values
from mstc.errors import WriteError, writing
from mstc.logs.decode import DecodedLog

MCAP_MAGIC = b"\x89MCAP"
"""How an MCAP file starts: an earlier export, which an export replaces."""
WORLD = "odom"
"""The fixed frame every pose is in: REP 105's odom, as the ROS 2 bridge and
the rosbag2 export name it (their world_frame's default)."""
CHILD_FRAMES = {"robot": "base_link", "reference": "mstc_reference"}
"""The /tf child frame of each pose: REP 105's base_link for the robot, and
the bridge's reference_frame default for the reference."""
OBSTACLE_HEIGHT = 0.3
"""Height of the obstacles' cylinders in the 3D view [m] (the plant is planar)."""
CIRCLE_POINTS = 72
"""Points of each D_s circle."""
_ROBOT_COLOR = Color(r=0.12, g=0.47, b=0.71, a=1.0)
_REFERENCE_COLOR = Color(r=0.5, g=0.5, b=0.5, a=1.0)
_OBSTACLE_COLOR = Color(r=0.84, g=0.15, b=0.16, a=0.8)
_SAFE_COLOR = Color(r=0.84, g=0.15, b=0.16, a=0.5)


@dataclass
class ExportSummary:
    """What an export wrote."""

    path: Path
    messages: dict[str, int] = field(default_factory=dict)
    """Messages by topic."""
    start_ns: int = 0
    """Earliest log time [ns]."""
    end_ns: int = 0
    """Latest log time [ns]."""
    not_exported: dict[str, int] = field(default_factory=dict)
    """Frames left out, by reason."""

    @property
    def total(self) -> int:
        """Messages written."""
        return sum(self.messages.values())


def _stamp(ns: int) -> Timestamp:
    return Timestamp(seconds=ns // 1_000_000_000, nanos=ns % 1_000_000_000)


def _pose(x: float, y: float, theta: float) -> Pose:
    """A planar pose: at height 0, turned by @p theta about z."""
    return Pose(
        position=Vector3(x=x, y=y, z=0.0),
        orientation=Quaternion(x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2)),
    )


def _signal_schema(signal: Signal) -> dict[str, Any]:
    """The JSON schema of one decoded signal's value."""
    unit = f" [{signal.unit}]" if signal.unit else ""
    if signal.choices:
        names = ", ".join(f"{raw} {name}" for raw, name in signal.choices.items())
        return {
            "type": ["string", "integer"],
            "description": f"the value table's name ({names}), or the raw value outside it",
        }
    integer = not signal.is_float and float(signal.scale).is_integer()
    integer = integer and float(signal.offset).is_integer()
    return {"type": "integer" if integer else "number", "description": f"{signal.name}{unit}"}


def message_schema(message: Message) -> dict[str, Any]:
    """The JSON schema of a decoded frame of @p message, from the DBC."""
    return {
        "title": f"mstc.can.{message.name}",
        "description": f"{message.name} (0x{message.frame_id:03X}) of the mstc DBC, decoded",
        "type": "object",
        "properties": {short_name(message, s.name): _signal_schema(s) for s in message.signals},
    }


class _Mcap:
    """The writer, its schemas and channels by topic; messages are held and
    written in log-time order by :meth:`finish`, as readers expect."""

    def __init__(self, writer: Writer, summary: ExportSummary) -> None:
        self.writer = writer
        self.summary = summary
        self.channels: dict[str, int] = {}
        self.protobuf_schemas: dict[str, int] = {}
        self.pending: list[tuple[int, int, str, bytes]] = []
        """(log time, order of arrival, topic, data)."""

    def json_channel(self, topic: str, schema: dict[str, Any]) -> None:
        if topic not in self.channels:
            schema_id = self.writer.register_schema(
                name=schema["title"], encoding="jsonschema", data=json.dumps(schema).encode()
            )
            self.channels[topic] = self.writer.register_channel(topic, "json", schema_id)

    def add(self, topic: str, ns: int, data: bytes) -> None:
        self.pending.append((ns, len(self.pending), topic, data))

    def proto(self, topic: str, ns: int, message: ProtoMessage) -> None:
        if topic not in self.channels:
            name = message.DESCRIPTOR.full_name
            if name not in self.protobuf_schemas:
                self.protobuf_schemas[name] = register_schema(self.writer, type(message))
            schema_id = self.protobuf_schemas[name]
            self.channels[topic] = self.writer.register_channel(topic, "protobuf", schema_id)
        self.add(topic, ns, message.SerializeToString())

    def finish(self) -> None:
        counts = self.summary.messages
        for ns, _, topic, data in sorted(self.pending, key=lambda m: (m[0], m[1])):
            sequence = counts.get(topic, 0)
            self.writer.add_message(
                self.channels[topic], log_time=ns, data=data, publish_time=ns, sequence=sequence
            )
            counts[topic] = sequence + 1
        if self.pending:
            self.summary.start_ns = min(m[0] for m in self.pending)
            self.summary.end_ns = max(m[0] for m in self.pending)
        self.writer.finish()  # type: ignore[no-untyped-call]  # mcap's Writer.finish is unannotated


def _frames(
    decoded: DecodedLog, db: Database, left_out: Counter[str]
) -> Iterator[tuple[Message, int, dict[str, float | int | str]]]:
    """Every frame of the log that the DBC decodes: (message, log time [ns], signals)."""
    log = decoded.log
    messages = {m.frame_id: m for m in db.messages}
    for row in range(len(log)):
        message = None if log.extended[row] else messages.get(int(log.frame_id[row]))
        if message is None:
            left_out["identifier not in the DBC"] += 1
            continue
        data = log.data[row, : int(log.dlc[row])].tobytes()
        try:
            signals = signal_values(message, data, choices=True)
        except Exception:  # cantools raises several kinds on bad data
            left_out["not decodable"] += 1
            continue
        yield message, decoded.ns(float(log.time[row])), signals


def _circle(x: float, y: float, r: float) -> list[Point3]:
    return [
        Point3(
            x=x + r * math.cos(2 * math.pi * i / CIRCLE_POINTS),
            y=y + r * math.sin(2 * math.pi * i / CIRCLE_POINTS),
            z=0.0,
        )
        for i in range(CIRCLE_POINTS + 1)
    ]


def _line(points: Sequence[Point3 | Vector3], thickness: float, color: Color) -> LinePrimitive:
    """A line strip through @p points in the world frame, @p thickness pixels wide."""
    return LinePrimitive(
        type=LinePrimitive.LINE_STRIP,
        pose=Pose(orientation=Quaternion(w=1.0)),
        thickness=thickness,
        scale_invariant=True,
        points=[Point3(x=p.x, y=p.y, z=p.z) for p in points],
        color=color,
    )


def _scene(decoded: DecodedLog, ns: int, paths: dict[str, list[Pose]]) -> SceneUpdate:
    """Obstacles with their D_s circles, and the paths as line strips."""
    stamp = _stamp(ns)
    entities = []
    for o in decoded.obstacles:
        d_s = decoded.params.safe_distance(o.radius)
        entities.append(
            SceneEntity(
                timestamp=stamp,
                frame_id=WORLD,
                id=f"obstacle-{o.id}",
                cylinders=[
                    CylinderPrimitive(
                        pose=Pose(
                            position=Vector3(x=o.x, y=o.y, z=OBSTACLE_HEIGHT / 2),
                            orientation=Quaternion(w=1.0),
                        ),
                        size=Vector3(x=2 * o.radius, y=2 * o.radius, z=OBSTACLE_HEIGHT),
                        bottom_scale=1.0,
                        top_scale=1.0,
                        color=_OBSTACLE_COLOR,
                    )
                ],
                lines=[_line(_circle(o.x, o.y, d_s), 2.0, _SAFE_COLOR)],
            )
        )
    for name, color in (("robot", _ROBOT_COLOR), ("reference", _REFERENCE_COLOR)):
        entities.append(
            SceneEntity(
                timestamp=stamp,
                frame_id=WORLD,
                id=f"{name}-path",
                lines=[_line([p.position for p in paths[name]], 3.0, color)],
            )
        )
    return SceneUpdate(entities=entities)


def export_mcap(decoded: DecodedLog, db: Database, out: Path) -> ExportSummary:
    """Write @p decoded (and its log's frames, decoded with @p db) to @p out.

    :raises WriteError: @p out cannot be written, or exists and is not an
        MCAP file (an earlier export there is replaced).
    """
    summary = ExportSummary(out)
    left_out: Counter[str] = Counter()
    with writing(str(out)):
        if out.is_dir() or (out.is_file() and out.open("rb").read(len(MCAP_MAGIC)) != MCAP_MAGIC):
            raise WriteError(f"{out} exists and is not an MCAP file: left alone")
        out.parent.mkdir(parents=True, exist_ok=True)
        with out.open("wb") as stream:
            writer = Writer(stream)
            writer.start(profile="", library="mstc export")
            mcap = _Mcap(writer, summary)

            for message, ns, signals in _frames(decoded, db, left_out):
                topic = f"/can/{message.name}"
                mcap.json_channel(topic, message_schema(message))
                mcap.add(topic, ns, json.dumps(signals).encode())

            trace = decoded.trace
            columns = {
                "robot": (trace["x"], trace["y"], trace["theta"]),
                "reference": (trace["x_r"], trace["y_r"], trace["theta_r"]),
            }
            known = np.ones(len(decoded.stamps), dtype=bool)
            for xs, ys, thetas in columns.values():
                known &= np.isfinite(xs) & np.isfinite(ys) & np.isfinite(thetas)
            steps = np.flatnonzero(known)
            stamps = [decoded.ns(float(decoded.stamps[k])) for k in steps]
            paths: dict[str, list[Pose]] = {}
            for name, (xs, ys, thetas) in columns.items():
                paths[name] = [_pose(float(xs[k]), float(ys[k]), float(thetas[k])) for k in steps]
            left_out["steps without a pose"] = len(known) - len(steps)

            if len(steps):
                first = stamps[0]
                for name, poses in paths.items():
                    mcap.proto(
                        f"/{name}/path",
                        first,
                        PosesInFrame(timestamp=_stamp(first), frame_id=WORLD, poses=poses),
                    )
                mcap.proto("/scene", first, _scene(decoded, first, paths))
            for i, ns in enumerate(stamps):
                for name, poses in paths.items():
                    pose = poses[i]
                    mcap.proto(
                        f"/{name}/pose",
                        ns,
                        PoseInFrame(timestamp=_stamp(ns), frame_id=WORLD, pose=pose),
                    )
                    mcap.proto(
                        "/tf",
                        ns,
                        FrameTransform(
                            timestamp=_stamp(ns),
                            parent_frame_id=WORLD,
                            child_frame_id=CHILD_FRAMES[name],
                            translation=pose.position,
                            rotation=pose.orientation,
                        ),
                    )

            # An event is stamped like the step that emitted it (the first step
            # at or after its time, for a log cut short).
            step_us = np.round(trace["t"] * 1e6)
            for event in decoded.events:
                k = min(int(np.searchsorted(step_us, event.t_us)), len(step_us) - 1)
                ns = decoded.ns(float(decoded.stamps[k]))
                side = f" {event.side}" if event.side else ""
                text = f"{event.kind} O{event.obstacle}{side} at t = {event.t:.6g} s"
                log = Log(timestamp=_stamp(ns), level=Log.INFO, message=text, name="mstc")
                mcap.proto("/events", ns, log)
            mcap.finish()
        summary.not_exported = {k: v for k, v in left_out.items() if v}
    return summary


def format_summary(summary: ExportSummary, source: Path) -> str:
    """What ``mstc export`` prints."""
    span = (summary.end_ns - summary.start_ns) / 1e9
    start = datetime.fromtimestamp(summary.start_ns / 1e9, UTC).isoformat(timespec="milliseconds")
    lines = [
        f"export: {source} -> {summary.path}: {summary.total:,} messages on "
        f"{len(summary.messages)} topics, {span:g} s from {start.replace('+00:00', 'Z')}"
    ]
    width = max((len(t) for t in summary.messages), default=0)
    for topic, n in sorted(summary.messages.items()):
        lines.append(f"  {topic:<{width}}  {n:>8,}")
    for reason, n in summary.not_exported.items():
        lines.append(f"  not exported: {n:,} ({reason})")
    return "\n".join(lines)
