# SPDX-License-Identifier: MIT
"""A run's inputs, as issue 21's cases 9, 11 and 12 found them handled:

- case 9: ``heading_noise = 1e308`` ended in a traceback (math domain error)
  on both buses, not in one line;
- case 11: ``position_noise = 1e6`` ran on ``--bus memory`` (its fault
  mislabelled "non-finite input") and stopped on ``--bus sil`` with an
  ODOM_XY range error, while docs/scenarios.md promises a scenario the same
  result on every bus;
- case 12: ``mstc hil`` without SocketCAN blamed the scenario
  (``error: <scenario>.toml: [Errno 97] ...``); ``mstc plot <run folder>``
  could not tell the log format while ``mstc export`` takes run folders.

Each command's error is compared between the buses, or read for what it
names, never against the code's own output.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Mapping
from pathlib import Path

import pytest

from conftest import SCENARIOS
from mstc.can.dbc import load_database
from mstc.cli import main
from mstc.logs.decode import decode_log
from mstc.logs.read import read_log
from mstc.model import EventKind
from mstc.report import plots

ROOT = Path(__file__).resolve().parents[2]
LOG = ROOT / "tests" / "data" / "paper-line.log"


def _noisy(tmp_path: Path, table: str) -> Path:
    """paper-line.toml with an [imperfections] table."""
    text = (SCENARIOS / "paper-line.toml").read_text()
    path = tmp_path / "noisy.toml"
    path.write_text(text + f"\n[imperfections]\nseed = 1\n{table}\n")
    return path


def _sim(bus: str, scenario: Path, out: Path, lib: Path) -> list[str]:
    return ["sim", "--bus", bus, "--lib", str(lib), "--no-figures", "-q", "--out", str(out),
            str(scenario)]  # fmt: skip


def _errors(capsys: pytest.CaptureFixture[str]) -> list[str]:
    return capsys.readouterr().err.strip().splitlines()


def test_an_absurd_heading_noise_is_one_line_on_every_bus(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = _noisy(tmp_path, "heading_noise = 1e308")
    for bus in ("memory", "sil"):
        assert main(_sim(bus, scenario, tmp_path / bus, sil_lib)) == 2
        err = _errors(capsys)
        assert len(err) == 1 and err[0].startswith(
            f"error: {scenario}: imperfections.heading_noise"
        )


@pytest.mark.parametrize(
    ("table", "signal"),
    [("position_noise = 1e6", "ODOM_XY."), ("obstacle_noise = 1e6", "OBSTACLE.")],
)
def test_noise_beyond_the_frames_gives_the_same_result_on_every_bus(
    tmp_path: Path, sil_lib: Path, capsys: pytest.CaptureFixture[str], table: str, signal: str
) -> None:
    scenario = _noisy(tmp_path, table)
    results = {}
    for bus in ("memory", "sil"):
        rc = main(_sim(bus, scenario, tmp_path / bus, sil_lib))
        results[bus] = (rc, _errors(capsys))
    assert results["memory"] == results["sil"]
    rc, err = results["sil"]
    assert rc == 1 and len(err) == 1, err
    assert err[0].startswith(f"error: {scenario}: {signal}") and "outside its range" in err[0]
    assert not (tmp_path / "memory" / "noisy").exists()  # nothing written, as on sil


def test_hil_without_a_bus_blames_the_bus_not_the_scenario(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # No such interface on any machine: EAFNOSUPPORT where the kernel has no
    # SocketCAN (this one), ENODEV where it has.
    scenario = SCENARIOS / "paper-line.toml"
    rc = main(["hil", "--channel", "mstcnosuch0", "--out", str(tmp_path), str(scenario)])
    err = _errors(capsys)
    assert rc == 3, err
    assert len(err) == 1 and err[0].startswith("error: cannot open socketcan bus 'mstcnosuch0'")
    assert str(scenario) not in err[0]
    assert "SocketCAN" in err[0] or "no such interface" in err[0]


def test_plot_takes_a_run_folder_as_export_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "paper-line"
    run.mkdir()
    shutil.copy(LOG, run / "bus.log")
    out = tmp_path / "plots"
    assert main(["plot", "--no-figures", "-q", "--out", str(out), str(run)]) == 0
    assert (out / "paper-line" / "events.json").is_file()
    # (mstc export: test_export.test_a_run_folder_is_read_through_its_bus_log)
    empty = tmp_path / "empty"
    empty.mkdir()
    capsys.readouterr()
    assert main(["plot", "--no-figures", "-q", "--out", str(out), str(empty)]) == 2
    err = _errors(capsys)
    assert (
        len(err) == 1
        and err[0] == f"error: {empty} is a directory without a bus.log: not a run folder"
    )


# A scene where "mstc" reports an obstacle it cannot keep away within the
# wheels' limits: an "infeasible" event.
_INFEASIBLE = {
    # An obstacle closing head-on at 3 m/s, 0.5 m off the robot's line,
    # under the gearmotor profile: the filter reports that it cannot null the
    # closing speed in time (infeasible, at 0.18 s), and the obstacle passes
    # 0.46 m from the robot's centre (no contact).
    "robot": {"pose": [0.0, 0.0, 0.0]},
    "reference": {"pose": [0.0, 0.0, 0.0], "v": 0.5, "w": 0.0},
    "obstacles": [{"position": [4.0, 0.5], "radius": 0.1, "velocity": [-3.0, 0.0]}],
    "sim": {"duration": 6.0, "dt": 0.02, "integrator": "euler"},
    "actuator": {"time_constant": 0.06, "max_accel": 20.0, "encoder_counts": 1920},
    "params": {"strategy": "mstc"},
}


def test_every_event_kind_is_drawn_in_the_path_figure(
    tmp_path: Path, sil_lib: Path, write_scenario: Callable[[Mapping[str, object], str], Path]
) -> None:
    """Every kind has a marker and a legend entry; a run whose events include
    "infeasible" writes its figures (it stopped with a KeyError in
    draw_path, in `mstc sim` and in `mstc sweep`'s gallery)."""
    assert set(plots._MARKERS) == set(EventKind)
    path = write_scenario(_INFEASIBLE, "infeasible")
    out = tmp_path / "out"
    assert main(["sim", "--lib", str(sil_lib), "-q", "--out", str(out), str(path)]) == 0
    run = out / "infeasible"
    kinds = {e["event"] for e in json.loads((run / "events.json").read_text())["events"]}
    assert "infeasible" in kinds, kinds
    assert (run / "path.png").stat().st_size > 0


CLUSTER = {
    # The scene cluster-0000 of sim/suites/standard.toml (mstc sweep
    # --generate-only), under the paper's strategy: 8 events among 5
    # obstacles close together, whose labels covered each other.
    "robot": {"pose": [0.0082, 0.0096, 0.0383]},
    "reference": {"pose": [0.0, 0.0, 0.2547], "v": 0.5416, "w": 0.0},
    "obstacles": [
        {"position": p}
        for p in (
            [4.4035, 1.0215],
            [4.1488, 0.6181],
            [3.9477, 1.6522],
            [4.7689, 0.6791],
            [4.4774, 0.2403],
        )
    ],
    "sim": {"duration": 30.0, "dt": 0.02},
    "params": {"strategy": "paper"},
}


def test_the_path_figures_event_labels_do_not_overlap(
    tmp_path: Path, sil_lib: Path, write_scenario: Callable[[Mapping[str, object], str], Path]
) -> None:
    """path.png as `mstc sim` saves it (7 x 5 in at 120 dpi), of a run whose
    events come close together on the path: no event's time label over
    another's (issue 35). Checked on the figure as laid out for saving."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    path = write_scenario(CLUSTER, "cluster")
    out = tmp_path / "out"
    main(["sim", "--lib", str(sil_lib), "-q", "--no-figures", "--out", str(out), str(path)])
    db = load_database()
    decoded = decode_log(read_log(out / "cluster" / "bus.log", db), db)
    fig = Figure(figsize=(7.0, 5.0), layout="constrained")
    ax = fig.add_subplot()
    plots.draw_path(ax, plots.PlotData.from_log(decoded))
    plots._save(fig, tmp_path / "path.png", dpi=120)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    boxes = [
        (t.get_text(), t.get_window_extent(renderer))
        for t in ax.texts
        if t.get_gid() == plots._EVENT_LABEL
    ]
    assert len(boxes) >= 6, [text for text, _ in boxes]
    for i, (text_a, a) in enumerate(boxes):
        for text_b, b in boxes[i + 1 :]:
            assert not a.overlaps(b), f"{text_a!r} over {text_b!r}"
