# SPDX-License-Identifier: MIT
"""HIL over vcan (issue: CAN between plant and firmware): mstc-fw as its own
process on vcan0 and the plant on python-can's socketcan interface, inside the
vcan VM where the host kernel has no CAN (tools/vm/with-vcan). Never skipped:
without a vcan the test fails and says why.

Expected values: the paper's events (via the scenario files' [[expected]]
times, which test_paper.py checks against the paper's) and the in-memory loop.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import can
import pytest

from mstc.firmware import SilController
from mstc.report.outputs import event_record
from mstc.sim.run import simulate
from mstc.sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "sim" / "scenarios"
DBC = ROOT / "firmware" / "comm" / "mstc.dbc"
NAMES = ("paper-line", "paper-circle")


@pytest.fixture(scope="module")
def hil_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    fw = os.environ.get("MSTC_FW")
    if not fw or not Path(fw).is_file():
        pytest.fail(f"MSTC_FW={fw!r}: `make test-python` builds build/host/mstc-fw", pytrace=False)
    # The VM shares the working directory read-write, so the output goes there.
    out = ROOT / "build" / "test-hil"
    cmd = [
        str(ROOT / "tools" / "vm" / "with-vcan"),
        "--timeout",
        "900",
        "--",
        str(Path(sys.executable).parent / "mstc"),
        "hil",
        "--channel",
        "vcan0",
        "--fw",
        fw,
        "--no-figures",
        "--out",
        str(out),
        *(str(SCENARIOS / f"{n}.toml") for n in NAMES),
    ]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=1500)
    if done.returncode != 0:
        pytest.fail(
            f"HIL run failed ({done.returncode}):\n{done.stdout}\n{done.stderr}", pytrace=False
        )
    return out


@pytest.mark.parametrize("name", NAMES)
def test_hil_gives_the_in_memory_events_exactly(hil_out: Path, sil_lib: Path, name: str) -> None:
    scenario = load_scenario(SCENARIOS / f"{name}.toml")
    memory = simulate(scenario, SilController(scenario.params, sil_lib))
    got = json.loads((hil_out / name / "events.json").read_text())
    assert got["events"] == [event_record(e) for e in memory.events]
    assert len(got["events"]) == 6
    assert min(got["min_distance"]) >= 0.35


@pytest.mark.parametrize("name", NAMES)
def test_hil_bus_log_decodes_with_cantools(hil_out: Path, name: str) -> None:
    log = hil_out / name / "bus.log"
    lines = log.read_text().splitlines()
    assert all(" vcan0 " in line for line in lines)
    out = subprocess.run(
        [sys.executable, "-m", "cantools", "decode", "--single-line", str(DBC)],
        input=log.read_text(),
        capture_output=True,
        text=True,
        check=True,
    ).stdout.splitlines()
    assert len(out) == len(lines)
    assert all("::" in line and "Unknown" not in line for line in out)
    assert len(list(can.LogReader(log))) == len(lines)
