# SPDX-License-Identifier: MIT
"""`mstc sweep`'s client holds neither the scenes nor the rows of a sweep.

A suite's scenes are made where they run: the client sends slices (a few
numbers of the suite and a range of indices) and gets rows back, never a
scene; a slice's size does not grow with its scenes. Scenario files are
parsed once by the validation pass into the spool (mstc.sweep.spool), and a
slice reads its scenes back from it as it is sent. The rows go to runs.csv
and into the summary's counts, which do not grow with them (docs/sweeps.md,
"Memory")."""

from __future__ import annotations

import hashlib
import json
import pickle
import tracemalloc
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import pytest

from mstc.can.protocol import wire_limits
from mstc.cli import main
from mstc.plant.scenario import load_scenario
from mstc.sweep import plan
from mstc.sweep.engine import ROW_COLUMNS, Job, Scene, run_batch, shipped
from mstc.sweep.folder import text_sha256
from mstc.sweep.plan import Slice, SliceResult
from mstc.sweep.spool import Spool
from mstc.sweep.suite import generate, load_suite
from mstc.sweep.summary import Tally

SCENES = 12
SUITE = f"""\
[suite]
name = "memory"

[family.isolated]
count = {SCENES}
seed = 5
duration = 2.0
"""


def test_a_suites_slices_carry_no_scene_and_its_results_no_scene_but_failures(
    tmp_path: Path, sil_lib: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each slice is pickled as the pool and Dask send it: no Scenario in
    it, and no bigger with 6 scenes (12 runs: half the scenes on the one
    worker, two strategies) than with 1 (the first slices are smaller); the
    results hold the rows, and no scene file or events.json unless the run
    failed (none does here)."""
    (tmp_path / "memory.toml").write_text(SUITE)
    real = plan.run_tasks
    sent: list[tuple[int, int]] = []
    results: list[SliceResult] = []

    def watched(tasks: Callable[[int], Iterable[Slice]], work: Any, emit: Any, **kw: Any) -> None:
        def seen(task: Slice, result: SliceResult) -> None:
            data = pickle.dumps(task)
            assert b"Scenario" not in data and b"[robot]" not in data
            sent.append((len(data), len(task.runs())))
            results.append(result)
            emit(task, result)

        real(tasks, work, seen, **kw)

    monkeypatch.setattr(plan, "run_tasks", watched)
    args = ["--lib", str(sil_lib), "--strategy", "paper,mstc", "--jobs", "1", "--batch", "24"]
    out = tmp_path / "out"
    args += ["--gallery", "0", "-q", "--out", str(out), str(tmp_path / "memory.toml")]
    assert main(["sweep", *args]) == 0
    runs = [n for _, n in sent]
    assert sum(runs) == 2 * SCENES and min(runs) == 2 and max(runs) == 12
    small = min(size for size, n in sent if n == min(runs))
    assert all(size <= small + 200 for size, _ in sent), sent
    assert all(len(r.rows) and not r.files for r in results)
    assert not (out / "scenes").exists() and not (out / "mstc").exists()
    assert not [p for p in out.iterdir() if p.name.startswith(".spool")]


def test_the_summarys_counts_do_not_grow_with_the_rows() -> None:
    """A Tally of 2,000 rows and one of 20,000 (of one family, the same
    values over and over, as a long sweep gives them) take the same memory
    within 64 kB: each row kept would take some 0.8 kB, 14 MB more."""

    def rows(n: int) -> list[list[str]]:
        values = dict.fromkeys(ROW_COLUMNS, "0")
        values.update(scene="s", family="f", actuator="ideal", strategy="mstc", error="")
        out = []
        for i in range(n):
            row = dict(values, min_clearance=f"{0.1 + (i % 1000) * 1e-4:.6g}")
            out.append([row[c] for c in ROW_COLUMNS])
        return out

    sizes = []
    for n in (2000, 20000):
        batch = rows(n)
        tracemalloc.start()
        tally = Tally(["mstc"], gallery=6)
        for i in range(0, n, 500):
            tally.add(batch[i : i + 500])
        size = tracemalloc.get_traced_memory()[0]
        tracemalloc.stop()
        assert tally.rows == n
        sizes.append(size)
    assert abs(sizes[1] - sizes[0]) < 64 * 1024, sizes


@pytest.fixture
def files(tmp_path: Path) -> list[Path]:
    """The suite's scene files."""
    (tmp_path / "memory.toml").write_text(SUITE)
    return [f.path for f in generate(load_suite(tmp_path / "memory.toml"), tmp_path / "scenes")]


def test_the_spool_gives_back_each_scene_as_parsed_one_object_per_scene(
    tmp_path: Path, files: list[Path]
) -> None:
    """What a worker unpickles is the scenario the loader gives for the file
    (load_scenario, independently); a scene's jobs share one object, so a
    batch's pickle carries its bytes once; a scene that carries its text is
    sent as it is."""
    files = files[:3]
    wire = wire_limits()
    with Spool(tmp_path) as spool:
        records = []
        for path in files:
            scenario = load_scenario(path, wire)
            spool.add(path.stem, scenario)
            records.append(Scene.from_scenario(scenario, text_sha256(path.read_text())))
        assert len(spool) == 3 and spool.size > 0
        texted = Scene.from_file(files[0])
        jobs: list[Job] = [(r, s) for r in records for s in ("paper", "dwa")] + [(texted, "dwa")]
        sent = shipped(jobs, spool)
    assert [s for _, s in sent] == [s for _, s in jobs]
    assert sent[0][0] is sent[1][0] and sent[2][0] is sent[3][0]
    assert sent[-1][0] is texted
    for (scene, _), path in zip(sent[::2], files, strict=False):
        assert scene.text == "" and scene.scenario is None and scene.pickled
        assert scene.parsed() == load_scenario(path, wire)
        assert scene.digest() == text_sha256(path.read_text())
        assert (scene.family, scene.seed) == ("isolated", Scene.from_file(path).seed)


def test_a_worker_unpickles_a_scene_once_and_a_broken_one_is_its_rows(
    tmp_path: Path, files: list[Path]
) -> None:
    """DWA needs no library: both jobs of a good scene run; both of a scene
    whose bytes are not a pickle are error rows, and the batch goes on."""
    path = files[0]
    with Spool(tmp_path) as spool:
        spool.add(path.stem, load_scenario(path, wire_limits()))
        record = Scene.from_scenario(load_scenario(path, wire_limits()), "")
        ((good, _),) = shipped([(record, "dwa")], spool)
    broken = Scene("broken", "broken.toml", "", pickled=b"not a pickle")
    jobs: list[Job] = [(good, "dwa"), (broken, "dwa"), (good, "dwa"), (broken, "dwa")]
    outcomes = run_batch(jobs, "")
    assert [o.row["error"] == "" for o in outcomes] == [True, False, True, False]
    assert outcomes[0].events is not None and outcomes[0].events == outcomes[2].events


def test_every_unreadable_scene_file_is_reported_before_anything_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each file read once: a file that is not UTF-8, one that is not TOML and
    one that is no scenario are each one line in load_scenario's words (those
    of `mstc sim`), all three at once, and nothing runs (exit 2)."""
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "a.toml").write_bytes(b"\xff\xfe")
    (folder / "b.toml").write_text("[robot\n")
    (folder / "c.toml").write_text("[robot]\npose = [0.0, 0.0, 0.0]\n")
    out = tmp_path / "out"
    assert main(["sweep", "--strategy", "dwa", "-q", "--out", str(out), str(folder)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 3, err
    assert err[0].startswith(f"error: {folder / 'a.toml'}") and "not UTF-8 text" in err[0]
    assert err[1].startswith(f"error: {folder / 'b.toml'}") and "TOML syntax error" in err[1]
    assert err[2].startswith(f"error: {folder / 'c.toml'}")
    assert not (out / "runs.csv").exists()


def test_a_crlf_scene_keeps_the_digest_resume_compares(tmp_path: Path) -> None:
    """sources.json holds the sha256 of a scene's text as read with universal
    newlines (what it held when the client kept the text), so a sweep of
    before resumes: computed here with hashlib on the bytes, CRLF -> LF."""
    raw = (
        b"[robot]\r\npose = [0.0, 0.0, 0.0]\r\n[reference]\r\npose = [0.0, 0.0, 0.0]\r\n"
        b'v = 0.3\r\nw = 0.0\r\n[sim]\r\nduration = 1.0\r\ndt = 0.02\r\nintegrator = "euler"\r\n'
    )
    (tmp_path / "crlf.toml").write_bytes(raw)
    out = tmp_path / "out"
    args = ["sweep", "--strategy", "dwa", "--jobs", "1", "--gallery", "0", "-q", "--out", str(out)]
    assert main([*args, str(tmp_path / "crlf.toml")]) == 0
    sources = json.loads((out / "sources.json").read_text())
    assert sources["scenes"] == {"crlf": hashlib.sha256(raw.replace(b"\r\n", b"\n")).hexdigest()}
