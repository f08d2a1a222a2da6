# SPDX-License-Identifier: MIT
"""The plant's wheels (sim/mstc/plant/actuator.py, docs/scenarios.md [actuator])
against hand computation: the lag, the acceleration limit, the encoder's
quantisation, the delay; the scenario loader handing the firmware its
parameters; and runs end to end with the actuator, in memory and over CAN.

Expected values: the closed forms written beside each test, from the model's
definition (a first-order lag is exact per substep, so after n substeps of
h a step response is u (1 − e^(−n h / τ)); a speed limited to a·h per
substep ramps linearly; the encoder counts floor(angle · N / 2π)).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from pathlib import Path

import can
import pytest

from mstc.can.protocol import wire_limits
from mstc.errors import ScenarioError
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import CanController, simulate
from mstc.model import Pose
from mstc.plant.actuator import Actuator, substeps
from mstc.plant.plant import Integrator, UnicyclePlant
from mstc.plant.scenario import DC_HANDED, IDEAL_WHEEL_ACCEL, ActuatorSpec, Scenario
from mstc.plant.scenario import load_scenario as load_with_wire

R, TRACK, DT = 0.05, 0.3, 0.02


def load_scenario(path: Path) -> Scenario:
    return load_with_wire(path, wire_limits())


def wheels(spec: ActuatorSpec, delay: int = 0) -> Actuator:
    plant = UnicyclePlant(Pose(0.0, 0.0, 0.0), R, TRACK, Integrator.EULER)
    return Actuator(spec, plant, DT, delay)


def test_a_period_is_cut_into_substeps_of_at_most_a_millisecond() -> None:
    assert substeps(0.02) == 20
    assert substeps(0.001) == 1
    assert substeps(0.0105) == 11
    assert substeps(0.0001) == 1


def test_the_lag_is_a_first_order_step_response() -> None:
    # No acceleration limit: after a period, u (1 − e^(−dt/τ)); after two,
    # u (1 − e^(−2 dt/τ)). The exact measurement (no encoder) is the mean
    # over the period of the substeps' trapezoid, ∫ = u (t − τ (1 − e^(−t/τ)))
    # to the trapezoid's error (h²/12 of the curvature: 1e-4 relative here).
    act = wheels(ActuatorSpec(time_constant=0.05))
    left, right = act.step(10.0, -4.0)
    assert act.speed[0] == pytest.approx(10.0 * (1.0 - math.exp(-0.4)), rel=1e-12)
    assert act.speed[1] == pytest.approx(-4.0 * (1.0 - math.exp(-0.4)), rel=1e-12)
    mean = 10.0 * (DT - 0.05 * (1.0 - math.exp(-0.4))) / DT
    assert left == pytest.approx(mean, rel=2e-4)
    assert right == pytest.approx(-0.4 * mean, rel=2e-4)
    act.step(10.0, -4.0)
    assert act.speed[0] == pytest.approx(10.0 * (1.0 - math.exp(-0.8)), rel=1e-12)


def test_the_acceleration_limit_ramps_the_speed() -> None:
    # No lag, 20 rad/s²: 0.02 rad/s per substep, 0.4 rad/s a period, so a
    # setpoint of 1 rad/s is reached in the third period (0.4, 0.8, 1.0);
    # the mean over the first period is 0.2 rad/s (a linear ramp), exact.
    act = wheels(ActuatorSpec(max_accel=20.0))
    left, right = act.step(1.0, -1.0)
    assert act.speed == pytest.approx([0.4, -0.4], abs=1e-12)
    assert left == pytest.approx(0.2, abs=1e-12)
    assert right == pytest.approx(-0.2, abs=1e-12)
    act.step(1.0, -1.0)
    assert act.speed == pytest.approx([0.8, -0.8], abs=1e-12)
    act.step(1.0, -1.0)
    assert act.speed == pytest.approx([1.0, -1.0], abs=1e-12)


def test_lag_and_limit_together_the_limit_binds_first() -> None:
    # τ = 0.06 s and 20 rad/s² from rest towards 10 rad/s: the lag asks
    # (10 − w)(1 − e^(−h/τ)) ≈ 0.166 rad/s of the first substep, the limit
    # allows 0.02: the limit binds while 10 − w > a τ ≈ 1.2 rad/s, so the
    # first period is the ramp of the test above.
    act = wheels(ActuatorSpec(time_constant=0.06, max_accel=20.0))
    act.step(10.0, 10.0)
    assert act.speed == pytest.approx([0.4, 0.4], abs=1e-12)


def test_the_encoder_quantises_the_measured_speed() -> None:
    # No lag, no limit, 1,920 counts a turn: the wheel jumps to 10 rad/s in
    # the first substep (its mean there 5 rad/s), so after a period its
    # angle is 0.001 × 5 + 0.019 × 10 = 0.195 rad: floor(0.195 × 1920 / 2π)
    # = floor(59.588) = 59 counts, reported as 59 × 2π / (1920 × 0.02) =
    # 9.65373 rad/s. The next period turns 0.2 rad more: 0.395 rad,
    # floor(120.70) = 120 counts, 61 more: 9.98097 rad/s.
    act = wheels(ActuatorSpec(encoder_counts=1920))
    left, right = act.step(10.0, 10.0)
    assert act.count == [59, 59]
    assert left == pytest.approx(59 * math.tau / (1920 * DT), rel=1e-12)
    assert left == right
    left, _ = act.step(10.0, 10.0)
    assert act.count[0] == 120
    assert left == pytest.approx(61 * math.tau / (1920 * DT), rel=1e-12)


def test_negative_angles_count_down() -> None:
    # Backwards: −0.195 rad, floor(−59.588) = −60 counts.
    act = wheels(ActuatorSpec(encoder_counts=1920))
    left, _ = act.step(-10.0, -10.0)
    assert act.count[0] == -60
    assert left == pytest.approx(-60 * math.tau / (1920 * DT), rel=1e-12)


def test_the_delay_holds_the_setpoints_back() -> None:
    act = wheels(ActuatorSpec(), delay=2)
    assert act.step(10.0, 10.0) == (0.0, 0.0)
    assert act.step(20.0, 20.0) == (0.0, 0.0)
    left, _ = act.step(30.0, 30.0)
    assert act.speed == [10.0, 10.0]  # the first command, two periods late
    assert left == pytest.approx((0.001 * 5.0 + 0.019 * 10.0) / DT, rel=1e-12)


def test_the_pose_follows_the_wheels_angles() -> None:
    # Both wheels alike: a straight line along θ = 0 of length r × angle,
    # whatever the speeds did within the period (v = r times the wheels'
    # mean over each substep, the same trapezoid as the angle).
    act = wheels(ActuatorSpec(time_constant=0.06, max_accel=20.0))
    for _ in range(30):
        act.step(15.0, 15.0)
    pose = act.plant.pose
    assert pose.y == 0.0 and pose.theta == 0.0
    assert pose.x == pytest.approx(R * act.angle[0], rel=1e-12)
    # Opposite wheels: a turn in place of r (θ_R − θ_L) / L.
    act = wheels(ActuatorSpec(time_constant=0.06, max_accel=20.0))
    for _ in range(10):
        act.step(-5.0, 5.0)
    pose = act.plant.pose
    assert pose.x == pytest.approx(0.0, abs=1e-15)
    assert pose.theta == pytest.approx(R * (act.angle[1] - act.angle[0]) / TRACK, rel=1e-12)


# ------------------------------------------------------------ the loader


def _scene(extra: Mapping[str, object]) -> dict[str, object]:
    doc: dict[str, object] = {
        "robot": {"pose": [0.0, 0.0, 0.0]},
        "reference": {"pose": [0.0, 0.0, 0.0], "v": 0.5, "w": 0.0},
        "obstacles": [{"position": [3.0, 0.05]}],
        "sim": {"duration": 10.0, "dt": 0.02, "integrator": "euler"},
    }
    doc.update(extra)
    return doc


Write = Callable[[Mapping[str, object], str], Path]


def test_no_actuator_hands_the_firmware_ideal_wheels(write_scenario: Write) -> None:
    s = load_scenario(write_scenario(_scene({}), "ideal"))
    assert s.actuator == ActuatorSpec("ideal")
    assert (s.params.wheel_accel, s.params.wheel_tau) == (IDEAL_WHEEL_ACCEL, 0.0)


def test_dc_wheels_are_handed_the_motors_acceleration_and_a_slower_lag(
    write_scenario: Write,
) -> None:
    s = load_scenario(write_scenario(_scene({"actuator": {"model": "dc"}}), "dc"))
    assert s.actuator == ActuatorSpec("dc")
    assert (s.params.wheel_accel, s.params.wheel_tau) == (125.0, 0.06)
    assert DC_HANDED == {"wheel_accel": 125.0, "wheel_tau": 0.06}


def test_the_actuator_is_handed_to_the_firmware_unless_params_say_otherwise(
    write_scenario: Write,
) -> None:
    act = {"time_constant": 0.1, "max_accel": 10.0, "encoder_counts": 1920, "delay": 2}
    s = load_scenario(write_scenario(_scene({"actuator": act}), "sluggish"))
    assert s.actuator == ActuatorSpec("lag", 0.1, 10.0, 1920, 2)
    explicit = _scene({"actuator": {"model": "lag", **act}})
    assert load_scenario(write_scenario(explicit, "explicit")).actuator == s.actuator
    # wheel_tau = time_constant + delay × dt = 0.1 + 0.04
    assert s.params.wheel_accel == 10.0
    assert s.params.wheel_tau == pytest.approx(0.14, abs=1e-15)
    told = _scene({"actuator": act, "params": {"wheel_accel": 20.0}})
    s = load_scenario(write_scenario(told, "mismatch"))
    assert s.params.wheel_accel == 20.0
    assert s.params.wheel_tau == pytest.approx(0.14, abs=1e-15)


@pytest.mark.parametrize(
    ("actuator", "message"),
    [
        ({"time_constant": -0.1}, "actuator.time_constant: must be >= 0"),
        ({"max_accel": 0.0}, "actuator.max_accel: must be > 0"),
        ({"encoder_counts": 0}, "actuator.encoder_counts: must be >= 1"),
        ({"delay": 1.5}, "actuator.delay: must be an integer"),
        ({"lag": 0.1}, "actuator.lag: unknown key"),
        ({"model": "dc", "max_accel": 20.0}, 'actuator.max_accel: belongs to model "lag"'),
        ({"model": "ideal", "delay": 1}, 'actuator.delay: belongs to model "lag"'),
        ({"max_accel": 0.5}, "actuator.max_accel: hands the firmware wheel_accel = 0.5"),
        ({"time_constant": 2.0}, "actuator.time_constant: hands the firmware wheel_tau = 2"),
    ],
)
def test_a_bad_actuator_is_one_line_naming_the_key(
    write_scenario: Write, actuator: dict[str, object], message: str
) -> None:
    with pytest.raises(ScenarioError, match=message.replace(".", r"\.")):
        load_scenario(write_scenario(_scene({"actuator": actuator}), "bad"))


# ------------------------------------------------------------ end to end


def test_a_run_with_the_actuator_hands_the_firmware_what_the_wheels_measure(
    write_scenario: Write, sil_lib: Path
) -> None:
    # The firmware gets each period's measured speeds: record what it is
    # given and compare with an actuator stepped here on the same commands.
    act = {"time_constant": 0.06, "max_accel": 20.0, "encoder_counts": 1920}
    scenario = load_scenario(write_scenario(_scene({"actuator": act}), "gearmotor"))
    controller = SilController(scenario.params, sil_lib)
    given: list[tuple[float, float] | None] = []
    commands: list[tuple[float, float]] = []
    step = controller.step_values

    def spy(*args: object) -> object:
        given.append(args[-1])  # type: ignore[arg-type]
        out = step(*args)  # type: ignore[arg-type]
        commands.append((out[0], out[1]))
        return out

    controller.step_values = spy  # type: ignore[method-assign]
    result = simulate(scenario, controller)
    assert given[0] == (0.0, 0.0)
    mirror = wheels(ActuatorSpec("lag", 0.06, 20.0, 1920))
    for k, (left, right) in enumerate(commands[:-1]):
        assert given[k + 1] == mirror.step(left, right)
    # The rate limiter (20 rad/s² at 0.02 s: 0.4 rad/s a period) on every
    # wheel command, from standstill.
    previous = (0.0, 0.0)
    for left, right in commands:
        assert abs(left - previous[0]) <= 0.4 + 1e-6 and abs(right - previous[1]) <= 0.4 + 1e-6
        previous = (left, right)
    assert min(result.min_distance) > scenario.params.safe_distance(0.1)


def test_the_ideal_plant_is_untouched_by_an_empty_actuator_of_its_own(
    write_scenario: Write, sil_lib: Path
) -> None:
    # Without a table the loop never builds an actuator: its trace is the
    # one of the ideal plant; with an [actuator] of no lag, no limit and no
    # encoder the wheels reach their command in the first millisecond, a
    # different (and close) path.
    ideal = load_scenario(write_scenario(_scene({}), "ideal"))
    near = load_scenario(write_scenario(_scene({"actuator": {"delay": 0}}), "near"))
    a = simulate(ideal, SilController(ideal.params, sil_lib))
    b = simulate(near, SilController(near.params, sil_lib))
    assert not (a.trace.values == b.trace.values).all()
    assert abs(a.trace["x"][-1] - b.trace["x"][-1]) < 0.01


def test_frames_carry_the_measured_speeds(write_scenario: Write, sil_lib: Path) -> None:
    """Over the SIL frame path the plant sends WHEEL_SPEED before each STEP
    with the values the in-memory step gets, and both give the same run."""
    act = {"time_constant": 0.06, "max_accel": 20.0, "encoder_counts": 1920}
    scenario = load_scenario(write_scenario(_scene({"actuator": act}), "frames"))
    scenario = dataclasses.replace(scenario, sim=dataclasses.replace(scenario.sim, duration=4.0))
    sent: list[can.Message] = []
    with can.Bus(interface="mstc-sil", lib=str(sil_lib)) as bus:
        controller = CanController(bus, scenario.params, sim_time_stamps=True)
        send = controller._send

        def record(msg: can.Message) -> None:
            sent.append(msg)
            send(msg)

        controller._send = record  # type: ignore[method-assign]
        can_run = simulate(scenario, controller)
    mem_run = simulate(scenario, SilController(scenario.params, sil_lib))
    speeds = [m for m in sent if m.arbitration_id == 0x105]
    steps = [m for m in sent if m.arbitration_id == 0x104]
    assert len(speeds) == len(steps) == scenario.sim.steps + 1
    # Scaled to 2^-10 rad/s on the wire, so the frame path is within a
    # millimetre of the in-memory one, not bit-equal.
    assert abs(can_run.trace["x"] - mem_run.trace["x"]).max() < 1e-3
