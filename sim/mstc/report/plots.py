# SPDX-License-Identifier: MIT
"""Figures of a run, like the paper's Figures 5 and 6.

Drawn with matplotlib's object API on the Agg canvas: no display and no
pyplot state, so runs can make figures from any thread or process.
"""

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Self

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import PatchCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch
from matplotlib.text import Annotation
from matplotlib.transforms import Bbox

from mstc.logs.decode import DecodedLog
from mstc.loop.result import RunResult, Trace
from mstc.loop.timing import Timing
from mstc.model import Event, EventKind, Obstacle, Params

_ROBOT = "tab:blue"
_REFERENCE = "0.35"
_AVOIDING = "tab:orange"
_OBSTACLE_COLORS = ("tab:red", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink")
_LABEL_BOX = {"fc": "white", "ec": "none", "alpha": 0.7, "pad": 0.5}
_EVENT_LABEL = "mstc-event-time"
"""The gid of the path figure's event time labels (:func:`separate_labels`)."""
_MAX_LABEL_MOVES = 40
"""How far down a label may be moved, in label heights."""
"""Behind small labels, so lines under them do not hide them."""
_MARKERS = {
    EventKind.DETECT: "o",
    EventKind.ACTIVATE: "^",
    EventKind.COMPLETE: "s",
    EventKind.BLOCKED: "X",
    EventKind.RESUME: "P",
    EventKind.FILTER: "D",
    EventKind.INFEASIBLE: "v",
}
"""The marker of each event kind (every kind: test_run_inputs checks it)."""
_ALWAYS_IN_LEGEND = (EventKind.DETECT, EventKind.ACTIVATE, EventKind.COMPLETE)
"""The paper's events: in every path figure's legend; the others when they occur."""


def _obstacle_color(obstacle: int) -> str:
    return _OBSTACLE_COLORS[(obstacle - 1) % len(_OBSTACLE_COLORS)]


@dataclass(frozen=True)
class PlotData:
    """What the figures draw: a run's trace and events, the parameters, and the
    obstacles of the distance columns. Made from a simulation by
    :meth:`from_run`, or from a bus log (mstc.logs.decode), so that both are
    drawn alike (:meth:`from_log`)."""

    name: str
    """Names the figures (the scenario's or the log's file stem)."""
    title: str
    """Title of overview.png."""
    trace: Trace
    events: tuple[Event, ...]
    params: Params
    """For D_s and D_act."""
    obstacles: tuple[Obstacle, ...]
    """One per column of ``trace.distance``, with the id events refer to."""
    world: int = 0
    """How many of :attr:`obstacles` (the last ones) are a scenario's
    ``[world]``: drawn as plain circles and summarised by the nearest, not
    each labelled."""

    @classmethod
    def from_run(cls, result: RunResult) -> Self:
        """The figures of a simulated run."""
        scenario = result.scenario
        return cls(
            name=scenario.name,
            title=f"{scenario.name} ({scenario.sim.integrator}, dt = {scenario.sim.dt:g} s)",
            trace=result.trace,
            events=result.events,
            params=scenario.params,
            obstacles=scenario.obstacles,
            world=scenario.world,
        )

    @classmethod
    def from_log(cls, decoded: DecodedLog) -> Self:
        """The figures of a decoded bus log, drawn as a simulation's."""
        title = f"{decoded.name} (bus log, {len(decoded.steps)} steps"
        title += f", dt = {decoded.dt:g} s)" if decoded.dt else ")"
        return cls(
            name=decoded.name,
            title=title,
            trace=decoded.trace,
            events=decoded.events,
            params=decoded.params,
            obstacles=decoded.obstacles,
        )


@dataclass(frozen=True)
class _Interval:
    """A stretch of avoidance: activation to completion (or the end) [s]."""

    start: float
    end: float
    obstacle: int


def _avoid_intervals(result: PlotData) -> list[_Interval]:
    intervals = []
    start: tuple[float, int] | None = None
    for event in result.events:
        if event.kind is EventKind.ACTIVATE:
            start = (event.t, event.obstacle)
        elif event.kind is EventKind.COMPLETE and start is not None:
            intervals.append(_Interval(start[0], event.t, start[1]))
            start = None
    if start is not None:
        intervals.append(_Interval(start[0], float(result.trace["t"][-1]), start[1]))
    return intervals


def _shade_avoidance(ax: Axes, result: PlotData) -> None:
    """Shade the avoidance intervals of a time plot, labelled once per obstacle."""
    labelled: set[int] = set()
    for iv in _avoid_intervals(result):
        label = None if iv.obstacle in labelled else f"avoiding O{iv.obstacle}"
        labelled.add(iv.obstacle)
        ax.axvspan(iv.start, iv.end, color=_obstacle_color(iv.obstacle), alpha=0.12, label=label)


def _time_axes(ax: Axes, result: PlotData, ylabel: str) -> None:
    _shade_avoidance(ax, result)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    ax.set_xlim(0.0, float(result.trace["t"][-1]))
    ax.grid(True, alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize="small")


def draw_path(ax: Axes, result: PlotData) -> None:
    """(a) robot and reference paths, obstacles with their D_s and D_act
    circles, and the switching events on the robot's path. A moving
    obstacle is drawn with its track (dotted), faint where it started, and
    with its circles where it came closest to the robot, at the time given."""
    trace = result.trace
    p = result.params
    x, y = trace["x"], trace["y"]
    ax.plot(trace["x_r"], trace["y_r"], "--", color=_REFERENCE, lw=1.2, label="reference")
    ax.plot(x, y, color=_ROBOT, lw=1.5, label="robot")
    # The avoiding stretches over the path, each including the step that ends it.
    avoiding = trace.avoiding
    mask = avoiding | np.concatenate(([False], avoiding[:-1]))
    if mask.any():
        ax.plot(
            np.where(mask, x, np.nan),
            np.where(mask, y, np.nan),
            color=_AVOIDING,
            lw=2.5,
            label="robot, avoiding",
        )
    ax.plot(x[0], y[0], "o", color=_ROBOT, ms=5)
    ax.plot(trace["x_r"][0], trace["y_r"][0], "o", color=_REFERENCE, ms=5)

    track = trace.obstacle_xy
    listed = len(result.obstacles) - result.world
    if result.world:  # hundreds of static circles: drawn, not labelled
        world = result.obstacles[listed:]
        ax.add_collection(
            PatchCollection([Circle((o.x, o.y), o.radius) for o in world], color="0.45")
        )
    for i, o in enumerate(result.obstacles[:listed]):
        color = _obstacle_color(o.id)
        d_s, d_act = p.safe_distance(o.radius), p.activation_distance(o.radius)
        cx, cy = o.x, o.y
        if track is not None and o.moving:
            # A moving obstacle: its track, where it started (faint), and the
            # obstacle with its circles where it came closest to the robot.
            k = int(np.argmin(trace.distance[:, i]))
            cx, cy = float(track[k, i, 0]), float(track[k, i, 1])
            ax.plot(track[:, i, 0], track[:, i, 1], ":", color=color, lw=1.0)
            ax.add_patch(Circle((o.x, o.y), o.radius, color=color, alpha=0.25))
            ax.annotate(
                f"t = {trace['t'][k]:.2f} s",
                (cx, cy - d_act),
                textcoords="offset points",
                xytext=(0, -3),
                ha="center",
                va="top",
                fontsize="x-small",
                color=color,
            )
        ax.add_patch(Circle((cx, cy), o.radius, color=color, alpha=0.85))
        ax.add_patch(Circle((cx, cy), d_s, fill=False, ls="--", lw=1.0, ec=color))
        ax.add_patch(Circle((cx, cy), d_act, fill=False, ls=":", lw=1.0, ec=color))
        ax.annotate(
            f"O{o.id}",
            (cx, cy + d_act),
            textcoords="offset points",
            xytext=(0, 3),
            ha="center",
            va="bottom",
            fontsize="small",
            color=color,
        )

    labelled_times: set[int] = set()
    t = trace["t"]
    for event in result.events:
        # The row of the step that emitted it (a log's steps need not be regular).
        k = min(int(np.searchsorted(t, event.t)), len(t) - 1)
        ax.plot(
            x[k],
            y[k],
            _MARKERS[event.kind],
            color=_obstacle_color(event.obstacle) if event.obstacle else "0.5",
            ms=7,
            mfc="none"
            if event.kind is EventKind.DETECT or not event.obstacle
            else _obstacle_color(event.obstacle),
            mec="black",
            mew=0.6,
        )
        if event.t_us not in labelled_times:
            labelled_times.add(event.t_us)
            ax.annotate(
                f"{event.t:.2f} s",
                (x[k], y[k]),
                textcoords="offset points",
                xytext=(6, -10),
                fontsize="x-small",
                bbox=_LABEL_BOX,
                gid=_EVENT_LABEL,
            )

    handles, _ = ax.get_legend_handles_labels()
    handles += [
        Patch(fc="0.5", label="obstacle"),
        Line2D([], [], ls="--", color="0.2", lw=1.0, label="$D_s$"),
        Line2D([], [], ls=":", color="0.2", lw=1.0, label="$D_{act}$"),
        *(
            Line2D(
                [],
                [],
                ls="",
                marker=m,
                color="0.5",
                mec="black",
                label=str(kind),
                mfc="none" if kind is EventKind.DETECT else "0.5",
            )
            for kind, m in _MARKERS.items()
            if kind in _ALWAYS_IN_LEGEND or any(e.kind is kind for e in result.events)
        ),
    ]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize="small")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)


