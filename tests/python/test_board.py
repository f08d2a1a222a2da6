# SPDX-License-Identifier: MIT
"""``mstc board`` against the in-process firmware (mstc-sil): version, get,
set, arm, disarm, status, monitor; node ids, and two firmwares with
different node ids on one bus, each driven by its own ``mstc board``.

Expected values: the version from pyproject.toml and the protocol from the
DBC's VERSION line (read here, not from the firmware); defaults and limits
from sim/mstc/ctl_params.toml (D_s = 0.35 m, Table 1 of the paper); what a
set or an arm is answered with from the firmware's documented rules
(docs/safety.md: D_s must stay below D_act = 0.5 m; arming needs odometry).
"""

from __future__ import annotations

import re
import shutil
import tomllib
from collections.abc import Iterator
from pathlib import Path

import can
import pytest

from conftest import ROOT
from mstc.can import secoc
from mstc.can.protocol import Protocol
from mstc.can.silbus import SilBus
from mstc.cli import board as board_cli
from mstc.cli import main
from mstc.loop.lockstep import odometry_frames, reference_frames, step_frame
from mstc.model import Pose

KEY = ["--key-file", str(secoc.TEST_KEY_FILE)]
"""The in-process firmware takes $MSTC_KEY_FILE (conftest: the test key)."""


