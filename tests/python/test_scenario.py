# SPDX-License-Identifier: MIT
"""Scenario loader: valid files, every kind of bad file, and what the CLI does
with a bad file (one error line, exit 2, nothing written)."""

import copy
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import pytest

from conftest import ROOT, SCENARIOS
from mstc.can.protocol import wire_limits
from mstc.cli import main
from mstc.errors import ScenarioError
from mstc.model import EventKind, Params, Pose, Side, Strategy
from mstc.plant.plant import Integrator
from mstc.plant.scenario import IDEAL_WHEEL_ACCEL, load_scenario

WriteScenario = Callable[[Mapping[str, object], str], Path]

VALID: dict[str, Any] = {
    "robot": {"pose": [0.0, 2.5, 0.5]},
    "reference": {"pose": [0.1, 2.6, 0.7], "v": 0.5, "w": 0.0},
    "obstacles": [{"position": [3.0, 5.2]}, {"position": [4.0, 5.8], "radius": 0.2}],
    "sim": {"duration": 2.0, "dt": 0.02, "integrator": "euler"},
    "params": {"D_s": 0.3, "tracking_gains": [3, 12, 6]},
    "expected": [
        {"t": 0.5, "event": "detect", "obstacle": 1},
        {"t": 1.0, "event": "activate", "obstacle": 2, "side": "left"},
    ],
}


def edit(path: str, value: object = None, *, delete: bool = False) -> dict[str, Any]:
    """VALID with one key set (or deleted); path like "params.D_s",
    "obstacles[2].position" (1-based, as in the error messages)."""
    doc = copy.deepcopy(VALID)
    *parents, last = path.split(".")
    node: Any = doc
    for part in parents:
        if part.endswith("]"):
            name, index = part[:-1].split("[")
            node = node[name][int(index) - 1]
        else:
            node = node.setdefault(part, {})
    if delete:
        del node[last]
    else:
        node[last] = value
    return doc


def test_valid_file_loads_with_table_1_defaults_and_overrides(
    write_scenario: WriteScenario,
) -> None:
    s = load_scenario(write_scenario(VALID, "valid"), wire_limits())
    assert s.name == "valid"
    assert s.robot == Pose(0.0, 2.5, 0.5)
    assert s.reference.pose == Pose(0.1, 2.6, 0.7)
    assert (s.reference.v, s.reference.w) == (0.5, 0.0)
    assert [(o.x, o.y, o.radius) for o in s.obstacles] == [(3.0, 5.2, 0.1), (4.0, 5.8, 0.2)]
    assert (s.sim.duration, s.sim.dt, s.sim.integrator) == (2.0, 0.02, Integrator.EULER)
    assert (s.sim.steps, s.sim.dt_us) == (100, 20_000)
    # No [actuator]: the firmware is told its wheels follow at once.
    assert s.params == Params(d_s=0.3, wheel_accel=IDEAL_WHEEL_ACCEL, wheel_tau=0.0)
    assert [(e.t, e.event, e.obstacle, e.side) for e in s.expected] == [
        (0.5, EventKind.DETECT, 1, None),
        (1.0, EventKind.ACTIVATE, 2, Side.LEFT),
    ]


def test_table_1_defaults() -> None:
    p = Params()
    assert (p.r_m, p.r_ob, p.d_det, p.d_act, p.d_s) == (0.2, 0.1, 3.5, 0.5, 0.35)
    assert p.tracking_gains == (3, 12, 6)
    assert p.avoidance_gains == (3, 6)
    assert (p.wheel_radius, p.track_width, p.max_wheel_speed) == (0.05, 0.3, 100)


def test_minimal_file_without_obstacles_params_or_expected(write_scenario: WriteScenario) -> None:
    doc = {k: v for k, v in VALID.items() if k not in ("obstacles", "params", "expected")}
    doc["reference"] = {"pose": [0, 0, 0], "v": 1, "w": -1}  # integers are numbers
    s = load_scenario(write_scenario(doc, "minimal"), wire_limits())
    assert s.obstacles == ()
    assert s.expected == ()
    assert s.params == Params(wheel_accel=IDEAL_WHEEL_ACCEL, wheel_tau=0.0)
    assert (s.reference.v, s.reference.w) == (1.0, -1.0)


def test_obstacle_radius_defaults_to_the_overridden_r_ob(write_scenario: WriteScenario) -> None:
    # 0.05: D_s (0.3 here) must stay >= R_m + R_ob (docs/safety.md).
    s = load_scenario(write_scenario(edit("params.R_ob", 0.05), "r_ob"), wire_limits())
    assert s.obstacles[0].radius == 0.05


