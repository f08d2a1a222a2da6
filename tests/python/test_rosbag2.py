# SPDX-License-Identifier: MIT
"""``mstc export RUN_DIR --rosbag2 OUT`` (mstc.ros.bag): the paper-line run
of ``mstc sim`` written as a rosbag2 and read back with rosbags' reader,
each message deserialized with the type definition stored in the bag.

Expected values come from the run's own files, written by the simulation
(not by the exporter): trace.csv (poses, reference, body velocity, one row
per step), events.json (the events), bus.log (the frames, counted and
compared line by line), and from the scenario file (the sensor range,
wheel radius and track width).
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math
import shutil
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import cantools
import pytest
from rosbags.highlevel import AnyReader

from conftest import SCENARIOS
from logfiles import DBC
from mstc.can.protocol import wire_limits
from mstc.cli import main
from mstc.plant.scenario import load_scenario

SCENARIO = SCENARIOS / "paper-line.toml"
TYPES = {
    "/odom": "nav_msgs/msg/Odometry",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/reference": "geometry_msgs/msg/PoseStamped",
    "/reference/path": "nav_msgs/msg/Path",
    "/obstacles": "visualization_msgs/msg/MarkerArray",
    "/cmd_wheels": "sensor_msgs/msg/JointState",
    "/mstc/status": "diagnostic_msgs/msg/DiagnosticArray",
    "/mstc/events": "diagnostic_msgs/msg/DiagnosticArray",
    "/can/frames": "can_msgs/msg/Frame",
}
POSITION_LSB = 2.0**-16
"""ODOM_XY's and REF_XY's resolution [m] (docs/protocol.md)."""
HEADING_LSB = 2.0**-15
"""The coarser of ODOM_THETA's and REF_MOTION_theta's resolutions [rad]."""
WHEEL_LSB = 2.0**-10
"""WHEEL_CMD's resolution [rad/s]."""


RUN_BOUNDS: dict[str, int] = {}
"""The wall clock [ns since 1970] before and after the fixture's ``mstc sim``."""


@pytest.fixture(scope="module")
def run(sil_lib: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, str]:
    """A paper-line run folder, and its bag."""
    out = tmp_path_factory.mktemp("rosbag2")
    quiet = io.StringIO()
    with contextlib.redirect_stdout(quiet):
        RUN_BOUNDS["before"] = time.time_ns()
        rc = main(["sim", "--lib", str(sil_lib), "--out", str(out), "-q", str(SCENARIO)])
        RUN_BOUNDS["after"] = time.time_ns()
        assert rc == 0
        folder = out / "paper-line"
        bag = out / "bag"
        rc = main(["export", str(folder), "--rosbag2", str(bag), "-q"])
    assert rc == 0
    return folder, bag, quiet.getvalue()


def messages(bag: Path, topic: str) -> list[tuple[int, Any]]:
    """(record time, message) of every message on @p topic, deserialized
    with the definitions stored in the bag."""
    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:  # (rosbags reads every connection when given none)
            return []
        return [
            (t, reader.deserialize(raw, c.msgtype))
            for c, t, raw in reader.messages(connections=conns)
        ]


def started(folder: Path) -> int:
    """The run's start [ns since 1970], from its run.json: where the bag
    places the simulation's bus time 0."""
    return int(json.loads((folder / "run.json").read_text())["started_ns"])


def stamp_ns(header: Any) -> int:
    return int(header.stamp.sec) * 10**9 + int(header.stamp.nanosec)


def yaw(q: Any) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))


def wrapped(a: float) -> float:
    return math.remainder(a, math.tau)


def trace_rows(folder: Path) -> list[dict[str, str]]:
    with (folder / "trace.csv").open() as f:
        return list(csv.DictReader(f))


def test_topics_types_and_storage(run: tuple[Path, Path, str]) -> None:
    folder, bag, printed = run
    metadata = (bag / "metadata.yaml").read_text()
    assert "storage_identifier: mcap" in metadata
    with AnyReader([bag]) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == TYPES
        # The type definitions travel in the bag (rosbags needs no ROS to read it).
        assert reader.typestore.fielddefs["can_msgs/msg/Frame"]
    rows = len(trace_rows(folder))
    odom_line = next(line for line in printed.splitlines() if line.strip().startswith("/odom "))
    assert odom_line.split()[1] == f"{rows:,}"


