# SPDX-License-Identifier: MIT
"""`mstc sweep`'s client holds no parsed scene while the sweep runs: the
validation pass parses each file once into the spool (mstc.sweep.spool), and
a batch is read back from it as it is sent, so only the batches in flight
are in memory (docs/sweeps.md, "Memory").

The first test fails on the client that kept every parsed scene (the commit
before the spool): 12 live Scenario objects when the pool starts, not 0."""

from __future__ import annotations

import gc
import hashlib
import inspect
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from mstc.can.protocol import wire_limits
from mstc.cli import main
from mstc.plant.scenario import Scenario, load_scenario
from mstc.sweep import engine
from mstc.sweep.engine import IN_FLIGHT, Job, Scene, run_batch, shipped
from mstc.sweep.folder import text_sha256
from mstc.sweep.spool import Spool
from mstc.sweep.suite import generate, load_suite

SCENES = 12
SUITE = f"""\
[suite]
name = "memory"

[family.isolated]
count = {SCENES}
seed = 5
duration = 2.0
"""


def _live(kind: type) -> list[Any]:
    gc.collect()
    return [o for o in gc.get_objects() if type(o) is kind]


def test_the_client_holds_no_parsed_scene_while_the_sweep_runs(
    tmp_path: Path, sil_lib: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The pool runs one worker with batches of one job (12 scenes, two
    strategies: 24 batches): when it starts, no Scenario more is alive in the client
    than before the sweep; each time a batch is made, none either, and the
    scenes carrying their pickled scenario are the new batch's and those of
    at most IN_FLIGHT others: the ones in the pool's hands (IN_FLIGHT - 1)
    and one whose result has come back while the pool's thread has not yet
    dropped it. The client before the spool held all 12 scenarios."""
    (tmp_path / "memory.toml").write_text(SUITE)
    real = engine.run_local
    at_start: list[int] = []
    made: list[tuple[int, int]] = []

    def watched(*args: Any, **kwargs: Any) -> None:
        at_start.append(len(_live(Scenario)))
        bound = inspect.signature(real).bind(*args, **kwargs)
        ship: Callable[[list[Job]], list[Job]] | None = bound.arguments.get("ship")
        if ship is not None:

            def counted(batch: list[Job]) -> list[Job]:
                sent = ship(batch)
                carrying = sum(1 for s in _live(Scene) if s.pickled is not None)
                made.append((len(_live(Scenario)) - scenarios_before, carrying - carrying_before))
                return sent

            bound.arguments["ship"] = counted
        real(*bound.args, **bound.kwargs)

    monkeypatch.setattr(engine, "run_local", watched)
    scenarios_before = len(_live(Scenario))
    carrying_before = sum(1 for s in _live(Scene) if s.pickled is not None)
    args = ["--lib", str(sil_lib), "--strategy", "paper,mstc", "--jobs", "1", "--batch", "1"]
    out = tmp_path / "out"
    assert (
        main(
            [
                "sweep",
                *args,
                "--gallery",
                "0",
                "-q",
                "--out",
                str(out),
                str(tmp_path / "memory.toml"),
            ]
        )
        == 0
    )
    assert [n - scenarios_before for n in at_start] == [0]
    assert len(made) == 2 * SCENES  # --batch 1: a batch is one job
    assert all(scenarios == 0 for scenarios, _ in made), made
    assert all(1 <= carrying <= IN_FLIGHT + 1 for _, carrying in made), made
    assert sum(1 for _ in (out / "mstc").iterdir()) == SCENES
    assert not [p for p in out.iterdir() if p.name.startswith(".spool")]


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
    outcomes = run_batch([(good, "dwa"), (broken, "dwa"), (good, "dwa"), (broken, "dwa")], "")
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
