# SPDX-License-Identifier: MIT
"""Scenario files: TOML, validated strictly (format: docs/scenarios.md).

Every problem with a file raises :class:`ScenarioError`, whose text is one
line naming the file, the key (a dotted path such as ``params.D_s`` or
``obstacles[2].position``, obstacles and expected events counted from 1 like
O1, O2) and what is wrong with it.

A scenario must also fit the frames that carry it to the firmware over CAN
(firmware/comm/mstc.dbc): poses, speeds, obstacle positions, radii and ids
are checked against the ranges of their signals, so that ``--bus sil`` never
clips what ``--bus memory`` passes exactly. The loader does not read the DBC
itself: its caller hands it those ranges (:class:`~mstc.model.WireLimits`,
from :func:`mstc.can.protocol.wire_limits`). A run is bounded by
:data:`MAX_STEPS`.
"""

import difflib
import json
import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from datetime import date, datetime, time
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from mstc.errors import ScenarioError
from mstc.limits import Limit, Violation, load_table, violation
from mstc.model import EventKind, Obstacle, Params, Pose, Side, SignalRange, Strategy, WireLimits
from mstc.plant.plant import Integrator

DEFAULT_INTEGRATOR = Integrator.EULER.value
"""[sim] integrator when a file names none: forward Euler, the paper's
scheme (its figures), so a file without it runs as the paper's do."""
MAX_DT = 0.05
"""The longest control period a scenario may have [s]: the "mstc" safety
filter's guarantee (ḣ >= −α h kept by a step of dt) needs α·dt <= 1, α = 20/s
(firmware/ctrl/cbf.h, CBF_MAX_PERIOD_MS; docs/strategy.md). Beyond it a head-on
obstacle at 3 m/s was touched (issue 21)."""
MAX_STEPS = 100_000
"""Control steps one scenario may have: N = round(duration / dt) (the run has
N + 1 rows). It bounds a run's time and memory: about 0.15 kB per step in
memory, 2.6 kB per step through CAN (the frames kept for bus.log), and 1.3 to
2 ms per step through CAN, so 2 to 3 minutes at the limit (docs/scenarios.md)."""


MAX_HEADING_NOISE = math.pi
"""The largest ``heading_noise`` [rad]: the heading is an angle, and a wrapped
normal of standard deviation π is already all but uniform on the circle."""


@dataclass(frozen=True)
class ImperfectionSpec:
    """What a real robot adds to the ideal loop (``[imperfections]``). The
    defaults are the ideal loop, bit for bit."""

    seed: int = 0
    """Seeds the noise and the dropouts of this scene."""
    position_noise: float = 0.0
    """Standard deviation of the Gaussian noise on the odometry's x and y [m]."""
    heading_noise: float = 0.0
    """Standard deviation of the Gaussian noise on the odometry's θ [rad]."""
    obstacle_noise: float = 0.0
    """Standard deviation of the Gaussian noise on each reported obstacle
    centre's x and y [m]."""
    sensor_range: float | None = None
    """The sensor's real range [m]; None: params.D_det."""
    dropout: float = 0.0
    """Probability that a report of an obstacle in range is missed, per
    obstacle and step, 0 <= p < 1."""
    delay: int = 0
    """Whole control periods between a command and the motion it causes."""

    @property
    def noisy(self) -> bool:
        """Whether any random draw is needed."""
        return bool(
            self.position_noise or self.heading_noise or self.obstacle_noise or self.dropout
        )


@dataclass(frozen=True)
class MetaSpec:
    """Where a generated scene comes from (``[meta]``, informational)."""

    family: str = ""
    """Scene family of the suite ("" for a hand-written scene)."""
    seed: int | None = None
    """The seed the scene was drawn with."""
    index: int | None = None
    """The scene's number within its family."""
    actuator: str = ""
    """The suite's actuator profile ("" for a hand-written scene)."""


@dataclass(frozen=True)
class ReferenceSpec:
    """The reference: the paper's virtual robot (pose, v, w), or a path
    travelled at a speed (``path``, docs/scenarios.md)."""

    pose: Pose
    """Initial pose q_r(0) (of a path: its first point, heading along its
    first segment)."""
    v: float
    """v_r [m/s] (of a path: its speed)."""
    w: float
    """ω_r [rad/s] (of a path: 0, the start)."""
    path: tuple[tuple[float, float], ...] = ()
    """The path's vertices (x, y) [m], repeated points dropped; () for the
    virtual robot."""
    wait: bool = True
    """A path's target waits for the robot (:meth:`mstc.plant.reference.PathReference.follow`);
    False: it runs on the clock (:meth:`~mstc.plant.reference.PathReference.at`)."""
    goal_radius: float | None = None
    """The run ends once the robot is within this of the path's end [m]."""


@dataclass(frozen=True)
class SimSpec:
    """How the run is integrated."""

    duration: float
    """[s]."""
    dt: float
    """Control period [s], a whole number of microseconds."""
    integrator: Integrator

    @property
    def steps(self) -> int:
        """N: the run has control steps k = 0..N at t = k·dt."""
        return round(self.duration / self.dt)

    @property
    def dt_us(self) -> int:
        """Control period [µs]."""
        return round(self.dt * 1e6)


