# SPDX-License-Identifier: MIT
"""BARN's worlds (docs/barn.md): the JSON-lines file, one world a line, read
and checked; the benchmark's score; its published DWA run.

The 300 static worlds of the benchmark travel with the package
(``mstc/barn/data/``, with their licence notice ``LICENSE.BARN``); any file
in the same format can stand in for them (``mstc barn --worlds FILE``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mstc.errors import UsageError

DATA = Path(__file__).resolve().parent / "data"
"""The vendored data: worlds.jsonl, dwa_out.txt, LICENSE.BARN, README.md."""
WORLDS = DATA / "worlds.jsonl"
"""The benchmark's 300 static worlds."""
PUBLISHED_DWA = DATA / "dwa_out.txt"
"""The benchmark's published run of ROS move_base with DWA."""

OPTIMAL_SPEED = 2.0
"""The speed of the benchmark's optimal time OT = L / 2 m/s [m/s] (the
challenge's run.py: the Jackal's top speed)."""
TIME_LIMIT = 100.0
"""A run that has not reached the goal by then times out [s]."""

KEYS = ("world", "start", "goal", "goal_radius", "cylinder_radius", "cylinders", "path")
"""The keys of a line of a worlds file."""


@dataclass(frozen=True)
class World:
    """One line of a worlds file."""

    index: int
    """Its ``world`` number."""
    start: tuple[float, float, float]
    """x, y [m], heading [rad]."""
    goal: tuple[float, float]
    goal_radius: float
    cylinder_radius: float
    cylinders: tuple[tuple[float, float], ...]
    path: tuple[tuple[float, float], ...]
    """The map's A* path, from near the start to near the goal."""

    def polyline(self, reference: str) -> list[list[float]]:
        """The reference's way points: ``line`` the start and the goal, ``path``
        the start, the world's path and the goal (the benchmark's OT polyline)."""
        middle = [list(p) for p in self.path] if reference == "path" else []
        return [list(self.start[:2]), *middle, list(self.goal)]

    @property
    def optimal_time(self) -> float:
        """OT: the length of the start, path, goal polyline at 2 m/s [s]."""
        pts = self.polyline("path")
        length = sum(math.dist(a, b) for a, b in zip(pts, pts[1:], strict=False))
        return length / OPTIMAL_SPEED


def score(success: bool, time: float, optimal: float) -> float:
    """The benchmark's score of one run: success × OT / clip(AT, 2·OT, 8·OT),
    AT the run's time @p time, OT @p optimal (at most 0.5)."""
    if not success:
        return 0.0
    return optimal / min(max(time, 2.0 * optimal), 8.0 * optimal)


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _points(value: object, size: int) -> bool:
    return isinstance(value, list) and all(
        isinstance(p, list) and len(p) == size and all(_number(v) for v in p) for p in value
    )


def parse_world(text: str, where: str) -> World:
    """One line of a worlds file, checked.

    :raises UsageError: not JSON, not an object, a key missing or of the
        wrong kind (named, with @p where: ``FILE:LINE``).
    """
    try:
        entry = json.loads(text)
    except json.JSONDecodeError as exc:
        raise UsageError(f"{where}: not JSON: {exc.msg} (column {exc.colno})") from exc
    if not isinstance(entry, dict):
        raise UsageError(f"{where}: a line must be a JSON object, one world")
    missing = [k for k in KEYS if k not in entry]
    if missing:
        raise UsageError(f"{where}: missing key {', '.join(repr(k) for k in missing)}")
    index = entry["world"]
    if not isinstance(index, int) or isinstance(index, bool) or index < 0:
        raise UsageError(f"{where}: world must be a whole number ≥ 0, got {index!r}")
    checks = {
        "start": _points([entry["start"]], 3),
        "goal": _points([entry["goal"]], 2),
        "goal_radius": _number(entry["goal_radius"]) and entry["goal_radius"] > 0,
        "cylinder_radius": _number(entry["cylinder_radius"]) and entry["cylinder_radius"] > 0,
        "cylinders": _points(entry["cylinders"], 2) and bool(entry["cylinders"]),
        "path": _points(entry["path"], 2),
    }
    expected = {
        "start": "[x, y, θ]",
        "goal": "[x, y]",
        "goal_radius": "a number > 0",
        "cylinder_radius": "a number > 0",
        "cylinders": "a non-empty array of [x, y]",
        "path": "an array of [x, y]",
    }
    for key, good in checks.items():
        if not good:
            raise UsageError(f"{where}: world {index}: {key} must be {expected[key]}")
    return World(
        index,
        (float(entry["start"][0]), float(entry["start"][1]), float(entry["start"][2])),
        (float(entry["goal"][0]), float(entry["goal"][1])),
        float(entry["goal_radius"]),
        float(entry["cylinder_radius"]),
        tuple((float(x), float(y)) for x, y in entry["cylinders"]),
        tuple((float(x), float(y)) for x, y in entry["path"]),
    )


