# SPDX-License-Identifier: MIT
"""`mstc sweep` against the inputs of issue 21's cases 8 to 10: what it must
refuse, and what it must not keep.

- case 8: `--resume` after the suite changed (same --out, another seed) kept
  the old seed's rows ("0 run now, 3 resumed"); two sweeps into one --out at
  once both ran, and one's rows were lost;
- case 9: a suite with circle_radius = [0, 0] (ZeroDivisionError), a
  corrupted value in runs.csv then --resume (ValueError in summary.py),
  `--scheduler nonsense` (a traceback from distributed), and a closed
  scheduler port, which waited 30 s and then blamed "the outputs";
- case 10: a suite checked as the loader checks a scene (negative noise, a
  radius of 3 to 4 m, v_r of 20 to 30 m/s were taken, and the sweep then
  failed naming a generated scene, not the suite's key, which docs/sweeps.md
  promises); count = 10¹² wrote files until the disk was full; an empty
  suite file reported "1 scene files" and wrote none.

The expected rows of a resumed sweep are those of a fresh sweep of the same
inputs into another folder (every column but the measured step cost is the
same for the same inputs, docs/sweeps.md); the limits named in the expected
messages are docs/scenarios.md's (the ranges of the frames).
"""

from __future__ import annotations

import csv
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mstc.cli import main
from mstc.errors import SuiteError
from mstc.sweep.engine import MEASURED_COLUMNS
from mstc.sweep.suite import load_suite

SUITE = """\
[suite]
name = "small"

[family.isolated]
count = 3
seed = {seed}
duration = 3.0
"""


def _sweep(out: Path, *args: str) -> int:
    return main(["sweep", "--strategy", "dwa", "--jobs", "1", "-q", "--out", str(out), *args])


def _rows(out: Path) -> list[dict[str, str]]:
    with (out / "runs.csv").open(newline="") as f:
        return [
            {k: v for k, v in r.items() if k not in MEASURED_COLUMNS} for r in csv.DictReader(f)
        ]


# ------------------------------------------------------------------ case 8


def test_resume_after_the_suite_changed_runs_the_new_scenes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    suite = tmp_path / "small.toml"
    suite.write_text(SUITE.format(seed=1))
    out = tmp_path / "out"
    assert _sweep(out, str(suite)) == 0
    suite.write_text(SUITE.format(seed=2))
    capsys.readouterr()
    assert _sweep(out, "--resume", str(suite)) == 0
    text = capsys.readouterr().out
    fresh = tmp_path / "fresh"
    assert _sweep(fresh, str(suite)) == 0
    # Every row is the new seed's, as a fresh sweep of the changed suite has it.
    assert [r["seed"] for r in _rows(out)] == ["2000000", "2000001", "2000002"]
    assert _rows(out) == _rows(fresh)
    assert "3 runs (3 run now, 0 resumed)" in text


def _group_alive(pgid: int) -> bool:
    """Whether a process of group @p pgid is still running (a zombie, ended
    but not yet reaped, holds no file)."""
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            # pid (comm) state ppid pgrp ...: comm may hold spaces, so after its ")"
            state, _ppid, pgrp = stat.read_text().rsplit(")", 1)[1].split()[:3]
        except (OSError, ValueError, IndexError):
            continue  # ended while listed
        if int(pgrp) == pgid and state != "Z":
            return True
    return False


