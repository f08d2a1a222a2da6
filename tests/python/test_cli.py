# SPDX-License-Identifier: MIT
"""The command line and what a run writes, through the real library."""

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import SCENARIOS
from mstc.cli import COMMANDS, main
from mstc.errors import FirmwareError
from mstc.firmware.sil import SilController
from mstc.model import Params

TRACE_HEADER = "t,x,y,theta,x_r,y_r,theta_r,v,w,v_r,w_r,mode,e1,e2,e3,e,d1,d2".split(",")
FIGURES = ("path", "position_error", "angle_error", "v", "w", "distance", "overview")


def mstc(*args: str) -> subprocess.CompletedProcess[str]:
    """The installed ``mstc`` command, beside this interpreter (the .venv's)."""
    exe = Path(sys.executable).parent / "mstc"
    return subprocess.run([str(exe), *args], capture_output=True, text=True, check=False)


def test_help_describes_the_sim_command() -> None:
    top = mstc("--help")
    assert top.returncode == 0
    for command, text in COMMANDS.items():  # every one, its module imported or not
        assert f"    {command} " in top.stdout, command
        assert " ".join(text.split()[:3]) in " ".join(top.stdout.split()), command
    run = mstc("sim", "--help")
    assert run.returncode == 0
    for words in ("--lib", "--out", "events.json", "trace.csv", "exit status", "MSTC_SIL_LIB"):
        assert words in run.stdout


def test_a_command_imports_its_own_module_alone() -> None:
    """`mstc sweep` starts without the other commands' modules (BARN's,
    ROS's, the MCAP export's, matplotlib): a sweep's client pays only for
    its own imports (test_help_describes_the_sim_command: `mstc --help`
    still lists every command)."""
    probe = (
        "import sys; from mstc.cli import COMMANDS, main\n"
        "try:\n    main(['sweep', '--help'])\nexcept SystemExit:\n    pass\n"
        "print(sorted(n for n in COMMANDS if f'mstc.cli.{n}' in sys.modules), "
        "'matplotlib' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert done.stdout.splitlines()[-1] == "['sweep'] False", done.stdout


def test_version() -> None:
    done = mstc("--version")
    assert done.returncode == 0
    assert done.stdout.strip() == "mstc 0.1.0"


@pytest.mark.parametrize("args", [["sim", "--bogus", "x.toml"], ["sim"], ["fly"], []])
def test_bad_arguments_exit_2(args: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(args)
    assert info.value.code == 2
    assert "error:" in capsys.readouterr().err


def test_run_writes_events_trace_and_figures(
    sil_lib: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "sim"
    rc = main(["sim", "--lib", str(sil_lib), "--out", str(out), str(SCENARIOS / "paper-line.toml")])
    report = capsys.readouterr().out
    assert rc == 0
    folder = out / "paper-line"

    doc = json.loads((folder / "events.json").read_text())
    assert list(doc) == ["events", "min_distance"]
    assert doc["events"] == [
        {"t": 0.82, "event": "detect", "obstacle": 1},
        {"t": 3.1, "event": "detect", "obstacle": 2},
        {"t": 6.82, "event": "activate", "obstacle": 1, "side": "right"},
        {"t": 8.76, "event": "complete", "obstacle": 1},
        {"t": 9.36, "event": "activate", "obstacle": 2, "side": "left"},
        {"t": 11.1, "event": "complete", "obstacle": 2},
    ]
    assert [list(e) for e in doc["events"]][2] == ["t", "event", "obstacle", "side"]
    assert len(doc["min_distance"]) == 2
    assert all(d == round(d, 4) and d >= 0.35 for d in doc["min_distance"])

    with (folder / "trace.csv").open() as f:
        rows = list(csv.reader(f))
    assert rows[0] == TRACE_HEADER
    assert len(rows) == 1 + 1001
    assert {row[TRACE_HEADER.index("mode")] for row in rows[1:]} == {"track", "avoid"}
    assert float(rows[-1][0]) == 20.0

    for name in FIGURES:
        assert (folder / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    for line in ("activate  O1", "right", "6.82", "min distance", str(folder)):
        assert line in report


def test_missing_library_fails_before_writing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    scenario = str(SCENARIOS / "paper-line.toml")
    rc = main(["sim", "--lib", str(tmp_path / "absent.so"), "--out", str(out), scenario])
    assert rc == 1
    assert "cannot load firmware library" in capsys.readouterr().err
    # Neither --lib nor MSTC_SIL_LIB, and no default build: the error says how to get one.
    monkeypatch.delenv("MSTC_SIL_LIB", raising=False)
    monkeypatch.setattr("mstc.cli.common.DEFAULT_LIB", tmp_path / "not-built.so")
    rc = main(["sim", "--out", str(out), scenario])
    assert rc == 1
    err = capsys.readouterr().err
    assert "MSTC_SIL_LIB" in err and "make lib" in err and "--lib" in err
    assert not out.exists()


def test_firmware_defaults_are_table_1(sil_lib: Path) -> None:
    fw = SilController.defaults(sil_lib)
    py = Params()
    for name in ("r_m", "r_ob", "d_det", "d_act", "d_s", "wheel_radius", "track_width"):
        # float: 6e-8 relative; Q16.16: half an lsb, 2^-17 (0.2 is 0.1999969).
        assert getattr(fw, name) == pytest.approx(getattr(py, name), rel=1e-6, abs=2**-17), name
    assert fw.tracking_gains == py.tracking_gains
    assert fw.avoidance_gains == py.avoidance_gains
    assert fw.max_wheel_speed == py.max_wheel_speed


def test_firmware_rejects_invalid_parameters_clearly(sil_lib: Path) -> None:
    with pytest.raises(FirmwareError, match="rejected the parameters.*EINVAL"):
        SilController(Params(d_s=0.6), sil_lib)
