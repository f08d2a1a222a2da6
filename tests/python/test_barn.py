# SPDX-License-Identifier: MIT
"""BARN (docs/barn.md): the acceptance figures of issue 31 on a seeded subset
of the benchmark's worlds, and ``mstc barn``'s inputs, rows and summary.

The subset: :data:`SUBSET` worlds drawn with seed :data:`SEED` from the 300,
each with both references, "mstc", ideal wheels, 0.5 m/s, on the batched
engine (as ``mstc barn`` runs them). It fails on any collision, on any period
with an obstacle within D_act unreported, and on success below 95 % (line)
or 99 % (path) of the subset: the issue's thresholds for all 300 worlds.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path

import pytest

from mstc.barn.run import COLUMNS, BarnWork, plan, tasks
from mstc.barn.worlds import WORLDS, World, load_worlds, pick, published_dwa, score
from mstc.cli import main

SUBSET = 30
"""Worlds of the seeded subset (the issue: at least 30)."""
SEED = 31
"""Its seed (``mstc barn --sample 30 --seed 31`` runs the same worlds)."""
THRESHOLD = {"line": 0.95, "path": 0.99}
"""Least success of each reference (issue 31's acceptance)."""

_C = {c: i for i, c in enumerate(COLUMNS)}


def test_the_seeded_subset_meets_the_issues_figures(sil_lib: Path) -> None:
    worlds = pick(load_worlds(WORLDS), None, SUBSET, SEED)
    assert len({w.index for w in worlds}) == SUBSET
    planned = plan(worlds, ["mstc"], ["line", "path"], [0.5], ["ideal"])
    work = BarnWork(str(sil_lib), {"ideal": {}})
    # One batch, in this process: the batched engine as mstc barn runs it.
    rows = [row for task in tasks(planned, 1, per_worker=1) for row in work(task)]
    assert len(rows) == 2 * SUBSET
    problems = []
    for reference, least in THRESHOLD.items():
        mine = [r for r in rows if r[_C["reference"]] == reference]
        errors = [f"world {r[_C['world']]}: {r[_C['error']]}" for r in mine if r[_C["error"]]]
        hit = [r[_C["world"]] for r in mine if r[_C["status"]] == "collision"]
        unreported = [r[_C["world"]] for r in mine if r[_C["unreported"]] not in ("0", "")]
        failed = [
            f"{r[_C['world']]} ({r[_C['status']]})" for r in mine if r[_C["status"]] != "success"
        ]
        need = math.ceil(least * len(mine))
        if errors:
            problems.append(f"{reference}: runs that failed to run: {'; '.join(errors)}")
        if hit:
            problems.append(f"{reference}: collisions in worlds {', '.join(hit)}")
        if unreported:
            problems.append(f"{reference}: unreported periods in worlds {', '.join(unreported)}")
        if len(mine) - len(failed) < need:
            problems.append(
                f"{reference}: {len(mine) - len(failed)} of {len(mine)} successes, at least "
                f"{need} wanted ({least:.0%}); not reached: {', '.join(failed)}"
            )
    assert not problems, "\n".join(problems)


# ------------------------------------------------------------------ the score


def test_the_score_is_the_benchmarks_formula() -> None:
    # success × OT / clip(AT, 2·OT, 8·OT), by hand with OT = 10 s:
    assert score(True, 15.0, 10.0) == pytest.approx(10 / 20)  # faster than 2·OT: 0.5
    assert score(True, 40.0, 10.0) == pytest.approx(10 / 40)
    assert score(True, 95.0, 10.0) == pytest.approx(10 / 80)  # slower than 8·OT
    assert score(False, 40.0, 10.0) == 0.0


def _world(index: int, cylinders: list[list[float]], path: list[list[float]]) -> dict[str, object]:
    return {
        "world": index,
        "start": [0.0, 0.0, math.pi / 2],
        "goal": [0.0, 3.0],
        "goal_radius": 1.0,
        "cylinder_radius": 0.075,
        "cylinders": cylinders,
        "path": path,
    }


def test_the_optimal_time_is_the_polylines_length_at_2_m_s(tmp_path: Path) -> None:
    # start (0, 0), path (0, 1), (1, 1), (1, 2), (0, 2), goal (0, 3): 5 m, 2.5 s.
    file = tmp_path / "w.jsonl"
    file.write_text(
        json.dumps(_world(0, [[3.0, 3.0]], [[0.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]))
    )
    (world,) = load_worlds(file)
    assert world.optimal_time == pytest.approx(2.5)
    assert world.polyline("line") == [[0.0, 0.0], [0.0, 3.0]]


def test_the_published_dwa_run_is_the_benchmarks() -> None:
    # The BARN repository's dwa_out.txt: 50 worlds × 10 trials, 85.0 % / 5.6 % / 9.4 %
    # (the figures of issue 31, counted there independently).
    dwa = published_dwa()
    assert (dwa.runs, dwa.worlds) == (500, 50)
    assert (dwa.success, dwa.collision, dwa.timeout) == pytest.approx((85.0, 5.6, 9.4))


def test_the_vendored_worlds_are_barns_300() -> None:
    worlds = load_worlds(WORLDS)
    assert [w.index for w in worlds] == list(range(300))
    assert all(181 <= len(w.cylinders) <= 365 for w in worlds)
    assert {(w.start, w.goal, w.goal_radius, w.cylinder_radius) for w in worlds} == {
        ((-2.0, 3.0, 1.5708), (-2.0, 13.0), 1.0, 0.075)
    }
    assert (WORLDS.parent / "LICENSE.BARN").read_text().startswith("MIT License")


# ------------------------------------------------------------------ the command


def _barn(out: Path, *args: str) -> int:
    return main(["barn", "-q", "--workers", "1", "--gallery", "1", "--out", str(out), *args])


def _rows(out: Path) -> list[Mapping[str, str]]:
    import csv

    with (out / "runs.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def test_a_run_on_a_hand_made_world_is_judged_as_the_benchmark_judges(
    tmp_path: Path, sil_lib: Path
) -> None:
    # World 0: one cylinder far from the way: the robot reaches the goal
    # radius (1 m round (0, 3)) after some 2 m, its score OT / clip(time, 2·OT, 8·OT),
    # OT = 3 m / 2 m/s = 1.5 s. World 1: a cylinder 0.30 m from the start's
    # centre, nearer than R_m + its radius (0.27 + 0.075): the scenario loader
    # refuses a robot that starts inside an obstacle, so the run is an error
    # naming it, counted apart from the benchmark's three outcomes.
    file = tmp_path / "w.jsonl"
    lines = [_world(0, [[3.0, 3.0]], []), _world(1, [[0.30, 0.0], [3.0, 3.0]], [])]
    file.write_text("\n".join(json.dumps(w) for w in lines) + "\n")
    out = tmp_path / "out"
    assert (
        _barn(
            out,
            "--lib",
            str(sil_lib),
            "--worlds",
            str(file),
            "--reference",
            "line",
            "--strategy",
            "mstc",
        )
        == 0
    )
    with (out / "runs.csv").open() as f:
        assert f.readline().strip() == ",".join(COLUMNS)
    free, blocked = _rows(out)
    assert free["status"] == "success"
    assert 4.0 <= float(free["time"]) <= 6.0  # 2 m at 0.5 m/s, and the start
    assert float(free["score"]) == pytest.approx(1.5 / float(free["time"]), rel=1e-4)
    # Straight up x = 0 to the goal radius's edge (0, 2): nearest the cylinder there.
    assert float(free["clearance"]) == pytest.approx(math.hypot(3.0, 1.0) - 0.27 - 0.075, abs=0.02)
    assert free["unreported"] == "0"
    assert blocked["status"] == "error"
    assert "the robot starts inside it" in blocked["error"]
    summary = (out / "summary.md").read_text()
    assert "| mstc | line | 0.5 | ideal | 2 | 50.0 % | 0.0 % | 0.0 % | 1 |" in summary
    assert "| 500 | 85.0 % | 5.6 % | 9.4 % |" in summary
    assert list((out / "gallery").glob("*.png"))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--strategy", "bug2"], "--strategy: unknown bug2 (known: paper, mstc, dwa)"),
        (["--reference", "map"], "--reference: unknown map (known: line, path)"),
        (["--speed", "0"], "--speed: 0 is outside (0, 2] m/s"),
        (["--speed", "fast"], "--speed: 'fast' is not a number"),
        (["--only", "300"], "--only: no world 300 in the worlds file"),
        (["--only", "a-b"], "--only: 'a-b' is not a world number or a range a-b"),
        (["--sample", "301"], "--sample: expected 1 to 300 worlds, got 301"),
        (["--actuator", "turbo"], "--actuator: no profile turbo in"),
        (["--workers", "0"], "--workers must be at least 1"),
    ],
)
def test_bad_flags_are_one_line_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    assert _barn(tmp_path / "out", *args) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {message}"), err
    assert err.count("\n") == 1


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("{not json", "w.jsonl:2: not JSON"),
        ("[1, 2]", "w.jsonl:2: a line must be a JSON object"),
        ('{"world": 1}', "w.jsonl:2: missing key 'start'"),
        (json.dumps({**_world(1, [], []), "cylinders": []}), "w.jsonl:2: world 1: cylinders must"),
        (json.dumps(_world(0, [[3.0, 3.0]], [])), "w.jsonl:2: world 0 again (first on line 1)"),
    ],
)
def test_a_bad_line_of_the_worlds_file_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], line: str, message: str
) -> None:
    file = tmp_path / "w.jsonl"
    file.write_text(json.dumps(_world(0, [[3.0, 3.0]], [])) + "\n" + line + "\n")
    assert _barn(tmp_path / "out", "--worlds", str(file)) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err, err
    assert err.count("\n") == 1


