# SPDX-License-Identifier: MIT
"""``mstc export --mcap`` (mstc.logs.export): the committed paper-line log
written to MCAP and read back with the mcap reader, the protobuf messages
decoded from the schemas stored in the file.

Expected values come from the log's text (frames counted by identifier,
times of its first and last lines), from cantools decoding its lines
directly, and from the scenario file (obstacle positions, the paper's event
times)."""

from __future__ import annotations

import contextlib
import io
import json
import math
import shutil
import tomllib
from collections import Counter
from pathlib import Path
from typing import Any

import cantools
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from conftest import SCENARIOS
from logfiles import DATA, DBC, log_lines, split
from mstc.cli import main

LOG = DATA / "paper-line.log"
PROTOBUF_TOPICS = {
    "/robot/pose": "foxglove.PoseInFrame",
    "/reference/pose": "foxglove.PoseInFrame",
    "/robot/path": "foxglove.PosesInFrame",
    "/reference/path": "foxglove.PosesInFrame",
    "/tf": "foxglove.FrameTransform",
    "/scene": "foxglove.SceneUpdate",
    "/events": "foxglove.Log",
}


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp("export") / "paper-line.mcap"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        rc = main(["export", str(LOG), "--mcap", str(out), "--quiet"])
    assert rc == 0
    return out, printed.getvalue()


def summary_of(path: Path) -> Any:
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    return summary


def decoded(path: Path, topic: str) -> list[tuple[int, Any]]:
    """(log time, message) of each protobuf message on @p topic, decoded with
    the schema stored in the file."""
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [(m.log_time, d) for _, _, m, d in reader.iter_decoded_messages(topics=[topic])]


def test_channels_schemas_and_counts_match_the_log(exported: tuple[Path, str]) -> None:
    path, _ = exported
    db = cantools.database.load_file(DBC)
    lines = log_lines("paper-line")
    by_id = Counter(split(line)[1] for line in lines)
    summary = summary_of(path)
    channels = {c.topic: c for c in summary.channels.values()}
    counts = {
        summary.channels[cid].topic: n
        for cid, n in summary.statistics.channel_message_counts.items()
    }
    # Every DBC message in the log: one JSON channel, one message per frame.
    for frame_id, n in by_id.items():
        name = db.get_message_by_frame_id(frame_id).name
        channel = channels[f"/can/{name}"]
        schema = summary.schemas[channel.schema_id]
        assert (channel.message_encoding, schema.encoding) == ("json", "jsonschema")
        assert schema.name == f"mstc.can.{name}"
        assert counts[f"/can/{name}"] == n, name
    for topic, schema_name in PROTOBUF_TOPICS.items():
        channel = channels[topic]
        assert channel.message_encoding == "protobuf"
        assert summary.schemas[channel.schema_id].name == schema_name
    assert set(channels) == {f"/can/{db.get_message_by_frame_id(i).name}" for i in by_id} | set(
        PROTOBUF_TOPICS
    )
    steps = by_id[0x180]  # one control step per WHEEL_CMD
    assert counts["/robot/pose"] == counts["/reference/pose"] == steps
    assert counts["/tf"] == 2 * steps
    assert counts["/robot/path"] == counts["/reference/path"] == counts["/scene"] == 1
    assert summary.statistics.message_count == sum(counts.values())
    # The time range is the log's, in nanoseconds.
    first, last = split(lines[0])[0], split(lines[-1])[0]
    assert summary.statistics.message_start_time == round(first * 1e9)
    assert summary.statistics.message_end_time == round(last * 1e9)