def test_the_bag_starts_when_the_run_did(run: tuple[Path, Path, str]) -> None:
    """Issue 35: a simulation's bag started in 1970. Its bus time 0 is the
    run's start, which lies between the wall clock read before and after
    ``mstc sim``; metadata.yaml's starting_time is that, and what the
    command prints."""
    folder, bag, printed = run
    t0 = started(folder)
    assert RUN_BOUNDS["before"] <= t0 <= RUN_BOUNDS["after"]
    with AnyReader([bag]) as reader:
        assert reader.start_time == t0  # the first step's frames, at bus time 0
    iso = datetime.fromtimestamp(t0 / 1e9, UTC).isoformat(timespec="milliseconds")
    (line,) = (line for line in printed.splitlines() if line.startswith("export: "))
    assert line.endswith(f" from {iso.replace('+00:00', 'Z')}"), line


def test_a_log_moved_out_of_its_run_folder_counts_from_1970(
    run: tuple[Path, Path, str], tmp_path: Path
) -> None:
    """Without the run.json beside it, the log's own stamps are all there is."""
    folder, _, _ = run
    log = tmp_path / "moved.log"
    shutil.copy(folder / "bus.log", log)
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["export", str(log), "--rosbag2", str(tmp_path / "bag"), "-q"]) == 0
    with AnyReader([tmp_path / "bag"]) as reader:
        assert reader.start_time == 0


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("{", "cannot read the run's start"),
        ('{"started": "today"}', "cannot read the run's start"),
        ('{"started_ns": -5}', "started_ns: expected ns since 1970, got -5"),
        ('{"started_ns": 1.5e18}', "started_ns: expected ns since 1970, got 1.5e+18"),
    ],
)
def test_a_broken_run_json_is_named(
    run: tuple[Path, Path, str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    text: str,
    problem: str,
) -> None:
    folder, _, _ = run
    copy = tmp_path / "run"
    shutil.copytree(folder, copy)
    (copy / "run.json").write_text(text)
    capsys.readouterr()
    # exit 2: a log that cannot be used (mstc export --help)
    assert main(["export", str(copy), "--rosbag2", str(tmp_path / "bag"), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"error: {copy / 'run.json'}: {problem}" in err, err
    assert not (tmp_path / "bag").exists()


def test_odometry_reference_and_time_match_the_trace(run: tuple[Path, Path, str]) -> None:
    folder, bag, _ = run
    t0 = started(folder)
    rows = trace_rows(folder)
    odom = messages(bag, "/odom")
    refs = messages(bag, "/reference")
    tf = messages(bag, "/tf")
    assert len(odom) == len(refs) == len(tf) == len(rows)
    for row, (t, o), (_, r), (_, f) in zip(rows, odom, refs, tf, strict=True):
        # The SIL run's bus time is the simulation's: each step at its t.
        assert t == stamp_ns(o.header) == t0 + round(float(row["t"]) * 1e9)
        assert (o.header.frame_id, o.child_frame_id) == ("odom", "base_link")
        p = o.pose.pose
        # Odometry through ODOM_XY and ODOM_THETA: the trace's pose, rounded to the frame's LSB.
        assert abs(p.position.x - float(row["x"])) <= POSITION_LSB / 2 + 1e-12
        assert abs(p.position.y - float(row["y"])) <= POSITION_LSB / 2 + 1e-12
        assert abs(wrapped(yaw(p.orientation) - float(row["theta"]))) <= HEADING_LSB
        assert abs(o.twist.twist.linear.x - float(row["v"])) <= 1e-9
        assert abs(o.twist.twist.angular.z - float(row["w"])) <= 1e-9
        rp = r.pose
        assert abs(rp.position.x - float(row["x_r"])) <= POSITION_LSB / 2 + 1e-12
        assert abs(rp.position.y - float(row["y_r"])) <= POSITION_LSB / 2 + 1e-12
        assert abs(wrapped(yaw(rp.orientation) - float(row["theta_r"]))) <= HEADING_LSB
        (transform,) = f.transforms
        assert (transform.header.frame_id, transform.child_frame_id) == ("odom", "base_link")
        assert transform.transform.translation.x == p.position.x
    ((_, path),) = messages(bag, "/reference/path")
    assert len(path.poses) == len(rows)


def test_wheel_commands_give_the_traces_velocity(run: tuple[Path, Path, str]) -> None:
    """v = r (ω_R + ω_L)/2 and ω = r (ω_R − ω_L)/L of the JointState's
    speeds are the trace's v and ω."""
    folder, bag, _ = run
    params = load_scenario(SCENARIO, wire_limits()).params
    r, track = params.wheel_radius, params.track_width
    rows = trace_rows(folder)
    cmds = messages(bag, "/cmd_wheels")
    assert len(cmds) == len(rows)
    for row, (_, c) in zip(rows, cmds, strict=True):
        assert list(c.name) == ["left_wheel_joint", "right_wheel_joint"]
        left, right = c.velocity
        assert left / WHEEL_LSB == round(left / WHEEL_LSB)  # WHEEL_CMD's values
        assert abs(r * (left + right) / 2 - float(row["v"])) <= 1e-9
        assert abs(r * (right - left) / track - float(row["w"])) <= 1e-9


def test_events_match_events_json(run: tuple[Path, Path, str]) -> None:
    folder, bag, _ = run
    want = json.loads((folder / "events.json").read_text())["events"]
    got = messages(bag, "/mstc/events")
    t0 = started(folder)
    assert len(got) == len(want) == 6
    for w, (t, array) in zip(want, got, strict=True):
        (status,) = array.status
        values = {kv.key: kv.value for kv in status.values}
        assert values["kind"] == w["event"]
        assert int(values["obstacle"]) == w["obstacle"]
        assert values["side"] == w.get("side", "")
        assert float(values["t"]) == pytest.approx(w["t"], abs=1e-9)
        # Stamped at its step's time.
        assert t == stamp_ns(array.header) == t0 + round(w["t"] * 1e9)


def test_raw_frames_are_the_bus_log(run: tuple[Path, Path, str]) -> None:
    folder, bag, _ = run
    lines = (folder / "bus.log").read_text().split("\n")
    lines = [line for line in lines if line.strip()]
    frames = messages(bag, "/can/frames")
    t0 = started(folder)
    assert len(frames) == len(lines)
    # Frames in the log's order (the bag sorts by time; equal times keep it).
    for line, (t, f) in zip(lines, frames, strict=True):
        stamp, channel, frame = line.split()
        ident, data = frame.split("#")
        assert t == t0 + round(float(stamp.strip("()")) * 1e9)
        assert f.header.frame_id == channel
        assert f.id == int(ident, 16)
        assert not f.is_extended
        assert bytes(f.data[: f.dlc]) == bytes.fromhex(data)


def test_obstacles_are_those_the_sensor_saw(run: tuple[Path, Path, str]) -> None:
    """Each step's MarkerArray holds the obstacles within D_det of the
    robot, as the scenario's ideal sensor reports them, at their place."""
    folder, bag, _ = run
    scenario = load_scenario(SCENARIO, wire_limits())
    rows = trace_rows(folder)
    arrays = messages(bag, "/obstacles")
    assert len(arrays) == len(rows)
    for row, (_, array) in zip(rows, arrays, strict=True):
        assert array.markers[0].action == 3  # DELETEALL
        seen = {m.id: m for m in array.markers[1:]}
        x, y = float(row["x"]), float(row["y"])
        for i, o in enumerate(scenario.obstacles, start=1):
            d = math.hypot(o.x - x, o.y - y)
            if abs(d - scenario.params.d_det) < 1e-6:
                continue  # on the edge of the range
            assert (i in seen) == (d <= scenario.params.d_det), (row["t"], i, d)
            if i in seen:
                m = seen[i]
                assert m.type == 3  # CYLINDER
                assert abs(m.pose.position.x - o.x) <= 2**-13
                assert abs(m.scale.x - 2 * o.radius) <= 1e-9


@pytest.mark.parametrize(
    "actuator",
    [
        # drives that report what they measure (external drives: the plant
        # sends WHEEL_SPEED)
        "time_constant = 0.06\nmax_accel = 20.0\nencoder_counts = 1920\n",
        # the integrated board: the firmware's own wheel loop sends it
        'model = "dc"\n',
    ],
    ids=["lag", "dc"],
)
def test_measured_wheel_speeds_are_the_wheel_speed_frames(
    sil_lib: Path, tmp_path: Path, actuator: str
) -> None:
    """A run whose wheels are not ideal (an ``[actuator]``) carries
    WHEEL_SPEED frames; /joint_states holds each of them, at its bus time,
    with the speeds cantools decodes from bus.log's line (the DBC read here,
    not by the exporter); a run with ideal wheels has none (the fixture's)."""
    scenario = tmp_path / "wheels.toml"
    # The paper's line without its expected events (real wheels switch
    # later), with wheels of their own.
    text = SCENARIO.read_text()
    scenario.write_text(text[: text.index("[[expected]]")] + "\n[actuator]\n" + actuator)
    quiet = io.StringIO()
    with contextlib.redirect_stdout(quiet):
        rc = main(["sim", "--lib", str(sil_lib), "--out", str(tmp_path), "-q", str(scenario)])
        # The paper's strategy on lagging wheels may touch an obstacle (exit 4,
        # docs/strategy-wheels.md); the run's outputs are written either way.
        assert rc in (0, 4)
        rc = main(["export", str(tmp_path / "wheels"), "--rosbag2", str(tmp_path / "bag"), "-q"])
        assert rc == 0
    db = cantools.database.load_file(str(DBC))
    wheel_speed = db.get_message_by_name("WHEEL_SPEED")
    want = []
    t0 = started(tmp_path / "wheels")
    for line in (tmp_path / "wheels" / "bus.log").read_text().splitlines():
        stamp, _, frame = line.split()
        ident, data = frame.split("#")
        if int(ident, 16) == wheel_speed.frame_id:
            s = wheel_speed.decode(bytes.fromhex(data))
            t = t0 + round(float(stamp.strip("()")) * 1e9)
            want.append((t, s["WHEEL_SPEED_left"], s["WHEEL_SPEED_right"]))
    got = messages(tmp_path / "bag", "/joint_states")
    steps = len(trace_rows(tmp_path / "wheels"))
    assert steps - 1 <= len(want) <= steps  # one a step, after the first
    assert any(left != 0.0 for _, left, _ in want)
    assert len(got) == len(want)
    for (t, left, right), (t_bag, js) in zip(want, got, strict=True):
        assert t_bag == stamp_ns(js.header) == t
        assert list(js.name) == ["left_wheel_joint", "right_wheel_joint"]
        assert list(js.velocity) == [left, right]


def test_a_run_with_ideal_wheels_has_no_measured_speeds(run: tuple[Path, Path, str]) -> None:
    _, bag, _ = run
    assert messages(bag, "/joint_states") == []


def test_an_export_replaces_an_earlier_one_and_leaves_anything_else(
    run: tuple[Path, Path, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """One overwrite rule for both exports (issue 35: the MCAP export
    overwrote silently, the rosbag2 export refused): an earlier export at
    the path is replaced, anything else there is left alone (exit 1)."""
    folder, bag, _ = run
    copy = tmp_path / "bag"
    shutil.copytree(bag, copy)
    before = len(messages(copy, "/odom"))
    assert main(["export", str(folder), "--rosbag2", str(copy), "-q"]) == 0
    assert len(messages(copy, "/odom")) == before
    mcap = tmp_path / "run.mcap"
    for _ in range(2):
        assert main(["export", str(folder), "--mcap", str(mcap), "-q"]) == 0
    other = tmp_path / "notes.txt"
    other.write_text("mine\n")
    (tmp_path / "dir").mkdir()
    capsys.readouterr()
    assert main(["export", str(folder), "--mcap", str(other), "-q"]) == 1
    assert main(["export", str(folder), "--rosbag2", str(tmp_path / "dir"), "-q"]) == 1
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"error: {other} exists and is not an MCAP file: left alone",
        f"error: {tmp_path / 'dir'} exists and is not a rosbag2 folder: left alone",
    ]
    assert other.read_text() == "mine\n"


def test_the_bag_names_its_distribution(run: tuple[Path, Path, str]) -> None:
    """metadata.yaml names the ROS 2 distribution whose message definitions
    the bag holds (Kilted: rosbags' store ROS2_KILTED), not "rosbags"."""
    _, bag, _ = run
    meta = (bag / "metadata.yaml").read_text()
    assert "ros_distro: kilted" in meta, meta