@dataclass(frozen=True)
class ExpectedEvent:
    """A reference result (e.g. the paper's time) to compare the run against."""

    t: float
    """[s]."""
    event: EventKind
    obstacle: int
    """1-based obstacle number."""
    side: Side | None
    """Set on activate only."""
    tolerance: float = 0.0
    """How far the run's event may be from t and still meet it [s]."""

    @property
    def t_us(self) -> int:
        """[µs]."""
        return round(self.t * 1e6)


ACTUATOR_MODELS = ("ideal", "lag", "dc")
"""Values of ``[actuator] model``: "ideal" wheels turn at their command at once
(the plant's own), "lag" wheels follow it through a first-order lag under an
acceleration limit, measured by encoders (:mod:`mstc.plant.actuator`), "dc"
are DC gearmotors under the firmware's own wheel loop
(:class:`mstc.firmware.wheels.DcWheels`, docs/wheel.md)."""
LAG_KEYS = ("time_constant", "max_accel", "encoder_counts", "delay")
"""The keys of the "lag" model; any of them makes it the model."""


@dataclass(frozen=True)
class ActuatorSpec:
    """The wheels (``[actuator]``)."""

    model: str = "ideal"
    """One of :data:`ACTUATOR_MODELS`."""
    time_constant: float = 0.0
    """"lag": τ [s], the lag of a wheel's speed to its setpoint; 0: none."""
    max_accel: float = math.inf
    """"lag": a [rad/s²], the largest |dω/dt| of a wheel; inf: no limit."""
    encoder_counts: int = 0
    """"lag": N, encoder counts per wheel revolution; 0: measured exactly."""
    delay: int = 0
    """"lag": whole control periods between a command and the setpoint it
    becomes (added to ``[imperfections] delay``)."""


@dataclass(frozen=True)
class Scenario:
    """A validated scenario file."""

    path: Path
    robot: Pose
    """Initial robot pose."""
    reference: ReferenceSpec
    obstacles: tuple[Obstacle, ...]
    """Numbered from 1 in file order (their ids), where they are at t = 0."""
    sim: SimSpec
    params: Params
    expected: tuple[ExpectedEvent, ...]
    imperfections: ImperfectionSpec = ImperfectionSpec()
    meta: MetaSpec = MetaSpec()
    actuator: ActuatorSpec = ActuatorSpec()
    world: int = 0
    """How many of :attr:`obstacles` (the last ones) come from ``[world]``."""
    world_source: str = ""
    """Where the ``[world]`` came from: ``FILE, world N`` or ``inline``
    (reports summarise a world by it rather than list its obstacles)."""
    slots: int = 0
    """With a world, the slot ids the sensor reports under (what OBSTACLE's id
    carries: :class:`mstc.plant.sensor.SlotSensor`); 0: obstacle i under id i."""

    @property
    def name(self) -> str:
        """The file's stem: names the output folder."""
        return self.path.stem


_TOP_KEYS = (
    "robot",
    "reference",
    "obstacles",
    "world",
    "sim",
    "params",
    "imperfections",
    "meta",
    "expected",
    "actuator",
)
_TOP_REQUIRED = ("robot", "reference", "sim")


@lru_cache(maxsize=1)
def _param_keys() -> tuple[dict[str, Limit], dict[str, tuple[Limit, ...]]]:
    """The [params] keys, from the limits table (firmware/ctrl/ctl_params.toml):
    scalar keys (``R_m``; the Params attribute is the key in lower case), and
    arrays (``tracking_gains``, one parameter per element, in order)."""
    scalars: dict[str, Limit] = {}
    arrays: dict[str, list[Limit]] = {}
    for p in load_table().params:
        element = re.fullmatch(r"(\w+)\[(\d+)\]", p.scenario)
        if element is not None:
            arrays.setdefault(element[1], []).append(p)
        elif p.scenario:
            scalars[p.scenario] = p
    return scalars, {k: tuple(v) for k, v in arrays.items()}


def params_values(p: Params) -> dict[str, float]:
    """The parameters a scenario sets, by their name in the limits table."""
    scalars, arrays = _param_keys()
    values = {limit.name: float(getattr(p, key.lower())) for key, limit in scalars.items()}
    for key, limits in arrays.items():
        values.update(zip((x.name for x in limits), getattr(p, key), strict=True))
    return values


def changed_params(params: Params) -> list[str]:
    """The ``[params]`` settings that differ from Table 1, as a file writes
    them (``params.D_det = 20000``): where to look when the firmware refuses
    a parameter set the loader took."""
    default = Params()
    scalars, arrays = _param_keys()
    settings = []
    for key in scalars:
        value = getattr(params, key.lower())
        if value != getattr(default, key.lower()):
            settings.append(f"params.{key} = {value:g}")
    for key in arrays:
        if getattr(params, key) != getattr(default, key):
            gains = ", ".join(f"{k:g}" for k in getattr(params, key))
            settings.append(f"params.{key} = [{gains}]")
    if params.strategy != default.strategy:
        settings.append(f'params.strategy = "{params.strategy}"')
    return settings