def test_paper_scenarios_load() -> None:
    for name in ("paper-line", "paper-circle"):
        s = load_scenario(SCENARIOS / f"{name}.toml", wire_limits())
        assert s.params == Params(
            strategy=Strategy.PAPER, wheel_accel=IDEAL_WHEEL_ACCEL, wheel_tau=0.0
        )
        assert (s.sim.dt, s.sim.integrator) == (0.02, Integrator.EULER)


FORTY_NINE_OBSTACLES = [{"position": [float(i), 10.0]} for i in range(49)]
# The frames' ranges (firmware/comm/mstc.dbc, read by hand): positions ±128 m
# (ODOM_XY, REF_XY, OBSTACLE), v_r and ω_r ±16, radius 0.01 to 2.55 m in
# whole centimetres, obstacle ids 1 to 48.

# (document, key named in the message (None: the whole file), words of the problem)
BAD: dict[str, tuple[dict[str, Any], str | None, str]] = {
    "missing robot": (edit("robot", delete=True), "robot", "missing required table [robot]"),
    "missing robot.pose": (edit("robot.pose", delete=True), "robot.pose", "missing"),
    "missing reference.v": (edit("reference.v", delete=True), "reference.v", "missing"),
    "missing reference.w": (edit("reference.w", delete=True), "reference.w", "missing"),
    "missing sim": (edit("sim", delete=True), "sim", "missing"),
    "missing sim.dt": (edit("sim.dt", delete=True), "sim.dt", "missing"),
    "missing sim.duration": (edit("sim.duration", delete=True), "sim.duration", "missing"),
    "obstacle on the robot's start": (
        edit("obstacles[1].position", [0.1, 2.6]),  # 0.141 m from the robot: R_m + R_ob = 0.3 m
        "obstacles[1].position",
        "the robot starts inside it",
    ),
    "missing obstacle position": (
        edit("obstacles[2].position", delete=True),
        "obstacles[2].position",
        "missing",
    ),
    "missing expected t": (edit("expected[1].t", delete=True), "expected[1].t", "missing"),
    "missing activate side": (
        edit("expected[2].side", delete=True),
        "expected[2].side",
        "missing",
    ),
    "unknown top-level table": (edit("simulation", {"dt": 0.02}), "simulation", "unknown key"),
    "misspelled param": (edit("params.Ds", 0.3), "params.Ds", "did you mean 'D_s'"),
    "wrong-case param": (edit("params.d_s", 0.3), "params.d_s", "did you mean 'D_s'"),
    "unknown key in robot": (edit("robot.heading", 0.5), "robot.heading", "unknown key"),
    "misspelled obstacle key": (
        edit("obstacles[2].radious", 0.2),
        "obstacles[2].radious",
        "did you mean 'radius'",
    ),
    "unknown key in sim": (edit("sim.steps", 10), "sim.steps", "unknown key"),
    "unknown key in expected": (edit("expected[1].when", 1.0), "expected[1].when", "unknown"),
    "string for number": (edit("reference.v", "fast"), "reference.v", "must be a number"),
    "boolean for number": (edit("reference.w", True), "reference.w", "got boolean"),
    "boolean in pose": (edit("robot.pose", [0.0, True, 0.0]), "robot.pose", "element y"),
    "string in position": (
        edit("obstacles[1].position", [3.0, "5"]),
        "obstacles[1].position",
        "element y must be a number",
    ),
    "boolean param": (edit("params.D_det", False), "params.D_det", "got boolean"),
    "boolean gain": (
        edit("params.avoidance_gains", [3, True]),
        "params.avoidance_gains",
        "element k2 must be a number",
    ),
    "number for pose": (edit("robot.pose", 1.0), "robot.pose", "must be an array"),
    "robot not a table": (edit("robot", 3), "robot", "must be a table"),
    "params not a table": (edit("params", [1, 2]), "params", "must be a table"),
    "obstacles not tables": (edit("obstacles", 3), "obstacles", "array of tables"),
    "nan number": (edit("reference.v", math.nan), "reference.v", "finite"),
    "inf in pose": (edit("robot.pose", [0.0, math.inf, 0.0]), "robot.pose", "finite"),
    "inf param": (edit("params.D_det", math.inf), "params.D_det", "finite"),
    "nan duration": (edit("sim.duration", math.nan), "sim.duration", "finite"),
    "huge integer": (edit("reference.v", 10**400), "reference.v", "finite"),
    "huge integer in pose": (edit("robot.pose", [0, 10**400, 0]), "robot.pose", "element y"),
    "short pose": (edit("robot.pose", [0.0, 2.5]), "robot.pose", "3 elements"),
    "long position": (
        edit("obstacles[1].position", [3.0, 5.2, 0.0]),
        "obstacles[1].position",
        "2 elements",
    ),
    "two tracking gains": (
        edit("params.tracking_gains", [3, 12]),
        "params.tracking_gains",
        "3 elements",
    ),
    "D_s equal to D_act": (edit("params.D_s", 0.5), "params.D_s", "D_act"),
    "D_s above D_act": (edit("params.D_act", 0.25), "params.D_s", "must be < D_act"),
    "D_s below R_m": (edit("params.D_s", 0.15), "params.D_s", "must be >= R_m"),
    "R_m above D_s": (edit("params.R_m", 0.4), "params.D_s", "R_m"),
    "D_act above D_det": (edit("params.D_act", 4.0), "params.D_act", "must be <= D_det"),
    "D_det below D_act": (edit("params.D_det", 0.4), "params.D_det", "D_act"),
    "zero tracking gain": (
        edit("params.tracking_gains", [3, 0, 6]),
        "params.tracking_gains",
        "k2 must be > 0",
    ),
    "negative avoidance gain": (
        edit("params.avoidance_gains", [-3, 6]),
        "params.avoidance_gains",
        "k1 must be > 0",
    ),
    "zero dt": (edit("sim.dt", 0.0), "sim.dt", "must be > 0"),
    "negative dt": (edit("sim.dt", -0.02), "sim.dt", "must be > 0"),
    "sub-microsecond dt": (edit("sim.dt", 2.5e-7), "sim.dt", "whole number of microseconds"),
    "zero duration": (edit("sim.duration", 0), "sim.duration", "must be > 0"),
    "negative R_m": (edit("params.R_m", -0.2), "params.R_m", "must be > 0"),
    "zero R_ob": (edit("params.R_ob", 0.0), "params.R_ob", "must be > 0"),
    "zero obstacle radius": (edit("obstacles[2].radius", 0.0), "obstacles[2].radius", "> 0"),
    "negative obstacle radius": (edit("obstacles[1].radius", -0.1), "obstacles[1].radius", "> 0"),
    "zero wheel radius": (edit("params.wheel_radius", 0), "params.wheel_radius", "> 0"),
    "negative track width": (edit("params.track_width", -0.3), "params.track_width", "> 0"),
    "zero wheel limit": (edit("params.max_wheel_speed", 0.0), "params.max_wheel_speed", "> 0"),
    "unknown integrator": (edit("sim.integrator", "rk4"), "sim.integrator", 'got "rk4"'),
    "integrator not a string": (edit("sim.integrator", 1), "sim.integrator", "must be a string"),
    "49 obstacles": (edit("obstacles", FORTY_NINE_OBSTACLES), "obstacles", "at most 48"),
    # Issue 13, case 4: what the frames cannot carry, naming the key and the limit.
    "robot beyond 128 m": (edit("robot.pose", [200.0, 2.5, 0.5]), "robot.pose", "-128"),
    "robot below -128 m": (edit("robot.pose", [0.0, -128.5, 0.5]), "robot.pose", "ODOM_XY.y"),
    "reference beyond 128 m": (edit("reference.pose", [0.1, 130, 0]), "reference.pose", "REF_XY"),
    "reference at 20 m/s": (edit("reference.v", 20.0), "reference.v", "REF_MOTION.v"),
    "reference at -16.5 m/s": (edit("reference.v", -16.5), "reference.v", "-16"),
    "reference turning at 17 rad/s": (edit("reference.w", 17), "reference.w", "REF_MOTION.w"),
    "obstacle of radius 3 m": (edit("obstacles[2].radius", 3.0), "obstacles[2].radius", "2.55"),
    "obstacle radius off the cm grid": (
        edit("obstacles[2].radius", 0.123),
        "obstacles[2].radius",
        "whole number of centimetres",
    ),
    "obstacle beyond 128 m": (
        edit("obstacles[1].position", [3.0, 200.0]),
        "obstacles[1].position",
        "OBSTACLE.y",
    ),
    "reference leaving the frames' range": (
        edit("sim.duration", 400.0),  # 0.5 m/s from x = 0.1 along θ = 0.7: x = 128 at 334.5 s
        "reference",
        "REF_XY",
    ),
    # Issue 13, case 5: one clear line instead of a crash or a hang.
    "duration 1e308": (edit("sim.duration", 1e308), "sim.duration", "100,000 control steps"),
    "reference w 1e308": (edit("reference.w", 1e308), "reference.w", "REF_MOTION.w"),
    "1e13 steps": (
        edit("sim", {"duration": 1e7, "dt": 1e-6, "integrator": "euler"}),
        "sim.duration",
        "100,000 control steps",
    ),
    "unknown event": (edit("expected[1].event", "collide"), "expected[1].event", "one of"),
    "side on detect": (edit("expected[1].side", "left"), "expected[1].side", "only activate"),
    "unknown side": (edit("expected[2].side", "up"), "expected[2].side", '"left", "right"'),
    "no such obstacle": (edit("expected[1].obstacle", 3), "expected[1].obstacle", "no obstacle 3"),
    "boolean obstacle": (
        edit("expected[1].obstacle", True),
        "expected[1].obstacle",
        "must be an integer",
    ),
    "expected after the end": (edit("expected[1].t", 2.5), "expected[1].t", "within the run"),
    "unknown strategy": (edit("params.strategy", "fast"), "params.strategy", '"paper", "mstc"'),
    "velocity of 3": (
        edit("obstacles[1].velocity", [1, 2, 3]),
        "obstacles[1].velocity",
        "2 elements [vx, vy]",
    ),
    "velocity not finite": (
        edit("obstacles[1].velocity", [math.inf, 0.0]),
        "obstacles[1].velocity",
        "finite",
    ),
    "negative noise": (
        edit("imperfections.position_noise", -0.1),
        "imperfections.position_noise",
        ">= 0",
    ),
    "dropout of 1": (edit("imperfections.dropout", 1.0), "imperfections.dropout", "< 1"),
    "fractional delay": (edit("imperfections.delay", 1.5), "imperfections.delay", "integer"),
    "negative delay": (edit("imperfections.delay", -1), "imperfections.delay", ">= 0"),
    "zero sensor range": (
        edit("imperfections.sensor_range", 0.0),
        "imperfections.sensor_range",
        "> 0",
    ),
    "misspelled imperfection": (
        edit("imperfections.dropouts", 0.1),
        "imperfections.dropouts",
        "did you mean 'dropout'",
    ),
    "meta family not a string": (edit("meta.family", 3), "meta.family", "must be a string"),
    # Issue 21, cases 9 and 13.
    "heading noise above π": (
        edit("imperfections.heading_noise", 3.2),
        "imperfections.heading_noise",
        "at most π",
    ),
    "negative tolerance": (
        edit("expected[1].tolerance", -0.02),
        "expected[1].tolerance",
        ">= 0",
    ),
}


