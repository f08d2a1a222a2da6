# SPDX-License-Identifier: MIT
"""The world a scenario makes: the robot, the reference, the obstacles and the
sensor at t = 0, with the scenario's imperfections. Both loops
(:mod:`mstc.loop.lockstep`, :mod:`mstc.loop.realtime`) run in it, whatever
their clock."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mstc.model import Obstacle
from mstc.plant.actuator import Actuator
from mstc.plant.plant import UnicyclePlant
from mstc.plant.reference import PathReference, ReferenceRobot
from mstc.plant.scenario import Scenario
from mstc.plant.sensor import RangeSensor, SlotSensor


def random_streams(
    seed: int,
) -> tuple[np.random.Generator, np.random.Generator, np.random.Generator]:
    """Independent random streams of a scene (odometry noise, sensor noise,
    dropouts), so that one imperfection's draws do not move when another is
    switched on."""
    odometry, sensor, dropout = np.random.SeedSequence(seed).spawn(3)
    return (
        np.random.Generator(np.random.PCG64(odometry)),
        np.random.Generator(np.random.PCG64(sensor)),
        np.random.Generator(np.random.PCG64(dropout)),
    )


@dataclass(frozen=True)
class World:
    """What a run moves and senses, whatever its clock."""

    plant: UnicyclePlant
    reference: ReferenceRobot | PathReference
    obstacles: tuple[Obstacle, ...]
    sensor: RangeSensor | SlotSensor
    odometry_rng: np.random.Generator
    """The stream of the odometry noise (the sensor has its own)."""
    actuator: Actuator | None = None
    """The "lag" wheels that move the plant (docs/scenarios.md,
    ``[actuator]``); None: the plant's own ideal wheels, or a
    :class:`~mstc.plant.plant.WheelDrive` the loop is given ("dc")."""


def make_world(scenario: Scenario) -> World:
    """The robot, the reference, the obstacles and the sensor at t = 0, with
    the scenario's imperfections (docs/scenarios.md)."""
    p = scenario.params
    sim = scenario.sim
    imp = scenario.imperfections
    plant = UnicyclePlant(scenario.robot, p.wheel_radius, p.track_width, sim.integrator)
    spec = scenario.reference
    ref: ReferenceRobot | PathReference
    if spec.path:
        ref = PathReference(spec.path, spec.v, sim.dt, wait=spec.wait)
    else:
        ref = ReferenceRobot(spec.pose, spec.v, spec.w, sim.integrator)
    obstacles = scenario.obstacles
    odometry_rng, sensor_rng, dropout_rng = random_streams(imp.seed)
    d_det = p.d_det if imp.sensor_range is None else imp.sensor_range
    sensor: RangeSensor | SlotSensor
    if scenario.slots:
        sensor = SlotSensor(
            obstacles, d_det, r_ob=p.r_ob, slots=scenario.slots, r_m=p.r_m, d_act=p.d_act
        )
    else:
        sensor = RangeSensor(
            obstacles,
            d_det,
            r_ob=p.r_ob,
            noise=imp.obstacle_noise,
            dropout=imp.dropout,
            rng=sensor_rng if (imp.obstacle_noise or imp.dropout) else None,
            dropout_rng=dropout_rng,
        )
    actuator = None
    if scenario.actuator.model == "lag":
        actuator = Actuator(scenario.actuator, plant, sim.dt, imp.delay + scenario.actuator.delay)
    return World(plant, ref, obstacles, sensor, odometry_rng, actuator)