def load_worlds(path: Path) -> list[World]:
    """Every world of the JSON-lines file @p path (blank lines skipped), in
    file order.

    :raises UsageError: the file cannot be read, a bad line (the first, named
        ``FILE:LINE``), a world number twice, no world at all.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"--worlds {path}: cannot read it: {exc}") from exc
    worlds: list[World] = []
    seen: dict[int, int] = {}
    for n, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        world = parse_world(line, f"{path}:{n}")
        if world.index in seen:
            raise UsageError(
                f"{path}:{n}: world {world.index} again (first on line {seen[world.index]})"
            )
        seen[world.index] = n
        worlds.append(world)
    if not worlds:
        raise UsageError(f"{path}: no world in this file")
    return worlds


@dataclass(frozen=True)
class Published:
    """The rates of a published run (percent of its runs)."""

    runs: int
    worlds: int
    success: float
    collision: float
    timeout: float


def published_dwa(path: Path = PUBLISHED_DWA) -> Published:
    """The benchmark's published move_base DWA run, from its ``dwa_out.txt``
    (world, success, collided, timed out, time, old score; one run a line)."""
    rows = [line.split() for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
    n = len(rows)
    worlds = len({r[0] for r in rows})

    def rate(column: int) -> float:
        return 100.0 * sum(int(r[column]) for r in rows) / n

    return Published(n, worlds, rate(1), rate(2), rate(3))


def pick(worlds: Sequence[World], only: str | None, sample: int | None, seed: int) -> list[World]:
    """The worlds of @p worlds to run: those @p only names (``0,5,10-19``),
    then @p sample of them drawn with @p seed (in world order).

    :raises UsageError: a bad list, a world the file does not hold, a sample
        larger than the worlds.
    """
    chosen = list(worlds)
    if only is not None:
        by_index = {w.index: w for w in worlds}
        wanted: list[int] = []
        for part in (p.strip() for p in only.split(",")):
            lo, dash, hi = part.partition("-")
            try:
                span = range(int(lo), int(hi) + 1) if dash else range(int(lo), int(lo) + 1)
            except ValueError:
                raise UsageError(f"--only: {part!r} is not a world number or a range a-b") from None
            if not span:
                raise UsageError(f"--only: {part!r} is an empty range")
            wanted.extend(span)
        unknown = sorted(set(wanted) - by_index.keys())
        if unknown:
            shown = ", ".join(map(str, unknown[:5])) + (", …" if len(unknown) > 5 else "")
            raise UsageError(f"--only: no world {shown} in the worlds file")
        chosen = [by_index[i] for i in sorted(set(wanted))]
    if sample is not None:
        if not 1 <= sample <= len(chosen):
            raise UsageError(f"--sample: expected 1 to {len(chosen)} worlds, got {sample}")
        keep = np.random.default_rng(seed).choice(len(chosen), size=sample, replace=False)
        chosen = [chosen[i] for i in sorted(keep.tolist())]
    return chosen
