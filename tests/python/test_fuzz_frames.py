# SPDX-License-Identifier: MIT
"""The frames fuzzer, fuzz/fuzz_frames.c (issue 30, F0): it must be able to
send every frame of the DBC, and its invariants must allow every halt the
firmware documents (docs/safety.md: STATUS_halt 1 to 7).

The harness is run as libFuzzer runs a single input (``build/fuzz/frames
FILE``), with ``MSTC_FUZZ_TRACE`` set: it then writes the identifier of each
frame it hands to the application and each change of the halt reason. The
expected identifiers are the DBC's, read with cantools (not the harness's
list); the halt input is built by hand from the protocol (records as
fuzz_frames.c documents them, payloads from mstc's encoder) and its halt, 7,
is the one test_app_safety.c derives for wheel speeds lost while one wheel
was last measured turning.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import ROOT
from mstc.can.protocol import Protocol

HARNESS = ROOT / "build" / "fuzz" / "frames"
RECORD = 12
"""Bytes of one record: [op, id, dlc, b0..b7, arg]."""
HALT_WHEEL_SPEED = 7


def harness() -> Path:
    """build/fuzz/frames, built (or brought up to date) by make; fails the
    test, loudly, when it cannot be (clang with libFuzzer is needed)."""
    make = shutil.which("make")
    if make is None:
        pytest.fail("make not found: the harness is built by `make build/fuzz/frames`")
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    done = subprocess.run(
        [make, "-s", "--no-print-directory", str(HARNESS.relative_to(ROOT))],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        pytest.fail(f"make build/fuzz/frames failed:\n{done.stdout}{done.stderr}")
    return HARNESS


def run(path: Path, records: bytes, tmp_path: Path) -> tuple[int, list[str]]:
    """Run the harness once on @p records; its exit status and trace lines."""
    data = tmp_path / "input"
    data.write_bytes(records)
    done = subprocess.run(
        [str(path), str(data)],
        env={**os.environ, "MSTC_FUZZ_TRACE": "1"},
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = [ln for ln in done.stderr.splitlines() if ln.startswith(("frame ", "halt "))]
    return done.returncode, lines


def record(op: int, selector: int, data: bytes = bytes(8), arg: int = 0) -> bytes:
    return bytes([op, selector, 8]) + data.ljust(8, b"\0")[:8] + bytes([arg])


def selectors(path: Path, tmp_path: Path) -> dict[int, int]:
    """The identifier each value of a record's id byte sends (op 1), by
    identifier: the first selector that sends it."""
    status, lines = run(path, b"".join(record(1, k) for k in range(256)), tmp_path)
    assert status == 0, lines
    sent = [int(ln.split()[1], 16) for ln in lines if ln.startswith("frame ")]
    assert len(sent) == 256, f"{len(sent)} frames traced for 256 records"
    found: dict[int, int] = {}
    for k, frame_id in enumerate(sent):
        found.setdefault(frame_id, k)
    return found


def test_fuzz_frames_reaches_every_identifier_of_the_dbc(tmp_path: Path) -> None:
    dbc = {m.frame_id: m.name for m in Protocol().db.messages}
    found = selectors(harness(), tmp_path)
    missing = sorted(dbc[i] for i in dbc.keys() - found.keys())
    assert not missing, f"fuzz_frames never sends {', '.join(missing)}"


def test_fuzz_frames_takes_the_wheel_speed_halt_as_legitimate(tmp_path: Path) -> None:
    """The robot armed in real-time mode (op 2 ticks of 20 ms), standing on
    its reference; three ticks with WHEEL_SPEED saying the left wheel turns
    at 1 rad/s, then three without: the firmware halts with reason 7 at the
    third (test_app_safety_wheel_speeds_lost_while_only_measured_moving_halt),
    a documented halt the harness must not abort on."""
    path = harness()
    sel = selectors(path, tmp_path)
    proto = Protocol(node=None)

    def frame(name: str, **signals: float) -> bytes:
        message = proto.message(name)
        if message.frame_id not in sel:
            pytest.fail(f"fuzz_frames cannot send {name}")
        # The harness makes counter and CRC right (op 1); raw fills the rest.
        data = bytes(proto.encode(name, raw=name == "PARAM_AUTH", **signals).data)
        return record(1, sel[message.frame_id], data)

    inputs = (
        frame("ODOM_XY", x=0.0, y=0.0)
        + frame("ODOM_THETA", theta=0.0)
        + frame("REF_XY", x=0.0, y=0.0)
        + frame("REF_MOTION", theta=0.0, v=0.0, w=0.0)
    )
    tick = record(2, 0, arg=20)
    records = (
        inputs * 5
        + frame("PARAM_SET", index=proto.tables.arm_index, value=1.0)
        + frame("PARAM_AUTH", freshness=0, mac=0)  # the harness signs it
        + (frame("WHEEL_SPEED", left=1.0, right=0.0, faults=0) + inputs + tick) * 3
        + (inputs + tick) * 3
    )
    status, lines = run(path, records, tmp_path)
    halts = [int(ln.split()[1]) for ln in lines if ln.startswith("halt ")]
    assert status == 0, f"the harness aborted (exit {status}); halts {halts}"
    assert halts == [0, HALT_WHEEL_SPEED], halts
