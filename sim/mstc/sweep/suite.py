# SPDX-License-Identifier: MIT
"""Suite files: families of seeded random scenes, written as scenario files.

A suite (TOML, format in docs/sweeps.md) names families; each family has a
kind (the geometry it draws), a count, a seed and the ranges of its random
draws. Scene i of a family is drawn from its own stream,
``random.Random(seed * 1_000_000 + i)``, using only ``random()``, whose
sequence Python guarantees on every platform and version; numbers are written
rounded to 4 decimals with ``repr``. So the same suite gives the same files,
byte for byte, on every machine, and any scene can be made alone.
"""

from __future__ import annotations

import difflib
import math
import random
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mstc.can.protocol import wire_limits
from mstc.errors import ScenarioError, SuiteError
from mstc.model import Params
from mstc.plant.plant import Integrator
from mstc.plant.scenario import parse_scenario

SEED_STRIDE = 1_000_000
"""Scene i of a family with seed s is drawn with seed s·SEED_STRIDE + i."""
MAX_TRIES = 1000
"""Draws of one obstacle before the generator gives up on a scene's geometry."""
MAX_COUNT = 100_000
"""Scenes a family may have: 0.5 to 1.5 kB of scene file each, so at most
about 150 MB a family (and well below SEED_STRIDE, which keeps the streams of
two families apart)."""


Range = tuple[float, float]

# Draws every kind takes, with their defaults.
_COMMON: dict[str, object] = {
    "duration": 30.0,
    "v_r": (0.4, 0.6),
    "heading": (-math.pi, math.pi),
    "start_offset": (0.0, 0.15),
    "heading_offset": (-0.3, 0.3),
    "radius": (0.1, 0.1),
}
# Per kind: its own draws and defaults (ranges are [low, high]; "obstacles"
# and "wall" are integer ranges).
_KINDS: dict[str, dict[str, object]] = {
    "isolated": {"obstacles": (1, 3), "along": (2.0, 8.0), "lateral": (-0.6, 0.6), "spacing": 2.0},
    "cluster": {
        "obstacles": (2, 5),
        "along": (3.0, 5.0),
        "lateral": (-0.3, 0.3),
        "gap": (0.3, 0.8),
    },
    "head_on": {"obstacles": (1, 1), "along": (2.0, 6.0), "spacing": 3.0},
    "circle": {
        "obstacles": (1, 4),
        "along": (1.5, 9.0),
        "circle_radius": (1.2, 3.0),
        "offset": (-0.5, 0.5),
        "spacing": 1.0,
    },
    "moving": {
        "obstacles": (1, 3),
        "along": (3.0, 8.0),
        "speed": (0.1, 0.5),
        "angle": (math.pi / 4, 3 * math.pi / 4),
        "lag": (-1.5, 1.5),
    },
    "dense": {
        "obstacles": (8, 15),
        "along": (1.5, 10.0),
        "lateral": (-2.0, 2.0),
        "separation": 0.35,
        "clear_start": 1.0,
    },
    "narrow": {
        "gap": (0.45, 0.9),
        "wall": (3, 6),
        "pitch": (0.2, 0.3),
        "along": (3.0, 5.0),
        "lateral": (-0.1, 0.1),
    },
    "through": {"along": (3.0, 6.0), "fraction": (-0.8, 0.8)},
    "start_active": {
        "between": (0.1, 0.9),
        "bearing": (-math.pi / 2, math.pi / 2),
        "obstacles": (0, 2),
        "along": (3.0, 8.0),
        "spacing": 2.0,
    },
}
# Defaults a kind changes from _COMMON: exact head-on and "through" scenes
# start on the reference, along the x axis, so the geometry is exact.
_KIND_COMMON = {
    "head_on": {"heading": (0.0, 0.0), "start_offset": (0.0, 0.0), "heading_offset": (0.0, 0.0)},
    "through": {"heading": (0.0, 0.0), "radius": (0.2, 0.5)},
}
_INTEGER_DRAWS = ("obstacles", "wall")
_SCALARS = ("duration", "spacing", "separation", "clear_start")
_IMPERFECTIONS = (
    "position_noise",
    "heading_noise",
    "obstacle_noise",
    "sensor_range",
    "dropout",
    "delay",
)
_FAMILY_KEYS = ("kind", "count", "seed", "imperfections")


