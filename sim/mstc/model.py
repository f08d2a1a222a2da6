# SPDX-License-Identifier: MIT
"""The ground floor of mstc: the domain types every other module speaks.

The robot's pose, an obstacle, the controller's parameters and strategy, one
control step's result and the :class:`Controller` that produces it, the
:class:`Progress` a long run reports to, and what the wire carries of a
scenario's values (:class:`WireLimits`). This module imports nothing else of
the package (docs/architecture.md, "The Python package"), so the plant, the
loops, CAN, logs, sweeps and reports can all use these types without knowing
each other.

The parameters' defaults are those of the limits table
(``firmware/ctrl/ctl_params.toml``), the same the firmware's
``ctl_params_default`` is generated from; :mod:`mstc.limits` checks the
table and judges parameter sets against it.
"""

from __future__ import annotations

import functools
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from enum import IntFlag, StrEnum
from pathlib import Path
from typing import Any, NamedTuple, Protocol

# ------------------------------------------------------------------ geometry


class Pose(NamedTuple):
    """Pose in the world frame."""

    x: float
    """[m]"""
    y: float
    """[m]"""
    theta: float
    """Heading [rad], not wrapped: it grows continuously as the robot turns."""


def wrap_angle(a: float) -> float:
    """Angle @p a wrapped into (-π, π], as a heading sensor reports it."""
    w = math.remainder(a, math.tau)
    return math.pi if w == -math.pi else w


@dataclass(frozen=True)
class Obstacle:
    """A circular obstacle: as a scenario places it, the world holds it and the
    sensor reports it."""

    id: int
    """1-based index in the scenario file, stable over the run."""
    x: float
    """Centre [m] (at t = 0 in the world; where it was seen in a report)."""
    y: float
    """Centre [m]."""
    radius: float
    """[m], > 0."""
    vx: float = 0.0
    """Constant velocity [m/s]; 0 for a static obstacle. The centre is at
    (x + vx t, y + vy t)."""
    vy: float = 0.0
    """[m/s]."""

    @property
    def moving(self) -> bool:
        """Whether the obstacle moves."""
        return self.vx != 0.0 or self.vy != 0.0

    def at(self, t: float) -> Obstacle:
        """The obstacle at time @p t [s]: moved by its velocity (itself when static)."""
        if not self.moving:
            return self
        return replace(self, x=self.x + self.vx * t, y=self.y + self.vy * t)

    def distance(self, pose: Pose) -> float:
        """Centre-to-centre distance D_r to a robot at ``pose`` [m], eq. (5)."""
        return math.hypot(self.x - pose.x, self.y - pose.y)


# ------------------------------------------------------------------ one step


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


StepValues = tuple[float, float, Mode, int, float, float, float, float, tuple[Event, ...]]
"""What the lock-step loop records of one step: the wheel speeds (left,
right), the mode, the fault bits, e1, e2, e3, e and the events (a
controller's ``step_values``, when it has one, returns them without building
a :class:`StepResult`)."""


class Controller(Protocol):
    """The firmware's control step, however it is reached: in process
    (:class:`mstc.firmware.sil.SilController`), through CAN frames
    (:class:`mstc.loop.lockstep.CanController`), or a baseline
    (:class:`mstc.sweep.dwa.DwaController`)."""

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


class Progress(Protocol):
    """Where a long run says how far it has come (a progress bar on the
    command line: :class:`mstc.report.progress.ProgressBar`)."""

    def update(self, done: int) -> None:
        """@p done units of the run's total are done."""
        ...

    def close(self) -> None:
        """The run is over."""
        ...


# ------------------------------------------------------------------ parameters

PARAMS_TABLE = Path(__file__).parent / "ctl_params.toml"
"""The parameters' table, firmware/ctrl/ctl_params.toml (a link to it in the
source tree, its copy in an installed package): the defaults here, the limits
in :mod:`mstc.limits`."""


@functools.cache
def _defaults() -> dict[str, float]:
    """Each parameter's default by its name in the table (read once)."""
    with PARAMS_TABLE.open("rb") as f:
        table = tomllib.load(f)
    return {str(p["name"]): float(p["default"]) for p in table.get("param", [])}


def _default(name: str) -> float:
    return _defaults()[name]


class Strategy(StrEnum):
    """Which switching strategy the firmware runs (ctl_params_t.strategy). The
    values are the names of the DBC's global value table Strategy, which gives
    their numbers on the wire and the in-process ABI (:mod:`mstc.can.dbc`)."""

    PAPER = "paper"
    """The paper's switch strategy, exactly (section 4)."""
    MSTC = "mstc"
    """mstc's own strategy (docs/strategy.md; the firmware default)."""


