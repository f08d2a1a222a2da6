# SPDX-License-Identifier: MIT
"""Issue 21, case 6: an accepted parameter set must not drive the robot into
an obstacle of a radius an OBSTACLE frame can carry (up to 2.55 m).

With D_det = 1.0 m (every relation of the limits table holds) and one static
obstacle of radius 1.0 m ahead, the firmware took the report only when the
obstacle's centre came within D_det, while D_s and D_act grow by r − R_ob:
it was detected inside its own safe distance and touched. Either the sensor
range counts from the obstacle's boundary, or the whole-set check refuses
what cannot be avoided; both are accepted here: the scenario is refused by
the loader (one line naming the file), or it runs and the robot keeps clear
of the obstacle (centre distance at least R_m + r: no contact, Definition 3
of the paper with the obstacle's own radius), for both radii, both switch
strategies, head on and slightly off the line, in both numeric modes.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import pytest

from conftest import scenario_or_refusal
from mstc.loop.lockstep import simulate
from mstc.sweep.engine import controller_for

R_M = 0.2
"""Robot radius: the default (Table 1)."""


@pytest.mark.parametrize("radius", [1.0, 2.55])
@pytest.mark.parametrize("strategy", ["mstc", "paper"])
@pytest.mark.parametrize("offset", [0.0, 0.3])
def test_a_large_obstacle_within_d_det_is_avoided_or_the_set_refused(
    write_scenario: Callable[[Mapping[str, object], str], Path],
    libs: dict[str, Path],
    radius: float,
    strategy: str,
    offset: float,
) -> None:
    path = write_scenario(
        {
            "robot": {"pose": [0.0, 0.0, 0.0]},
            "reference": {"pose": [0.1, 0.0, 0.0], "v": 0.5, "w": 0.0},
            "obstacles": [{"position": [6.0, offset], "radius": radius}],
            "sim": {"duration": 30.0, "dt": 0.02, "integrator": "euler"},
            "params": {"D_det": 1.0},
        },
        "large-obstacle",
    )
    scenario = scenario_or_refusal(path, "D_det")
    if scenario is None:
        return
    for mode, lib in libs.items():
        run, controller = controller_for(scenario, strategy, str(lib))
        result = simulate(run, controller)
        (closest,) = result.min_distance
        assert closest >= R_M + radius, (
            f"{mode}, {strategy}: the robot came within {closest:.3f} m of the centre "
            f"of an obstacle of radius {radius} m (contact below {R_M + radius:.2f} m)"
        )
