# SPDX-License-Identifier: MIT
"""Bounded work and safe outputs of ``mstc sim`` (issue 13, case 5): progress
on long runs, a refusal at run time that names the file and the key, output
folders that stay inside --out, and a rerun that clears the earlier run's
outputs (or refuses a folder holding files mstc did not write).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import pytest

from conftest import to_toml
from mstc.can.protocol import wire_limits
from mstc.cli import main
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import simulate
from mstc.plant import scenario as scenario_module
from mstc.plant.scenario import load_scenario
from mstc.report.progress import ProgressBar

SHORT: dict[str, Any] = {
    "robot": {"pose": [0.0, 0.0, 0.0]},
    "reference": {"pose": [0.1, 0.1, 0.0], "v": 0.5, "w": 0.0},
    "obstacles": [{"position": [2.0, 0.3]}],
    "sim": {"duration": 0.2, "dt": 0.02, "integrator": "euler"},
}
FIGURES = ("path", "position_error", "angle_error", "v", "w", "distance", "overview")


def write(folder: Path, name: str, doc: dict[str, Any]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(to_toml(doc))
    return path


def sim(*args: str | Path) -> int:
    return main(["sim", *(str(a) for a in args)])


class FakeClock:
    """Half a second passes at each reading."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        self.now += 0.5
        return self.now


def test_the_steps_limit_is_documented_and_reachable(tmp_path: Path) -> None:
    assert scenario_module.MAX_STEPS == 100_000
    # The reference circles (radius 1 m), so that the path stays within the frames' range.
    doc = {
        **SHORT,
        "reference": {"pose": [0.1, 0.1, 0.0], "v": 0.5, "w": 0.5},
        "sim": {"duration": 2000.0, "dt": 0.02, "integrator": "euler"},
    }
    assert (
        load_scenario(write(tmp_path, "limit.toml", doc), wire_limits()).sim.steps
        == scenario_module.MAX_STEPS
    )
    doc["sim"]["duration"] = 2000.02
    with pytest.raises(ValueError, match="100,000 control steps"):
        load_scenario(write(tmp_path, "over.toml", doc), wire_limits())


def test_long_runs_show_progress(tmp_path: Path, sil_lib: Path) -> None:
    scenario = load_scenario(write(tmp_path, "s.toml", SHORT), wire_limits())
    stream = io.StringIO()
    bar = ProgressBar(scenario.sim.steps + 1, "sim s", "steps", stream=stream, plain=True,
                   delay=0.0, clock=FakeClock())  # fmt: skip
    result = simulate(scenario, SilController(scenario.params, sil_lib), progress=bar)
    lines = stream.getvalue().splitlines()
    assert len(result.trace.values) == 11
    assert lines[0].startswith("sim s: 10% (")
    assert "/11 steps)" in lines[0]
    assert lines[-1].startswith("sim s: done in")


def test_sim_takes_quiet(tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, "q.toml", SHORT)
    rc = sim(
        "--quiet",
        "--bus",
        "memory",
        "--no-figures",
        "--lib",
        sil_lib,
        "--out",
        tmp_path / "o",
        path,
    )
    assert rc == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("bus", ["sil", "memory"])
@pytest.mark.parametrize(
    ("params", "key"),
    [({"D_det": 20000.0}, "D_det"), ({"tracking_gains": [3, 1e5, 6]}, "tracking_gains")],
)
def test_parameters_the_firmware_refuses_name_the_file_and_the_key(
    bus: str,
    params: dict[str, Any],
    key: str,
    tmp_path: Path,
    sil_lib: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = write(tmp_path, "p.toml", {**SHORT, "params": params})
    rc = sim("--bus", bus, "--no-figures", "--lib", sil_lib, "--out", tmp_path / "out", path)
    err = capsys.readouterr().err.splitlines()
    assert rc != 0
    assert len(err) == 1
    assert err[0].startswith(f"error: {path}: ")
    assert key in err[0]
    assert not (tmp_path / "out" / "p").exists()


@pytest.mark.parametrize("name", ["...toml", "..toml"])
def test_no_scenario_name_writes_outside_out(
    name: str, tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write(tmp_path / "scenarios", name, SHORT)
    out = tmp_path / "work" / "out"
    rc = sim("--bus", "memory", "--no-figures", "--lib", sil_lib, "--out", out, path)
    err = capsys.readouterr().err
    assert rc == 2
    assert f"error: {path}: " in err and "--out" in err
    written = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    assert written == [Path("scenarios") / name]


def test_a_rerun_clears_the_earlier_runs_outputs(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write(tmp_path, "again.toml", SHORT)
    out = tmp_path / "out"
    assert sim("--bus", "sil", "--lib", sil_lib, "--out", out, path) == 0
    folder = out / "again"
    first = sorted(p.name for p in folder.iterdir())
    want = ["bus.log", "events.json", "run.json", "trace.csv", *(f"{f}.png" for f in FIGURES)]
    assert first == sorted(want)
    assert sim("--bus", "memory", "--no-figures", "--lib", sil_lib, "--out", out, path) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["events.json", "run.json", "trace.csv"]
    capsys.readouterr()


def test_a_folder_holding_other_files_is_refused_and_left_alone(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write(tmp_path, "mine.toml", SHORT)
    folder = tmp_path / "out" / "mine"
    folder.mkdir(parents=True)
    (folder / "trace.csv").write_text("old\n")
    (folder / "notes.txt").write_text("keep me\n")
    rc = sim("--bus", "memory", "--no-figures", "--lib", sil_lib, "--out", tmp_path / "out", path)
    err = capsys.readouterr().err
    assert rc == 2
    assert "notes.txt" in err and str(folder) in err
    assert (folder / "notes.txt").read_text() == "keep me\n"
    assert (folder / "trace.csv").read_text() == "old\n"


def test_an_output_folder_that_is_a_link_is_refused(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write(tmp_path, "linked.toml", SHORT)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "trace.csv").write_text("not mstc's\n")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "linked").symlink_to(elsewhere)
    rc = sim("--bus", "memory", "--no-figures", "--lib", sil_lib, "--out", tmp_path / "out", path)
    assert rc == 2
    assert "link" in capsys.readouterr().err
    assert (elsewhere / "trace.csv").read_text() == "not mstc's\n"
