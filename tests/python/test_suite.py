# SPDX-License-Identifier: MIT
"""Suite files and the scene families they generate: the same files on every
run, and each family's geometry as docs/sweeps.md promises it, checked on the
generated files with independent geometry."""

import math
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from mstc.can.protocol import wire_limits
from mstc.errors import SuiteError
from mstc.model import Params
from mstc.plant.scenario import Scenario, load_scenario
from mstc.sweep.suite import IDEAL, ActuatorProfile, generate, load_suite, scene_doc, scene_text

ROOT = Path(__file__).resolve().parents[2]
STANDARD = ROOT / "sim" / "suites" / "standard.toml"
P = Params()


def _small(tmp_path: Path, count: int = 12) -> Path:
    """The standard suite with @p count scenes a family."""
    text = STANDARD.read_text().replace("count = 200", f"count = {count}")
    path = tmp_path / "small.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Scenario]]:
    tmp = tmp_path_factory.mktemp("suite")
    suite = load_suite(_small(tmp))
    files = generate(suite, tmp / "scenes")
    by_family: dict[str, list[Scenario]] = {}
    for f in files:
        by_family.setdefault(f.family, []).append(load_scenario(f.path, wire_limits()))
    return by_family


def _generate_in_subprocess(suite: Path, out: Path, hashseed: str) -> dict[str, bytes]:
    code = (
        "import sys; from pathlib import Path; from mstc.sweep.suite import load_suite, generate;"
        "generate(load_suite(sys.argv[1]), Path(sys.argv[2]))"
    )
    env = {**os.environ, "PYTHONHASHSEED": hashseed}
    subprocess.run([sys.executable, "-c", code, str(suite), str(out)], check=True, env=env)
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*.toml"))}


def test_same_seed_same_files_byte_for_byte(tmp_path: Path) -> None:
    suite = _small(tmp_path, count=5)
    first = _generate_in_subprocess(suite, tmp_path / "a", "1")
    second = _generate_in_subprocess(suite, tmp_path / "b", "12345")
    # 10 families × 3 actuator profiles × 5 scenes.
    assert len(first) == 150 and first == second


def test_scene_i_does_not_depend_on_the_count(tmp_path: Path) -> None:
    few = _generate_in_subprocess(_small(tmp_path, count=3), tmp_path / "few", "0")
    (tmp_path / "more").mkdir()
    many = _generate_in_subprocess(_small(tmp_path / "more", count=6), tmp_path / "many", "0")
    assert all(many[name] == text for name, text in few.items())


def test_a_scenes_document_is_its_file_parsed(tmp_path: Path) -> None:
    """What a worker runs (the document, never written as text) is what the
    file `--generate-only` writes gives to a TOML parser (tomllib, an
    independent reader of the text), for every family and profile."""
    suite = load_suite(_small(tmp_path, count=4))
    for family in suite.families:
        for profile in suite.actuators:
            wheels = None if profile == ActuatorProfile(IDEAL, {}) else profile
            for i in (0, 3, 99_999):
                doc = scene_doc(suite, family, i, actuator=wheels)
                assert tomllib.loads(scene_text(suite, family, i, actuator=wheels)) == doc


def test_every_scene_is_a_valid_scenario_with_at_most_15_obstacles(
    scenes: dict[str, list[Scenario]],
) -> None:
    assert sorted(scenes) == sorted(f.name for f in load_suite(STANDARD).families)
    profiles = [a.name for a in load_suite(STANDARD).actuators]
    assert profiles == ["ideal", "gearmotor", "sluggish"]
    for family, items in scenes.items():
        # Each scene under every profile: the same geometry, its own wheels.
        assert len(items) == 12 * len(profiles)
        ideal = [s for s in items if s.actuator.model == "ideal"]
        assert len(ideal) == 12 and all(s.meta.actuator == "" for s in ideal)
        for s in items:
            if s.actuator.model != "ideal":
                twin = ideal[s.meta.index or 0]
                assert (s.robot, s.obstacles) == (twin.robot, twin.obstacles)
        for s in items:
            assert 0 < len(s.obstacles) <= 15, s.path
            assert s.meta.family == family and s.meta.seed is not None
            assert s.sim.dt == 0.02 and s.sim.duration == 30.0


def _gap_to_start(s: Scenario) -> list[float]:
    """Centre distance minus that obstacle's D_s, at t = 0."""
    return [
        math.hypot(o.x - s.robot.x, o.y - s.robot.y) - P.safe_distance(o.radius)
        for o in s.obstacles
    ]


def test_no_scene_starts_in_contact_or_inside_d_s(scenes: dict[str, list[Scenario]]) -> None:
    for items in scenes.values():
        for s in items:
            assert min(_gap_to_start(s)) > 0.0, s.path


