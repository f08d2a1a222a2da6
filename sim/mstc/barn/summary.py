# SPDX-License-Identifier: MIT
"""What ``mstc barn`` makes of its rows: the table of rates and scores per
configuration beside the benchmark's published DWA run (summary.md), and the
gallery of the worst runs (the robot's path over the world)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mstc.barn.run import COLUMNS, JACKAL, STATUSES, Run, Track
from mstc.barn.worlds import Published, World

_C = {c: i for i, c in enumerate(COLUMNS)}
CONFIG = ("strategy", "reference", "speed", "actuator")
"""What a line of the table is made of."""


@dataclass(frozen=True)
class Line:
    """One configuration's figures."""

    config: tuple[str, ...]
    runs: int
    counts: Mapping[str, int]
    """Runs of each status (and "error")."""
    score: float
    """Mean BARN score over the runs that ran."""
    clearance: float
    """Smallest clearance of any run [m]."""
    unreported: int
    """Runs with unreported periods."""
    time: float
    """Median time of the successes [s] (nan without)."""

    def percent(self, status: str) -> float:
        return 100.0 * self.counts.get(status, 0) / self.runs if self.runs else math.nan


def lines(rows: Sequence[Sequence[str]]) -> list[Line]:
    """The table's lines, in the order the configurations first come."""
    groups: dict[tuple[str, ...], list[Sequence[str]]] = {}
    for row in rows:
        groups.setdefault(tuple(row[_C[c]] for c in CONFIG), []).append(row)
    out = []
    for config, group in groups.items():
        ran = [r for r in group if r[_C["status"]] in STATUSES]
        counts = {s: sum(1 for r in group if r[_C["status"]] == s) for s in (*STATUSES, "error")}
        times = [float(r[_C["time"]]) for r in ran if r[_C["status"]] == "success"]
        out.append(
            Line(
                config,
                len(group),
                counts,
                float(np.mean([float(r[_C["score"]]) for r in ran])) if ran else math.nan,
                min((float(r[_C["clearance"]]) for r in ran), default=math.nan),
                sum(1 for r in ran if int(r[_C["unreported"]]) > 0),
                float(np.median(times)) if times else math.nan,
            )
        )
    return out


def table(found: Sequence[Line], published: Published | None) -> list[str]:
    """summary.md's table, with the published DWA run's line."""
    out = [
        "| strategy | reference | speed [m/s] | actuator | runs | success | collision | timeout "
        "| errors | mean score | median time of successes [s] | min clearance [m] "
        "| runs with unreported periods |",
        "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for line in found:
        out.append(
            "| "
            + " | ".join(line.config)
            + f" | {line.runs} | "
            + " | ".join(f"{line.percent(s):.1f} %" for s in STATUSES)
            + f" | {line.counts['error']} | {line.score:.3f} | {line.time:.1f} | "
            f"{line.clearance:.3f} | {line.unreported} |"
        )
    if published is not None:
        out.append(
            f"| published move_base DWA ({published.worlds} worlds × "
            f"{published.runs // max(1, published.worlds)} trials, dwa_out.txt) | lidar costmap, "
            f"global planner | ≤ 0.5 | Gazebo | {published.runs} | {published.success:.1f} % | "
            f"{published.collision:.1f} % | {published.timeout:.1f} % | — | — | — | — | — |"
        )
    return out


def worst(rows: Sequence[Sequence[str]], count: int) -> list[Sequence[str]]:
    """The @p count worst runs of each strategy: collisions, then timeouts,
    then the successes of lowest score, each kind by smallest clearance."""
    order = {"error": 0, "collision": 1, "timeout": 2, "success": 3}
    out: list[Sequence[str]] = []
    for strategy in dict.fromkeys(r[_C["strategy"]] for r in rows):
        mine = [r for r in rows if r[_C["strategy"]] == strategy and r[_C["status"]] != "error"]
        mine.sort(
            key=lambda r: (
                order[r[_C["status"]]],
                float(r[_C["score"]]),
                float(r[_C["clearance"]]),
            )
        )
        out += mine[:count]
    return out


def gallery(
    out: Path, picked: Sequence[Sequence[str]], worlds: Mapping[int, World], paths: Sequence[Track]
) -> list[str]:
    """The figures of @p picked under ``out/gallery/``, each with its run's
    path again (@p paths, :func:`mstc.barn.run.tracks`), and their lines of
    summary.md."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PatchCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    if not picked:
        return []
    folder = out / "gallery"
    folder.mkdir(parents=True, exist_ok=True)
    text: list[str] = []
    for row, track in zip(picked, paths, strict=True):
        world = worlds[int(row[_C["world"]])]
        fig = Figure(figsize=(5.0, 8.0), layout="constrained")
        ax = fig.add_subplot()
        ax.add_collection(
            PatchCollection(
                [Circle(c, world.cylinder_radius) for c in world.cylinders], color="0.35"
            )
        )
        ref = np.array(world.polyline(row[_C["reference"]]))
        ax.plot(ref[:, 0], ref[:, 1], "--", color="tab:blue", lw=1.0, label="reference's way")
        ax.plot(track.x, track.y, color="tab:red", lw=1.5, label="robot")
        end = (float(track.x[-1]), float(track.y[-1]))
        ax.add_patch(Circle(end, JACKAL["R_m"], fill=False, ec="tab:red", lw=1.0))
        ax.add_patch(
            Circle(world.goal, world.goal_radius, fill=False, ec="tab:green", ls=":", lw=1.2)
        )
        ax.plot(*world.start[:2], "o", color="tab:red", ms=4)
        ax.set_aspect("equal")
        ax.set_xlim(-5.0, 0.5)
        ax.set_ylim(-0.5, 14.5)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower right", fontsize="small")
        config = ", ".join(row[_C[c]] for c in CONFIG)
        again = track.status
        note = "" if again == row[_C["status"]] else f" (run again: {again})"
        title = f"world {world.index}: {config}\n{row[_C['status']]} at {row[_C['time']]} s{note}"
        ax.set_title(title, fontsize="small")
        name = "-".join(row[_C[c]] for c in ("world", *CONFIG))
        FigureCanvasAgg(fig)
        fig.savefig(folder / f"{name}.png", dpi=80)
        text.append(
            f"- world {world.index}, {config}: {row[_C['status']]} at {row[_C['time']]} s, "
            f"score {float(row[_C['score']]):.3f}, min clearance "
            f"{float(row[_C['clearance']]):.3f} m{note}\n\n  ![world {world.index}]"
            f"(gallery/{name}.png)"
        )
    return text


def picked_runs(
    picked: Sequence[Sequence[str]], worlds: Mapping[int, World]
) -> list[tuple[World, Run]]:
    """The runs of the rows @p picked, to run again (:func:`mstc.barn.run.tracks`)."""
    return [
        (
            worlds[int(r[_C["world"]])],
            Run(0, r[_C["strategy"]], r[_C["reference"]], float(r[_C["speed"]]), r[_C["actuator"]]),
        )
        for r in picked
    ]
