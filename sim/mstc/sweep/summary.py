# SPDX-License-Identifier: MIT
"""summary.md of a sweep: rates with 95 % Wilson intervals and medians per
family and strategy, histograms, and a gallery of the worst runs."""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes

from mstc.loop.result import RunResult

Z95 = 1.959963984540054
"""The standard normal quantile of a two-sided 95 % interval."""


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a proportion k/n (Wilson 1927; the interval
    Brown, Cai and DasGupta 2001 recommend for small n and rates near 0 or 1).

    :returns: (low, high); (0, 1) when n = 0.
    """
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z / (1 + z2 / n) * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n))
    return (max(0.0, centre - half), min(1.0, centre + half))


def _rate(rows: Sequence[Mapping[str, str]], column: str) -> str:
    n = len(rows)
    if n == 0:
        return "—"
    k = sum(1 for r in rows if r[column] == "1")
    lo, hi = wilson(k, n)
    return f"{100 * k / n:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}] ({k}/{n})"


def _median(rows: Sequence[Mapping[str, str]], column: str, digits: int = 3) -> str:
    values = [float(r[column]) for r in rows if r[column] not in ("", "nan")]
    finite = [v for v in values if math.isfinite(v)]
    if not values:
        return "—"
    if len(finite) < len(values) and not finite:
        return "∞"
    return f"{statistics.median(values):.{digits}g}"


_TABLE_HEAD = (
    "| family | actuator | strategy | runs | errors | contact | of which after an infeasible "
    "report | D_s kept | rejoined (not blocked, judged) "
    "| blocked | most activations of one obstacle "
    "| median min clearance [m] | median RMS error [m] | median path ratio "
    "| median ∫\\|ω\\|dt [rad] | median switches | median avoiding [s] | median step [µs] |"
)
_TABLE_HEAD_RULE = "|" + "---|" * 18


def runs_of(
    rows: Sequence[Mapping[str, str]], family: str, actuator: str, strategy: str
) -> list[Mapping[str, str]]:
    """The rows of @p family (``(none)``: rows without one) and @p actuator
    (``ideal``: rows without one) run with @p strategy."""
    return [
        r
        for r in rows
        if (r["family"] or "(none)") == family
        and (r["actuator"] or "ideal") == actuator
        and r["strategy"] == strategy
    ]


def _table_row(family: str, actuator: str, strategy: str, rows: Sequence[Mapping[str, str]]) -> str:
    ok = [r for r in rows if not r["error"]]
    judged = [r for r in ok if r["blocked"] == "0" and r["rejoined"] != ""]
    contacts = sum(1 for r in ok if r["contact"] == "1")
    reported = sum(1 for r in ok if r["contact_reported"] == "1")
    cells = (
        family,
        actuator,
        strategy,
        str(len(rows)),
        str(len(rows) - len(ok)),
        _rate(ok, "contact"),
        f"{reported}/{contacts}",
        _rate(ok, "ds_kept"),
        _rate(judged, "rejoined"),
        _rate(ok, "blocked"),
        str(max((int(r["max_activations"]) for r in ok), default=0)),
        _median(ok, "min_clearance"),
        _median(ok, "rms_error"),
        _median(ok, "path_ratio"),
        _median(ok, "int_abs_w"),
        _median(ok, "switches"),
        _median(ok, "avoid_time"),
        _median(ok, "step_us"),
    )
    return "| " + " | ".join(cells) + " |"


def _histograms(
    rows: Sequence[Mapping[str, str]], strategies: Sequence[str], out: Path
) -> list[str]:
    """clearance.png and tracking_error.png: one histogram per strategy."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    written = []
    for column, label, name in (
        ("min_clearance", "smallest clearance over the run [m] (< 0: contact)", "clearance"),
        ("rms_error", "RMS tracking error [m]", "tracking_error"),
    ):
        fig = Figure(figsize=(7.5, 4.5), layout="constrained")
        ax = fig.add_subplot()
        values = {
            s: np.array(
                [float(r[column]) for r in rows if r["strategy"] == s and not r["error"]],
                dtype=float,
            )
            for s in strategies
        }
        finite = np.concatenate([v[np.isfinite(v)] for v in values.values()] or [np.zeros(0)])
        if finite.size:
            lo, hi = float(finite.min()), float(finite.max())
            bins = np.linspace(lo, hi if hi > lo else lo + 1.0, 41).tolist()
            for strategy, v in values.items():
                ax.hist(v[np.isfinite(v)], bins=bins, alpha=0.5, label=strategy)
        if column == "min_clearance":
            ax.axvline(0.0, color="black", lw=1.0, ls="--", label="contact")
        ax.set_xlabel(label)
        ax.set_ylabel("runs")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right")
        FigureCanvasAgg(fig)
        fig.savefig(out / f"{name}.png", dpi=100)
        written.append(f"{name}.png")
    return written