def test_clusters_hold_2_to_5_obstacles_each_0_3_to_0_8_m_from_another(
    scenes: dict[str, list[Scenario]],
) -> None:
    for s in scenes["cluster"]:
        obs = s.obstacles
        assert 2 <= len(obs) <= 5
        for i, a in enumerate(obs):
            others = [math.hypot(a.x - b.x, a.y - b.y) for j, b in enumerate(obs) if j != i]
            assert any(0.3 - 1e-3 <= d <= 0.8 + 1e-3 for d in others), s.path


def test_head_on_obstacles_are_exactly_on_the_path(scenes: dict[str, list[Scenario]]) -> None:
    for s in scenes["head_on"]:
        assert s.robot == s.reference.pose == (0.0, 0.0, 0.0)
        assert all(o.y == 0.0 and o.x > 0 for o in s.obstacles)


def test_circle_scenes_run_on_a_circle_with_obstacles_near_it(
    scenes: dict[str, list[Scenario]],
) -> None:
    for s in scenes["circle"]:
        v, w = s.reference.v, s.reference.w
        rho = abs(v / w)
        assert 1.2 - 1e-3 <= rho <= 3.0 + 1e-3
        x0, y0, th0 = s.reference.pose
        sgn = math.copysign(1.0, w)
        cx, cy = x0 - sgn * rho * math.sin(th0), y0 + sgn * rho * math.cos(th0)
        for o in s.obstacles:
            assert abs(math.hypot(o.x - cx, o.y - cy) - rho) <= 0.5 + 2e-3, s.path


def test_moving_obstacles_cross_the_reference_line(scenes: dict[str, list[Scenario]]) -> None:
    for s in scenes["moving"]:
        x0, y0, th = s.reference.pose
        n = (-math.sin(th), math.cos(th))  # the line's normal
        for o in s.obstacles:
            assert o.moving
            lateral = (o.x - x0) * n[0] + (o.y - y0) * n[1]
            rate = o.vx * n[0] + o.vy * n[1]
            crossing = -lateral / rate  # when it is on the line
            assert 0.0 < crossing < s.sim.duration, s.path


def test_narrow_passages_are_wider_than_the_robot(scenes: dict[str, list[Scenario]]) -> None:
    for s in scenes["narrow"]:
        obs = s.obstacles
        # Walls in pairs, facing each other: the passage is the gap between them.
        gaps = [
            math.hypot(a.x - b.x, a.y - b.y) - a.radius - b.radius
            for a, b in zip(obs[::2], obs[1::2], strict=True)
        ]
        assert all(2 * P.r_m < g <= 0.9 + 1e-3 for g in gaps), s.path


def test_the_reference_passes_through_the_obstacle(scenes: dict[str, list[Scenario]]) -> None:
    for s in scenes["through"]:
        (o,) = s.obstacles
        assert s.reference.pose.theta == 0.0 and s.reference.w == 0.0
        assert abs(o.y) < o.radius and o.x > 0


def test_start_active_starts_between_d_s_and_d_act(scenes: dict[str, list[Scenario]]) -> None:
    for s in scenes["start_active"]:
        o = s.obstacles[0]
        d = math.hypot(o.x - s.robot.x, o.y - s.robot.y)
        assert P.safe_distance(o.radius) < d < P.activation_distance(o.radius), s.path


def test_noisy_family_writes_imperfections_within_its_ranges(
    scenes: dict[str, list[Scenario]],
) -> None:
    for s in scenes["cluster_noisy"]:
        imp = s.imperfections
        assert imp.seed == s.meta.seed and imp.delay in (1, 2)
        assert 0.0 <= imp.position_noise <= 0.01 and 0.0 <= imp.dropout <= 0.1


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("[family.a]\ncount = 1\nseed = 1\nkind = 'spiral'\n", "unknown kind"),
        ("[family.isolated]\ncount = 1\nseed = 1\nalong = [5, 1]\n", "low (5) must be <= high"),
        ("[family.isolated]\ncount = 1\nseed = 1\nalng = [1, 5]\n", "did you mean 'along'"),
        ("[family.cluster]\ncount = 1\nseed = 1\nobstacles = [2, 49]\n", "at most 48"),
        ("[family.narrow]\ncount = 1\nseed = 1\nwall = [3, 25]\n", "at most 48"),
        ("[family.isolated]\nseed = 1\n", "count: must be an integer"),
        ("[suite]\ndt = -1\n[family.isolated]\ncount = 1\nseed = 1\n", "suite.dt"),
        ("[suite]\nname = 'x'\n", "no [family.<name>] table"),
    ],
)
def test_bad_suites_are_one_clear_line(tmp_path: Path, text: str, problem: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(SuiteError) as info:
        load_suite(path)
    assert str(info.value).startswith(f"{path}: ") and problem in str(info.value)
    assert "\n" not in str(info.value)
