# SPDX-License-Identifier: MIT
"""tools/vm/with-vcan gives a command a working vcan0, on the host or in a VM.

Where the host kernel has no CAN (this project's build and CI machines), the
round-trip test boots the vcan VM once (about 15-60 s under software
emulation, depending on the machine's load). It never skips: a machine that
can give neither a host vcan0 nor the VM fails it, with with-vcan's reason.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.vm

TOP = Path(__file__).resolve().parents[2]
WITH_VCAN = TOP / "tools" / "vm" / "with-vcan"

# (ID, extended, payload hex): classic frames of every length class, both ID
# widths, the extreme IDs.
FRAMES = [
    (0x123, False, "0011223344556677"),
    (0x7FF, False, ""),
    (0x000, False, "ff"),
    (0x1ABCDE0F, True, "a55a"),
    (0x1FFFFFFF, True, "deadbeef01"),
]

# Runs inside: two socketcan buses on vcan0, each frame sent on one and
# received on the other before the next. Reports what arrived, where it ran,
# and proves the working directory, the environment and stderr come through.
GUEST = r"""
import json, os, sys, time
import can

frames = json.loads(sys.argv[1])
tx = can.Bus(interface="socketcan", channel="vcan0")
rx = can.Bus(interface="socketcan", channel="vcan0")
received = []
for ident, extended, payload in frames:
    tx.send(can.Message(arbitration_id=ident, is_extended_id=extended,
                        data=bytes.fromhex(payload)))
    msg = rx.recv(5.0)
    received.append(None if msg is None else
                    [msg.arbitration_id, msg.is_extended_id, msg.dlc, msg.data.hex()])
count = 300
start = time.perf_counter()
for i in range(count):
    tx.send(can.Message(arbitration_id=0x321, is_extended_id=False, data=i.to_bytes(2, "little")))
    assert rx.recv(5.0) is not None
rate = count / (time.perf_counter() - start)
tx.shutdown()
rx.shutdown()
with open("written-inside.txt", "w") as f:
    f.write("hello from " + os.environ.get("MSTC_VCAN_WHERE", "?"))
print(json.dumps({
    "received": received,
    "where": os.environ.get("MSTC_VCAN_WHERE"),
    "cwd": os.getcwd(),
    "token": os.environ.get("MSTC_TEST_TOKEN"),
    "round_trips_per_s": round(rate),
}))
print("stderr comes through", file=sys.stderr)
sys.exit(3)
"""


def test_python_can_round_trip_through_with_vcan(tmp_path: Path) -> None:
    token = f"token-{os.getpid()}"
    env = dict(os.environ, MSTC_TEST_TOKEN=token)
    proc = subprocess.run(
        [
            str(WITH_VCAN),
            "--verbose",
            "--timeout",
            "300",
            "--",
            sys.executable,
            "-c",
            GUEST,
            json.dumps(FRAMES),
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    report = (
        f"with-vcan exit {proc.returncode}\n--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}"
    )
    # 3 is the command's own status: anything else means with-vcan (125), the
    # time limit (124) or the command failed.
    assert proc.returncode == 3, report
    assert "stderr comes through" in proc.stderr, report
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    expected = [
        [ident, extended, len(payload) // 2, payload] for ident, extended, payload in FRAMES
    ]
    assert result["received"] == expected, report
    assert result["where"] in ("host", "vm"), report
    assert result["cwd"] == str(tmp_path.resolve()), report
    assert result["token"] == token, report
    assert (tmp_path / "written-inside.txt").read_text() == f"hello from {result['where']}"
    print(f"vcan0 on the {result['where']}: {result['round_trips_per_s']} python-can round trips/s")
    print(proc.stderr)


def test_with_vcan_refuses_a_missing_command() -> None:
    proc = subprocess.run([str(WITH_VCAN), "--"], capture_output=True, text=True, check=False)
    assert proc.returncode == 125
    assert "no command given" in proc.stderr


def test_with_vcan_rejects_a_bad_timeout() -> None:
    proc = subprocess.run(
        [str(WITH_VCAN), "--timeout", "soon", "--", "true"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 125
    assert "--timeout wants whole seconds" in proc.stderr
