# SPDX-License-Identifier: MIT
"""Parameters that are safe as a set (issue 13): the scenario loader refuses,
naming the file, the key and the limit, every [params] set the firmware's check
would refuse; the report never calls a meaningless distance ok.

Expected limits are derived by hand from what they protect (docs/safety.md,
"Parameters"): D_s >= R_m + R_ob keeps the robot's body clear of an obstacle
of radius R_ob; WHEEL_CMD carries ±128 rad/s; OBSTACLE_radius up to 2.55 m.
"""

from __future__ import annotations

import os
import random
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mstc.can.protocol import wire_limits
from mstc.errors import FirmwareError, ScenarioError
from mstc.firmware.sil import SilController
from mstc.limits import Held, load_table, violation
from mstc.loop.result import RunResult, Trace
from mstc.model import Obstacle, Params, Pose
from mstc.plant.plant import Integrator
from mstc.plant.scenario import ReferenceSpec, Scenario, SimSpec, load_scenario, params_values
from mstc.report.table import format_report

WriteScenario = Callable[[Mapping[str, object], str], Path]

BASE: dict[str, Any] = {
    "robot": {"pose": [0.0, 0.0, 0.0]},
    "reference": {"pose": [0.1, 0.0, 0.0], "v": 0.5, "w": 0.0},
    "obstacles": [{"position": [3.0, 0.05], "radius": 0.1}],
    "sim": {"duration": 1.0, "dt": 0.02, "integrator": "euler"},
}


def with_params(**params: object) -> dict[str, Any]:
    return dict(BASE, params=params)


def refusal(write_scenario: WriteScenario, doc: Mapping[str, object]) -> ScenarioError:
    path = write_scenario(doc, "hostile")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, wire_limits())
    assert str(path) in str(info.value), "the error names the file"
    return info.value


# ------------------------------------------------------------- issue 13 cases


def test_the_loader_refuses_an_obstacle_radius_that_switches_avoidance_off(
    write_scenario: WriteScenario,
) -> None:
    """Case 2: R_ob = 1.0 with Table 1's D_s = 0.35 and R_m = 0.2 would move a
    0.1 m obstacle's D_s to 0.35 + 0.1 - 1.0 = -0.55 m."""
    e = refusal(write_scenario, with_params(R_ob=1.0))
    assert e.key == "params.R_ob"
    assert "R_m + R_ob" in e.problem and "1.2" in e.problem, e.problem


@pytest.mark.parametrize(
    ("key", "value", "limit"),
    [
        ("D_det", 20000.0, "60"),  # case 5: passed the loader, failed at run time
        ("max_wheel_speed", 300.0, "127.99"),  # case 4: WHEEL_CMD carries ±128 rad/s
        ("R_ob", 3.0, "2.55"),  # case 4: OBSTACLE_radius carries 2.55 m
    ],
)
def test_the_loader_refuses_a_value_beyond_its_range_naming_the_limit(
    write_scenario: WriteScenario, key: str, value: float, limit: str
) -> None:
    e = refusal(write_scenario, with_params(**{key: value}))
    assert e.key == f"params.{key}"
    assert limit in e.problem, e.problem


def test_the_loader_refuses_a_gain_beyond_its_range(write_scenario: WriteScenario) -> None:
    """Case 5: a gain of 1e5 passed the loader and failed at run time."""
    e = refusal(write_scenario, with_params(tracking_gains=[3.0, 1e5, 6.0]))
    assert e.key == "params.tracking_gains"
    assert "k2" in e.problem and "1000" in e.problem, e.problem


def _report_line(params: Params, min_distance: float) -> str:
    """The report's min-distance line of one 0.1 m obstacle passed at
    @p min_distance (a scenario built directly, as no loader would let it)."""
    scenario = Scenario(
        path=Path("hostile.toml"),
        robot=Pose(0.0, 0.0, 0.0),
        reference=ReferenceSpec(Pose(0.1, 0.0, 0.0), 0.5, 0.0),
        obstacles=(Obstacle(1, 3.0, 0.05, 0.1),),
        sim=SimSpec(1.0, 0.02, Integrator.EULER),
        params=params,
        expected=(),
    )
    trace = Trace(np.zeros((1, 15)), (), np.zeros((1, 1)))
    result = RunResult(scenario, trace, (), (min_distance,), {})
    lines = [line for line in format_report(result, Path("out")).splitlines() if "O1 " in line]
    assert len(lines) == 1
    return lines[0]