def draw_position_error(ax: Axes, result: PlotData) -> None:
    """(b) position tracking errors e1, e2, eq. (1)."""
    t = result.trace["t"]
    ax.plot(t, result.trace["e1"], label="$e_1$")
    ax.plot(t, result.trace["e2"], label="$e_2$")
    _time_axes(ax, result, "position error [m]")


def draw_angle_error(ax: Axes, result: PlotData) -> None:
    """(c) heading error e3, eq. (1), and the avoidance error e, eq. (21),
    while avoiding."""
    t = result.trace["t"]
    ax.plot(t, result.trace["e3"], label="$e_3$")
    e = np.where(result.trace.avoiding, result.trace["e"], np.nan)
    ax.plot(t, e, color="tab:green", label="$e$ (avoiding)")
    _time_axes(ax, result, "angle error [rad]")


def draw_v(ax: Axes, result: PlotData) -> None:
    """(d) robot linear velocity v against the reference's v_r."""
    t = result.trace["t"]
    ax.plot(t, result.trace["v"], color=_ROBOT, label="$v$")
    ax.plot(t, result.trace["v_r"], "--", color=_REFERENCE, label="$v_r$")
    _time_axes(ax, result, "linear velocity [m/s]")


def draw_w(ax: Axes, result: PlotData) -> None:
    """(e) robot angular velocity ω against the reference's ω_r."""
    t = result.trace["t"]
    ax.plot(t, result.trace["w"], color=_ROBOT, label=r"$\omega$")
    ax.plot(t, result.trace["w_r"], "--", color=_REFERENCE, label=r"$\omega_r$")
    _time_axes(ax, result, "angular velocity [rad/s]")