def _type_name(value: object) -> str:
    """The TOML name of a value's type."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "float"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "array"
    if isinstance(value, dict):
        return "table"
    if isinstance(value, datetime | date | time):
        return "date/time"
    return type(value).__name__


class _Checker:
    """Reads values out of the parsed TOML, raising ScenarioError on the first
    problem."""

    def __init__(self, path: str) -> None:
        self.path = path

    def fail(self, key: str | None, problem: str) -> ScenarioError:
        return ScenarioError(self.path, key, problem)

    def table(self, value: object, key: str) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(key, f"must be a table, got {_type_name(value)}")
        return value

    def keys(
        self,
        table: Mapping[str, object],
        prefix: str,
        required: tuple[str, ...],
        allowed: tuple[str, ...],
    ) -> None:
        """Reject unknown keys (suggesting the closest known one), then
        missing required ones."""
        for key in table:
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
                hint = (
                    f"did you mean '{close[0]}'?" if close else "known keys: " + ", ".join(allowed)
                )
                raise self.fail(_join(prefix, key), f"unknown key ({hint})")
        for key in required:
            if key not in table:
                what = "key" if prefix else f"table [{key}]"
                raise self.fail(_join(prefix, key), f"missing required {what}")

    def number(self, value: object, key: str) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"must be a number, got {_type_name(value)}")
        return self._finite(value, key, "")

    def integer(self, value: object, key: str, minimum: int = 0) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"must be an integer, got {_type_name(value)}")
        if value < minimum:
            raise self.fail(key, f"must be >= {minimum}, got {value}")
        return value

    def non_negative(self, value: object, key: str) -> float:
        result = self.number(value, key)
        if result < 0.0:
            raise self.fail(key, f"must be >= 0, got {result:g}")
        return result

    def positive(self, value: object, key: str) -> float:
        result = self.number(value, key)
        if result <= 0.0:
            raise self.fail(key, f"must be > 0, got {result:g}")
        return result

    def numbers(self, value: object, key: str, names: tuple[str, ...]) -> tuple[float, ...]:
        """An array of exactly len(names) numbers; names are used in messages."""
        if (
            type(value) is list
            and len(value) == len(names)
            and all(type(v) is float and -math.inf < v < math.inf for v in value)
        ):  # the common case, checked at once (a sweep parses every scene)
            return tuple(value)
        if not isinstance(value, list):
            raise self.fail(
                key,
                f"must be an array of {len(names)} numbers [{', '.join(names)}], "
                f"got {_type_name(value)}",
            )
        if len(value) != len(names):
            raise self.fail(
                key, f"must have {len(names)} elements [{', '.join(names)}], got {len(value)}"
            )
        result = []
        for name, item in zip(names, value, strict=True):
            if isinstance(item, bool) or not isinstance(item, int | float):
                raise self.fail(key, f"element {name} must be a number, got {_type_name(item)}")
            result.append(self._finite(item, key, f"element {name} "))
        return tuple(result)

    def _finite(self, value: int | float, key: str, what: str) -> float:
        try:
            result = float(value)
        except OverflowError:  # an integer beyond the range of a double
            result = math.inf
        if not math.isfinite(result):
            raise self.fail(key, f"{what}must be a finite number, got {result}")
        return result

    def within(self, value: float, key: str, carried: SignalRange, what: str = "") -> float:
        """@p value, if the frames carry it."""
        if value not in carried:
            raise self.fail(key, f"{what}must be within {carried.text()}, got {value:g}")
        return value

    def choice(self, value: object, key: str, choices: tuple[str, ...]) -> str:
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string, got {_type_name(value)}")
        if value not in choices:
            quoted = ", ".join(f'"{c}"' for c in choices)
            raise self.fail(key, f'must be one of {quoted}, got "{value}"')
        return value

    def array_of_tables(self, value: object, key: str) -> list[dict[str, Any]]:
        if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
            raise self.fail(
                key, f"must be an array of tables ([[{key}]] entries), got {_type_name(value)}"
            )
        return value


def _join(prefix: str, key: str) -> str:
    return f"{prefix}.{key}" if prefix else key


def load_scenario(path: str | Path, wire: WireLimits) -> Scenario:
    """Read and validate a scenario file.

    :param path: the TOML file; error messages name it as given.
    :param wire: what the frames carry (:func:`mstc.can.protocol.wire_limits`).

    :returns: The scenario.

    :raises ScenarioError: the file cannot be read, is not TOML, or is not a valid
        scenario.
    """
    name = str(path)
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except OSError as exc:
        raise ScenarioError(name, None, f"cannot read: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise ScenarioError(name, None, f"not UTF-8 text: {exc.reason}") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(name, None, f"TOML syntax error: {exc}") from exc
    return parse_scenario(data, name, wire)


def load_scenarios(
    paths: Sequence[str | Path], wire: WireLimits
) -> tuple[list[Scenario], list[str]]:
    """Every valid scenario file of @p paths, and the problem of each that is
    not (its :class:`ScenarioError`'s line), so that a caller can report them
    all at once."""
    scenarios: list[Scenario] = []
    problems: list[str] = []
    for path in paths:
        try:
            scenarios.append(load_scenario(path, wire))
        except ScenarioError as exc:
            problems.append(str(exc))
    return scenarios, problems


def parse_scenario(data: Mapping[str, object], path: str, wire: WireLimits) -> Scenario:
    """Validate parsed TOML as a scenario.

    :param data: the parsed document.
    :param path: the file it came from, for error messages and the output name.
    :param wire: what the frames carry (:func:`mstc.can.protocol.wire_limits`).

    :raises ScenarioError: the document is not a valid scenario.
    """
    c = _Checker(path)
    if "suite" in data and "robot" not in data:
        raise ScenarioError(
            path, None, "this is a suite of scenes, not a scenario: run it with mstc sweep"
        )
    c.keys(data, "", _TOP_REQUIRED, _TOP_KEYS)

    params = _parse_params(c, data.get("params", {}))

    robot = c.table(data["robot"], "robot")
    c.keys(robot, "robot", ("pose",), ("pose",))
    robot_pose = _pose(c, robot["pose"], "robot.pose", wire.robot)

    reference = _parse_reference(c, data["reference"], wire)
    world = _parse_world(c, data["world"], path, wire) if "world" in data else ()
    obstacles = _parse_obstacles(c, data.get("obstacles", []), params, wire, bool(world))
    listed = len(obstacles)
    obstacles += tuple(replace(o, id=listed + o.id) for o in world)
    for o in obstacles:
        gap = math.hypot(o.x - robot_pose.x, o.y - robot_pose.y) - params.r_m - o.radius
        if gap < 0.0:  # the bodies overlap at t = 0: a collision before the first step
            where = (
                f"obstacles[{o.id}].position"
                if o.id <= listed
                else f"world (obstacle {o.id - listed}, at {o.x:g}, {o.y:g})"
            )
            raise c.fail(
                where,
                f"the robot starts inside it (its body, R_m = {params.r_m:g} m, overlaps the "
                f"obstacle's, radius {o.radius:g} m, by {-gap:.4g} m)",
            )
    sim = _parse_sim(c, data["sim"])
    actuator = _parse_actuator(c, data.get("actuator", {}))
    params = _hand_actuator(c, params, actuator, c.table(data.get("params", {}), "params"), sim)
    if not reference.path:
        _check_reference_path(c, reference, sim, wire.reference)
    if world and data.get("expected"):
        raise c.fail(
            "expected",
            "a scenario with a [world] reports its obstacles under slot ids, not their "
            "numbers: expected events cannot name them",
        )
    expected = _parse_expected(c, data.get("expected", []), len(obstacles), sim)
    imperfections = _parse_imperfections(c, data.get("imperfections", {}))
    if world:
        for key in ("obstacle_noise", "dropout"):
            if getattr(imperfections, key):
                raise c.fail(
                    f"imperfections.{key}",
                    "is not modelled for a [world] (its sensor reports through slots)",
                )
    return Scenario(
        path=Path(path),
        robot=robot_pose,
        reference=reference,
        obstacles=obstacles,
        sim=sim,
        params=params,
        expected=expected,
        imperfections=imperfections,
        meta=_parse_meta(c, data.get("meta", {})),
        actuator=actuator,
        world=len(world),
        world_source=_world_source(data["world"]) if world else "",
        slots=wire.max_obstacles if world else 0,
    )


@lru_cache(maxsize=1)
def _default_params() -> Params:
    """Table 1's parameters, which the limits table passes (one frozen
    instance, made once)."""
    return Params()


@lru_cache(maxsize=64)
def _violation(p: Params) -> Violation | None:
    """The limits table's verdict on @p p, remembered: a sweep's scenes share
    a few parameter sets, and the check costs more than parsing the file."""
    return violation(params_values(p))


def _parse_params(c: _Checker, value: object) -> Params:
    """[params]: each value a positive number, then the whole set checked
    against the limits table as the firmware will check it (mstc.limits):
    the problem names the key and the limit."""
    table = c.table(value, "params")
    if not table:
        return _default_params()  # a sweep's scenes mostly set none
    scalars, arrays = _param_keys()
    c.keys(table, "params", (), (*scalars, *arrays, "strategy"))
    overrides: dict[str, Any] = {}
    if "strategy" in table:
        overrides["strategy"] = Strategy(
            c.choice(table["strategy"], "params.strategy", tuple(Strategy))
        )
    key_of: dict[str, str] = {}  # table name -> the file's key, for what the file sets
    element_of: dict[str, str] = {}  # table name -> "k2 " for an array element
    for key, limit in scalars.items():
        if key in table:
            read = c.positive if limit.minimum > 0.0 else c.non_negative
            overrides[key.lower()] = read(table[key], f"params.{key}")
            key_of[limit.name] = key
    for key, limits in arrays.items():
        names = tuple(f"k{i + 1}" for i in range(len(limits)))
        for limit, name in zip(limits, names, strict=True):
            element_of[limit.name] = f"{name} "
        if key in table:
            gains = c.numbers(table[key], f"params.{key}", names)
            for i, k in enumerate(gains):
                if k <= 0.0:
                    raise c.fail(f"params.{key}", f"gain k{i + 1} must be > 0, got {k:g}")
            overrides[key] = gains
            key_of.update((limit.name, key) for limit in limits)
    p = Params(**overrides)
    problem = _violation(p)
    if problem is None:
        return p
    # Blame the first parameter concerned that the file sets (the one to
    # change): there is one, since the defaults pass.
    name = next(n for n in problem.names if n in key_of)
    text = problem.problem if problem.relation else element_of.get(name, "") + problem.problem
    first = load_table().by_name(problem.names[0])
    if not first.scenario:
        text += f" ({first.name} is the firmware's {first.default:g} {first.unit}; "
        text += "a scenario cannot set it)"
    raise c.fail(f"params.{key_of[name]}", text)


def _pose(c: _Checker, value: object, key: str, carried: tuple[SignalRange, SignalRange]) -> Pose:
    """A pose [x, y, θ] whose position the frames carry (θ is sent wrapped)."""
    x, y, theta = c.numbers(value, key, ("x", "y", "θ"))
    c.within(x, key, carried[0], "element x ")
    c.within(y, key, carried[1], "element y ")
    return Pose(x, y, theta)


MAX_PATH_POINTS = 10_000
"""The most vertices a path may have."""
MAX_WORLD = 100_000
"""The most obstacles a ``[world]`` may hold."""
REFERENCE_KEYS = ("pose", "v", "w")
PATH_KEYS = ("path", "speed", "wait", "goal_radius")


def _parse_reference(c: _Checker, value: object, wire: WireLimits) -> ReferenceSpec:
    """[reference]: the virtual robot (pose, v, w) or a path (path, speed,
    wait, goal_radius)."""
    ref = c.table(value, "reference")
    if "path" not in ref:
        c.keys(ref, "reference", REFERENCE_KEYS, (*REFERENCE_KEYS, *PATH_KEYS))
        for key in PATH_KEYS:
            if key in ref:
                raise c.fail(f"reference.{key}", "belongs to a path reference (reference.path)")
        return ReferenceSpec(
            pose=_pose(c, ref["pose"], "reference.pose", wire.reference),
            v=c.within(c.number(ref["v"], "reference.v"), "reference.v", wire.v),
            w=c.within(c.number(ref["w"], "reference.w"), "reference.w", wire.w),
        )
    c.keys(ref, "reference", ("path", "speed"), (*REFERENCE_KEYS, *PATH_KEYS))
    for key in REFERENCE_KEYS:
        if key in ref:
            raise c.fail(
                f"reference.{key}", "belongs to the virtual robot, not to a path reference"
            )
    raw = ref["path"]
    if not isinstance(raw, list) or not raw:
        raise c.fail("reference.path", f"must be an array of [x, y] points, got {_type_name(raw)}")
    if len(raw) > MAX_PATH_POINTS:
        raise c.fail("reference.path", f"at most {MAX_PATH_POINTS:,} points, got {len(raw):,}")
    points: list[tuple[float, float]] = []
    for i, item in enumerate(raw, start=1):
        x, y = c.numbers(item, f"reference.path[{i}]", ("x", "y"))
        c.within(x, f"reference.path[{i}]", wire.reference[0], "element x ")
        c.within(y, f"reference.path[{i}]", wire.reference[1], "element y ")
        if not points or (x, y) != points[-1]:
            points.append((x, y))
    if len(points) < 2:
        raise c.fail("reference.path", "needs two distinct points")
    speed = c.positive(ref["speed"], "reference.speed")
    c.within(speed, "reference.speed", wire.v)
    wait = ref.get("wait", True)
    if not isinstance(wait, bool):
        raise c.fail("reference.wait", f"must be true or false, got {_type_name(wait)}")
    goal = None
    if "goal_radius" in ref:
        goal = c.positive(ref["goal_radius"], "reference.goal_radius")
    (x0, y0), (x1, y1) = points[0], points[1]
    return ReferenceSpec(
        pose=Pose(x0, y0, math.atan2(y1 - y0, x1 - x0)),
        v=speed,
        w=0.0,
        path=tuple(points),
        wait=wait,
        goal_radius=goal,
    )


def _parse_world(c: _Checker, value: object, path: str, wire: WireLimits) -> tuple[Obstacle, ...]:
    """[world]: static circles, inline (``obstacles``, ``radius``) or from a
    JSON-lines file (``file``, ``world``: the line whose "world" is that
    number, in the format of BARN's worlds, docs/barn.md). Ids 1.. in order;
    radii rounded up to what OBSTACLE carries."""
    table = c.table(value, "world")
    c.keys(table, "world", (), ("file", "world", "obstacles", "radius"))
    if ("file" in table) == ("obstacles" in table):
        raise c.fail("world", "needs either file (a JSON-lines file of worlds) or obstacles")
    if "file" in table:
        for key in ("obstacles", "radius"):
            if key in table:
                raise c.fail(f"world.{key}", "comes from the file (world.file)")
        centres, radius = _world_file(c, table, Path(path).parent)
    else:
        if "world" in table:
            raise c.fail("world.world", "names a world of world.file")
        if "radius" not in table:
            raise c.fail("world.radius", "missing required key (the obstacles' radius)")
        radius = c.positive(table["radius"], "world.radius")
        raw = table["obstacles"]
        if not isinstance(raw, list):
            raise c.fail("world.obstacles", f"must be an array of [x, y], got {_type_name(raw)}")
        centres = [
            c.numbers(item, f"world.obstacles[{i}]", ("x", "y")) for i, item in enumerate(raw, 1)
        ]
    key = "world.radius" if "radius" in table else "world.file"
    c.within(radius, key, wire.radius)
    # What OBSTACLE_radius carries, on the safe side: BARN's 0.075 m is 0.08 m.
    steps = math.ceil(radius / wire.radius.scale - 1e-9)
    reported = steps * wire.radius.scale
    if not centres:
        raise c.fail("world", "holds no obstacle")
    if len(centres) > MAX_WORLD:
        raise c.fail("world", f"at most {MAX_WORLD:,} obstacles, got {len(centres):,}")
    result = []
    for i, (x, y) in enumerate(centres, start=1):
        where = f"world.obstacles[{i}]" if "obstacles" in table else f"world.file (obstacle {i})"
        c.within(x, where, wire.obstacle[0], "element x ")
        c.within(y, where, wire.obstacle[1], "element y ")
        result.append(Obstacle(i, x, y, round(reported, 9)))
    return tuple(result)


def _world_source(table: object) -> str:
    """:attr:`Scenario.world_source` of a valid ``[world]`` table."""
    assert isinstance(table, Mapping)
    if "file" not in table:
        return "inline"
    return f"{table['file']}" + (f", world {table['world']}" if "world" in table else "")


def _world_file(
    c: _Checker, table: Mapping[str, object], folder: Path
) -> tuple[list[tuple[float, ...]], float]:
    """The obstacles of one line of a JSON-lines file of worlds, and their radius."""
    name = table["file"]
    if not isinstance(name, str):
        raise c.fail("world.file", f"must be a string, got {_type_name(name)}")
    file = folder / name
    want = c.integer(table["world"], "world.world") if "world" in table else None
    try:
        lines = file.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise c.fail("world.file", f"cannot read {file}: {exc}") from exc
    found = None
    for n, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            entry = json.loads(line)
        except json.JSONDecodeError as exc:
            raise c.fail("world.file", f"{file}:{n}: not JSON: {exc.msg}") from exc
        if not isinstance(entry, dict):
            raise c.fail("world.file", f"{file}:{n}: a line must be a JSON object")
        if want is None or entry.get("world") == want:
            if want is None and found is not None:
                raise c.fail("world.world", f"{file} holds several worlds: name one")
            found = (n, entry)
            if want is not None:
                break
    if found is None:
        what = f"no world {want}" if want is not None else "no world"
        raise c.fail("world.world" if want is not None else "world.file", f"{file}: {what}")
    n, entry = found
    where = f"world.file ({file}:{n})"
    for key in ("cylinders", "cylinder_radius"):
        if key not in entry:
            raise c.fail("world.file", f"{file}:{n}: missing key {key!r}")
    radius = c.positive(entry["cylinder_radius"], where)
    raw = entry["cylinders"]
    if not isinstance(raw, list):
        raise c.fail("world.file", f"{file}:{n}: cylinders must be an array of [x, y]")
    return [c.numbers(item, where, ("x", "y")) for item in raw], radius


def _parse_obstacles(
    c: _Checker, value: object, params: Params, wire: WireLimits, slots: bool = False
) -> tuple[Obstacle, ...]:
    entries = c.array_of_tables(value, "obstacles")
    if len(entries) > wire.max_obstacles and not slots:
        ids = wire.ids
        raise c.fail(
            "obstacles",
            f"at most {wire.max_obstacles} obstacles ({ids.name} carries {ids.lo:g} to "
            f"{ids.hi:g}), got {len(entries)}",
        )
    result = []
    default = f"the default radius params.R_ob = {params.r_ob:g} m "
    for i, entry in enumerate(entries, start=1):
        prefix = f"obstacles[{i}]"
        c.keys(entry, prefix, ("position",), ("position", "radius", "velocity"))
        x, y = c.numbers(entry["position"], f"{prefix}.position", ("x", "y"))
        c.within(x, f"{prefix}.position", wire.obstacle[0], "element x ")
        c.within(y, f"{prefix}.position", wire.obstacle[1], "element y ")
        radius, what = params.r_ob, default
        if "radius" in entry:
            radius, what = c.positive(entry["radius"], f"{prefix}.radius"), ""
        c.within(radius, f"{prefix}.radius", wire.radius, what)
        steps = radius / wire.radius.scale
        if abs(steps - round(steps)) > 1e-6:
            raise c.fail(
                f"{prefix}.radius",
                f"{what}must be a whole number of centimetres ({wire.radius.name} carries "
                f"steps of {wire.radius.scale:g} {wire.radius.unit}), got {radius:g}",
            )
        vx, vy = 0.0, 0.0
        if "velocity" in entry:
            vx, vy = c.numbers(entry["velocity"], f"{prefix}.velocity", ("vx", "vy"))
            c.within(vx, f"{prefix}.velocity", wire.velocity[0], "element vx ")
            c.within(vy, f"{prefix}.velocity", wire.velocity[1], "element vy ")
        result.append(Obstacle(i, x, y, radius, vx, vy))
    return tuple(result)


IDEAL_WHEEL_ACCEL = 10000.0
"""wheel_accel handed to the firmware for wheels without an acceleration
limit (ideal wheels, or a "lag" actuator without ``max_accel``): the
largest it takes [rad/s²]."""
DC_HANDED = {"wheel_accel": 125.0, "wheel_tau": 0.06}
"""What the "dc" wheels are handed: the acceleration the default motor still
has at 20 rad/s (docs/wheel.md, tuning step 5) and the "gearmotor" profile's
lag, which docs/wheel.md measures to be slower than this loop's."""


def _parse_actuator(c: _Checker, value: object) -> ActuatorSpec:
    table = c.table(value, "actuator")
    c.keys(table, "actuator", (), ("model", *LAG_KEYS))
    lag = [k for k in LAG_KEYS if k in table]
    model = table.get("model", "lag" if lag else "ideal")
    if model not in ACTUATOR_MODELS:
        raise c.fail(
            "actuator.model", f"must be one of {', '.join(ACTUATOR_MODELS)}, got {model!r}"
        )
    if lag and model != "lag":
        raise c.fail(f"actuator.{lag[0]}", f'belongs to model "lag", not {model!r}')
    values: dict[str, Any] = {"model": str(model)}
    if "time_constant" in table:
        values["time_constant"] = c.non_negative(table["time_constant"], "actuator.time_constant")
    if "max_accel" in table:
        values["max_accel"] = c.positive(table["max_accel"], "actuator.max_accel")
    if "encoder_counts" in table:
        values["encoder_counts"] = c.integer(table["encoder_counts"], "actuator.encoder_counts", 1)
    if "delay" in table:
        values["delay"] = c.integer(table["delay"], "actuator.delay")
    return ActuatorSpec(**values)


def _hand_actuator(
    c: _Checker,
    params: Params,
    spec: ActuatorSpec,
    table: Mapping[str, object],
    sim: SimSpec,
) -> Params:
    """@p params with what the wheels are handed to the firmware, where
    ``[params]`` does not set it: for "lag" wheels wheel_accel = max_accel
    (without a limit :data:`IDEAL_WHEEL_ACCEL`), wheel_tau = time_constant +
    delay × dt; for ideal ones :data:`IDEAL_WHEEL_ACCEL` and 0; for "dc"
    :data:`DC_HANDED`. A value the firmware would refuse names the
    actuator's key."""
    if spec.model == "dc":
        model = dict(DC_HANDED)
    else:
        model = {
            "wheel_accel": min(spec.max_accel, IDEAL_WHEEL_ACCEL),
            "wheel_tau": spec.time_constant + spec.delay * sim.dt,
        }
    handed: dict[str, float] = {}
    blame: dict[str, str] = {}
    if "wheel_accel" not in table:
        handed["wheel_accel"] = model["wheel_accel"]
        blame["wheel_accel"] = "actuator.max_accel"
    if "wheel_tau" not in table:
        handed["wheel_tau"] = model["wheel_tau"]
        blame["wheel_tau"] = "actuator.time_constant"
    if not handed:
        return params
    p = replace(
        params,
        wheel_accel=handed.get("wheel_accel", params.wheel_accel),
        wheel_tau=handed.get("wheel_tau", params.wheel_tau),
    )
    problem = _violation(p)
    if problem is not None:
        name = next(n for n in problem.names if n in blame)
        raise c.fail(
            blame[name],
            f"hands the firmware {name} = {handed[name]:g}, which it refuses: {problem.problem}",
        )
    return p


_IMPERFECTION_NOISES = ("position_noise", "heading_noise", "obstacle_noise")


def _parse_imperfections(c: _Checker, value: object) -> ImperfectionSpec:
    table = c.table(value, "imperfections")
    allowed = ("seed", *_IMPERFECTION_NOISES, "sensor_range", "dropout", "delay")
    c.keys(table, "imperfections", (), allowed)
    values: dict[str, Any] = {}
    for key in _IMPERFECTION_NOISES:
        if key in table:
            values[key] = c.non_negative(table[key], f"imperfections.{key}")
    if values.get("heading_noise", 0.0) > MAX_HEADING_NOISE:
        raise c.fail(
            "imperfections.heading_noise",
            f"must be at most π = {MAX_HEADING_NOISE:.6g} rad (a heading is an angle: "
            f"wider noise is no noisier), got {values['heading_noise']:g}",
        )
    if "seed" in table:
        values["seed"] = c.integer(table["seed"], "imperfections.seed")
    if "sensor_range" in table:
        values["sensor_range"] = c.positive(table["sensor_range"], "imperfections.sensor_range")
    if "dropout" in table:
        p = c.non_negative(table["dropout"], "imperfections.dropout")
        if p >= 1.0:
            raise c.fail("imperfections.dropout", f"must be a probability < 1, got {p:g}")
        values["dropout"] = p
    if "delay" in table:
        values["delay"] = c.integer(table["delay"], "imperfections.delay")
    return ImperfectionSpec(**values)


def _parse_meta(c: _Checker, value: object) -> MetaSpec:
    table = c.table(value, "meta")
    c.keys(table, "meta", (), ("family", "seed", "index", "actuator"))
    family = ""
    if "family" in table:
        if not isinstance(table["family"], str):
            raise c.fail("meta.family", f"must be a string, got {_type_name(table['family'])}")
        family = table["family"]
    seed = c.integer(table["seed"], "meta.seed") if "seed" in table else None
    index = c.integer(table["index"], "meta.index") if "index" in table else None
    actuator = ""
    if "actuator" in table:
        if not isinstance(table["actuator"], str):
            raise c.fail("meta.actuator", f"must be a string, got {_type_name(table['actuator'])}")
        actuator = table["actuator"]
    return MetaSpec(family, seed, index, actuator)


def _parse_sim(c: _Checker, value: object) -> SimSpec:
    table = c.table(value, "sim")
    allowed = ("duration", "dt", "integrator")
    c.keys(table, "sim", allowed[:2], allowed)
    duration = c.positive(table["duration"], "sim.duration")
    dt = c.positive(table["dt"], "sim.dt")
    dt_us = dt * 1e6
    if dt_us < 0.5 or abs(dt_us - round(dt_us)) > 1e-6:
        raise c.fail("sim.dt", f"must be a whole number of microseconds, got {dt:g} s")
    if dt > MAX_DT:
        raise c.fail(
            "sim.dt",
            f"{dt:g} s is longer than {MAX_DT:g} s, the longest period for which the "
            "safety filter's guarantee holds (alpha dt <= 1 with alpha = 20/s; docs/strategy.md)",
        )
    steps = duration / dt  # inf for duration = 1e308 at dt = 1e-6: refused, never rounded
    if not steps < MAX_STEPS + 1 or round(steps) > MAX_STEPS:
        raise c.fail(
            "sim.duration",
            f"{duration:g} s at dt = {dt:g} s is more than {MAX_STEPS:,} control steps "
            "(the limit per scenario, docs/scenarios.md)",
        )
    if round(steps) * round(dt_us) >= 1 << 64:
        raise c.fail(
            "sim.duration", f"{duration:g} s is beyond the firmware's clock (2^64 microseconds)"
        )
    integrator = c.choice(
        table.get("integrator", DEFAULT_INTEGRATOR), "sim.integrator", tuple(Integrator)
    )
    return SimSpec(duration, dt, Integrator(integrator))


def reference_path(reference: ReferenceSpec, sim: SimSpec) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the reference at every step k = 0..N, as
    :class:`~mstc.plant.reference.ReferenceRobot` integrates it (θ_k = θ_0 + k ω dt)."""
    v, w, dt = reference.v, reference.w, sim.dt
    theta = reference.pose.theta + w * dt * np.arange(sim.steps)
    if sim.integrator is Integrator.EULER:
        dx, dy = v * dt * np.cos(theta), v * dt * np.sin(theta)
    else:  # the chord of each arc: v dt sinc(ω dt/2) at θ + ω dt/2 (plant.integrate)
        half = 0.5 * w * dt
        chord = v * dt * float(np.sinc(half / np.pi))
        dx, dy = chord * np.cos(theta + half), chord * np.sin(theta + half)
    x = reference.pose.x + np.concatenate(([0.0], np.cumsum(dx)))
    y = reference.pose.y + np.concatenate(([0.0], np.cumsum(dy)))
    return x, y


REACH_MARGIN = 1e-6
"""Added to a reference's reach [m] for the rounding of its summed steps."""


def _check_reference_path(
    c: _Checker, reference: ReferenceSpec, sim: SimSpec, carried: tuple[SignalRange, SignalRange]
) -> None:
    """The reference must stay within what REF_XY carries for the whole run
    (the robot follows it; its own excursions beyond are refused at run time).
    No step moves it further than |v|·dt (an arc's chord is shorter), so a
    start that far inside the range needs no path: a sweep's scenes all are,
    and the path took half the time of parsing one."""
    start = reference.pose
    reach = abs(reference.v) * sim.dt * sim.steps + REACH_MARGIN
    if all(
        s.lo + reach <= p <= s.hi - reach for p, s in zip((start.x, start.y), carried, strict=True)
    ):
        return
    for axis, values, signal in zip("xy", reference_path(reference, sim), carried, strict=True):
        outside = np.flatnonzero((values < signal.lo) | (values > signal.hi))
        if len(outside):
            k = int(outside[0])
            raise c.fail(
                "reference",
                f"its path leaves {signal.text()} at t = {k * sim.dt:g} s "
                f"({axis} = {values[k]:g} m); shorten sim.duration or move the reference",
            )


def _parse_expected(
    c: _Checker, value: object, n_obstacles: int, sim: SimSpec
) -> tuple[ExpectedEvent, ...]:
    entries = c.array_of_tables(value, "expected")
    result = []
    for i, entry in enumerate(entries, start=1):
        prefix = f"expected[{i}]"
        allowed = ("t", "event", "obstacle", "side", "tolerance")
        c.keys(entry, prefix, ("t", "event", "obstacle"), allowed)
        t = c.number(entry["t"], f"{prefix}.t")
        if not 0.0 <= t <= sim.duration:
            raise c.fail(
                f"{prefix}.t", f"must be within the run, 0 to {sim.duration:g} s, got {t:g}"
            )
        event = EventKind(c.choice(entry["event"], f"{prefix}.event", tuple(EventKind)))
        obstacle = entry["obstacle"]
        if isinstance(obstacle, bool) or not isinstance(obstacle, int):
            raise c.fail(f"{prefix}.obstacle", f"must be an integer, got {_type_name(obstacle)}")
        if not 1 <= obstacle <= n_obstacles:
            known = f"1 to {n_obstacles}" if n_obstacles else "the scenario has none"
            raise c.fail(f"{prefix}.obstacle", f"no obstacle {obstacle} ({known})")
        side = None
        if event is EventKind.ACTIVATE:
            if "side" not in entry:
                raise c.fail(f"{prefix}.side", "missing required key (activate events have a side)")
            side = Side(c.choice(entry["side"], f"{prefix}.side", tuple(Side)))
        elif "side" in entry:
            raise c.fail(f"{prefix}.side", f"only activate events have a side, not {event}")
        tolerance = c.non_negative(entry.get("tolerance", 0.0), f"{prefix}.tolerance")
        result.append(ExpectedEvent(t, event, obstacle, side, tolerance))
    return tuple(result)
