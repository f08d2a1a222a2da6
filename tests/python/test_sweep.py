# SPDX-License-Identifier: MIT
"""`mstc sweep` end to end: the same inputs give the same files and rows; a
scene that fails in a worker is an error row, never a lost sweep; --resume
finishes an interrupted sweep without running again what was done; the
scene files and events.json of every failure and gallery run are written,
and of every run only when asked. The expected events.json is what
`mstc sim --bus memory` writes. The Dask cluster's tests are
test_sweep_cluster.py."""

import csv
import shutil
import time
from pathlib import Path

import pytest

from mstc.cli import main
from mstc.sweep.engine import MEASURED_COLUMNS, ROW_COLUMNS, Scene
from mstc.sweep.plan import Plan, run_sweep
from mstc.sweep.summary import Tally

SUITE = """\
[suite]
name = "tiny"

[family.head_on]
count = 2
seed = 3
duration = 8.0

[family.cluster]
count = 2
seed = 2
duration = 8.0
along = [2.0, 2.5]
"""
# A scene whose text fails in the worker: `mstc sweep` refuses such a file
# before anything runs (like `mstc sim`), but a scene that reaches a worker
# and fails there (a cluster's worker with another mstc, a file changed
# meanwhile, a crash of the plant) must become its row, not end the sweep.
# Here the reference runs at 1e308 m/s, which REF_MOTION.v cannot carry.
CRASH = """\
[robot]
pose = [0.0, 0.0, 0.0]
[reference]
pose = [0.0, 0.0, 0.0]
v = 1e308
w = 0.0
[sim]
duration = 3.0
dt = 0.02
integrator = "euler"
"""


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, ...]:
    tmp = tmp_path_factory.mktemp("inputs")
    (tmp / "tiny.toml").write_text(SUITE)
    return (tmp / "tiny.toml",)


def sweep(
    out: Path,
    inputs: tuple[Path, ...],
    lib: Path,
    *extra: str,
    capsys: pytest.CaptureFixture[str] | None = None,
    every: bool = True,
) -> str:
    """Sweep @p inputs into @p out; with @p every, write every scene file and
    events.json (--write-scenes, --write-events)."""
    args = ["sweep", "--lib", str(lib), "--strategy", "paper,dwa", "--out", str(out), "-q"]
    args += ["--write-scenes", "--write-events"] if every else []
    rc = main([*args, "--jobs", "2", "--gallery", "1", *extra, *map(str, inputs)])
    text = capsys.readouterr().out if capsys is not None else ""
    assert rc == 0, text
    return text