@dataclass(frozen=True)
class Family:
    """One family of a suite."""

    name: str
    kind: str
    count: int
    seed: int
    draws: Mapping[str, Any]
    """Every draw of the kind: a (low, high) range or a number."""
    imperfections: Mapping[str, Range]
    """Ranges of the scene's [imperfections], drawn per scene; empty: none."""

    def scene_seed(self, index: int) -> int:
        """The seed scene @p index is drawn with."""
        return self.seed * SEED_STRIDE + index

    def scene_name(self, index: int) -> str:
        """File stem of scene @p index (unique within a suite)."""
        return f"{self.name}-{index:04d}"


IDEAL = "ideal"
"""The actuator profile of a suite without ``[actuator.*]`` tables: ideal wheels."""
_ACTUATOR_KEYS = ("time_constant", "max_accel", "encoder_counts", "delay")


@dataclass(frozen=True)
class ActuatorProfile:
    """One ``[actuator.<name>]`` of a suite: the ``[actuator]`` table its
    scenes get (empty: ideal wheels, no table)."""

    name: str
    values: Mapping[str, float | int]


@dataclass(frozen=True)
class Suite:
    """A validated suite file."""

    path: Path
    name: str
    dt: float
    integrator: Integrator
    families: tuple[Family, ...]
    actuators: tuple[ActuatorProfile, ...] = (ActuatorProfile(IDEAL, {}),)
    """Every family runs with each (docs/sweeps.md)."""

    def scene_name(self, family: Family, index: int, actuator: ActuatorProfile) -> str:
        """File stem of a scene: ``family-NNNN`` with ideal wheels (the names
        of a suite without actuators), ``family-<actuator>-NNNN`` otherwise."""
        if not actuator.values and actuator.name == IDEAL:
            return family.scene_name(index)
        return f"{family.name}-{actuator.name}-{index:04d}"


