# SPDX-License-Identifier: MIT
"""The DWA baseline: its dynamic window holds the acceleration limits, it
follows a free reference, it never drives into an obstacle it can avoid and
it stops when every move collides. Bounds come from its configuration."""

import math
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import pytest

from mstc.can.protocol import wire_limits
from mstc.loop.lockstep import simulate
from mstc.model import Mode, Obstacle, Params, Pose
from mstc.plant.scenario import load_scenario
from mstc.sweep.dwa import DwaConfig, DwaController
from mstc.sweep.metrics import evaluate

WriteScenario = Callable[[Mapping[str, object], str], Path]


def straight(write: WriteScenario, obstacles: list[dict[str, object]], name: str) -> Path:
    doc: dict[str, object] = {
        "robot": {"pose": [0.0, 0.0, 0.0]},
        "reference": {"pose": [0.0, 0.0, 0.0], "v": 0.5, "w": 0.0},
        "sim": {"duration": 12.0, "dt": 0.02, "integrator": "euler"},
    }
    if obstacles:
        doc["obstacles"] = obstacles
    return write(doc, name)


def test_decisions_keep_the_acceleration_limits(write_scenario: WriteScenario) -> None:
    s = load_scenario(
        straight(write_scenario, [{"position": [2.0, 0.05]}], "limits"), wire_limits()
    )
    r = simulate(s, DwaController(s.params))
    c = DwaConfig()
    v, w = r.trace["v"][::5], r.trace["w"][::5]  # one decision every 0.1 s
    assert np.abs(np.diff(v)).max() <= c.max_accel * c.period + 1e-9
    assert np.abs(np.diff(w)).max() <= c.max_delta_yaw_rate * c.period + 1e-9
    assert np.abs(w).max() <= c.max_yaw_rate + 1e-9
    assert v.max() <= c.max_speed + 1e-9
    # Held in between: the same command for the 5 periods of a decision.
    assert all((r.trace["v"][k : k + 5] == r.trace["v"][k]).all() for k in range(0, 600, 5))


def test_follows_a_free_straight_reference(write_scenario: WriteScenario) -> None:
    s = load_scenario(straight(write_scenario, [], "free"), wire_limits())
    m = evaluate(simulate(s, DwaController(s.params)))
    assert m.final_error < 0.2 and 0.95 < m.path_ratio < 1.05
    assert m.avoid_time == 0.0


@pytest.mark.parametrize("lateral", [0.0, 0.15])
def test_an_obstacle_on_the_path_is_never_touched(
    write_scenario: WriteScenario, lateral: float
) -> None:
    # Exactly head-on, DWA stops in front of it (a local minimum of its
    # cost, docs/sweeps.md); slightly off the path it goes by. Neither touches.
    s = load_scenario(
        straight(write_scenario, [{"position": [2.0, lateral]}], "ahead"), wire_limits()
    )
    m = evaluate(simulate(s, DwaController(s.params)))
    assert not m.contact and m.avoid_time > 0.0


def test_stops_when_every_move_collides() -> None:
    ctl = DwaController(Params())
    inside = [Obstacle(1, 0.25, 0.0, 0.1)]  # centre 0.25 m: already within R_m + r
    result = ctl.step(Pose(0.0, 0.0, 0.0), Pose(0.0, 0.0, 0.0), 0.5, 0.0, inside, 0)
    assert (result.wheel_left, result.wheel_right) == (0.0, 0.0)
    assert result.status.mode is Mode.AVOID


def test_wheel_limits_bound_its_speeds() -> None:
    p = Params(max_wheel_speed=4.0)  # 0.2 m/s, 2.67 rad/s at most
    ctl = DwaController(p)
    assert ctl.max_speed == pytest.approx(0.2)
    assert ctl.max_yaw_rate == pytest.approx(min(math.radians(90.0), 2 * 0.2 / 0.3))
