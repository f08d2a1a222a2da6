# SPDX-License-Identifier: MIT
"""Plant, reference robot and sensor against closed-form motion."""

import math

import pytest

from mstc.model import Obstacle, Pose
from mstc.plant.plant import Integrator, UnicyclePlant, body_velocity, integrate
from mstc.plant.reference import ReferenceRobot
from mstc.plant.sensor import RangeSensor


def run(pose: Pose, v: float, w: float, dt: float, steps: int, integrator: Integrator) -> Pose:
    for _ in range(steps):
        pose = integrate(pose, v, w, dt, integrator)
    return pose


def circle(pose: Pose, v: float, w: float, t: float) -> Pose:
    """Closed form: the robot runs on the circle of radius v/ω whose centre is
    v/ω to its left; after t it is at angle θ0 + ω t on that circle."""
    radius = v / w
    cx = pose.x - radius * math.sin(pose.theta)
    cy = pose.y + radius * math.cos(pose.theta)
    theta = pose.theta + w * t
    return Pose(cx + radius * math.sin(theta), cy - radius * math.cos(theta), theta)


def error(a: Pose, b: Pose) -> float:
    return max(abs(a.x - b.x), abs(a.y - b.y), abs(a.theta - b.theta))


@pytest.mark.parametrize("integrator", list(Integrator))
@pytest.mark.parametrize("v", [0.5, -0.3])
def test_integrators_follow_a_straight_line_exactly(integrator: Integrator, v: float) -> None:
    start = Pose(1.0, -2.0, 0.7)
    end = run(start, v, 0.0, 0.02, 500, integrator)
    distance = v * 10.0
    expected = Pose(1.0 + distance * math.cos(0.7), -2.0 + distance * math.sin(0.7), 0.7)
    assert error(end, expected) < 1e-12


@pytest.mark.parametrize("dt", [0.001, 0.02, 0.1, 0.5, 2.0])
@pytest.mark.parametrize(("v", "w"), [(0.48, -0.3), (0.5, 1.2), (-0.4, 0.25)])
def test_exact_integrator_stays_on_the_closed_form_circle_at_any_dt(
    dt: float, v: float, w: float
) -> None:
    start = Pose(4.5, 6.5, 0.8)
    steps = round(10.0 / dt)
    end = run(start, v, w, dt, steps, Integrator.EXACT)
    assert error(end, circle(start, v, w, steps * dt)) < 1e-11


def test_exact_integrator_with_vanishing_rate_is_the_straight_line() -> None:
    start = Pose(0.0, 0.0, -2.0)
    end = integrate(start, 1.0, 1e-15, 0.5, Integrator.EXACT)
    assert error(end, Pose(0.5 * math.cos(-2.0), 0.5 * math.sin(-2.0), -2.0)) < 1e-15


def test_euler_converges_at_first_order_on_a_circle() -> None:
    start = Pose(0.0, 0.0, 0.3)
    v, w, t_end = 0.5, 0.8, 4.0
    expected = circle(start, v, w, t_end)
    errors = [
        error(run(start, v, w, dt, round(t_end / dt), Integrator.EULER), expected)
        for dt in (0.01, 0.005, 0.0025)
    ]
    assert errors[0] > 1e-4  # far above rounding, so the ratios mean something
    for coarse, fine in zip(errors, errors[1:], strict=False):
        assert coarse / fine == pytest.approx(2.0, rel=0.05)


@pytest.mark.parametrize(
    ("left", "right", "v", "w"),
    [
        (10.0, 10.0, 0.5, 0.0),  # straight: v = r ω
        (-10.0, 10.0, 0.0, 0.05 * 20.0 / 0.3),  # on the spot, counter-clockwise
        (4.0, 8.0, 0.05 * 6.0, 0.05 * 4.0 / 0.3),
    ],
)
def test_body_velocity_of_the_differential_drive(
    left: float, right: float, v: float, w: float
) -> None:
    assert body_velocity(left, right, 0.05, 0.3) == pytest.approx((v, w), abs=1e-15)


def test_plant_step_drives_the_arc_of_its_wheel_speeds() -> None:
    # Wheels (4, 8) rad/s: v = 0.3 m/s, ω = 2/3 rad/s.
    plant = UnicyclePlant(Pose(1.0, 1.0, 0.0), 0.05, 0.3, Integrator.EXACT)
    for _ in range(100):
        plant.step(4.0, 8.0, 0.01)
    assert error(plant.pose, circle(Pose(1.0, 1.0, 0.0), 0.3, 2.0 / 3.0, 1.0)) < 1e-12


