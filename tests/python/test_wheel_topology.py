# SPDX-License-Identifier: MIT
"""Where the control step's measured wheel speeds come from (issue 32;
docs/wheel.md, "Two topologies").

- The integrated board ("dc" wheels: the firmware's own wheel loop on its
  own motors): the step takes that loop's estimate, so a wrong WHEEL_SPEED
  on the bus changes nothing: the run is the same bit for bit, through CAN
  frames (the library's firmware instance, ``SilBus.attach_wheels``) and in
  memory (``SilController(wheels=...)``). The board reports what it
  measured as WHEEL_SPEED, every step.
- External drives ("lag" wheels: drivers that report WHEEL_SPEED): the same
  wrong frames do change the run; WHEEL_SPEED is the input there.
- Halt rules: a dead encoder on the integrated board halts it with reason 7
  (wheel speeds), as a missing WHEEL_SPEED halts a board on external drives
  (tests/unit/test_app_safety.c, test_app_wheels.c).

The wrong frames: 40 and -40 rad/s, a spin the robot never makes on the
paper's line, sent before every STEP.
"""

from __future__ import annotations

import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mstc.can.protocol import load_database, wire_limits
from mstc.firmware.sil import SilController
from mstc.firmware.wheels import DcWheels, wheels_for
from mstc.loop.lockstep import CanController, simulate, simulate_on_sil_bus
from mstc.loop.result import RunResult
from mstc.model import Obstacle, Pose, StepResult
from mstc.plant.scenario import Scenario, parse_scenario

ROOT = Path(__file__).resolve().parents[2]
WRONG = (40.0, -40.0)
"""What the lying frames say [rad/s]."""
HALT_WHEEL_SPEED = 7
"""STATUS_halt "wheel_speed" (mstc.dbc)."""


def _line(actuator: dict[str, Any]) -> Scenario:
    """The paper's line under "mstc" on @p actuator, 6 s."""
    data = tomllib.loads((ROOT / "sim" / "scenarios" / "paper-line.toml").read_text())
    data["params"] = {"strategy": "mstc"}
    data["sim"]["duration"] = 6.0
    data.pop("expected", None)
    data["actuator"] = actuator
    return parse_scenario(data, "line.toml", wire_limits())


DC = {"model": "dc"}
LAG = {"time_constant": 0.06, "max_accel": 20.0, "encoder_counts": 1920}
"""The suite's "gearmotor" profile: drives that report what they measure."""


class Lying:
    """A controller whose every step is preceded by a wrong WHEEL_SPEED: the
    wheel speeds the loop hands it are replaced by :data:`WRONG`, which a
    CanController sends as a WHEEL_SPEED frame and a SilController takes as
    its measured speeds."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.halt: int | None = None

    def step(
        self,
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        obstacles: Sequence[Obstacle],
        t_us: int,
        wheel_speeds: tuple[float, float] | None = None,
    ) -> StepResult:
        result: StepResult = self.inner.step(robot, ref, v_r, w_r, obstacles, t_us, WRONG)
        self.halt = getattr(self.inner, "halt", None)
        return result


def _through_can(scenario: Scenario, lib: Path, lie: bool) -> tuple[RunResult, CanController]:
    """@p scenario through CAN frames in process: the firmware an integrated
    board on the scenario's "dc" wheels, on external drives otherwise."""
    result, ctl, _ = simulate_on_sil_bus(
        scenario, lib, wheels_for(scenario, lib), wrap=Lying if lie else None
    )
    return result, ctl


def _in_memory(scenario: Scenario, lib: Path, lie: bool) -> RunResult:
    wheels = wheels_for(scenario, lib)
    controller = SilController(scenario.params, lib, wheels)
    return simulate(scenario, Lying(controller) if lie else controller, wheels=wheels)


def _same(a: RunResult, b: RunResult) -> bool:
    return np.array_equal(a.trace.values, b.trace.values) and a.events == b.events


