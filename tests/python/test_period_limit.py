# SPDX-License-Identifier: MIT
"""Issue 21, case 7: control periods beyond the safety filter's proof.

The filter's guarantee (firmware/ctrl/cbf.h, docs/strategy.md) needs
α·dt <= 1, so dt <= 0.05 s with α = 20/s. Periods of 0.15 to 0.2 s at 1.5 to
3 m/s broke D_s and touched a head-on obstacle. Either the guarantee is kept
for every accepted period, or the period is refused with one line that says
why: a scenario whose run keeps D_s, or a one-line error naming sim.dt;
mstc-fw --period-ms likewise.
"""

from __future__ import annotations

import os
import subprocess
from collections.abc import Callable, Mapping
from pathlib import Path

import pytest

from conftest import scenario_or_refusal
from mstc.loop.lockstep import simulate
from mstc.sweep.engine import controller_for

D_S = 0.35
"""Safe distance for an obstacle of radius R_ob (Table 1 defaults)."""


@pytest.mark.parametrize("dt", [0.06, 0.1, 0.15, 0.2])
@pytest.mark.parametrize("speed", [1.5, 3.0])
def test_a_long_period_keeps_d_s_or_is_refused(
    write_scenario: Callable[[Mapping[str, object], str], Path],
    sil_lib: Path,
    dt: float,
    speed: float,
) -> None:
    path = write_scenario(
        {
            "robot": {"pose": [0.0, 0.0, 0.0]},
            "reference": {"pose": [0.1, 0.0, 0.0], "v": speed, "w": 0.0},
            "obstacles": [{"position": [8.0, 0.0]}],
            "sim": {"duration": 8.0, "dt": dt, "integrator": "euler"},
        },
        "long-period",
    )
    scenario = scenario_or_refusal(path, "sim.dt")
    if scenario is None:
        return
    run, controller = controller_for(scenario, "mstc", str(sil_lib))
    (closest,) = simulate(run, controller).min_distance
    assert closest >= D_S - 1e-3, f"dt {dt} s at {speed} m/s: {closest:.3f} m < D_s"


def test_mstc_fw_refuses_a_period_beyond_the_filter_s_proof_in_one_line() -> None:
    value = os.environ.get("MSTC_FW")
    if not value or not Path(value).is_file():
        pytest.fail(f"MSTC_FW={value!r}: run `make test-python`", pytrace=False)
    r = subprocess.run(
        [value, "--can", "vcan0", "--realtime", "--period-ms", "150"],
        capture_output=True,
        text=True,
        timeout=10,
    )
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "--period-ms" in r.stderr, r.stderr
