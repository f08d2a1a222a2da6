# SPDX-License-Identifier: MIT
"""summary.md of a sweep, built as its rows come, in bounded memory.

A :class:`Tally` takes the rows of runs.csv as they are written (a batch at
a time) and keeps, per family, actuator profile and strategy (and over all
families), what summary.md shows: counts of runs, errors, contacts, D_s
kept, rejoined and blocked runs (so their rates and 95 % Wilson intervals),
the most activations of one obstacle; each column's median; the runs of
smallest clearance (a heap of ``gallery`` a strategy) and the first errors.
Nothing of it grows with the number of rows but the medians' bins, and those
are bounded (below).

A median is exact, in two passes: as the rows come, each value is counted in
its *bin* (the values that share a float's sign, exponent and first 8 bits
of mantissa: 2⁻⁸ wide, relatively; a few thousand bins a column at most, some
hundreds in practice); at the end, the bins of the middle value or values
are known, and one pass over runs.csv takes the values of those bins alone.
runs.csv holds 6 significant digits, so a bin holds at most a few thousand
distinct values, which are kept with their counts.
The same pass fills the histograms of clearance.png and tracking_error.png,
whose range the tally has kept. While the sweep runs, summary.md is written
now and then with the counts alone (:meth:`Tally.write` with ``final=False``).
"""

from __future__ import annotations

import csv
import math
from bisect import insort
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mstc.loop.result import RunResult
from mstc.sweep.engine import ROW_COLUMNS

if TYPE_CHECKING:
    from matplotlib.axes import Axes

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
    # At k = 0 (k = n) the low (high) end is exactly 0 (1): rounding leaves 1e-17.
    low = 0.0 if k == 0 else max(0.0, centre - half)
    high = 1.0 if k == n else min(1.0, centre + half)
    return (low, high)


def percent(x: float) -> str:
    """A percentage (0 to 100) with two significant digits of its distance
    from the nearer end, at least one decimal: 97.5, 0.0038, 99.9962."""
    if x <= 0.0:
        return "0"
    if x >= 100.0:
        return "100"
    near = min(x, 100.0 - x)
    return f"{x:.{max(1, 1 - math.floor(math.log10(near)))}f}"


def rate(k: int, n: int) -> str:
    """k of n as a percentage with its 95 % Wilson interval and the counts."""
    if n == 0:
        return "—"
    lo, hi = wilson(k, n)
    return f"{percent(100 * k / n)} % [{percent(100 * lo)}, {percent(100 * hi)}] ({k}/{n})"


_C = {c: i for i, c in enumerate(ROW_COLUMNS)}
MEDIANS = (
    "min_clearance",
    "rms_error",
    "path_ratio",
    "int_abs_w",
    "switches",
    "avoid_time",
    "step_us",
)
"""The columns whose medians summary.md gives, in its order."""
_HISTOGRAMS = (
    ("min_clearance", "smallest clearance over the run [m] (< 0: contact)", "clearance"),
    ("rms_error", "RMS tracking error [m]", "tracking_error"),
)
_SHIFT = np.uint64(44)
"""A median's bin: a float's 64 bits in sort order, less the last 44 (sign,
exponent and 8 bits of mantissa are left)."""
_TOP = np.uint64(1 << 63)


def _bins(x: np.ndarray) -> np.ndarray:
    """The bin of each value of @p x (float64): the float's bits turned so
    that they sort as the floats do, less the last :data:`_SHIFT`."""
    u = x.view(np.uint64)
    return np.where(u & _TOP, ~u, u | _TOP) >> _SHIFT


def _floats(rows: Sequence[Sequence[str]], column: str) -> np.ndarray:
    """The values of @p column of @p rows (runs.csv's fields), "nan" left
    out (as a median leaves them)."""
    i = _C[column]
    x = np.fromiter((float(r[i]) for r in rows), np.float64, len(rows))
    return x[~np.isnan(x)]