def test_a_wrong_wheel_speed_has_no_effect_on_the_integrated_board(sil_lib: Path) -> None:
    scenario = _line(DC)
    honest, ctl = _through_can(scenario, sil_lib, lie=False)
    lied, lied_ctl = _through_can(scenario, sil_lib, lie=True)
    # The lie did cross the bus, each step.
    db = load_database()
    wheel_speed_id = db.get_message_by_name("WHEEL_SPEED").frame_id
    sent = [m for m, ours in lied_ctl.traffic.frames if ours and m.arbitration_id == wheel_speed_id]
    assert len(sent) == scenario.sim.steps + 1
    assert _same(honest, lied)
    assert (ctl.halt, lied_ctl.halt) == (0, 0)
    # In memory: the same.
    assert _same(_in_memory(scenario, sil_lib, False), _in_memory(scenario, sil_lib, True))


def test_a_wrong_wheel_speed_misleads_a_board_on_external_drives(sil_lib: Path) -> None:
    scenario = _line(LAG)
    honest, _ = _through_can(scenario, sil_lib, lie=False)
    lied, _ = _through_can(scenario, sil_lib, lie=True)
    assert not np.array_equal(honest.trace.values, lied.trace.values)
    assert not _same(_in_memory(scenario, sil_lib, False), _in_memory(scenario, sil_lib, True))


def test_the_integrated_board_reports_what_it_measured(sil_lib: Path) -> None:
    """Every step's first frame from the firmware is its WHEEL_SPEED, the
    loop's estimate as the wheels' state had it at that step."""
    scenario = _line(DC)
    wheels = wheels_for(scenario, sil_lib)
    assert wheels is not None
    measured: list[tuple[float, float]] = []
    drive = wheels.drive

    def recording(plant: Any, left: float, right: float, dt: float) -> None:
        drive(plant, left, right, dt)
        measured.append(wheels.state.measured)

    wheels.drive = recording  # type: ignore[method-assign]  # record what the board measures
    _, ctl, _ = simulate_on_sil_bus(scenario, sil_lib, wheels)
    db = load_database()
    message = db.get_message_by_name("WHEEL_SPEED")
    reports = [
        message.decode(bytes(m.data))
        for m, ours in ctl.traffic.frames
        if not ours and m.arbitration_id == message.frame_id
    ]
    # One a step; the first is of the state at t = 0 (at rest).
    assert len(reports) == scenario.sim.steps + 1
    assert (reports[0]["WHEEL_SPEED_left"], reports[0]["WHEEL_SPEED_right"]) == (0.0, 0.0)
    lsb = 2.0**-10
    for report, (left, right) in zip(reports[1:], measured, strict=True):
        assert report["WHEEL_SPEED_left"] == pytest.approx(left, abs=lsb)
        assert report["WHEEL_SPEED_right"] == pytest.approx(right, abs=lsb)
        assert report["WHEEL_SPEED_faults"] == 0
    assert max(abs(r["WHEEL_SPEED_left"]) for r in reports) > 5.0  # it did drive


class KillingEncoder:
    """A controller that kills the left encoder of @p wheels before step
    @p at, then steps on."""

    def __init__(self, inner: CanController, wheels: DcWheels, at: int) -> None:
        self.inner, self.wheels, self.at, self.k = inner, wheels, at, 0
        self.halts: list[int] = []

    def step(self, *args: Any, **kwargs: Any) -> StepResult:
        if self.k == self.at:
            self.wheels.loop.kill_encoder(0)
        self.k += 1
        result: StepResult = self.inner.step(*args, **kwargs)
        self.halts.append(int(self.inner.halt or 0))
        return result


def test_a_dead_encoder_halts_the_integrated_board(sil_lib: Path) -> None:
    """The left encoder dies at step 100 (2 s, the robot driving): the wheel
    loop flags it within 0.1 s of drive without a count (docs/wheel.md), and
    the firmware halts with reason 7 at the next step that has the fault,
    within 6 steps (0.1 s and a period of the measurement's)."""
    scenario = _line(DC)
    wheels = wheels_for(scenario, sil_lib)
    assert wheels is not None
    killers: list[KillingEncoder] = []

    def killer(ctl: CanController) -> KillingEncoder:
        killers.append(KillingEncoder(ctl, wheels, 100))
        return killers[0]

    simulate_on_sil_bus(scenario, sil_lib, wheels, wrap=killer)
    halts = killers[0].halts
    first = next(k for k, h in enumerate(halts) if h)
    assert halts[first] == HALT_WHEEL_SPEED
    assert 100 < first <= 106
    assert all(h == HALT_WHEEL_SPEED for h in halts[first:])