def test_moving_obstacles_imperfections_strategy_and_meta_load(
    write_scenario: WriteScenario,
) -> None:
    doc = edit("obstacles[2].velocity", [0.25, -0.5])
    doc["params"]["strategy"] = "paper"
    doc["imperfections"] = {
        "seed": 4,
        "position_noise": 0.01,
        "heading_noise": 0.02,
        "obstacle_noise": 0.03,
        "sensor_range": 2.0,
        "dropout": 0.1,
        "delay": 2,
    }
    doc["meta"] = {"family": "cluster", "seed": 2000001, "index": 1}
    s = load_scenario(write_scenario(doc, "full"), wire_limits())
    assert [(o.vx, o.vy, o.moving) for o in s.obstacles] == [
        (0.0, 0.0, False),
        (0.25, -0.5, True),
    ]
    assert s.params.strategy is Strategy.PAPER
    imp = s.imperfections
    assert (imp.seed, imp.position_noise, imp.heading_noise, imp.obstacle_noise) == (
        4,
        0.01,
        0.02,
        0.03,
    )
    assert (imp.sensor_range, imp.dropout, imp.delay) == (2.0, 0.1, 2)
    assert (s.meta.family, s.meta.seed, s.meta.index) == ("cluster", 2000001, 1)


def test_without_the_new_keys_a_scene_is_ideal_static_and_mstc(
    write_scenario: WriteScenario,
) -> None:
    s = load_scenario(write_scenario(VALID, "plain"), wire_limits())
    assert not any(o.moving for o in s.obstacles)
    assert s.params.strategy is Strategy.MSTC
    imp = s.imperfections
    assert not imp.noisy and imp.delay == 0 and imp.sensor_range is None