def draw_distance(ax: Axes, result: PlotData) -> None:
    """(f) centre distance to each obstacle, with its D_s and the minimum."""
    t = result.trace["t"]
    p = result.params
    listed = len(result.obstacles) - result.world
    obstacles = result.obstacles[:listed]
    safe = {o.id: p.safe_distance(o.radius) for o in result.obstacles}
    one_line = len(set(safe.values())) <= 1
    if result.world:  # a world's obstacles: the nearest of them at each step
        d = result.trace.distance[:, listed:].min(axis=1)
        ax.plot(t, d, color="0.3", label=f"nearest of the world's {result.world}")
        k = int(np.argmin(d))
        ax.plot(t[k], d[k], "v", color="0.3", ms=6)
        ax.annotate(
            f"min {d[k]:.4f} m",
            (t[k], d[k]),
            textcoords="offset points",
            xytext=(4, 6),
            fontsize="x-small",
            bbox=_LABEL_BOX,
        )
    for i, o in enumerate(obstacles):
        color = _obstacle_color(o.id)
        d = result.trace.distance[:, i]
        ax.plot(t, d, color=color, label=f"$D_{{r{o.id}}}$")
        if not one_line:
            ax.axhline(safe[o.id], ls="--", lw=1.0, color=color, label=f"$D_s$ O{o.id}")
        k = int(np.argmin(d))
        ax.plot(t[k], d[k], "v", color=color, ms=6)
        near_end = t[k] > 0.75 * t[-1]  # keep the label inside the axes
        ax.annotate(
            f"min O{o.id} {d[k]:.4f} m",
            (t[k], d[k]),
            textcoords="offset points",
            xytext=(-4 if near_end else 4, 6 + 11 * i),
            ha="right" if near_end else "left",
            fontsize="x-small",
            bbox=_LABEL_BOX,
            color=color,
        )
    if not result.obstacles:
        ax.text(0.5, 0.5, "no obstacles", transform=ax.transAxes, ha="center", va="center")
    if one_line and safe:
        d_s = next(iter(safe.values()))
        ax.axhline(d_s, ls="--", lw=1.0, color="black", label=f"$D_s$ = {d_s:.3g} m")
    ax.set_ylim(bottom=0.0)
    _time_axes(ax, result, "distance to obstacle [m]")


_Draw = Callable[[Axes, PlotData], None]
PANELS: tuple[tuple[str, str, _Draw], ...] = (
    ("path", "path", draw_path),
    ("position_error", "position error", draw_position_error),
    ("angle_error", "angle error", draw_angle_error),
    ("v", "linear velocity", draw_v),
    ("w", "angular velocity", draw_w),
    ("distance", "distance to obstacles", draw_distance),
)
"""File stem, title and drawing function of each figure, in the paper's order."""