def rows(out: Path) -> list[dict[str, str]]:
    with (out / "runs.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def reproducible(table: list[dict[str, str]]) -> list[dict[str, str]]:
    """The rows without the measured columns (step cost)."""
    return [{k: v for k, v in r.items() if k not in MEASURED_COLUMNS} for r in table]


@pytest.fixture(scope="module")
def first(
    tmp_path_factory: pytest.TempPathFactory, inputs: tuple[Path, ...], sil_lib: Path
) -> Path:
    out = tmp_path_factory.mktemp("first")
    sweep(out, inputs, sil_lib)
    return out


def test_rows_in_plan_order_with_every_column(first: Path) -> None:
    table = rows(first)
    assert list(table[0]) == list(ROW_COLUMNS)
    names = [(r["scene"], r["strategy"]) for r in table]
    scenes = ["head_on-0000", "head_on-0001", "cluster-0000", "cluster-0001"]
    assert names == [(s, st) for s in scenes for st in ("paper", "dwa")]
    assert {r["family"] for r in table} == {"head_on", "cluster"}
    assert all(not r["error"] for r in table)
    assert [r["seed"] for r in table[:4:2]] == ["3000000", "3000001"]


def test_a_scene_failing_in_a_worker_is_an_error_row(
    inputs: tuple[Path, ...], sil_lib: Path, tmp_path: Path
) -> None:
    rc = main(["sweep", "--generate-only", "--out", str(tmp_path), "--family", "head_on",
               "--count", "1", str(inputs[0])])  # fmt: skip
    assert rc == 0
    ok = Scene.from_file(next((tmp_path / "scenes").rglob("*.toml")))
    crash = Scene("crash", "crash.toml", CRASH)
    out = tmp_path / "out"
    plan = Plan(["paper", "dwa"])
    assert plan.add_scenes([ok, crash]) == []
    tally = Tally(plan.strategies)
    result = run_sweep(plan, out, str(sil_lib.resolve()), workers=2, events=True, rows=tally.add)
    assert (result.runs, result.ran) == (4, 4)
    with (out / "runs.csv").open(newline="") as f:
        by_scene = {(r["scene"], r["strategy"]): r for r in csv.DictReader(f)}
    assert len(by_scene) == 4
    for strategy in ("paper", "dwa"):
        bad = by_scene[("crash", strategy)]
        assert "REF_MOTION.v" in bad["error"] and bad["contact"] == ""
        assert not (out / strategy / "crash" / "events.json").exists()
        assert by_scene[(ok.name, strategy)]["error"] == ""
        assert (out / strategy / ok.name / "events.json").is_file()
    tally.finish(out / "runs.csv")
    text = tally.write(out, title="crash", firmware="test").read_text()
    assert "| (none) | ideal | paper | 1 | 1 |" in text  # the crash scene: one run, one error
    assert "## Errors (2)" in text


def test_events_json_is_what_mstc_sim_writes(
    first: Path, sil_lib: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = first / "scenes" / "cluster" / "cluster-0001.toml"
    paper = tmp_path / "cluster-0001.toml"
    paper.write_text(scene.read_text() + '\n[params]\nstrategy = "paper"\n')
    rc = main(
        [
            "sim",
            "--bus",
            "memory",
            "--lib",
            str(sil_lib),
            "--no-figures",
            "--out",
            str(tmp_path / "sim"),
            str(paper),
        ]
    )
    assert rc == 0
    capsys.readouterr()
    want = (tmp_path / "sim" / "cluster-0001" / "events.json").read_text()
    assert (first / "paper" / "cluster-0001" / "events.json").read_text() == want


def test_same_inputs_same_files_and_rows(
    first: Path,
    inputs: tuple[Path, ...],
    sil_lib: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    sweep(tmp_path, inputs, sil_lib, capsys=capsys)
    assert reproducible(rows(tmp_path)) == reproducible(rows(first))
    for path in first.rglob("*.toml"):
        assert (tmp_path / path.relative_to(first)).read_bytes() == path.read_bytes()
    for path in first.rglob("events.json"):
        assert (tmp_path / path.relative_to(first)).read_text() == path.read_text()


def test_resume_runs_only_what_an_interruption_left(
    first: Path,
    inputs: tuple[Path, ...],
    sil_lib: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    out = tmp_path / "out"
    shutil.copytree(first, out)
    # Interrupted after 3 rows, in the middle of writing the 4th.
    lines = (out / "runs.csv").read_text().splitlines(keepends=True)
    (out / "runs.csv").write_text("".join(lines[:4]) + lines[4][:20])
    kept = [(r["strategy"], r["scene"]) for r in rows(first)[:3]]
    stamps = {k: (out / k[0] / k[1] / "events.json").stat().st_mtime_ns for k in kept}
    time.sleep(0.01)
    text = sweep(out, inputs, sil_lib, "--resume", capsys=capsys)
    assert "8 runs (5 run now, 3 resumed)" in text
    assert {k: (out / k[0] / k[1] / "events.json").stat().st_mtime_ns for k in kept} == stamps
    assert reproducible(rows(out)) == reproducible(rows(first))


def test_summary_has_the_tables_figures_and_gallery(first: Path) -> None:
    text = (first / "summary.md").read_text()
    for family in ("head_on", "cluster"):
        for strategy in ("paper", "dwa"):
            assert f"| {family} | ideal | {strategy} | 2 | 0 |" in text
    assert "Wilson" in text and "## Errors" not in text
    for name in ("clearance.png", "tracking_error.png"):
        assert (first / name).stat().st_size > 1000 and f"]({name})" in text
    assert len(list((first / "gallery").rglob("*.png"))) == 2


def test_more_scenes_a_family_keeps_the_rows_run_already(
    first: Path,
    inputs: tuple[Path, ...],
    sil_lib: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Scene i of a family does not depend on the family's count: resumed
    with --count 3, the sweep of 2 scenes a family keeps its 8 rows and runs
    the 4 of the third scenes; the rows are those of a fresh sweep of 3."""
    out = tmp_path / "out"
    shutil.copytree(first, out)
    text = sweep(out, inputs, sil_lib, "--resume", "--count", "3", capsys=capsys, every=False)
    assert "12 runs (4 run now, 8 resumed)" in text
    fresh = tmp_path / "fresh"
    sweep(fresh, inputs, sil_lib, "--count", "3", every=False)
    assert reproducible(rows(out)) == reproducible(rows(fresh))


def test_only_the_failures_and_the_gallery_leave_scene_files_by_default(
    inputs: tuple[Path, ...], sil_lib: Path, tmp_path: Path
) -> None:
    """Without --write-scenes and --write-events: the scene file and
    events.json of each run with a contact, and of the gallery's runs (one
    a strategy here), nothing else; each such scene file is byte for byte
    what --generate-only writes for it."""
    sweep(tmp_path, inputs, sil_lib, every=False)
    table = rows(tmp_path)
    failures = {(r["scene"], r["strategy"]) for r in table if r["contact"] == "1" or r["error"]}
    assert failures  # the premise: the paper's strategy touches some cluster 2 m ahead
    gallery = {(p.stem, p.parent.name) for p in (tmp_path / "gallery").rglob("*.png")}
    assert len(gallery) == 2
    events = {(p.parent.name, p.parent.parent.name) for p in tmp_path.rglob("events.json")}
    assert events == failures | gallery
    scenes = {p.stem for p in (tmp_path / "scenes").rglob("*.toml")}
    assert scenes == {scene for scene, _ in failures | gallery}
    generated = tmp_path / "generated"
    rc = main(["sweep", "--generate-only", "--out", str(generated), str(inputs[0])])
    assert rc == 0
    for path in (tmp_path / "scenes").rglob("*.toml"):
        assert path.read_bytes() == (generated / path.relative_to(tmp_path)).read_bytes()