@pytest.fixture(params=sorted(BAD))
def bad_case(request: pytest.FixtureRequest) -> tuple[str, dict[str, Any], str | None, str]:
    doc, key, problem = BAD[request.param]
    return request.param, doc, key, problem


def check_message(message: str, path: Path, key: str | None, problem: str) -> None:
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    if key is not None:
        assert message.startswith(f"{path}: {key}: ")
    assert problem in message


def test_bad_file_raises_one_line_naming_file_and_key(
    bad_case: tuple[str, dict[str, Any], str | None, str], write_scenario: WriteScenario
) -> None:
    _, doc, key, problem = bad_case
    path = write_scenario(doc, "bad")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, wire_limits())
    check_message(str(info.value), path, key, problem)


def test_values_at_the_frames_limits_load(write_scenario: WriteScenario) -> None:
    doc = edit("robot.pose", [127.99, -128.0, 100.0])  # θ is sent wrapped: any heading
    doc["reference"] = {"pose": [-125.0, 125.0, -50.0], "v": -15.99, "w": 15.99}  # a 1 m circle
    # At the opposite corner from the robot: an obstacle on its start is refused.
    doc["obstacles"] = [{"position": [-128.0, 127.99], "radius": 2.55}] * 48
    doc["expected"] = []
    s = load_scenario(write_scenario(doc, "limits"), wire_limits())
    assert len(s.obstacles) == 48
    assert s.obstacles[0].radius == 2.55
    # 0.15 m is 15.000000000000002 cm in binary: still a whole number of centimetres.
    assert (
        load_scenario(write_scenario(edit("obstacles[2].radius", 0.15), "cm"), wire_limits())
        .obstacles[1]
        .radius
        == 0.15
    )