def _zoom(ax: Axes, result: RunResult) -> None:
    """Frame the obstacles (where they came closest), 1.5 m around them:
    the whole path of a long run makes them specks."""
    trace = result.trace
    if not result.scenario.obstacles:
        return
    k = trace.distance.argmin(axis=0)
    if trace.obstacle_xy is not None:
        xy = trace.obstacle_xy[k, np.arange(len(k))]
    else:
        xy = np.array([(o.x, o.y) for o in result.scenario.obstacles])
    (x0, y0), (x1, y1) = xy.min(axis=0) - 1.5, xy.max(axis=0) + 1.5
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


Rerun = Callable[[Mapping[str, str]], RunResult | None]
"""Runs a row's scene again (same scene, strategy and library) for its figure."""


def _gallery(
    rows: Sequence[Mapping[str, str]],
    strategies: Sequence[str],
    out: Path,
    count: int,
    rerun: Rerun,
) -> list[str]:
    """Path figures of the @p count runs with the smallest clearance per strategy."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from mstc.report.plots import PlotData, draw_path

    lines = []
    for strategy in strategies:
        mine = [r for r in rows if r["strategy"] == strategy and not r["error"]]
        worst = sorted(mine, key=lambda r: (float(r["min_clearance"]), r["scene"]))[:count]
        if not worst:
            continue
        lines += ["", f"### {strategy}", ""]
        for row in worst:
            result = rerun(row)
            if result is None:
                continue
            folder = out / "gallery" / strategy
            folder.mkdir(parents=True, exist_ok=True)
            fig = Figure(figsize=(9.0, 6.0), layout="constrained")
            ax = fig.add_subplot()
            draw_path(ax, PlotData.from_run(result))
            _zoom(ax, result)
            ax.set_title(
                f"{row['scene']} ({strategy}): min clearance {float(row['min_clearance']):.3f} m"
            )
            FigureCanvasAgg(fig)
            name = f"gallery/{strategy}/{row['scene']}.png"
            fig.savefig(out / name, dpi=80)
            contact = "yes" if row["contact"] == "1" else "no"
            lines.append(
                f"- `{row['scene']}` ({row['family'] or 'no family'}): min clearance "
                f"{float(row['min_clearance']):.3f} m, contact {contact}; events: "
                f"`{strategy}/{row['scene']}/events.json`\n\n  ![{row['scene']}]({name})"
            )
    return lines


def write_summary(
    rows: Sequence[Mapping[str, str]],
    strategies: Sequence[str],
    out: Path,
    *,
    title: str,
    firmware: str,
    gallery: int = 6,
    rerun: Rerun | None = None,
) -> Path:
    """Write DIR/summary.md (and its figures) from the rows of runs.csv.

    :param title: what was swept (a suite's name, or the inputs).
    :param firmware: which firmware library ran.
    :param gallery: figures of the worst runs per strategy (0: none).
    :param rerun: runs a row's scene again for its figure (None: no gallery).
    """
    families = list(dict.fromkeys(r["family"] or "(none)" for r in rows))
    actuators = list(dict.fromkeys(r["actuator"] or "ideal" for r in rows))
    lines = [
        f"# Sweep: {title}",
        "",
        f"{len(rows)} runs: {len(rows) // max(1, len(strategies))} scenes × strategies "
        f"{', '.join(strategies)}; firmware {firmware}. Definitions of every column: "
        "docs/sweeps.md. Rates are percentages with their 95 % Wilson interval "
        "[low, high] and the counts; rejoined counts the runs that are not blocked "
        "and are judged (every pass after an obstacle is; a run none of whose passes "
        "lasts long enough to tell is not: docs/sweeps.md). "
        "A `mstc` row before the firmware has its strategy runs the paper's.",
        "",
        "## Per family and actuator",
        "",
        _TABLE_HEAD,
        _TABLE_HEAD_RULE,
    ]
    for family in families:
        for actuator in actuators:
            for strategy in strategies:
                mine = runs_of(rows, family, actuator, strategy)
                if mine:
                    lines.append(_table_row(family, actuator, strategy, mine))
    lines += ["", "## All families", "", _TABLE_HEAD, _TABLE_HEAD_RULE]
    for actuator in actuators:
        for strategy in strategies:
            mine = [
                r
                for r in rows
                if r["strategy"] == strategy and (r["actuator"] or "ideal") == actuator
            ]
            if mine:
                lines.append(_table_row("all", actuator, strategy, mine))
    errors = [r for r in rows if r["error"]]
    if errors:
        lines += ["", f"## Errors ({len(errors)})", ""]
        lines += [f"- `{r['scene']}` ({r['strategy']}): {r['error']}" for r in errors[:50]]
        if len(errors) > 50:
            lines.append(f"- … and {len(errors) - 50} more (runs.csv, column error)")
    lines += ["", "## Distributions", ""]
    for name in _histograms(rows, strategies, out):
        lines.append(f"![{name}]({name})")
    if gallery and rerun is not None:
        lines += ["", f"## The {gallery} runs of smallest clearance, per strategy"]
        lines += _gallery(rows, strategies, out, gallery, rerun)
    path = out / "summary.md"
    path.write_text("\n".join(lines) + "\n")
    return path