def test_two_sweeps_into_one_folder_at_once_the_second_is_refused(tmp_path: Path) -> None:
    suite = tmp_path / "long.toml"
    # 400 scenes of 30 s: minutes of work, far longer than the second sweep.
    long = SUITE.format(seed=1).replace("count = 3", "count = 400")
    suite.write_text(long.replace("duration = 3.0", "duration = 30.0"))
    out = tmp_path / "out"
    mstc = [sys.executable, "-m", "mstc", "sweep", "--strategy", "dwa", "-q", "--out", str(out)]
    first = subprocess.Popen(
        [*mstc, "--jobs", "1", str(suite)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 120
        while not (out / "runs.csv").exists():  # the first sweep is running its scenes
            assert first.poll() is None, first.communicate()[1]
            assert time.monotonic() < deadline, "the first sweep did not start within 120 s"
            time.sleep(0.2)
        second = subprocess.run(
            [*mstc, "--count", "1", str(suite)], capture_output=True, text=True, timeout=300
        )
        assert first.poll() is None, "the first sweep ended before the second was tried"
    finally:
        os.killpg(first.pid, signal.SIGTERM)
        first.wait(timeout=60)
        # Its worker processes too: each holds the lock it was forked with
        # (flock belongs to the open file, which a fork shares) until it ends,
        # which on a busy machine can be a while after the main process.
        deadline = time.monotonic() + 60
        while _group_alive(first.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
    assert second.returncode == 2, second.stdout + second.stderr
    lines = second.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(out) in lines[0], lines
    assert "another" in lines[0]
    # Once the first is gone its lock goes with it: the folder is free again.
    assert _sweep(out, "--count", "1", str(suite)) == 0


# ------------------------------------------------------------------ case 9


def test_a_corrupted_row_is_run_again_on_resume(tmp_path: Path) -> None:
    suite = tmp_path / "small.toml"
    suite.write_text(SUITE.format(seed=1))
    out = tmp_path / "out"
    assert _sweep(out, str(suite)) == 0
    good = _rows(out)
    runs = out / "runs.csv"
    lines = runs.read_text().splitlines(keepends=True)
    cells = lines[2].split(",")
    cells[6] = "abc"  # min_clearance of the second row
    lines[2] = ",".join(cells)
    runs.write_text("".join(lines))
    assert _sweep(out, "--resume", str(suite)) == 0
    assert _rows(out) == good


def test_a_suite_circle_of_radius_zero_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    suite = tmp_path / "circle.toml"
    suite.write_text("[family.circle]\ncount = 2\nseed = 1\ncircle_radius = [0, 0]\n")
    assert _sweep(tmp_path / "out", str(suite)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {suite}: family.circle.circle_radius: ")


def test_a_scheduler_address_that_is_not_one_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    suite = tmp_path / "small.toml"
    suite.write_text(SUITE.format(seed=1))
    assert _sweep(tmp_path / "out", "--scheduler", "nonsense", str(suite)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --scheduler") and "nonsense" in err[0]


def test_a_closed_scheduler_port_blames_the_scheduler_not_the_outputs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    suite = tmp_path / "small.toml"
    suite.write_text(SUITE.format(seed=1))
    assert _sweep(tmp_path / "out", "--scheduler", address, str(suite)) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and address in err[0] and "scheduler" in err[0], err
    assert "outputs" not in err[0]


# ------------------------------------------------------------------ case 10

FAMILY = "[family.isolated]\ncount = 2\nseed = 1\n"


@pytest.mark.parametrize(
    ("text", "key", "problem"),
    [
        (
            FAMILY + "[family.isolated.imperfections]\nposition_noise = [-1, -0.5]\n",
            "family.isolated.imperfections.position_noise",
            ">= 0",
        ),
        (
            FAMILY + "[family.isolated.imperfections]\nsensor_range = [-1, 2]\n",
            "family.isolated.imperfections.sensor_range",
            "> 0",
        ),
        (FAMILY + "radius = [3, 4]\n", "family.isolated.radius", "OBSTACLE.radius"),
        (FAMILY + "v_r = [20, 30]\n", "family.isolated.v_r", "REF_MOTION.v"),
        (FAMILY + "duration = 1e6\n", "family.isolated.duration", "100,000 control steps"),
        ("[suite]\ndt = 0.0000005\n" + FAMILY, "suite.dt", "whole number of microseconds"),
        (
            "[family.circle]\ncount = 2\nseed = 1\ncircle_radius = [0.01, 3]\nv_r = [1, 1]\n",
            "family.circle.circle_radius",
            "REF_MOTION.w",
        ),
        (
            "[family.moving]\ncount = 2\nseed = 1\nspeed = [1, 40]\n",
            "family.moving.speed",
            "OBSTACLE_VEL",
        ),
        (
            "[family.isolated]\ncount = 1000000000000\nseed = 1\n",
            "family.isolated.count",
            "at most",
        ),
    ],
)
def test_a_suite_is_checked_as_the_loader_checks_a_scene_naming_the_suite_key(
    tmp_path: Path, text: str, key: str, problem: str
) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(SuiteError) as info:
        load_suite(path)
    message = str(info.value)
    assert message.startswith(f"{path}: {key}: ") and problem in message, message
    assert "\n" not in message


def test_a_scene_the_loader_refuses_is_named_with_its_family(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 15.9 m/s for 30 s: the reference leaves what REF_XY carries (±128 m).
    path = tmp_path / "far.toml"
    path.write_text(FAMILY + "v_r = [15, 15.9]\nheading = [0, 0]\n")
    assert _sweep(tmp_path / "out", str(path)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err and all(line.startswith(f"error: {path}: family.isolated: ") for line in err), err
    assert "REF_XY" in err[0]


def test_an_empty_suite_file_is_refused_not_counted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    empty = tmp_path / "empty.toml"
    empty.write_text("")
    out = tmp_path / "out"
    assert main(["sweep", "--generate-only", "--out", str(out), str(empty)]) == 2
    captured = capsys.readouterr()
    assert "scene files" not in captured.out
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {empty}: not a suite file"), err