def test_a_pose_is_the_odometry_the_step_used(exported: tuple[Path, str]) -> None:
    path, _ = exported
    db = cantools.database.load_file(DBC)
    lines = [split(line) for line in log_lines("paper-line")]
    k = next(i for i, (_, frame_id, _) in enumerate(lines) if frame_id == 0x180) + 200
    k = next(i for i in range(k, len(lines)) if lines[i][1] == 0x180)  # the 201st step or so
    step_time = lines[k][0]

    def last_before(frame_id: int) -> dict[str, Any]:
        i = max(j for j in range(k) if lines[j][1] == frame_id)
        return db.decode_message(frame_id, bytes.fromhex(lines[i][2]))

    xy, theta = last_before(0x100), last_before(0x101)["ODOM_THETA_theta"]
    poses = dict(decoded(path, "/robot/pose"))
    pose = poses[round(step_time * 1e9)]
    assert pose.frame_id == "odom"  # REP 105, as the rosbag2 export and the bridge
    assert pose.pose.position.x == pytest.approx(xy["ODOM_XY_x"], abs=1e-9)
    assert pose.pose.position.y == pytest.approx(xy["ODOM_XY_y"], abs=1e-9)
    q = pose.pose.orientation
    assert (q.x, q.y) == (0.0, 0.0)
    assert math.atan2(q.z, q.w) * 2 == pytest.approx(theta, abs=1e-9)
    assert pose.timestamp.seconds + pose.timestamp.nanos / 1e9 == pytest.approx(step_time)


def test_the_can_channels_carry_the_decoded_signals(exported: tuple[Path, str]) -> None:
    path, _ = exported
    db = cantools.database.load_file(DBC)
    first_status = next(split(line) for line in log_lines("paper-line") if split(line)[1] == 0x181)
    want = db.decode_message(0x181, bytes.fromhex(first_status[2]))
    with path.open("rb") as f:
        _, channel, message = next(make_reader(f).iter_messages(topics=["/can/STATUS"]))
    got = json.loads(message.data)
    assert got == {
        k.removeprefix("STATUS_"): v if isinstance(v, int | float) else str(v)
        for k, v in want.items()
    }
    assert got["mode"] == "track"  # the value table's name, not the number
    assert message.log_time == round(first_status[0] * 1e9)


def test_the_scene_has_the_obstacles_and_the_paths(exported: tuple[Path, str]) -> None:
    path, _ = exported
    scenario = tomllib.loads((SCENARIOS / "paper-line.toml").read_text())
    [(_, scene)] = decoded(path, "/scene")
    entities = {e.id: e for e in scene.entities}
    for i, obstacle in enumerate(scenario["obstacles"], start=1):
        [cylinder] = entities[f"obstacle-{i}"].cylinders
        x, y = obstacle["position"]
        # OBSTACLE frames carry positions to 1/1024 m.
        assert cylinder.pose.position.x == pytest.approx(x, abs=1e-3)
        assert cylinder.pose.position.y == pytest.approx(y, abs=1e-3)
        assert cylinder.size.x == pytest.approx(2 * 0.1, abs=1e-3)  # R_ob, Table 1
    steps = sum(1 for line in log_lines("paper-line") if split(line)[1] == 0x180)
    [(_, robot_path)] = decoded(path, "/robot/path")
    [line] = entities["robot-path"].lines
    assert len(robot_path.poses) == len(line.points) == steps
    start = robot_path.poses[0].position
    assert (start.x, start.y) == pytest.approx((0.0, 2.5), abs=1e-3)  # the scenario's robot pose


def test_events_are_logged_at_the_papers_times(exported: tuple[Path, str]) -> None:
    path, _ = exported
    scenario = tomllib.loads((SCENARIOS / "paper-line.toml").read_text())
    events = decoded(path, "/events")
    texts = [log.message for _, log in events]
    assert len(texts) == len(scenario["expected"])
    for want in scenario["expected"]:
        assert any(
            text.startswith(f"{want['event']} O{want['obstacle']}")
            and f"t = {want['t']:g} s" in text
            for text in texts
        ), (want, texts)
    for log_time, log in events:
        assert log_time == log.timestamp.seconds * 10**9 + log.timestamp.nanos


def test_the_command_prints_what_it_wrote(exported: tuple[Path, str]) -> None:
    path, printed = exported
    assert printed.startswith(f"export: {LOG} -> {path}: ")
    assert "/robot/pose" in printed and "/can/STATUS" in printed


def test_a_run_folder_is_read_through_its_bus_log(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "paper-line"
    run.mkdir()
    shutil.copyfile(LOG, run / "bus.log")
    out = tmp_path / "run.mcap"
    assert main(["export", str(run), "--mcap", str(out), "-q"]) == 0
    assert summary_of(out).statistics.message_count > 0
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["export", str(empty), "--mcap", str(tmp_path / "no.mcap")]) == 2
    assert "without a bus.log" in capsys.readouterr().err
    assert not (tmp_path / "no.mcap").exists()
