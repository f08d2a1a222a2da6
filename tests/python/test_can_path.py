# SPDX-License-Identifier: MIT
"""The plant and the firmware through CAN frames (issue: CAN between plant and
firmware): the in-process firmware behind the python-can interface "mstc-sil"
must give the same events as the in-memory step, and every run's bus.log must
be byte-exact candump -L that python-can and cantools read back.

Expected values: the in-memory loop (itself checked against the paper in
test_paper.py) and the candump -L line format of can-utils.
"""

import re
import subprocess
import sys
from pathlib import Path

import can
import pytest

from mstc.can.protocol import Protocol, wire_limits
from mstc.cli import main
from mstc.errors import ControllerError
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import CanController, simulate
from mstc.loop.result import RunResult
from mstc.plant.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "sim" / "scenarios"
DBC = ROOT / "firmware" / "comm" / "mstc.dbc"
NAMES = ("paper-line", "paper-circle")
# candump -L: "(seconds.micro) iface ID#DATA", ID three hex digits for a
# standard frame, DATA upper-case hex, nothing after it.
CANDUMP_LINE = re.compile(r"^\(\d+\.\d{6}\) sil0 [0-9A-F]{3}#(?:[0-9A-F]{2}){0,8}$")


def _events(result: RunResult) -> list[tuple[int, str, int, str | None]]:
    return [(e.t_us, str(e.kind), e.obstacle, e.side and str(e.side)) for e in result.events]


@pytest.fixture(scope="module", params=NAMES)
def both_paths(request: pytest.FixtureRequest, sil_lib: Path) -> tuple[RunResult, RunResult]:
    scenario = load_scenario(SCENARIOS / f"{request.param}.toml", wire_limits())
    memory = simulate(scenario, SilController(scenario.params, sil_lib))
    with can.Bus(interface="mstc-sil", lib=str(sil_lib)) as bus:
        frames = simulate(scenario, CanController(bus, scenario.params, sim_time_stamps=True))
    return memory, frames


def test_frames_give_the_same_events_as_the_in_memory_step(
    both_paths: tuple[RunResult, RunResult],
) -> None:
    memory, frames = both_paths
    assert _events(frames) == _events(memory)
    assert len(frames.events) == 6


def test_frames_keep_the_path_within_a_millimetre_of_the_in_memory_step(
    both_paths: tuple[RunResult, RunResult],
) -> None:
    # The frames quantise poses to 2^-16 m and wheel speeds to 2^-10 rad/s
    # (docs/protocol.md); the loop corrects what that perturbs.
    memory, frames = both_paths
    dx = frames.trace["x"] - memory.trace["x"]
    dy = frames.trace["y"] - memory.trace["y"]
    assert float(max(abs(dx).max(), abs(dy).max())) < 1e-3
    assert frames.min_distance == pytest.approx(memory.min_distance, abs=5e-4)


@pytest.fixture(scope="module")
def cli_run(tmp_path_factory: pytest.TempPathFactory, sil_lib: Path) -> Path:
    out = tmp_path_factory.mktemp("sil")
    rc = main(
        [
            "sim",
            "--bus",
            "sil",
            "--lib",
            str(sil_lib),
            "--out",
            str(out),
            str(SCENARIOS / "paper-line.toml"),
        ]
    )
    assert rc == 0
    return out / "paper-line"


def test_bus_log_is_candump_format_byte_for_byte(cli_run: Path) -> None:
    text = (cli_run / "bus.log").read_text()
    assert text.endswith("\n")
    lines = text.splitlines()
    # One STEP frame per control step: 1001 steps in 20 s at 50 Hz.
    assert sum(1 for line in lines if " 104#" in line) == 1001
    bad = [line for line in lines if not CANDUMP_LINE.match(line)]
    assert bad == []
    # Time stamps are the simulated time and never go back.
    stamps = [float(line[1 : line.index(")")]) for line in lines]
    assert stamps == sorted(stamps)
    assert stamps[-1] == 20.0


def test_bus_log_reads_back_with_python_can(cli_run: Path) -> None:
    lines = (cli_run / "bus.log").read_text().splitlines()
    messages = list(can.LogReader(cli_run / "bus.log"))
    assert len(messages) == len(lines)
    for line, msg in zip(lines, messages, strict=True):
        ident, data = line.split(" ")[2].split("#")
        assert msg.arbitration_id == int(ident, 16)
        assert bytes(msg.data) == bytes.fromhex(data)
        assert not msg.is_extended_id