def _table(c: Callable[[str, str], SuiteError], value: object, key: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise c(key, "must be a table")
    return value


def _unknown(
    c: Callable[[str, str], SuiteError],
    table: Mapping[str, object],
    prefix: str,
    allowed: tuple[str, ...],
) -> None:
    for key in table:
        if key not in allowed:
            close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else "known keys: " + ", ".join(allowed)
            raise c(f"{prefix}.{key}", f"unknown key ({hint})")


def _number(c: Callable[[str, str], SuiteError], value: object, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise c(key, f"must be a finite number, got {value!r}")
    return float(value)


def _range(
    c: Callable[[str, str], SuiteError], value: object, key: str, integer: bool
) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise c(key, "must be a range [low, high]")
    if integer:
        if not all(isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in value):
            raise c(key, "must be a range of integers >= 0 [low, high]")
        lo, hi = value
    else:
        lo, hi = (_number(c, v, key) for v in value)
    if lo > hi:
        raise c(key, f"low ({lo:g}) must be <= high ({hi:g})")
    return (lo, hi)


def is_suite(path: Path) -> bool:
    """Whether @p path is a suite file (a TOML file with ``[family.<name>]`` or
    ``[suite]`` tables) rather than a scenario; a file that is not TOML is not
    (the scenario loader then says what is wrong with it)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    return "family" in data or "suite" in data


def load_suite(path: str | Path) -> Suite:
    """Read and validate a suite file.

    :raises SuiteError: the file cannot be read or is not a valid suite.
    """
    name = str(path)

    def fail(key: str | None, problem: str) -> SuiteError:
        return SuiteError(name, key, problem)

    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise fail(None, f"cannot read: {exc.strerror or exc}") from exc
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise fail(None, f"not a TOML file: {exc}") from exc
    _unknown(fail, data, "", ("suite", "family", "actuator"))
    head = _table(fail, data.get("suite", {}), "suite")
    _unknown(fail, head, "suite", ("name", "dt", "integrator"))
    suite_name = head.get("name", Path(path).stem)
    if not isinstance(suite_name, str):
        raise fail("suite.name", "must be a string")
    dt = _number(fail, head.get("dt", 0.02), "suite.dt")
    if dt <= 0.0:
        raise fail("suite.dt", f"must be > 0, got {dt:g}")
    integrator = head.get("integrator", "euler")
    if integrator not in tuple(Integrator):
        raise fail("suite.integrator", f'must be "euler" or "exact", got {integrator!r}')
    families_table = _table(fail, data.get("family", {}), "family")
    if not families_table:
        raise fail("family", "the suite has no [family.<name>] table")
    families = tuple(
        _family(fail, fname, _table(fail, value, f"family.{fname}"))
        for fname, value in families_table.items()
    )
    _probe(fail, "suite.dt", dt, integrator)
    for family in families:
        _check_scenes(fail, family, dt, integrator)
    actuators = _actuators(fail, _table(fail, data.get("actuator", {}), "actuator"))
    for profile in actuators:
        if profile.values:
            _probe(fail, f"actuator.{profile.name}", dt, integrator, actuator=dict(profile.values))
    return Suite(Path(path), suite_name, dt, Integrator(integrator), families, actuators)


def _actuators(
    fail: Callable[[str, str], SuiteError], table: Mapping[str, Any]
) -> tuple[ActuatorProfile, ...]:
    """The ``[actuator.<name>]`` profiles, in file order; none: ideal wheels."""
    if not table:
        return (ActuatorProfile(IDEAL, {}),)
    profiles = []
    for name, value in table.items():
        prefix = f"actuator.{name}"
        if not name.replace("_", "").isalnum():
            raise fail(prefix, "actuator names are letters, digits and _")
        values = _table(fail, value, prefix)
        _unknown(fail, values, prefix, _ACTUATOR_KEYS)
        checked: dict[str, float | int] = {}
        for key, v in values.items():
            if key in ("encoder_counts", "delay"):
                if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                    raise fail(f"{prefix}.{key}", "must be an integer >= 0")
                checked[key] = v
            else:
                checked[key] = _number(fail, v, f"{prefix}.{key}")
        profiles.append(ActuatorProfile(name, checked))
    return tuple(profiles)


def _probe(
    fail: Callable[[str, str], SuiteError],
    key: str,
    dt: float,
    integrator: str,
    what: str = "",
    **tables: object,
) -> None:
    """Give the scenario loader a scene of one step at the origin with
    @p tables in it, and blame @p key (and @p what of it) for what it refuses:
    a suite's ranges are checked with the loader's own rules."""
    doc = {
        "robot": {"pose": [0.0, 0.0, 0.0]},
        "reference": {"pose": [0.0, 0.0, 0.0], "v": 0.0, "w": 0.0},
        "sim": {"duration": dt, "dt": dt, "integrator": integrator},
        **tables,
    }
    try:
        parse_scenario(doc, key, wire_limits())
    except ScenarioError as exc:
        raise fail(key, what + exc.problem) from exc


def _check_scenes(
    fail: Callable[[str, str], SuiteError], family: Family, dt: float, integrator: str
) -> None:
    """What the loader will check in each scene of @p family, on the ends of
    its ranges, naming the suite's key (docs/sweeps.md): the reference's speed
    and turn rate, the obstacles' radii and speeds, the run's length and the
    imperfections. Where a scene goes (its reference's path, its obstacles'
    positions) depends on every draw at once: `mstc sweep` names the family
    of a generated scene the loader refuses."""
    prefix = f"family.{family.name}"
    g = family.draws

    def probe(key: str, what: str = "", **tables: object) -> None:
        _probe(fail, f"{prefix}.{key}", dt, integrator, what, **tables)

    def reference(v: float, w: float = 0.0) -> dict[str, object]:
        return {"pose": [0.0, 0.0, 0.0], "v": v, "w": w}

    for v in g["v_r"]:
        probe("v_r", reference=reference(v))
    for r in g["radius"]:  # drawn in whole centimetres
        probe("radius", obstacles=[{"position": [5.0, 0.0], "radius": round(r, 2)}])
    probe("duration", sim={"duration": g["duration"], "dt": dt, "integrator": integrator})
    if family.kind == "circle":
        if g["circle_radius"][0] <= 0.0:
            raise fail(f"{prefix}.circle_radius", "radii must be > 0")
        fastest = max(abs(v) for v in g["v_r"])
        turn = reference(fastest, fastest / g["circle_radius"][0])
        probe("circle_radius", "the reference's turn rate v_r / circle_radius ", reference=turn)
    for s in g.get("speed", ()):
        for v in (s, -s):  # either component, either way
            probe(
                "speed",
                "an obstacle's velocity ",
                obstacles=[{"position": [5.0, 0.0], "velocity": [v, v]}],
            )
    for key, ends in family.imperfections.items():
        for end in ends:
            probe(f"imperfections.{key}", imperfections={key: end})


def _family(fail: Callable[[str, str], SuiteError], fname: str, table: Mapping[str, Any]) -> Family:
    prefix = f"family.{fname}"
    if not fname.replace("_", "").isalnum():
        raise fail(prefix, "family names are letters, digits and _")
    kind = table.get("kind", fname)
    if kind not in _KINDS:
        raise fail(f"{prefix}.kind", f"unknown kind {kind!r} (kinds: {', '.join(_KINDS)})")
    defaults = {**_COMMON, **_KIND_COMMON.get(kind, {}), **_KINDS[kind]}
    _unknown(fail, table, prefix, (*_FAMILY_KEYS, *defaults))
    for key in ("count", "seed"):
        value = table.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise fail(f"{prefix}.{key}", "must be an integer >= 0 (required)")
    if table["count"] > MAX_COUNT:
        raise fail(
            f"{prefix}.count", f"at most {MAX_COUNT:,} scenes a family, got {table['count']:,}"
        )
    draws: dict[str, Any] = {}
    for key, default in defaults.items():
        value = table.get(key)
        if value is None:
            draws[key] = default
        elif key in _SCALARS:
            draws[key] = _number(fail, value, f"{prefix}.{key}")
        else:
            draws[key] = _range(fail, value, f"{prefix}.{key}", key in _INTEGER_DRAWS)
    if draws["duration"] <= 0.0:
        raise fail(f"{prefix}.duration", "must be > 0")
    if draws["radius"][0] <= 0.0:
        raise fail(f"{prefix}.radius", "radii must be > 0")
    most = draws["wall"][1] * 2 if kind == "narrow" else draws.get("obstacles", (0, 1))[1]
    most += 1 if kind == "start_active" else 0
    carried = wire_limits().max_obstacles
    if most > carried:
        raise fail(prefix, f"up to {most} obstacles a scene, at most {carried}")
    imperfections = _table(fail, table.get("imperfections", {}), f"{prefix}.imperfections")
    _unknown(fail, imperfections, f"{prefix}.imperfections", _IMPERFECTIONS)
    imp = {
        key: _range(fail, value, f"{prefix}.imperfections.{key}", key == "delay")
        for key, value in imperfections.items()
    }
    return Family(fname, kind, table["count"], table["seed"], draws, imp)


# ------------------------------------------------------------------ drawing


class _Draw:
    """The random draws of one scene (``random()`` only, see the module)."""

    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)

    def u(self, r: Range) -> float:
        lo, hi = r
        return lo + (hi - lo) * self.rng.random()

    def cm(self, r: Range) -> float:
        """A radius drawn from @p r, in whole centimetres: what the OBSTACLE
        frame carries (a scenario may not hold another, docs/scenarios.md)."""
        return round(self.u(r), 2)

    def i(self, r: Range) -> int:
        lo, hi = int(r[0]), int(r[1])
        return lo + min(int(self.rng.random() * (hi - lo + 1)), hi - lo)

    def sign(self) -> float:
        return 1.0 if self.rng.random() < 0.5 else -1.0


@dataclass
class _Scene:
    """A scene being drawn: reference at (0, 0, heading), obstacles in the world."""

    heading: float
    v_r: float
    w_r: float
    robot: tuple[float, float, float]
    obstacles: list[tuple[float, float, float, float, float]]
    """x, y, radius, vx, vy"""

    def __post_init__(self) -> None:
        self._c, self._s = math.cos(self.heading), math.sin(self.heading)

    def point(self, along: float, lateral: float) -> tuple[float, float]:
        """World point at @p along the straight reference and @p lateral to its left."""
        c, s = self._c, self._s
        return (along * c - lateral * s, along * s + lateral * c)


def _clear(scene: _Scene, x: float, y: float, r: float, p: Params, separation: float) -> bool:
    """Whether an obstacle at (x, y) of radius r keeps off the robot's start
    (outside its D_act, with a margin) and off the other obstacles."""
    rx, ry, _ = scene.robot
    if math.hypot(x - rx, y - ry) <= p.activation_distance(r) + 0.1:
        return False
    hypot = math.hypot
    for ox, oy, orad, _, _ in scene.obstacles:
        if hypot(x - ox, y - oy) < max(separation, r + orad + 0.05):
            return False
    return True


def _place(
    scene: _Scene,
    d: _Draw,
    p: Params,
    make: Callable[[], tuple[float, float, float, float, float] | None],
    separation: float = 0.0,
) -> None:
    """Draw an obstacle with @p make until it is clear of the start and the
    others; after MAX_TRIES draws without room, the scene goes without it."""
    for _ in range(MAX_TRIES):
        ob = make()
        if ob is not None and _clear(scene, ob[0], ob[1], ob[2], p, separation):
            scene.obstacles.append(ob)
            return


def _isolated(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    for _ in range(d.i(g["obstacles"])):
        _place(
            scene,
            d,
            p,
            lambda: (*scene.point(d.u(g["along"]), d.u(g["lateral"])), d.cm(g["radius"]), 0.0, 0.0),
            separation=g["spacing"],
        )


def _cluster(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    n = d.i(g["obstacles"])
    _place(
        scene,
        d,
        p,
        lambda: (*scene.point(d.u(g["along"]), d.u(g["lateral"])), d.cm(g["radius"]), 0.0, 0.0),
    )
    while len(scene.obstacles) < n:

        def member() -> tuple[float, float, float, float, float]:
            ox, oy, *_ = scene.obstacles[
                min(int(d.rng.random() * len(scene.obstacles)), len(scene.obstacles) - 1)
            ]
            a, gap = d.u((-math.pi, math.pi)), d.u(g["gap"])
            return (ox + gap * math.cos(a), oy + gap * math.sin(a), d.cm(g["radius"]), 0.0, 0.0)

        _place(scene, d, p, member, separation=g["gap"][0])


def _head_on(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    n = d.i(g["obstacles"])
    s = d.u(g["along"])
    for k in range(n):

        def on_path(at: float = s + k * g["spacing"]) -> tuple[float, float, float, float, float]:
            x, y = scene.point(at, 0.0)
            return (x, y, d.cm(g["radius"]), 0.0, 0.0)

        _place(scene, d, p, on_path)


def _circle(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    rho = d.u(g["circle_radius"])
    sgn = d.sign()
    scene.w_r = sgn * scene.v_r / rho
    th0 = scene.heading
    cx, cy = -sgn * rho * math.sin(th0), sgn * rho * math.cos(th0)  # p0 = (0, 0)
    for _ in range(d.i(g["obstacles"])):

        def near() -> tuple[float, float, float, float, float]:
            th = th0 + sgn * d.u(g["along"]) / rho
            r = rho + d.u(g["offset"])
            return (
                cx + sgn * r * math.sin(th),
                cy - sgn * r * math.cos(th),
                d.cm(g["radius"]),
                0.0,
                0.0,
            )

        _place(scene, d, p, near, separation=g["spacing"])


def _moving(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    for _ in range(d.i(g["obstacles"])):

        def crossing() -> tuple[float, float, float, float, float]:
            s = d.u(g["along"])
            qx, qy = scene.point(s, 0.0)
            t_cross = s / scene.v_r + d.u(g["lag"])
            a = scene.heading + d.sign() * d.u(g["angle"])
            speed = d.u(g["speed"])
            vx, vy = speed * math.cos(a), speed * math.sin(a)
            return (qx - vx * t_cross, qy - vy * t_cross, d.cm(g["radius"]), vx, vy)

        _place(scene, d, p, crossing)


def _dense(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    for _ in range(d.i(g["obstacles"])):

        def anywhere() -> tuple[float, float, float, float, float] | None:
            x, y = scene.point(d.u(g["along"]), d.u(g["lateral"]))
            if math.hypot(x - scene.robot[0], y - scene.robot[1]) < g["clear_start"]:
                return None
            return (x, y, d.cm(g["radius"]), 0.0, 0.0)

        _place(scene, d, p, anywhere, separation=g["separation"])


def _narrow(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    gap, n = d.u(g["gap"]), d.i(g["wall"])
    pitch, s0, axis = d.u(g["pitch"]), d.u(g["along"]), d.u(g["lateral"])
    r = d.cm(g["radius"])
    for k in range(n):
        for side in (1.0, -1.0):
            x, y = scene.point(s0 + k * pitch, axis + side * (gap / 2 + r))
            scene.obstacles.append((x, y, r, 0.0, 0.0))


def _through(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    r = d.cm(g["radius"])
    s = d.u(g["along"])
    _place(scene, d, p, lambda: (*scene.point(s, d.u(g["fraction"]) * r), r, 0.0, 0.0))


def _start_active(scene: _Scene, d: _Draw, g: Mapping[str, Any], p: Params) -> None:
    rx, ry, rth = scene.robot
    r = d.cm(g["radius"])
    dist = p.safe_distance(r) + d.u(g["between"]) * (p.activation_distance(r) - p.safe_distance(r))
    b = rth + d.u(g["bearing"])
    # Placed directly: this one is meant to be within D_act of the start.
    scene.obstacles.append((rx + dist * math.cos(b), ry + dist * math.sin(b), r, 0.0, 0.0))
    for _ in range(d.i(g["obstacles"])):
        _place(
            scene,
            d,
            p,
            lambda: (*scene.point(d.u(g["along"]), d.u((-0.5, 0.5))), d.cm(g["radius"]), 0.0, 0.0),
            separation=g["spacing"],
        )


_DRAWERS: dict[str, Callable[[_Scene, _Draw, Mapping[str, Any], Params], None]] = {
    "isolated": _isolated,
    "cluster": _cluster,
    "head_on": _head_on,
    "circle": _circle,
    "moving": _moving,
    "dense": _dense,
    "narrow": _narrow,
    "through": _through,
    "start_active": _start_active,
}


def _round(x: float) -> float:
    """A number as the files hold it: rounded to 4 decimals, no -0."""
    value = round(x, 4)
    return value + 0.0 if value != 0.0 else 0.0


def _num(x: float) -> str:
    """A number as the files write it: rounded (:func:`_round`), shortest repr."""
    return repr(_round(x))


def _array(values: tuple[float, ...] | list[float]) -> list[float]:
    return [_round(v) for v in values]


def scene_doc(
    suite: Suite,
    family: Family,
    index: int,
    params: Params | None = None,
    actuator: ActuatorProfile | None = None,
) -> dict[str, Any]:
    """Scene @p index of @p family as a scenario document: what
    ``tomllib.loads(scene_text(...))`` gives (the text is written from it),
    which :func:`mstc.plant.scenario.parse_scenario` takes as it is, so a
    worker makes its scenes without writing or parsing any text. The wheels
    are those of @p actuator (default: ideal): the same scene, drawn from the
    same seed, under every profile."""
    p = params or Params()
    g = family.draws
    seed = family.scene_seed(index)
    d = _Draw(seed)
    heading = d.u(g["heading"])
    v_r = d.u(g["v_r"])
    off, direction = d.u(g["start_offset"]), d.u((-math.pi, math.pi))
    robot = (
        off * math.cos(direction),
        off * math.sin(direction),
        heading + d.u(g["heading_offset"]),
    )
    # Positions are rounded when written: draw from the rounded start.
    robot = (round(robot[0], 4), round(robot[1], 4), round(robot[2], 4))
    scene = _Scene(round(heading, 4), v_r, 0.0, robot, [])
    _DRAWERS[family.kind](scene, d, g, p)
    imp = {key: (d.i(r) if key == "delay" else d.u(r)) for key, r in family.imperfections.items()}

    meta: dict[str, Any] = {"family": family.name, "seed": seed, "index": index}
    if actuator is not None:
        meta["actuator"] = actuator.name
    doc: dict[str, Any] = {
        "meta": meta,
        "robot": {"pose": _array(scene.robot)},
        "reference": {
            "pose": _array((0.0, 0.0, scene.heading)),
            "v": _round(scene.v_r),
            "w": _round(scene.w_r),
        },
    }
    obstacles = []
    for x, y, r, vx, vy in scene.obstacles:
        entry: dict[str, Any] = {"position": _array((x, y)), "radius": _round(r)}
        if vx or vy:
            entry["velocity"] = _array((vx, vy))
        obstacles.append(entry)
    if obstacles:
        doc["obstacles"] = obstacles
    doc["sim"] = {
        "duration": _round(g["duration"]),
        "dt": _round(suite.dt),
        "integrator": str(suite.integrator),
    }
    if imp:
        doc["imperfections"] = {
            "seed": seed,
            **{k: v if k == "delay" else _round(float(v)) for k, v in imp.items()},
        }
    if actuator is not None and actuator.values:
        doc["actuator"] = {
            k: v if isinstance(v, int) else _round(float(v)) for k, v in actuator.values.items()
        }
    return doc


def _value(v: object) -> str:
    """A value of a scene document as TOML writes it (numbers already rounded)."""
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return repr(v)


def doc_text(doc: Mapping[str, Any]) -> list[str]:
    """The lines of the TOML text of a scene document (:func:`scene_doc`):
    its tables in order, an array of tables as ``[[name]]`` entries."""
    lines: list[str] = []
    for name, table in doc.items():
        for entry in table if isinstance(table, list) else [table]:
            lines += ["", f"[[{name}]]" if isinstance(table, list) else f"[{name}]"]
            lines += [f"{k} = {_value(v)}" for k, v in entry.items()]
    return lines


def scene_text(
    suite: Suite,
    family: Family,
    index: int,
    params: Params | None = None,
    actuator: ActuatorProfile | None = None,
) -> str:
    """Scene @p index of @p family as the text of a scenario file: the
    document of :func:`scene_doc`, under a comment saying where it comes from."""
    return text_of(suite, family, index, scene_doc(suite, family, index, params, actuator))


def text_of(suite: Suite, family: Family, index: int, doc: Mapping[str, Any]) -> str:
    """The text of scene @p index of @p family, whose document is @p doc."""
    lines = [
        "# SPDX-License-Identifier: MIT",
        f"# Generated by `mstc sweep` from the suite {suite.name} ({suite.path.name}), family",
        f"# {family.name} (kind {family.kind}), scene {index}: format docs/scenarios.md.",
        *doc_text(doc),
    ]
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class SceneFile:
    """A generated scene on disk."""

    path: Path
    family: str
    seed: int


def generate(
    suite: Suite,
    out: Path,
    families: tuple[str, ...] | None = None,
    actuators: tuple[str, ...] | None = None,
) -> list[SceneFile]:
    """Write every scene of @p suite under ``out/<family>/<name>.toml``
    (:meth:`Suite.scene_name`), once per actuator profile.

    :param families: only these families (default: all).
    :param actuators: only these actuator profiles (default: all).
    :returns: The files, family by family in suite order, then profile by
        profile, scene by scene.
    """
    written = []
    for family in suite.families:
        if families is not None and family.name not in families:
            continue
        folder = out / family.name
        folder.mkdir(parents=True, exist_ok=True)
        for actuator in suite.actuators:
            if actuators is not None and actuator.name not in actuators:
                continue
            profile = None if actuator == ActuatorProfile(IDEAL, {}) else actuator
            for i in range(family.count):
                path = folder / f"{suite.scene_name(family, i, actuator)}.toml"
                text = scene_text(suite, family, i, actuator=profile)
                if not path.exists() or path.read_text() != text:
                    path.write_text(text)
                written.append(SceneFile(path, family.name, family.scene_seed(i)))
    return written
