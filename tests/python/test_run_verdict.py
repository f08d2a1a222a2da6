# SPDX-License-Identifier: MIT
"""A run that misses what its scenario expects says so and exits non-zero
(issue 21, case 13): a scenario whose ``[[expected]]`` event is 50 steps off
printed Δ +50 and exited 0, ``make sim`` too; a real-time run whose firmware
halted at 0.73 s (paper-circle on a loaded machine: only the two detections)
completed with status 0.

The expected times are the paper's (sim/scenarios/*.toml, checked against
the paper by test_paper.py), moved by hand; the halted run is the real-time
loop against the firmware library on test_realtime's virtual clock, the
plant held up for 0.3 s at 0.7 s (a descheduled process): the firmware finds
no odometry for three periods and halts (docs/safety.md).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import pytest

from conftest import SCENARIOS, TEST_KEY_FILE
from mstc.can.protocol import wire_limits
from mstc.cli import main
from mstc.cli.common import run_scenarios
from mstc.errors import ExpectationError, MstcError
from mstc.loop.result import RunResult
from mstc.plant.scenario import Scenario, load_scenario
from test_realtime import run_virtual

ROOT = Path(__file__).resolve().parents[2]


def _late(tmp_path: Path, name: str, tolerance: str = "") -> Path:
    """paper-line.toml with its first activation expected 1 s (50 steps) late."""
    text = (SCENARIOS / "paper-line.toml").read_text()
    assert text.count("t = 6.82\n") == 1
    path = tmp_path / f"{name}.toml"
    path.write_text(text.replace("t = 6.82\n", f"t = 7.82\n{tolerance}"))
    return path


def test_an_expected_event_off_by_50_steps_fails_the_run(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = _late(tmp_path, "late")
    args = ["sim", "--bus", "memory", "--lib", str(sil_lib), "--no-figures", "-q"]
    rc = main([*args, "--out", str(tmp_path / "out"), str(scenario)])
    captured = capsys.readouterr()
    assert "-50" in captured.out  # the table is still printed, outputs written
    assert (tmp_path / "out" / "late" / "events.json").is_file()
    assert rc == 4, rc  # docs/scenarios.md: the run is done, its expectations missed
    last = captured.err.strip().splitlines()[-1]
    assert last.startswith(f"error: {scenario}: ") and "activate O1" in last, last


def test_an_event_within_its_tolerance_passes(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = _late(tmp_path, "tolerated", "tolerance = 1.0\n")
    args = ["sim", "--bus", "memory", "--lib", str(sil_lib), "--no-figures", "-q"]
    assert main([*args, "--out", str(tmp_path / "out"), str(scenario)]) == 0
    assert capsys.readouterr().err == ""


def test_make_sim_fails_on_a_missed_expectation(tmp_path: Path, sil_lib: Path) -> None:
    scenario = _late(tmp_path, "i21-missed-expectation")
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    try:
        r = subprocess.run(
            [
                "make",
                "--no-print-directory",
                "sim",
                f"SCENARIO={scenario}",
                "BUS=memory",
                f"KEY_FILE={TEST_KEY_FILE}",
            ],  # fmt: skip
            cwd=ROOT,
            capture_output=True,
            text=True,
            env=env,
            timeout=600,
        )
    finally:
        shutil.rmtree(ROOT / "build" / "sim" / scenario.stem, ignore_errors=True)
    assert r.returncode != 0, r.stdout[-2000:]
    assert "activate O1" in r.stderr


def test_a_real_time_run_that_ends_halted_fails(tmp_path: Path, sil_lib: Path) -> None:
    path = SCENARIOS / "paper-circle.toml"
    scenario = load_scenario(path, wire_limits())
    run = run_virtual(scenario, sil_lib, stall=(0.7, 0.3))
    kinds = [str(e.kind) for e in run.result.events]
    assert kinds == ["detect", "detect"]  # the halt of the issue: nothing after
    with pytest.raises(MstcError) as info:
        run_scenarios(
            [path], tmp_path, False, lambda s, bar: ("virtual firmware", run.result, None), ()
        )
    assert info.value.exit_status != 0
    last = str(info.value).splitlines()[-1]
    assert str(path) in last and "halted" in last, last


def test_a_comm_loss_trial_halts_as_asked_and_passes(tmp_path: Path, sil_lib: Path) -> None:
    """--stop-odometry-at asks for the halt; the events expected after the
    cut cannot happen and are not judged, the ones before are."""
    path = SCENARIOS / "paper-line.toml"
    scenario = load_scenario(path, wire_limits())
    run = run_virtual(scenario, sil_lib, stop_odometry_at=3.5)
    assert run.result.halt == 2  # odometry (docs/safety.md)

    def run_one(s: Scenario, bar: object) -> tuple[str, RunResult, None]:
        return ("virtual firmware", replace(run.result, scenario=s), None)

    assert run_scenarios([path], tmp_path / "a", False, run_one, (), stop_at=3.5) == 0
    # The detection of O2 at 3.10 s is judged: expected a step later, it misses.
    late = tmp_path / "late.toml"
    late.write_text(path.read_text().replace("t = 3.10\n", "t = 3.12\n"))
    with pytest.raises(ExpectationError, match=r"detect O2 expected at 3.12 s"):
        run_scenarios([late], tmp_path / "b", False, run_one, (), stop_at=3.5)