def test_the_report_never_calls_a_negative_safe_distance_ok() -> None:
    """Case 2: the robot passed 0.05 m from the obstacle's centre, through it,
    and the report said (D_s -0.55 m: ok)."""
    line = _report_line(Params(r_ob=1.0), 0.05)
    assert ": ok" not in line, line
    assert "COLLISION" in line, line
    # Clear of the body (0.32 > R_m + radius = 0.3) but against a threshold
    # below it: not ok either.
    line = _report_line(Params(r_ob=1.0), 0.32)
    assert ": ok" not in line, line
    assert "meaningless" in line, line


def test_the_report_still_says_ok_and_below() -> None:
    assert _report_line(Params(), 0.36).endswith("(D_s 0.35 m: ok)")
    assert _report_line(Params(), 0.34).endswith("(D_s 0.35 m: BELOW D_s)")


# ------------------------------------------- the loader agrees with the firmware


def _near_limits(rng: random.Random) -> dict[str, float]:
    """Table 1 with one to three parameters moved to, or a hair across, an end
    of their range or of a relation they are in."""
    table = load_table()
    values = {p.name: p.default for p in table.params if p.held}
    for _ in range(rng.randint(1, 3)):
        p = rng.choice([p for p in table.params if p.scenario])
        r = rng.random()
        if r < 0.4:
            base = rng.choice((p.minimum, p.maximum))
        else:
            relation = rng.choice(table.relations)
            total = relation.factor * sum(values[n] for n in relation.rhs)
            base = total if p.name == relation.lhs else rng.uniform(p.minimum, p.maximum)
        hair = rng.choice((0.0, 1e-9, -1e-9, 1e-7, -1e-7, 1e-5, -1e-5, 2**-17, -(2**-17)))
        values[p.name] = base * (1.0 + hair) if r < 0.9 else base + hair
    return values


def _params_of(values: Mapping[str, float]) -> Params:
    return Params(
        r_m=values["R_m"],
        r_ob=values["R_ob"],
        d_det=values["D_det"],
        d_act=values["D_act"],
        d_s=values["D_s"],
        tracking_gains=(values["trk_k1"], values["trk_k2"], values["trk_k3"]),
        avoidance_gains=(values["avd_k1"], values["avd_k2"]),
        wheel_radius=values["wheel_radius"],
        track_width=values["track_width"],
        max_wheel_speed=values["max_wheel_speed"],
        wheel_accel=values["wheel_accel"],
        wheel_tau=values["wheel_tau"],
    )


@pytest.mark.parametrize(("numeric", "held"), [("float", Held.FLOAT), ("fixed", Held.FIXED_DOUBLE)])
def test_the_loader_and_the_firmware_agree_on_sets_at_the_limits(numeric: str, held: Held) -> None:
    """mstc.limits, holding values as the library's mstc_sil_init does, and the
    firmware's ctl_params_check (through mstc_sil_init) accept and refuse the
    same sets, over 3000 sets at and a hair across the ends of ranges and
    relations: the rounding the loader emulates is the firmware's."""
    var = f"MSTC_SIL_LIB_{numeric.upper()}"
    lib = os.environ.get(var)
    if not lib or not Path(lib).is_file():
        pytest.fail(f"{var}={lib!r}: `make test-python` builds both libraries", pytrace=False)
    rng = random.Random(f"limits-{numeric}")
    verdicts = {True: 0, False: 0}
    for _ in range(3000):
        values = _near_limits(rng)
        loader = violation(values, ways=(held,)) is None
        try:
            SilController(_params_of(values), lib)
            firmware = True
        except FirmwareError:
            firmware = False
        assert loader == firmware, (values, violation(values, ways=(held,)))
        verdicts[firmware] += 1
    assert min(verdicts.values()) > 500, verdicts


def test_every_held_value_is_checked_in_every_way_the_firmware_holds_it() -> None:
    """0.3 = 0.2 + 0.1 as held: the float and both Q16.16 roundings accept
    D_s = R_m + R_ob there, though 0.2 + 0.1 > 0.3 in double; and a gain of
    1e-6, in range for nothing, is refused whatever the way (0 in Q16.16)."""
    assert violation({"D_s": 0.3}) is None
    for way in Held:
        problem = violation({"trk_k1": 1e-6}, ways=(way,))
        assert problem is not None and problem.names == ("trk_k1",) and not problem.relation


def test_table_1s_defaults_pass_the_limits_table_in_every_way_it_is_held() -> None:
    """The scenario loader takes Table 1's parameters without a check when a
    scenario's [params] sets none (a sweep's scenes): the table must pass
    them, as the firmware's own defaults, in every way a value is held."""
    for way in Held:
        assert violation(params_values(Params()), ways=(way,)) is None, way
