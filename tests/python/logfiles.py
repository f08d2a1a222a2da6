# SPDX-License-Identifier: MIT
"""Fixtures and helpers of the bus-log tests (test_log_*.py, test_replay.py):
the committed logs, the DBC, and the ``mstc replay`` / ``mstc play`` commands
run in process. Loaded as a pytest plugin by conftest.py."""

from __future__ import annotations

import ctypes
import re
from collections.abc import Callable
from pathlib import Path

import cantools
import pytest

from conftest import ROOT
from mstc.can.protocol import load_database
from mstc.cli import main

DATA = ROOT / "tests" / "data"
NAMES = ("paper-line", "paper-circle")
DBC = ROOT / "firmware" / "comm" / "mstc.dbc"
CANDUMP_LINE = re.compile(r"^\(\d+\.\d{6}\) \S+ [0-9A-F]{3}#(?:[0-9A-F]{2}){0,8}$")
FIGURES = ("path", "position_error", "angle_error", "v", "w", "distance", "overview")


# ---------------------------------------------------------------- fixtures


@pytest.fixture(scope="session")
def float_lib(sil_lib: Path) -> Path:
    """The float build: the committed logs were recorded from it. Under
    NUMERIC=fixed, $MSTC_SIL_LIB is the fixed build, and the float one must
    have been built too; without it the tests fail, loudly."""
    dll = ctypes.CDLL(str(sil_lib.resolve()))
    dll.mstc_sil_numeric.restype = ctypes.c_char_p
    if dll.mstc_sil_numeric() == b"float":
        return sil_lib
    other = ROOT / "build" / "host" / "float" / "libmstc_sil.so"
    if not other.is_file():
        pytest.fail(
            f"{sil_lib} is not the float build, and {other} does not exist: the committed "
            "logs replay bit-exact through the float build only (make lib NUMERIC=float)",
            pytrace=False,
        )
    return other


@pytest.fixture(scope="session")
def db() -> cantools.database.can.Database:
    return load_database()


@pytest.fixture(scope="session")
def fw_ids() -> tuple[set[int], set[int]]:
    """What the DBC's FW node receives and sends, read with cantools directly."""
    raw = cantools.database.load_file(DBC)
    receives = {m.frame_id for m in raw.messages if "FW" in m.receivers}
    sends = {m.frame_id for m in raw.messages if "FW" in m.senders}
    return receives, sends


def split(line: str) -> tuple[float, int, str]:
    """(time, identifier, hex data) of a candump -L line, by hand."""
    stamp, _, frame = line.split()
    ident, _, data = frame.partition("#")
    return float(stamp[1:-1]), int(ident, 16), data


def log_lines(name: str) -> list[str]:
    return (DATA / f"{name}.log").read_text().splitlines()


@pytest.fixture(scope="module")
def short_lines() -> list[str]:
    """The first ~3 s of the line scenario's log, up to a WHEEL_CMD (the end of
    a control step's answer), so that it replays bit-exact on its own."""
    lines = log_lines("paper-line")[:1600]
    last = max(i for i, line in enumerate(lines) if split(line)[1] == 0x180)
    return lines[: last + 1]


def write(tmp_path: Path, lines: list[str], name: str = "bus.log") -> Path:
    path = tmp_path / name
    path.write_text("".join(line + "\n" for line in lines))
    return path


Run = Callable[..., tuple[int, str, str]]


@pytest.fixture
def run_replay(capsys: pytest.CaptureFixture[str], float_lib: Path) -> Run:
    """``mstc replay --lib <float build>`` in process: (exit status, stdout, stderr)."""

    def run(*args: str | Path, lib: bool = True) -> tuple[int, str, str]:
        argv = [str(a) for a in args]
        if lib:
            argv = ["--lib", str(float_lib), *argv]
        rc = main(["replay", *argv])
        out, err = capsys.readouterr()
        return rc, out, err

    return run


@pytest.fixture
def run_play(capsys: pytest.CaptureFixture[str]) -> Run:
    """``mstc play`` in process: (exit status, stdout, stderr)."""

    def run(*args: str | Path) -> tuple[int, str, str]:
        rc = main(["play", *(str(a) for a in args)])
        out, err = capsys.readouterr()
        return rc, out, err

    return run


def index_of(lines: list[str], frame_id: int, after: float = 0.0) -> int:
    """The first line of @p frame_id at or after time @p after."""
    return next(
        i for i, line in enumerate(lines) if split(line)[1] == frame_id and split(line)[0] >= after
    )