def board(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    rc = main(["board", *KEY, *args])
    out, err = capsys.readouterr()
    return rc, out, err


def test_version_names_the_package_version_the_protocol_and_the_node(
    capsys: pytest.CaptureFixture[str], sil_lib: Path
) -> None:
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    protocol = re.search(r'^VERSION "mstc (\d+)"', (ROOT / "sim/mstc/can/mstc.dbc").read_text())
    assert protocol is not None
    for node in ("0", "3"):
        rc, out, err = board(capsys, "--lib", str(sil_lib), "--node", node, "version")
        assert rc == 0, err
        assert out.startswith(f"node {node}: mstc firmware {version} (build ")
        assert out.rstrip().endswith(f", float, protocol {protocol[1]}")


def test_get_set_and_refusals_with_their_reasons(
    capsys: pytest.CaptureFixture[str], sil_lib: Path
) -> None:
    lib = ["--lib", str(sil_lib)]
    rc, out, _ = board(capsys, *lib, "get", "D_s", "strategy")
    assert rc == 0
    lines = out.splitlines()
    assert re.match(r"D_s\s+0\.35 m\s+\[0\.05 \.\. 60\]", lines[0]), lines
    assert re.match(r"strategy\s+mstc\s+one of paper, mstc", lines[1]), lines
    # Each `mstc board` starts a fresh in-process firmware: a set holds for its own run.
    rc, out, _ = board(capsys, *lib, "set", "D_s", "0.4")
    assert (rc, out) == (0, "D_s = 0.4 m\n")
    rc, out, err = board(capsys, *lib, "set", "D_s", "0.6")  # D_s < D_act = 0.5 m: refused
    assert rc == 1
    assert err.startswith("error: set D_s 0.6: rejected: the set that would result breaks")
    assert err.rstrip().endswith("(value in force: 0.35 m)")
    rc, out, err = board(capsys, *lib, "set", "Ds", "1")
    assert (rc, err) == (2, "error: no parameter 'Ds': did you mean D_s?\n")
    rc, out, err = board(capsys, *lib, "arm")  # no odometry, no reference: not ready
    assert rc == 1
    assert err.startswith("error: arm: rejected: not ready: the firmware arms only when odometry")
    rc, out, _ = board(capsys, *lib, "disarm")
    assert (rc, out) == (0, "disarmed (a ramped stop)\n")


def test_a_set_under_another_key_is_refused_and_says_why(
    capsys: pytest.CaptureFixture[str], sil_lib: Path, tmp_path: Path
) -> None:
    """The firmware has the test key; the tool signs with another: no status
    verifies, nothing is signed, and the error says so."""
    other = tmp_path / "other.key"
    other.write_text("00112233445566778899aabbccddeeff\n")
    other.chmod(0o600)
    rc = main(["board", "--lib", str(sil_lib), "--key-file", str(other), "set", "D_s", "0.4"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "does not verify under the key" in err, err


class PlantFed(SilBus):
    """The in-process firmware after a plant's few control steps: its
    answers wait in its queue for whoever reads the bus."""

    def __init__(self, *args: object, steps: int = 3, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        proto = Protocol(node="PLANT", node_id=self._node or 0)
        for k in range(steps):
            for msg in [
                *odometry_frames(proto, Pose(0.0, 0.0, 0.0)),
                *reference_frames(proto, Pose(0.1, 0.0, 0.0), 0.5, 0.0),
                step_frame(proto, k, 20_000 * (k + 1)),
            ]:
                self.send(msg)


def test_status_and_monitor_show_what_the_firmware_sent(
    capsys: pytest.CaptureFixture[str], sil_lib: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Three control steps of a plant, then `mstc board status` and
    `monitor`: the firmware, not armed, holds the robot (mode stop, halt
    not_armed, wheels at 0: docs/safety.md), and the monitor decodes its frames."""
    key = secoc.read_key(secoc.TEST_KEY_FILE)

    def fed(args: object, **config: object) -> can.BusABC:
        return PlantFed(lib=str(sil_lib), key=key, node=config.get("node"))

    monkeypatch.setattr(board_cli, "open_args_bus", fed)
    rc, out, _ = board(capsys, "-n", "1", "status")
    assert rc == 0
    assert "armed no" in out
    assert re.search(r"mode\s+stop, halt not_armed, faults none", out), out
    assert "left 0.000 rad/s, right 0.000 rad/s (WHEEL_CMD)" in out
    rc, out, _ = board(capsys, "-n", "8", "monitor")
    assert rc == 0
    lines = out.splitlines()
    assert len(lines) == 8
    assert any(re.search(r"0x180  WHEEL_CMD\s+step=0 left=0rad/s right=0rad/s", x) for x in lines)
    assert any(re.search(r"0x181  STATUS\s+mode=stop side=none", x) for x in lines), lines


class SharedBus(can.BusABC):
    """One CAN bus with two firmwares on it (two copies of the library, so
    two instances), as two boards on one cable: a frame sent reaches both,
    and what each sends reaches the other and the tool."""

    def __init__(self, firmwares: list[SilBus]) -> None:
        self.firmwares = firmwares
        self.queue: list[can.Message] = []
        self.channel_info = "two mstc-sil firmwares on one bus"
        super().__init__(channel="shared")

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        pending = [(None, msg)]
        while pending:
            source, frame = pending.pop(0)
            for fw in self.firmwares:
                if fw is source:
                    continue
                fw.send(frame)
                while (out := fw.recv(timeout=0.0)) is not None:
                    pending.append((fw, out))
                    self.queue.append(out)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        return (self.queue.pop(0) if self.queue else None), False

    def shutdown(self) -> None:
        """Kept open across the `mstc board` runs of the test."""


@pytest.fixture
def two_boards(sil_lib: Path, tmp_path: Path) -> Iterator[SharedBus]:
    key = secoc.read_key(secoc.TEST_KEY_FILE)
    firmwares = []
    for node in (0, 1):
        copy = tmp_path / f"node{node}" / sil_lib.name
        copy.parent.mkdir()
        shutil.copy(sil_lib, copy)
        firmwares.append(SilBus(lib=str(copy), key=key, node=node))
    yield SharedBus(firmwares)
    for fw in firmwares:
        fw.shutdown()


def test_two_firmwares_with_different_node_ids_on_one_bus(
    capsys: pytest.CaptureFixture[str], two_boards: SharedBus, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each `mstc board --node N` reaches its own board only: the versions
    name their nodes, and a set on one leaves the other's value."""
    monkeypatch.setattr(board_cli, "open_args_bus", lambda args, **config: two_boards)
    for node in ("0", "1"):
        rc, out, err = board(capsys, "--node", node, "version")
        assert rc == 0, err
        assert out.startswith(f"node {node}: ")
    assert board(capsys, "--node", "0", "set", "D_s", "0.4")[:2] == (0, "D_s = 0.4 m\n")
    assert board(capsys, "--node", "1", "set", "D_s", "0.45")[:2] == (0, "D_s = 0.45 m\n")
    for node, value in (("0", "0.4"), ("1", "0.45")):
        rc, out, _ = board(capsys, "--node", node, "get", "D_s")
        assert rc == 0
        assert re.match(rf"D_s\s+{value} m", out), out
