# SPDX-License-Identifier: MIT
"""``mstc board`` against ``mstc-fw`` on vcan0 (tools/vm/with-vcan: the host's
vcan where its kernel has CAN, else the vcan VM, booted once): two firmwares
with node ids 0 and 1 on one bus, each driven by its own ``mstc board``
process. Never skipped: a machine that can give neither a host vcan0 nor the
VM fails it, with with-vcan's reason.

Expected values as in test_board.py: the version of pyproject.toml, D_s =
0.35 m by default (Table 1), a set of D_s above D_act refused, an arm
refused without odometry; node 1 runs on its own timer (--realtime), so it
sends its status unasked and the monitor sees its frames under 0x2xx.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

pytestmark = pytest.mark.vm

TOP = Path(__file__).resolve().parents[2]
WITH_VCAN = TOP / "tools" / "vm" / "with-vcan"
KEY = TOP / "tests" / "data" / "test.key"

# Runs on the host under with-vcan --bridge (vcan0 and the firmwares in the
# VM where the host has no CAN, as make hil runs): the two firmwares, started
# in the guest through the bridge's agent, then each `mstc board` command as
# a process of its own on the host; prints (arguments, exit status, stdout,
# stderr) of each.
GUEST = r"""
import json, os, select, subprocess, sys, time
fw, key = sys.argv[1], sys.argv[2]
both = (f"trap 'kill 0' TERM; {fw} --can vcan0 --key-file {key} --node 0 & "
        f"{fw} --can vcan0 --key-file {key} --node 1 --realtime & wait")
runner = [sys.executable, "-m", "mstc.can.vmbridge", "run", "--"]
if not os.environ.get("MSTC_VCAN_BRIDGE"):
    runner = []  # the host has vcan0
# One session for both firmwares: the VM's agent runs them side by side.
proc = subprocess.Popen([*runner, "bash", "-c", both], stderr=subprocess.PIPE)
# The start lines from the pipe itself: a buffered readline() may take both
# lines in one read (they come together on a busy machine), and select() on
# the pipe then waits for a second line that is already in the buffer.
err, fd, deadline = b"", proc.stderr.fileno(), time.monotonic() + 300
while err.count(b"\n") < 2 and select.select([fd], [], [], max(deadline - time.monotonic(), 0))[0]:
    chunk = os.read(fd, 4096)
    if not chunk:
        break
    err += chunk
starts = err.decode(errors="replace").splitlines()[:2]
starts += ["(no start line in 300 s)"] * (2 - len(starts))
runs = []
if all(" mode on " in line for line in starts):
    for args in json.loads(sys.argv[3]):
        done = subprocess.run(
            [sys.executable, "-m", "mstc", "board", "-i", "socketcan", "-c", "vcan0",
             "--key-file", key, "--timeout", "3", *args],
            capture_output=True, text=True, timeout=300)
        runs.append([args, done.returncode, done.stdout, done.stderr])
proc.terminate()
proc.wait(timeout=60)
print(json.dumps({"starts": starts, "runs": runs}))
"""

COMMANDS = [
    ["--node", "0", "version"],
    ["--node", "1", "version"],
    ["--node", "0", "set", "D_s", "0.4"],
    ["--node", "1", "set", "D_s", "0.45"],
    ["--node", "0", "get", "D_s"],
    ["--node", "1", "get", "D_s"],
    ["--node", "0", "set", "D_s", "0.6"],
    ["--node", "0", "arm"],
    ["--node", "1", "-n", "1", "status"],
    ["--node", "1", "-n", "5", "monitor"],
]


def test_two_mstc_fw_on_vcan_each_driven_by_its_own_mstc_board(tmp_path: Path) -> None:
    fw = os.environ.get("MSTC_FW", str(TOP / "build" / "host" / "mstc-fw"))
    proc = subprocess.run(
        [str(WITH_VCAN), "--bridge", "--verbose", "--timeout", "900", "--"]
        + [sys.executable, "-c", GUEST]
        + [str(Path(fw).resolve()), str(KEY), json.dumps(COMMANDS)],
        cwd=TOP,
        env=dict(os.environ, XDG_CACHE_HOME=str(tmp_path)),  # mstc board's counters, here
        capture_output=True,
        text=True,
        timeout=1200,
        check=False,
    )
    report = (
        f"with-vcan exit {proc.returncode}\n--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}"
    )
    assert proc.returncode == 0, report
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert all(", node " in x for x in result["starts"]), report
    assert sorted(x.split(", node ")[1][0] for x in result["starts"]) == ["0", "1"], report
    runs = {" ".join(args): (rc, out, err) for args, rc, out, err in result["runs"]}
    version = tomllib.loads((TOP / "pyproject.toml").read_text())["project"]["version"]
    for node in ("0", "1"):
        rc, out, err = runs[f"--node {node} version"]
        assert rc == 0, err
        assert out.startswith(f"node {node}: mstc firmware {version} (build "), out
    assert runs["--node 0 set D_s 0.4"][:2] == (0, "D_s = 0.4 m\n"), runs
    assert runs["--node 1 set D_s 0.45"][:2] == (0, "D_s = 0.45 m\n"), runs
    assert runs["--node 0 get D_s"][1].split()[:3] == ["D_s", "0.4", "m"], runs
    assert runs["--node 1 get D_s"][1].split()[:3] == ["D_s", "0.45", "m"], runs
    rc, _, err = runs["--node 0 set D_s 0.6"]
    assert rc == 1 and "rejected: the set that would result breaks" in err, err
    rc, _, err = runs["--node 0 arm"]
    assert rc == 1 and "rejected: not ready" in err, err
    rc, out, err = runs["--node 1 -n 1 status"]
    assert rc == 0, err
    assert "halt not_armed" in out, out  # its own timer steps it: a STATUS, unasked
    rc, out, err = runs["--node 1 -n 5 monitor"]
    assert rc == 0, err
    lines = out.splitlines()
    assert len(lines) == 5 and all("  node 1 " in x for x in lines), out
