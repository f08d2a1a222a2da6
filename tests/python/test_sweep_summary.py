# SPDX-License-Identifier: MIT
"""summary.md's figures, built as the rows come (mstc.sweep.summary.Tally):
the medians are exact, as statistics.median gives them from every value
(the independent computation), though the tally keeps no row; the rates'
intervals are Wilson's, written so that a rate of one in a million still
shows its bound."""

from __future__ import annotations

import random
import statistics
from pathlib import Path

import pytest

from mstc.sweep.engine import ROW_COLUMNS
from mstc.sweep.summary import MEDIANS, Tally, percent, rate, wilson


def _row(**values: str) -> list[str]:
    row = dict.fromkeys(ROW_COLUMNS, "0")
    row.update(scene="s", family="f", actuator="ideal", strategy="mstc", error="", rejoined="1")
    row.update(values)
    return [row[c] for c in ROW_COLUMNS]


def _value(rng: random.Random) -> str:
    """A value as runs.csv writes it: 6 significant digits, now and then a
    repeated one, an infinity or nan."""
    r = rng.random()
    if r < 0.3:
        return rng.choice(["0", "1", "2.5", "-0.1"])
    if r < 0.35:
        return rng.choice(["inf", "-inf", "nan"])
    return f"{rng.uniform(-5, 5) * 10 ** rng.randint(-6, 4):.6g}"


@pytest.mark.parametrize("seed", range(40))
def test_the_medians_are_those_of_every_value(tmp_path: Path, seed: int) -> None:
    """Rows added in batches of random sizes, written to runs.csv as the
    sweep writes them; every median of summary.md's table is
    statistics.median of the column's values ("nan" left out; "∞" when
    every value is infinite), formatted with 3 significant digits."""
    rng = random.Random(seed)
    n = rng.randint(1, 300)
    rows = [_row(**{c: _value(rng) for c in MEDIANS}) for _ in range(n)]
    runs = tmp_path / "runs.csv"
    runs.write_text(",".join(ROW_COLUMNS) + "\n" + "".join(",".join(r) + "\n" for r in rows))
    tally = Tally(["mstc"])
    i = 0
    while i < n:
        k = rng.randint(1, 40)
        tally.add(rows[i : i + k])
        i += k
    tally.finish(runs)
    got = tally.groups[("f", "ideal", "mstc")].cells("f", "ideal", "mstc", final=True).split(" | ")
    for j, column in enumerate(MEDIANS):
        values = [float(r[ROW_COLUMNS.index(column)]) for r in rows]
        values = [v for v in values if v == v]  # not nan
        if not values:
            want = "—"
        elif all(abs(v) == float("inf") for v in values):
            want = "∞"
        else:
            want = f"{statistics.median(values):.3g}"
        assert got[11 + j].strip(" |") == want, column


def test_wilson_bounds_at_the_ends_are_exact() -> None:
    # k = 0: the interval is [0, z²/(n + z²)] (Wilson 1927, with p = 0).
    z2 = 1.959963984540054**2
    assert wilson(0, 1_000_000) == (0.0, pytest.approx(z2 / (1_000_000 + z2), rel=1e-12))
    assert wilson(5, 5)[1] == 1.0
    assert wilson(0, 0) == (0.0, 1.0)


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (0.0, "0"),
        (100.0, "100"),
        (97.5, "97.5"),
        (45.04, "45.0"),
        (0.00384, "0.0038"),
        (99.99616, "99.9962"),
        (2.5, "2.5"),
    ],
)
def test_percentages_keep_two_digits_of_their_distance_from_an_end(value: float, text: str) -> None:
    assert percent(value) == text


def test_no_contact_in_a_million_runs_shows_its_upper_bound() -> None:
    # 0 of 1,000,000: the upper end z²/(n + z²) = 3.84e-6, 0.00038 %.
    assert rate(0, 1_000_000) == "0 % [0, 0.00038] (0/1000000)"


def test_the_histograms_count_whole_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 35: clearance.png's axis showed fractional run counts. With
    three runs, one a bin, matplotlib's own ticks would be 0, 0.2, ... 1.0;
    the axis's ticks are whole numbers of runs."""
    from matplotlib.figure import Figure

    rows = [
        _row(scene=f"s{i}", min_clearance=f"{0.1 * (i + 1):g}", rms_error=f"{0.01 * (i + 1):g}")
        for i in range(3)
    ]
    runs = tmp_path / "runs.csv"
    runs.write_text(",".join(ROW_COLUMNS) + "\n" + "".join(",".join(r) + "\n" for r in rows))
    tally = Tally(["mstc"])
    tally.add(rows)
    tally.finish(runs)
    ticks: dict[str, list[float]] = {}

    def savefig(fig: Figure, path: Path, **_: object) -> None:
        (ax,) = fig.axes
        lo, hi = ax.get_ylim()
        ticks[Path(path).stem] = [t for t in ax.get_yticks() if lo <= t <= hi]

    monkeypatch.setattr(Figure, "savefig", savefig)
    assert tally._histograms(tmp_path) == ["clearance.png", "tracking_error.png"]
    for name, values in ticks.items():
        assert any(t > 0 for t in values), (name, values)
        assert all(t == round(t) for t in values), (name, values)