def test_a_missing_worlds_file_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _barn(tmp_path / "out", "--worlds", str(tmp_path / "none.jsonl")) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: --worlds {tmp_path / 'none.jsonl'}: cannot read it"), err


def test_pick_draws_the_same_subset_for_the_same_seed() -> None:
    worlds: list[World] = load_worlds(WORLDS)
    a = pick(worlds, "10-49", 5, 7)
    assert [w.index for w in a] == [w.index for w in pick(worlds, "10-49", 5, 7)]
    assert all(10 <= w.index <= 49 for w in a) and len(a) == 5
    assert [w.index for w in pick(worlds, "3,1,2-4", None, 0)] == [1, 2, 3, 4]


def test_mstc_sim_runs_a_barn_world_and_summarises_it(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # World 0 from the vendored file, the straight line, "mstc": a scenario as
    # docs/barn.md writes it, through the lock-step loop in memory.
    scenario = tmp_path / "world0.toml"
    scenario.write_text(
        "[robot]\npose = [-2.0, 3.0, 1.5708]\n"
        "[reference]\npath = [[-2.0, 3.0], [-2.0, 13.0]]\nspeed = 0.5\ngoal_radius = 1.0\n"
        f'[world]\nfile = "{WORLDS}"\nworld = 0\n'
        '[sim]\nduration = 100.0\ndt = 0.02\nintegrator = "euler"\n'
        "[params]\nR_m = 0.27\nR_ob = 0.075\nD_s = 0.35\nD_act = 0.5\nD_det = 1.5\n"
        'wheel_radius = 0.098\ntrack_width = 0.376\nstrategy = "mstc"\n'
    )
    out = tmp_path / "out"
    args = ["sim", "--bus", "memory", "--lib", str(sil_lib), "--out", str(out), "-q"]
    assert main([*args, str(scenario)]) == 0
    printed = capsys.readouterr().out
    cylinders = len(load_worlds(WORLDS)[0].cylinders)
    assert f"world         {cylinders} obstacles ({WORLDS}, world 0): nearest O" in printed
    assert "came within D_s" in printed
    assert " O150 " not in printed  # the world's obstacles are not listed one by one
    assert {p.name for p in (out / "world0").iterdir()} >= {"path.png", "trace.csv", "events.json"}
