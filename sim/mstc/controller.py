# SPDX-License-Identifier: MIT
"""What the run loop needs from the firmware, independent of how it is reached.

The loop talks to a :class:`Controller`: one call per control period, plain
Python values in and out. :class:`mstc.firmware.SilController` implements
it by calling the firmware's step in-process; a CAN transport implements the
same protocol with frames, and the loop does not change.
"""

from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntFlag, StrEnum
from typing import Protocol

from mstc.sim.plant import Pose
from mstc.sim.sensor import Obstacle


class Mode(StrEnum):
    """Which controller ran (sup_mode_t)."""

    TRACK = "track"
    """Trajectory tracking, eq. (1)-(3)."""
    AVOID = "avoid"
    """Obstacle avoidance, eq. (9)-(24)."""
    STOP = "stop"
    """p3: v_r = ω_r = 0."""
    BLOCKED = "blocked"
    """Strategy "mstc": no way on; the robot waits, stopped (docs/strategy.md)."""


class EventKind(StrEnum):
    """Switching events (sup_event_kind_t)."""

    DETECT = "detect"
    """First step with D_r <= D_det (Definition 1)."""
    ACTIVATE = "activate"
    """p2 held: avoidance starts, on a side."""
    COMPLETE = "complete"
    """p1 held for the active obstacle: tracking resumes."""
    BLOCKED = "blocked"
    """Strategy "mstc": the robot stops and waits, no way on (docs/strategy.md)."""
    RESUME = "resume"
    """Strategy "mstc": the way cleared; the blocked robot moves again."""
    FILTER = "filter"
    """Strategy "mstc": the first step of an intervention of the safety filter,
    on the obstacle that constrained it."""
    INFEASIBLE = "infeasible"
    """Strategy "mstc": the first step at which the safety filter finds an
    obstacle coming in that no command within the wheels' limits keeps away."""


class Side(StrEnum):
    """Side of the avoidance, the sign of α in eq. (10)-(12) (docs/equations.md, side naming)."""

    LEFT = "left"
    """α = +π/2: the robot turns to its left, the obstacle on its right."""
    RIGHT = "right"
    """α = −π/2: the robot turns to its right."""


class Fault(IntFlag):
    """Status bits of a step (CTL_FAULT_*)."""

    INPUT_NONFINITE = 1
    """A pose or velocity was NaN or infinite: the robot was stopped."""
    OBSTACLE_DROPPED = 2
    """An obstacle report was rejected (bad value, or the table was full)."""
    SATURATED = 4
    """Wheel speeds were scaled down to the limit."""
    FRAME_DROPPED = 8
    """Through CAN only: a received frame failed its checks since the last
    STATUS (wrong length, CRC, alive counter, unknown identifier)."""
    FILTER = 16
    """Strategy "mstc": the safety filter changed the command this step."""
    TELEMETRY_CLIPPED = 32
    """Through CAN only: a value the firmware sent since the last STATUS (in
    it, STATUS_TRK or WHEEL_CMD) was beyond its field's range and clipped."""


@dataclass(frozen=True)
class Event:
    """A switching event, stamped with the time of the step that emitted it."""

    t_us: int
    """Step time [µs]."""
    kind: EventKind
    obstacle: int
    """Obstacle id."""
    side: Side | None = None
    """Set on ACTIVATE only."""

    @property
    def t(self) -> float:
        """Step time [s]."""
        return self.t_us / 1e6


@dataclass(frozen=True)
class Status:
    """What the controller did in one step (telemetry)."""

    mode: Mode
    active_obstacle: int
    """Id of the obstacle being avoided, 0 when none."""
    side: Side | None
    faults: Fault
    e1: float
    """Tracking error along the robot's heading [m], eq. (1)."""
    e2: float
    """Tracking error across the robot's heading [m], eq. (1)."""
    e3: float
    """Heading error wrap(θ_r − θ) [rad], eq. (1)."""
    e: float
    """Avoidance heading error wrap(β − θ) [rad], eq. (21); 0 unless avoiding."""
    v: float
    """Commanded linear velocity after saturation [m/s]."""
    w: float
    """Commanded angular velocity after saturation [rad/s]."""


@dataclass(frozen=True)
class StepResult:
    """Outputs of one control step."""

    wheel_left: float
    """Left wheel angular speed command [rad/s]."""
    wheel_right: float
    """Right wheel angular speed command [rad/s]."""
    status: Status
    events: tuple[Event, ...]


class Controller(Protocol):
    """The firmware's control step, however it is reached."""

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
        """Run one control period.

        :param robot: robot pose at the start of the period.
        :param ref: reference pose at the same instant.
        :param v_r: reference linear velocity [m/s].
        :param w_r: reference angular velocity [rad/s].
        :param obstacles: what the range sensor reports now.
        :param t_us: step time [µs].
        :param wheel_speeds: the wheel speeds the wheels' drivers measured
            (left, right) [rad/s], each the mean over the period that just
            ended (WHEEL_SPEED), or None when the plant has none (ideal
            wheels): the controller then predicts them from its commands.

        :returns: Wheel speed commands, status and the events of this step.
        """
        ...