def test_bus_log_decodes_with_cantools_and_the_dbc(cli_run: Path) -> None:
    log = (cli_run / "bus.log").read_text()
    out = subprocess.run(
        [sys.executable, "-m", "cantools", "decode", "--single-line", str(DBC)],
        input=log,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.splitlines()
    assert len(out) == len(log.splitlines())
    undecoded = [line for line in out if "::" not in line or "Unknown" in line]
    assert undecoded == []
    assert any("EVENT_kind: activate" in line and "EVENT_side: right" in line for line in out)


def test_every_frame_passes_the_e2e_checks_of_both_sides(cli_run: Path) -> None:
    # The plant's protocol (same rules as comm.c) accepts every frame of the
    # log in order: no CRC error, no repeated or skipped counter.
    proto = Protocol()
    for msg in can.LogReader(cli_run / "bus.log"):
        proto.decode(msg)
    assert all(n == 0 for n in proto.drops.values())


def test_the_interface_is_registered_for_can_bus(sil_lib: Path) -> None:
    with can.Bus(interface="mstc-sil", lib=str(sil_lib)) as bus:
        assert bus.numeric in ("float", "fixed")
        with pytest.raises(can.CanOperationError, match="11-bit"):
            bus.send(can.Message(arbitration_id=0x100, is_extended_id=True, data=b"\0" * 8))
        # The firmware answers nothing it was not asked.
        assert bus.recv(timeout=0) is None


def test_missing_library_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(can.CanInitializationError, match="cannot load firmware library"):
        can.Bus(interface="mstc-sil", lib=str(tmp_path / "absent.so"))


def test_corrupt_frames_are_dropped_counted_and_reported(sil_lib: Path) -> None:
    scenario = load_scenario(SCENARIOS / "paper-line.toml", wire_limits())
    with can.Bus(interface="mstc-sil", lib=str(sil_lib)) as bus:
        ctl = CanController(bus, scenario.params, sim_time_stamps=True)
        bad = ctl.proto.encode("ODOM_XY", x=1.0, y=2.0)
        bad.data[3] ^= 0x01  # a flipped bit: the CRC no longer matches
        bus.send(bad)
        short = can.Message(arbitration_id=0x101, is_extended_id=False, data=b"\0" * 4)
        bus.send(short)
        bus.send(can.Message(arbitration_id=0x7FF, is_extended_id=False, data=b"\0" * 8))
        result = simulate(scenario, ctl)
    # The step after the drops reports them in its STATUS (fault bit 3), and
    # the firmware's counters (STATUS_COUNTERS, every 100 ms) count each.
    assert result.trace.values.shape[0] == 1001
    assert ctl.traffic.firmware_drops == {
        "crc_errors": 1,
        "seq_errors": 0,
        "len_errors": 1,
        "unknown_ids": 1,
    }


def test_no_answer_is_a_clear_error(sil_lib: Path) -> None:
    class Silent(can.BusABC):
        def __init__(self) -> None:
            super().__init__(channel="silent")

        def send(self, msg: can.Message, timeout: float | None = None) -> None:
            pass

        def _recv_internal(self, timeout: float | None) -> tuple[None, bool]:
            return None, False

    scenario = load_scenario(SCENARIOS / "paper-line.toml", wire_limits())
    with pytest.raises(ControllerError, match="no AUTH_STATUS"):
        CanController(Silent(), scenario.params, timeout=0.05)


def test_moving_obstacles_send_obstacle_vel_and_the_strategy_is_set(
    sil_lib: Path, tmp_path: Path
) -> None:
    from mstc.model import Obstacle, Params, Pose, Strategy

    proto = Protocol(node=None)
    with can.Bus(interface="mstc-sil", lib=str(sil_lib)) as bus:
        ctl = CanController(bus, Params(strategy=Strategy.PAPER), sim_time_stamps=True)
        obstacles = [Obstacle(1, 2.0, 0.0, 0.1), Obstacle(2, 3.0, 1.0, 0.1, vx=-0.5, vy=0.25)]
        ctl.step(Pose(0.0, 0.0, 0.0), Pose(0.0, 0.0, 0.0), 0.5, 0.0, obstacles, 0)
    sent = [proto.decode(m) for m, own in ctl.traffic.frames if own]
    names = [f.name for f in sent]
    param = [f for f in sent if f.name == "PARAM_SET" and f.signals["index"] == 14]
    assert len(param) == 1 and param[0].signals["value"] == 0.0  # paper
    # One OBSTACLE_VEL, right after the OBSTACLE of the moving obstacle (id 2).
    step = names.index("STEP")
    tail = sent[names.index("OBSTACLE") : step]
    assert [(f.name, f.signals["id"]) for f in tail] == [
        ("OBSTACLE", 1),
        ("OBSTACLE", 2),
        ("OBSTACLE_VEL", 2),
    ]
    assert tail[2].signals["vx"] == -0.5 and tail[2].signals["vy"] == 0.25