def draw_timing(period_ax: Axes, latency_ax: Axes, timing: Timing) -> None:
    """A real-time run's timing over time: the interval between the
    firmware's wheel commands, and the latency from each odometry frame to the
    first wheel command computed from it (timing.json's series)."""
    nominal = 1e3 * timing.period_s
    period = np.array(timing.period_series, dtype=float).reshape(-1, 2)
    latency = np.array(timing.latency_series, dtype=float).reshape(-1, 2)
    period_ax.plot(
        period[:, 0], period[:, 1], ".", ms=2.5, color=_ROBOT, label="WHEEL_CMD interval"
    )
    period_ax.axhline(nominal, ls="--", lw=1.0, color="black", label=f"period {nominal:g} ms")
    period_ax.set_ylabel("interval [ms]")
    latency_ax.plot(
        latency[:, 0], latency[:, 1], ".", ms=2.5, color=_AVOIDING, label="odometry → wheel command"
    )
    latency_ax.set_ylabel("latency [ms]")
    latency_ax.set_xlabel("t [s]")
    loss = timing.comm_loss
    tops = (max([nominal, *period[:, 1]]), max([1.0, *latency[:, 1]]))
    for ax, top in zip((period_ax, latency_ax), tops, strict=True):
        if loss is not None:
            ax.axvline(loss.stopped_at, color=_OBSTACLE_COLORS[0], lw=1.0, label="odometry stopped")
            if loss.halt_t is not None:
                ax.axvline(loss.halt_t, color=_OBSTACLE_COLORS[1], lw=1.0, ls=":", label="halt")
        ax.set_ylim(0.0, 1.25 * top)  # room for the legend above the points
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")


def plot_timing(timing: Timing, name: str, path: Path) -> Path:
    """Write timing.png: :func:`draw_timing` with the run's figures in the title."""
    fig = Figure(figsize=(9.0, 6.0), layout="constrained")
    period_ax, latency_ax = fig.subplots(2, 1, sharex=True)
    draw_timing(period_ax, latency_ax, timing)
    p, lat = timing.period, timing.latency
    period_ax.set_title(
        f"{name}: wheel command every {p.mean:.2f} ms (p99 {p.p99:.2f}, max {p.max:.2f}); "
        f"missed {timing.missed}, doubled {timing.doubled}"
    )
    latency_ax.set_title(
        f"latency p50 {lat.p50:.2f} ms, p99 {lat.p99:.2f} ms, max {lat.max:.2f} ms"
    )
    _save(fig, path, dpi=120)
    return path


def separate_labels(fig: Figure, dpi: float) -> None:
    """Move the event labels of @p fig (drawn at @p dpi) that would cover
    another down, in time order, until none covers another: where events
    come close on the path (a cluster, a narrow passage) their times stay
    readable. Placed on the laid-out figure, so that the text's real
    extent is known."""
    FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    fig.draw_without_rendering()  # the layout, as saving does it
    for ax in fig.axes:
        placed: list[Bbox] = []
        for label in (t for t in ax.texts if t.get_gid() == _EVENT_LABEL):
            assert isinstance(label, Annotation)
            for _ in range(_MAX_LABEL_MOVES):
                box = label.get_window_extent()
                if not any(box.overlaps(other) for other in placed):
                    break
                dx, dy = label.xyann
                label.xyann = (dx, dy - box.height * 72.0 / dpi - 1.0)
            placed.append(label.get_window_extent())


def _save(fig: Figure, path: Path, dpi: int) -> None:
    separate_labels(fig, dpi)
    fig.savefig(path, dpi=dpi)


def plot_all(run: RunResult | PlotData, folder: Path) -> list[Path]:
    """Write one PNG per panel and overview.png with all six, (a)-(f); and
    timing.png for a real-time run.

    :param run: a simulated run, or the data of one (e.g. from a bus log).
    :returns: The files written.
    """
    result = run if isinstance(run, PlotData) else PlotData.from_run(run)
    name = result.name
    written = []
    for stem, title, draw in PANELS:
        fig = Figure(figsize=(7.0, 5.0), layout="constrained")
        ax = fig.add_subplot()
        draw(ax, result)
        ax.set_title(f"{name}: {title}")
        written.append(folder / f"{stem}.png")
        _save(fig, written[-1], dpi=120)

    fig = Figure(figsize=(19.0, 10.5), layout="constrained")
    for ax, letter, (_, title, draw) in zip(fig.subplots(2, 3).flat, "abcdef", PANELS, strict=True):
        draw(ax, result)
        ax.set_title(f"({letter}) {title}")
    fig.suptitle(result.title)
    written.append(folder / "overview.png")
    _save(fig, written[-1], dpi=100)
    if isinstance(run, RunResult) and run.timing is not None:
        written.append(plot_timing(run.timing, name, folder / "timing.png"))
    return written