def _reference_extent(
    x: float, y: float, theta: float, v: float, w: float, n: int, dt: float, integrator: str
) -> tuple[float, float, float, float]:
    """min x, max x, min y, max y of the reference's poses k = 0..n, stepped
    one period at a time like the plant (an independent, brute-force model)."""
    xs, ys = [x], [y]
    for _ in range(n):
        if integrator == "euler":
            x, y = x + v * math.cos(theta) * dt, y + v * math.sin(theta) * dt
        else:
            h = w * dt / 2
            chord = v * dt * (math.sin(h) / h if h else 1.0)
            x, y = x + chord * math.cos(theta + h), y + chord * math.sin(theta + h)
        theta += w * dt
        xs.append(x)
        ys.append(y)
    return min(xs), max(xs), min(ys), max(ys)


@pytest.mark.parametrize("integrator", ["euler", "exact"])
@pytest.mark.parametrize(
    ("start", "v", "w", "duration"),
    [
        ((118.0, 0.0, 0.0), 1.0, 0.5, 3.0),  # an arc of a 2 m circle that turns away in time
        ((118.0, 0.0, 0.0), 1.0, 0.05, 30.0),  # a 20 m circle, past 128 m in x
        ((118.0, 0.0, 0.0), 1.0, 0.05, 9.0),  # the same circle, stopped short of it
        ((0.0, 120.0, 1.0), 2.0, -0.3, 60.0),  # whole turns of a 6.7 m circle: y up to 123.1
        ((0.0, 126.0, 1.0), 2.0, -0.3, 60.0),  # the same circle 6 m higher: 129.1 m
        ((-100.0, 0.0, 3.0), 2.0, 0.0, 14.0),  # a straight line, just inside at -127.7
        ((-100.0, 0.0, 3.0), 2.0, 1e-9, 15.0),  # nearly straight, past -128 m
    ],
)
def test_the_reference_is_refused_exactly_when_its_path_leaves_the_frames_range(
    start: tuple[float, float, float],
    v: float,
    w: float,
    duration: float,
    integrator: str,
    write_scenario: WriteScenario,
) -> None:
    doc = edit("reference", {"pose": list(start), "v": v, "w": w})
    doc["sim"] = {"duration": duration, "dt": 0.02, "integrator": integrator}
    doc["expected"] = []
    n = round(duration / 0.02)
    x0, x1, y0, y1 = _reference_extent(*start, v, w, n, 0.02, integrator)
    leaves = x0 < -128 or y0 < -128 or x1 > 127.9999847412109375 or y1 > 127.9999847412109375
    path = write_scenario(doc, "arc")
    if leaves:
        with pytest.raises(ScenarioError) as info:
            load_scenario(path, wire_limits())
        check_message(str(info.value), path, "reference", "REF_XY")
    else:
        load_scenario(path, wire_limits())