@dataclass(frozen=True)
class Params:
    """Every parameter the controller takes (ctl_params_t), SI units.

    The defaults are Table 1 of the paper, with wheel limits high enough that
    the paper's scenarios never saturate (they peak near 32 rad/s). The
    firmware's max_wheel_decel is not here: a scenario cannot set it (it
    keeps the firmware's default, docs/safety.md).
    """

    r_m: float = _default("R_m")
    """Robot radius R_m [m]."""
    r_ob: float = _default("R_ob")
    """Default obstacle radius R_ob [m]."""
    d_det: float = _default("D_det")
    """Sensor range D_det [m]."""
    d_act: float = _default("D_act")
    """Activation distance D_act [m]."""
    d_s: float = _default("D_s")
    """Safe distance D_s [m]."""
    tracking_gains: tuple[float, float, float] = (
        _default("trk_k1"),
        _default("trk_k2"),
        _default("trk_k3"),
    )
    """k1, k2, k3 of eq. (2)-(3)."""
    avoidance_gains: tuple[float, float] = (_default("avd_k1"), _default("avd_k2"))
    """k1, k2 of eq. (23)-(24)."""
    wheel_radius: float = _default("wheel_radius")
    """r [m]."""
    track_width: float = _default("track_width")
    """L, distance between the wheels [m]."""
    max_wheel_speed: float = _default("max_wheel_speed")
    """Largest |wheel angular speed| [rad/s]."""
    strategy: Strategy = Strategy.MSTC
    """Switching strategy; the paper's scenario files select ``paper``."""
    wheel_accel: float = _default("wheel_accel")
    """What the wheels can do [rad/s²] ("mstc" limits its commands to it)."""
    wheel_tau: float = _default("wheel_tau")
    """The wheels' lag to their command, delays included [s]."""

    def safe_distance(self, radius: float) -> float:
        """D_s for an obstacle of ``radius`` [m]: moved out by (radius − R_ob),
        so the clearance to its surface is the one Table 1 gives for R_ob
        (the firmware's supervisor does the same, sup.h)."""
        return self.d_s + radius - self.r_ob

    def activation_distance(self, radius: float) -> float:
        """D_act for an obstacle of ``radius`` [m], moved out like :meth:`safe_distance`."""
        return self.d_act + radius - self.r_ob


PARAM_NAMES: dict[str, tuple[str, int | None]] = {
    "R_m": ("r_m", None),
    "R_ob": ("r_ob", None),
    "D_det": ("d_det", None),
    "D_act": ("d_act", None),
    "D_s": ("d_s", None),
    "trk_k1": ("tracking_gains", 0),
    "trk_k2": ("tracking_gains", 1),
    "trk_k3": ("tracking_gains", 2),
    "avd_k1": ("avoidance_gains", 0),
    "avd_k2": ("avoidance_gains", 1),
    "wheel_radius": ("wheel_radius", None),
    "track_width": ("track_width", None),
    "max_wheel_speed": ("max_wheel_speed", None),
    "wheel_accel": ("wheel_accel", None),
    "wheel_tau": ("wheel_tau", None),
}
"""The parameters the Python side sets and reads, by their name in the DBC's
PARAM_SET_index value table: the :class:`Params` field of each, and the
element for a gain. Their index numbers are the DBC's (:mod:`mstc.can.dbc`);
scenario files use the same names for the scalar ones (docs/scenarios.md)."""


def param_values(p: Params) -> dict[str, float]:
    """Every parameter of @p p by its :data:`PARAM_NAMES` name."""
    values = {}
    for name, (field, element) in PARAM_NAMES.items():
        value = getattr(p, field)
        values[name] = float(value if element is None else value[element])
    return values


def with_param_values(p: Params, values: Mapping[str, float]) -> Params:
    """@p p with the parameters of @p values (by :data:`PARAM_NAMES` name) set;
    names not there are ignored."""
    changes: dict[str, Any] = {}
    for name, value in values.items():
        if name not in PARAM_NAMES:
            continue
        field, element = PARAM_NAMES[name]
        if element is None:
            changes[field] = value
        else:
            gains = list(changes.get(field, getattr(p, field)))
            gains[element] = value
            changes[field] = tuple(gains)
    return replace(p, **changes)


# ------------------------------------------------------------------ the wire


@dataclass(frozen=True)
class SignalRange:
    """What one signal of the protocol carries, for the scenario loader's messages."""

    name: str
    """``MESSAGE.signal``, e.g. ``ODOM_XY.x``."""
    lo: float
    hi: float
    unit: str
    scale: float
    """The step between two values it carries."""

    def __contains__(self, value: object) -> bool:
        return isinstance(value, int | float) and self.lo <= value <= self.hi

    def text(self) -> str:
        """``[-128, 127.9999847] m (what ODOM_XY.x carries)``."""
        unit = f" {self.unit}" if self.unit else ""
        return f"[{self.lo:.10g}, {self.hi:.10g}]{unit} (what {self.name} carries)"


@dataclass(frozen=True)
class WireLimits:
    """The ranges of the signals a scenario's values travel in: made from the
    DBC by :func:`mstc.can.protocol.wire_limits` and handed to the scenario
    loader, so that the plant checks what the frames carry without knowing
    the frames."""

    robot: tuple[SignalRange, SignalRange]
    """x, y of ODOM_XY."""
    reference: tuple[SignalRange, SignalRange]
    """x, y of REF_XY."""
    v: SignalRange
    w: SignalRange
    obstacle: tuple[SignalRange, SignalRange]
    """x, y of OBSTACLE."""
    radius: SignalRange
    velocity: tuple[SignalRange, SignalRange]
    """vx, vy of OBSTACLE_VEL."""
    ids: SignalRange
    """OBSTACLE's id: obstacles are numbered 1.. in file order."""

    @property
    def max_obstacles(self) -> int:
        """Obstacles a scenario may hold: one per id the frames carry."""
        return int(self.ids.hi - self.ids.lo + 1)