def test_reference_robot_closes_its_circle_after_one_period() -> None:
    # ω_r = π/10 rad/s: one turn in 20 s = 1000 periods of 0.02 s.
    ref = ReferenceRobot(Pose(4.5, 6.5, 0.8), 0.48, math.pi / 10, Integrator.EXACT)
    for _ in range(1000):
        ref.step(0.02)
    assert error(ref.pose, Pose(4.5, 6.5, 0.8 + 2 * math.pi)) < 1e-12


def test_sensor_reports_obstacles_within_range_inclusive_in_world_order() -> None:
    obstacles = [
        Obstacle(1, 3.0, 4.0, 0.1),  # at 5 m exactly
        Obstacle(2, 0.0, -5.1, 0.1),  # just out of range
        Obstacle(3, -1.0, 0.0, 0.3),
    ]
    sensor = RangeSensor(obstacles, 5.0)
    assert [o.id for o in sensor.scan(Pose(0.0, 0.0, 0.0))] == [1, 3]
    assert sensor.scan(Pose(100.0, 0.0, 0.0)) == []


def test_moving_obstacle_is_reported_where_it_is_at_the_step() -> None:
    o = Obstacle(1, 1.0, 2.0, 0.1, vx=0.5, vy=-0.25)
    sensor = RangeSensor([o], 10.0)
    (seen,) = sensor.scan(Pose(0.0, 0.0, 0.0), 4.0)
    # x = 1 + 0.5·4, y = 2 − 0.25·4, velocity reported as it is.
    assert (seen.x, seen.y, seen.vx, seen.vy) == (3.0, 1.0, 0.5, -0.25)
    assert sensor.scan(Pose(0.0, 0.0, 0.0), 0.0) == [o]  # where it starts at t = 0


def test_moving_obstacle_leaves_the_range_as_it_moves() -> None:
    sensor = RangeSensor([Obstacle(1, 0.0, 0.0, 0.1, vx=1.0)], 2.0)
    assert len(sensor.scan(Pose(0.0, 0.0, 0.0), 2.0)) == 1  # at 2 m exactly: seen
    assert sensor.scan(Pose(0.0, 0.0, 0.0), 2.5) == []


def test_sensor_noise_and_dropout_follow_their_stream() -> None:
    import numpy as np

    obstacles = [Obstacle(i, float(i), 0.0, 0.1) for i in range(1, 4)]
    sensor = RangeSensor(
        obstacles, 10.0, noise=0.1, dropout=0.5, rng=np.random.Generator(np.random.PCG64(7))
    )
    got = [sensor.scan(Pose(0.0, 0.0, 0.0)) for _ in range(200)]
    # The same draws, made here independently: noise (3, 2) then uniforms (3).
    rng = np.random.Generator(np.random.PCG64(7))
    for seen in got:
        noise, keep = rng.standard_normal((3, 2)) * 0.1, rng.random(3) >= 0.5
        want = [
            (o.id, o.x + noise[i, 0], o.y + noise[i, 1]) for i, o in enumerate(obstacles) if keep[i]
        ]
        assert [(o.id, o.x, o.y) for o in seen] == want
    kept = sum(len(s) for s in got) / (3 * len(got))
    assert 0.4 < kept < 0.6


def test_dropouts_from_their_own_stream_leave_the_noise_alone() -> None:
    import numpy as np

    obstacles = [Obstacle(i, float(i), 0.0, 0.1) for i in range(1, 4)]
    sensor = RangeSensor(
        obstacles,
        10.0,
        noise=0.1,
        dropout=0.5,
        rng=np.random.Generator(np.random.PCG64(7)),
        dropout_rng=np.random.Generator(np.random.PCG64(8)),
    )
    got = [sensor.scan(Pose(0.0, 0.0, 0.0)) for _ in range(200)]
    # The noise: stream 7 alone, as without dropouts; the dropouts: stream 8.
    noise_rng, drop_rng = (
        np.random.Generator(np.random.PCG64(7)),
        np.random.Generator(np.random.PCG64(8)),
    )
    for seen in got:
        noise, keep = noise_rng.standard_normal((3, 2)) * 0.1, drop_rng.random(3) >= 0.5
        want = [
            (o.id, o.x + noise[i, 0], o.y + noise[i, 1]) for i, o in enumerate(obstacles) if keep[i]
        ]
        assert [(o.id, o.x, o.y) for o in seen] == want


def test_noisy_sensor_without_a_stream_is_refused() -> None:
    with pytest.raises(ValueError, match="random stream"):
        RangeSensor([], 3.5, noise=0.1)