def test_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "absent.toml"
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, wire_limits())
    check_message(str(info.value), path, None, "cannot read")


@pytest.mark.parametrize(
    "text",
    ["[robot]\npose = [0.0, 2.5, 0.5\n", "[robot]\npose = \n", "[sim]\n[sim]\n", "\xff\xfe"],
)
def test_toml_syntax_error(tmp_path: Path, text: str) -> None:
    path = tmp_path / "syntax.toml"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, wire_limits())
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert "TOML syntax error" in message or "UTF-8" in message


def run_cli(tmp_path: Path, *scenarios: Path) -> tuple[int, Path]:
    """`run` into tmp_path/out with a library that does not exist: a bad file
    must be caught before the library is even looked at."""
    out = tmp_path / "out"
    args = ["sim", "--lib", str(tmp_path / "never-loaded.so"), "--out", str(out)]
    return main([*args, *map(str, scenarios)]), out


def test_cli_exits_2_on_a_bad_file_and_writes_nothing(
    bad_case: tuple[str, dict[str, Any], str | None, str],
    write_scenario: WriteScenario,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _, doc, key, problem = bad_case
    path = write_scenario(doc, "bad")
    rc, out = run_cli(tmp_path, path)
    captured = capsys.readouterr()
    assert rc == 2
    assert not out.exists()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("error: ")
    check_message(lines[0].removeprefix("error: "), path, key, problem)


def test_cli_validates_every_file_before_running_any(
    write_scenario: WriteScenario, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = write_scenario(VALID, "good")
    bad = write_scenario(edit("params.D_s", 0.6), "bad")
    missing = tmp_path / "missing.toml"
    rc, out = run_cli(tmp_path, good, bad, missing)
    err = capsys.readouterr().err.splitlines()
    assert rc == 2
    assert not out.exists()
    assert [line.split(": ")[1] for line in err] == [str(bad), str(missing)]


def test_cli_refuses_two_scenarios_writing_the_same_folder(
    write_scenario: WriteScenario, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = write_scenario(VALID, "same")
    second = tmp_path / "sub" / "same.toml"
    second.parent.mkdir()
    second.write_text(first.read_text())
    rc, out = run_cli(tmp_path, first, second)
    assert rc == 2
    assert not out.exists()
    assert "would both write" in capsys.readouterr().err


def test_the_integrator_defaults_to_the_papers_euler(write_scenario: WriteScenario) -> None:
    """[sim] integrator is optional (issue 35: the README marked it so and
    the loader demanded it): forward Euler, the scheme of the paper's figures."""
    s = load_scenario(
        write_scenario(edit("sim.integrator", delete=True), "no_integrator"), wire_limits()
    )
    assert s.sim.integrator is Integrator.EULER


def test_a_suite_file_is_named_as_one(capsys: pytest.CaptureFixture[str]) -> None:
    """`mstc sim` on a suite says what it is and which command runs it,
    rather than `suite: unknown key` (issue 35)."""
    suite = ROOT / "sim" / "suites" / "standard.toml"
    assert main(["sim", "--bus", "memory", str(suite)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"error: {suite}: this is a suite of scenes, not a scenario: run it with mstc sweep"
    ]


def test_a_run_that_touches_an_obstacle_fails_with_status_4(
    write_scenario: WriteScenario, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A contact fails the run, so that CI notices (issue 35: it printed
    COLLISION and exited 0). The obstacle comes head-on at 3 m/s from 3 m
    while the robot drives at it at 0.5 m/s: the gap of 3 m - R_m - R_ob =
    2.7 m closes in 0.77 s if the robot only steers, and the paper's
    strategy has no safety filter that would slow it (docs/strategy.md)."""
    doc = {
        "robot": {"pose": [0.0, 0.0, 0.0]},
        "reference": {"pose": [0.0, 0.0, 0.0], "v": 0.5, "w": 0.0},
        "obstacles": [{"position": [3.0, 0.0], "velocity": [-3.0, 0.0]}],
        "sim": {"duration": 2.0, "dt": 0.02},
        "params": {"strategy": "paper"},
    }
    path = write_scenario(doc, "head_on")
    assert main(["sim", "--bus", "memory", "--out", str(tmp_path / "out"), str(path)]) == 4
    captured = capsys.readouterr()
    assert "COLLISION" in captured.out
    assert captured.err.startswith(f"error: {path}: missed its expectations: contact with O1: ")