class _Median:
    """The exact median of a column's values in two passes (the module's
    docstring): as :func:`statistics.median` gives it from every value."""

    __slots__ = ("n", "finite", "bins", "wanted", "below", "values")

    def __init__(self) -> None:
        self.n = 0
        self.finite = 0
        self.bins: dict[int, int] = {}
        self.wanted: dict[int, int] = {}
        """Bin -> the rank of its first value (the second pass)."""
        self.values: dict[float, int] = {}

    def add(self, x: np.ndarray) -> None:
        self.n += len(x)
        self.finite += int(np.isfinite(x).sum())
        keys, counts = np.unique(_bins(x), return_counts=True)
        bins = self.bins
        for k, c in zip(keys.tolist(), counts.tolist(), strict=True):
            bins[k] = bins.get(k, 0) + c

    def _ranks(self) -> tuple[int, int]:
        return ((self.n - 1) // 2, self.n // 2)

    def plan(self) -> None:
        """Note which bins hold the middle values (before the second pass)."""
        if not self.n:
            return
        below = 0
        ranks = self._ranks()
        for k in sorted(self.bins):
            count = self.bins[k]
            if any(below <= r < below + count for r in ranks):
                self.wanted[k] = below
            below += count

    def take(self, x: np.ndarray) -> None:
        """Keep the values of @p x in the middle bins (the second pass)."""
        if not self.wanted:
            return
        keep = np.isin(_bins(x), np.fromiter(self.wanted, dtype=np.uint64))
        values, counts = np.unique(x[keep], return_counts=True)
        for v, c in zip(values.tolist(), counts.tolist(), strict=True):
            self.values[v] = self.values.get(v, 0) + c

    def text(self, digits: int = 3) -> str:
        """The median as summary.md writes it: "—" without values, "∞" when
        all are infinite."""
        if not self.n:
            return "—"
        if not self.finite:
            return "∞"
        lo, hi = self._ranks()
        a, b = self._at(lo), self._at(hi)
        value = a if lo == hi else (a + b) / 2
        return f"{value:.{digits}g}"

    def _at(self, rank: int) -> float:
        """The value of @p rank (0: the smallest), one of the middle bins'."""
        seen = min(self.wanted.values())  # the rank of their first value
        for v in sorted(self.values):
            seen += self.values[v]
            if rank < seen:
                return v
        raise AssertionError("the second pass missed a middle value")


class _Group:
    """The counts of one family, actuator and strategy (or of all families)."""

    __slots__ = (
        "runs",
        "errors",
        "contact",
        "reported",
        "ds_kept",
        "judged",
        "rejoined",
        "blocked",
        "activations",
        "medians",
    )

    def __init__(self) -> None:
        self.runs = self.errors = self.contact = self.reported = self.ds_kept = 0
        self.judged = self.rejoined = self.blocked = self.activations = 0
        self.medians = {c: _Median() for c in MEDIANS}

    def add(self, rows: int, ok: Sequence[Sequence[str]], values: dict[str, np.ndarray]) -> None:
        """Count @p rows rows of this group, @p ok those without an error,
        whose median columns hold @p values."""
        self.runs += rows
        self.errors += rows - len(ok)
        if not ok:
            return

        def count(column: str, rows: Sequence[Sequence[str]] = ok) -> int:
            i = _C[column]
            return sum(1 for r in rows if r[i] == "1")

        self.contact += count("contact")
        self.reported += count("contact_reported")
        self.ds_kept += count("ds_kept")
        self.blocked += count("blocked")
        judged = [r for r in ok if r[_C["blocked"]] == "0" and r[_C["rejoined"]] != ""]
        self.judged += len(judged)
        self.rejoined += count("rejoined", judged)
        i = _C["max_activations"]
        self.activations = max(self.activations, max(int(r[i]) for r in ok))
        for column, median in self.medians.items():
            median.add(values[column])

    def cells(self, family: str, actuator: str, strategy: str, final: bool) -> str:
        """The group's line of summary.md's tables."""
        ok = self.runs - self.errors
        medians = [m.text() if final else "…" for m in self.medians.values()]
        cells = (
            family,
            actuator,
            strategy,
            str(self.runs),
            str(self.errors),
            rate(self.contact, ok),
            f"{self.reported}/{self.contact}",
            rate(self.ds_kept, ok),
            rate(self.rejoined, self.judged),
            rate(self.blocked, ok),
            str(self.activations),
            *medians,
        )
        return "| " + " | ".join(cells) + " |"


_TABLE_HEAD = (
    "| family | actuator | strategy | runs | errors | contact | of which after an infeasible "
    "report | D_s kept | rejoined (not blocked, judged) "
    "| blocked | most activations of one obstacle "
    "| median min clearance [m] | median RMS error [m] | median path ratio "
    "| median ∫\\|ω\\|dt [rad] | median switches | median avoiding [s] | median step [µs] |"
)
_TABLE_HEAD_RULE = "|" + "---|" * 18
ERRORS_LISTED = 50
"""Errors summary.md lists (the rest: runs.csv, column error)."""

Rerun = Callable[[Sequence[str]], RunResult | None]
"""Runs a row's scene again (same scene, strategy and library) for its figure."""

Key = tuple[str, str, str]


class Tally:
    """summary.md's figures of the rows added (the module's docstring).

    :param strategies: the sweep's strategies, in its order.
    :param gallery: runs of smallest clearance kept per strategy.
    """

    def __init__(self, strategies: Sequence[str], gallery: int = 0) -> None:
        self.strategies = tuple(strategies)
        self.gallery = gallery
        self.rows = 0
        self.groups: dict[Key, _Group] = {}
        """Per (family, actuator, strategy): family "(none)" for rows without
        one, actuator "ideal" for rows without one."""
        self.totals: dict[tuple[str, str], _Group] = {}
        """Over all families, per (actuator, strategy)."""
        self.families: dict[str, None] = {}
        self.actuators: dict[str, None] = {}
        self.error_count = 0
        self.errors: list[tuple[str, str, str]] = []
        """The first :data:`ERRORS_LISTED` errors: scene, strategy, error."""
        self.worst: dict[str, list[tuple[float, str, tuple[str, ...]]]] = {}
        """Per strategy, the runs of smallest clearance, smallest first."""
        self.ranges = {column: [math.inf, -math.inf] for column, _, _ in _HISTOGRAMS}
        """Of the histograms' columns: the smallest and largest finite value."""
        self.counts: dict[str, dict[str, np.ndarray]] = {}
        """Of the histograms' columns, per strategy: counts per bin (the end)."""
        self.final = False

    def _grouped(self, rows: Iterable[Sequence[str]]) -> dict[Key, list[Sequence[str]]]:
        by: dict[Key, list[Sequence[str]]] = {}
        f, a, s = _C["family"], _C["actuator"], _C["strategy"]
        for r in rows:
            key = (r[f] or "(none)", r[a] or "ideal", r[s])
            mine = by.get(key)
            if mine is None:
                by[key] = [r]
            else:
                mine.append(r)
        return by

    def add(self, rows: Iterable[Sequence[str]]) -> None:
        """Take @p rows of runs.csv (their fields in :data:`ROW_COLUMNS` order)."""
        for key, mine in self._grouped(rows).items():
            family, actuator, strategy = key
            self.rows += len(mine)
            self.families.setdefault(family)
            self.actuators.setdefault(actuator)
            ok = self._errors(mine)
            values = {column: _floats(ok, column) for column in MEDIANS}
            self.groups.setdefault(key, _Group()).add(len(mine), ok, values)
            self.totals.setdefault((actuator, strategy), _Group()).add(len(mine), ok, values)
            self._worst(strategy, ok)
            for column, _, _ in _HISTOGRAMS:
                x = values[column]
                x = x[np.isfinite(x)]
                if len(x):
                    span = self.ranges[column]
                    span[0] = min(span[0], float(x.min()))
                    span[1] = max(span[1], float(x.max()))

    def _errors(self, rows: list[Sequence[str]]) -> list[Sequence[str]]:
        """Note the error rows of @p rows; the others."""
        e = _C["error"]
        ok = []
        for r in rows:
            if not r[e]:
                ok.append(r)
                continue
            self.error_count += 1
            if len(self.errors) < ERRORS_LISTED:
                self.errors.append((r[_C["scene"]], r[_C["strategy"]], r[e]))
        return ok

    def _worst(self, strategy: str, ok: list[Sequence[str]]) -> None:
        if not self.gallery:
            return
        worst = self.worst.setdefault(strategy, [])
        c, s = _C["min_clearance"], _C["scene"]
        for r in ok:
            clearance = float(r[c])
            if len(worst) < self.gallery or (clearance, r[s]) < worst[-1][:2]:
                insort(worst, (clearance, r[s], tuple(r)))
                del worst[self.gallery :]

    def finish(self, runs: Path) -> None:
        """The second pass over @p runs (the rows added, as written): the
        medians' middle values and the histograms (the module's docstring)."""
        for group in (*self.groups.values(), *self.totals.values()):
            for median in group.medians.values():
                median.plan()
        edges = {column: self.edges(column) for column, _, _ in _HISTOGRAMS}
        self.counts = {
            column: {s: np.zeros(len(e) - 1, dtype=np.int64) for s in self.strategies}
            for column, e in edges.items()
        }
        for chunk in _chunks(runs):
            for key, mine in self._grouped(chunk).items():
                _, actuator, strategy = key
                ok = [r for r in mine if not r[_C["error"]]]
                if not ok:
                    continue
                values = {column: _floats(ok, column) for column in MEDIANS}
                for column, x in values.items():
                    self.groups[key].medians[column].take(x)
                    self.totals[(actuator, strategy)].medians[column].take(x)
                for column, e in edges.items():
                    x = values[column]
                    if strategy in self.counts[column]:
                        self.counts[column][strategy] += np.histogram(x[np.isfinite(x)], e)[0]
        self.final = True

    def edges(self, column: str) -> np.ndarray:
        """The 41 edges of @p column's histogram: its range in 40 bins."""
        lo, hi = self.ranges[column]
        if not math.isfinite(lo):
            return np.linspace(0.0, 1.0, 41)
        return np.linspace(lo, hi if hi > lo else lo + 1.0, 41)

    def lines(self, final: bool) -> list[str]:
        """summary.md's two tables."""
        lines = ["## Per family and actuator", "", _TABLE_HEAD, _TABLE_HEAD_RULE]
        for family in self.families:
            for actuator in self.actuators:
                for strategy in self.strategies:
                    group = self.groups.get((family, actuator, strategy))
                    if group is not None:
                        lines.append(group.cells(family, actuator, strategy, final))
        lines += ["", "## All families", "", _TABLE_HEAD, _TABLE_HEAD_RULE]
        for actuator in self.actuators:
            for strategy in self.strategies:
                group = self.totals.get((actuator, strategy))
                if group is not None:
                    lines.append(group.cells("all", actuator, strategy, final))
        return lines

    def write(
        self,
        out: Path,
        *,
        title: str,
        firmware: str,
        total: int | None = None,
        rerun: Rerun | None = None,
    ) -> Path:
        """Write DIR/summary.md: while the sweep runs (before :meth:`finish`),
        the counts of the rows so far; at the end, with the medians, the
        histograms and the gallery (its figures made with @p rerun).

        :param title: what was swept (a suite's name, or the inputs).
        :param firmware: which firmware library ran.
        :param total: the sweep's runs (the interim summary says how far it is).
        """
        final = self.final
        scenes = self.rows // max(1, len(self.strategies))
        lines = [
            f"# Sweep: {title}",
            "",
            f"{self.rows} runs: {scenes} scenes × strategies {', '.join(self.strategies)}; "
            f"firmware {firmware}. Definitions of every column: "
            "docs/sweeps.md. Rates are percentages with their 95 % Wilson interval "
            "[low, high] and the counts; rejoined counts the runs that are not blocked "
            "and are judged (every pass after an obstacle is; a run none of whose passes "
            "lasts long enough to tell is not: docs/sweeps.md). "
            "A `mstc` row before the firmware has its strategy runs the paper's.",
            "",
        ]
        if not final:
            lines += [
                f"**The sweep is running: {self.rows:,} of {total or 0:,} runs so far.** "
                "The medians (…), the figures and the gallery come when it ends.",
                "",
            ]
        lines += self.lines(final)
        if self.error_count:
            lines += ["", f"## Errors ({self.error_count})", ""]
            lines += [f"- `{scene}` ({strategy}): {why}" for scene, strategy, why in self.errors]
            if self.error_count > len(self.errors):
                rest = self.error_count - len(self.errors)
                lines.append(f"- … and {rest} more (runs.csv, column error)")
        if final:
            lines += ["", "## Distributions", ""]
            for name in self._histograms(out):
                lines.append(f"![{name}]({name})")
            if self.gallery and rerun is not None:
                lines += ["", f"## The {self.gallery} runs of smallest clearance, per strategy"]
                lines += self._gallery(out, rerun)
        path = out / "summary.md"
        tmp = out / "summary.md.tmp"
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(path)
        return path

    def _histograms(self, out: Path) -> list[str]:
        """clearance.png and tracking_error.png: one histogram per strategy."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.ticker import MaxNLocator

        written = []
        for column, label, name in _HISTOGRAMS:
            fig = Figure(figsize=(7.5, 4.5))
            # Fixed margins (room for 7-digit counts): a constrained layout
            # was a third of the figures' CPU time.
            fig.subplots_adjust(left=0.12, right=0.98, bottom=0.12, top=0.97)
            ax = fig.add_subplot()
            edges = self.edges(column)
            if math.isfinite(self.ranges[column][0]):
                for strategy, counts in self.counts[column].items():
                    ax.stairs(counts, edges, fill=True, alpha=0.5, label=strategy)
            if column == "min_clearance":
                ax.axvline(0.0, color="black", lw=1.0, ls="--", label="contact")
            ax.set_xlabel(label)
            ax.set_ylabel("runs")
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))  # whole runs
            ax.grid(True, alpha=0.3)
            ax.legend(loc="upper right")
            FigureCanvasAgg(fig)
            fig.savefig(out / f"{name}.png", dpi=100)
            written.append(f"{name}.png")
        return written

    def _gallery(self, out: Path, rerun: Rerun) -> list[str]:
        """Path figures of the runs of smallest clearance, per strategy."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        from mstc.report.plots import PlotData, draw_path, separate_labels

        lines = []
        for strategy in self.strategies:
            worst = self.worst.get(strategy, [])
            if not worst:
                continue
            lines += ["", f"### {strategy}", ""]
            for clearance, scene, row in worst:
                result = rerun(row)
                if result is None:
                    continue
                folder = out / "gallery" / strategy
                folder.mkdir(parents=True, exist_ok=True)
                fig = Figure(figsize=(9.0, 6.0), layout="constrained")
                ax = fig.add_subplot()
                draw_path(ax, PlotData.from_run(result))
                _zoom(ax, result)
                ax.set_title(f"{scene} ({strategy}): min clearance {clearance:.3f} m")
                FigureCanvasAgg(fig)
                name = f"gallery/{strategy}/{scene}.png"
                separate_labels(fig, 80)
                fig.savefig(out / name, dpi=80)
                contact = "yes" if row[_C["contact"]] == "1" else "no"
                family = row[_C["family"]] or "no family"
                lines.append(
                    f"- `{scene}` ({family}): min clearance {clearance:.3f} m, contact "
                    f"{contact}; events: `{strategy}/{scene}/events.json`\n\n  ![{scene}]({name})"
                )
        return lines

    def table(self) -> list[str]:
        """The counts as `mstc sweep` prints them at the end."""
        line = "  {:<16} {:<10} {:<9} {:>7} {:>8} {:>9} {:>13} {:>8} {:>7}"
        out = [
            line.format(
                "family",
                "actuator",
                "strategy",
                "runs",
                "contact",
                "D_s kept",
                "rejoined",
                "blocked",
                "errors",
            )
        ]
        for family in self.families:
            for actuator in self.actuators:
                for strategy in self.strategies:
                    g = self.groups.get((family, actuator, strategy))
                    if g is None:
                        continue
                    out.append(
                        line.format(
                            family,
                            actuator,
                            strategy,
                            g.runs,
                            g.contact,
                            g.ds_kept,
                            f"{g.rejoined}/{g.judged}",
                            g.blocked,
                            g.errors,
                        )
                    )
        return out


CHUNK = 20000
"""Rows read at a time by the second pass."""


def _chunks(path: Path) -> Iterator[list[list[str]]]:
    """The rows of runs.csv, :data:`CHUNK` at a time."""
    with path.open(newline="") as f:
        reader = csv.reader(f)
        next(reader, None)
        chunk: list[list[str]] = []
        for row in reader:
            chunk.append(row)
            if len(chunk) == CHUNK:
                yield chunk
                chunk = []
        if chunk:
            yield chunk


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
