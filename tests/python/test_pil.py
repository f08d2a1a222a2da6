# SPDX-License-Identifier: MIT
"""Processor in the loop: the board images themselves, under QEMU, in closed
loop with the plant (issues 14 and 32; docs/hil.md).

The images are the PIL variant of those `make flash` would write: built with
CAN=slcan (the same objects as the bxCAN images but for the CAN transport),
and with two simulated motors, the DC motor model, in place of the wheels'
drivers (the same objects as the slcan images but for those: both checked
here, object by object). `make pil` boots each under qemu-system-arm (F405
on netduinoplus2, F103 on netduino2), and the plant drives it through
python-can's slcan interface on its USART2, in lock-step.

- Both boards, both paper scenarios: every event at the paper's time to the
  control step, with the paper's sides, and the safe distance D_s kept (the
  paper's table is tests/python/test_paper.py's).
- The F103 image (Q16.16) runs the closed loop bit for bit as the host fixed
  build does through the same frames in process (`mstc sim`): trace.csv
  (every pose, the velocities from every wheel command, the errors) and
  events.json are byte-identical. The F405 image (float on the M4F's FPU)
  gives the host float build's events; its bits may differ (other libm,
  fused multiply-adds).
- The board ran one control step per STEP frame and none on its timer
  (loop_stats.json).
- The comm-loss trial of docs/safety.md against the F103 image: odometry cut
  at a seeded step and phase, the halt flagged within 3 control periods and
  the wheels ramped down at max_wheel_decel, checked by the very function the
  host build's test uses (tests/python/test_faults.py).
- The paper's line on "dc" wheels under "mstc" (issue 32): the board's wheel
  loop closes on its own simulated motors at 1 kHz, on the plant's time, and
  the control step runs on its measurements. Its events are the in-process
  run's (the host library of the board's numeric mode, an integrated board
  too) within two control steps; the wheel loop's figures from the board's
  motors (rise to 63 % and 90 % of the command, the largest and RMS error
  against the ramped command: mstc.firmware.wheels.loop_figures) within 5 %
  of those of the loop in process under the commands the board gave (its
  WHEEL_CMD in bus.log, decoded with cantools); no wheel fault; a
  WHEEL_SPEED from the board at every step.

Needs the cross toolchain and qemu-system-arm (tools/setup/debian-test.txt);
without them these fail, loudly. `make pil` takes about 2 to 3 minutes.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import can
import pytest

from mstc.can.protocol import load_database, wire_limits
from mstc.cli.hil import SLCAN_BITRATE
from mstc.firmware.qemu import PIL_TRACE_N, BoardVm
from mstc.firmware.wheels import SUBSTEP_US, loop_figures, wheels_for
from mstc.loop.lockstep import CanController, enter_lockstep, simulate, simulate_on_sil_bus
from mstc.model import Pose
from mstc.plant.plant import Integrator, UnicyclePlant
from mstc.plant.scenario import load_scenario
from mstc.report.outputs import events_json, write_trace_csv
from test_board_images import make
from test_faults import _cut_trial
from test_paper import D_S, PAPER

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "sim" / "scenarios"
PIL = ROOT / "build" / "pil"
BOARDS = ("stm32f405", "stm32f103")
NAMES = sorted(PAPER)
TRANSPORT = {"bxcan": {"bxcan.o", "bxcan_calc.o"}, "slcan": {"slcan.o", "slcan_codec.o"}}
WHEEL_DRIVERS = {"slcan": {"encoder.o", "motor_pwm.o"}, "pil": {"pil_wheels.o", "dcm.o"}}
DC = ROOT / "build" / "pil" / "scenarios" / "paper-line-dc.toml"
"""The paper's line on "dc" wheels under "mstc", as `make pil` writes it."""
CUT_SEEDS = (100, 109)
"""test_faults' seeds of two odometry cuts (steps 79 and 148, phases 3 and 1)."""


SIM_KEY_FILE = ROOT / "keys" / "sim.key"
"""The key `make pil` installs into its copies of the board images
(SIM_KEY_FILE, mk/auth.mk, mk/pil.mk): the simulations', never a device's."""
PIL_IMAGES = PIL / "images"
"""Where `make pil` keeps those copies."""
MODE = {"stm32f103": "fixed", "stm32f405": "float"}
"""Each board image's numeric mode."""


@pytest.fixture(scope="module")
def pil() -> str:
    """`make pil`: both boards, both paper scenarios; its output."""
    r = make("pil")
    out = r.stdout + r.stderr
    assert r.returncode == 0, out[-4000:]
    return out


def _folder(board: str, name: str) -> Path:
    return PIL / board / name


# ------------------------------------------------------------- the paper


@pytest.mark.parametrize("board", BOARDS)
@pytest.mark.parametrize("name", NAMES)
def test_pil_reproduces_every_event_of_the_paper_and_keeps_d_s(
    pil: str, board: str, name: str
) -> None:
    doc = json.loads((_folder(board, name) / "events.json").read_text())
    got = sorted(
        (round(e["t"] * 1e6), e["event"], e["obstacle"], e.get("side")) for e in doc["events"]
    )
    want = sorted((round(t * 1e6), kind, o, side) for t, kind, o, side in PAPER[name])
    # Equal lists: the same control step, the same side, nothing extra.
    assert got == want
    assert len(doc["min_distance"]) == 2 and all(d >= D_S for d in doc["min_distance"])
    for f in ("trace.csv", "bus.log", "loop_stats.json"):
        assert (_folder(board, name) / f).is_file()


@pytest.mark.parametrize("board", BOARDS)
@pytest.mark.parametrize("name", NAMES)
def test_pil_board_ran_one_step_per_step_frame_and_none_on_its_timer(
    pil: str, board: str, name: str
) -> None:
    stats = json.loads((_folder(board, name) / "loop_stats.json").read_text())
    steps = len((_folder(board, name) / "trace.csv").read_text().splitlines()) - 1
    assert (stats["board"], stats["steps"], stats["timer_steps"]) == (board, steps, 0)
    assert stats["instructions_per_step"]["mean"] > 0


def _host_run(lib: Path, name: str, out: Path) -> Path:
    """The scenario through the host build over CAN in process (mstc sim's
    path); its events.json and trace.csv in @p out."""
    scenario = load_scenario(SCENARIOS / f"{name}.toml", wire_limits())
    bus = can.Bus(interface="mstc-sil", channel="sil0", lib=str(lib))
    try:
        result = simulate(scenario, CanController(bus, scenario.params, sim_time_stamps=True))
    finally:
        bus.shutdown()
    (out / "events.json").write_text(events_json(result))
    write_trace_csv(result.trace, [o.id for o in scenario.obstacles], out / "trace.csv")
    return out


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# What each image must share with the host build of its numeric mode: the
# F103 (Q16.16) every bit of the closed loop, the F405 (float on the FPU) the
# events.
HOST = {
    "stm32f103": ("fixed", ("trace.csv", "events.json")),
    "stm32f405": ("float", ("events.json",)),
}


@pytest.mark.parametrize("board", BOARDS)
@pytest.mark.parametrize("name", NAMES)
def test_pil_closed_loop_is_the_host_builds_bit_for_bit_on_f103_in_events_on_f405(
    pil: str, libs: dict[str, Path], board: str, name: str, tmp_path: Path
) -> None:
    mode, files = HOST[board]
    host = _host_run(libs[mode], name, tmp_path)
    for f in files:
        assert _sha(_folder(board, name) / f) == _sha(host / f), f


# ------------------------------------------------------------ comm loss


class AnsweringBus:
    """A lock-step view of an asynchronous bus, for test_faults' Loop.

    Loop reads the firmware's answers with ``recv(timeout=0)`` right after
    sending, as the in-process bus answers at once. Here send() of a STEP,
    PARAM_AUTH or PARAM_GET returns only once its answer (the WHEEL_CMD
    echoing the step; the PARAM_VALUE and the AUTH_STATUS after it) has
    arrived; every frame received meanwhile is kept, in order, for recv().
    """

    def __init__(self, bus: can.BusABC, timeout: float = 5.0) -> None:
        self.bus = bus
        self.timeout = timeout
        self.db = load_database()
        self.received: deque[can.Message] = deque()

    def _signal(self, msg: can.Message, name: str, signal: str) -> int | None:
        message = self.db.get_message_by_name(name)
        if msg.arbitration_id != message.frame_id:
            return None
        return int(message.decode(bytes(msg.data), decode_choices=False)[f"{name}_{signal}"])

    def _answer(self, msg: can.Message) -> Callable[[can.Message], bool] | None:
        step = self._signal(msg, "STEP", "step")
        if step is not None:
            return lambda m: self._signal(m, "WHEEL_CMD", "step") == step
        # A PARAM_SET is answered once its PARAM_AUTH is in (docs/safety.md):
        # wait after that one; a PARAM_GET is answered at once. The status
        # that follows every PARAM_VALUE ends the wait: its second half,
        # AUTH_CHALLENGE.
        if self._signal(msg, "PARAM_AUTH", "freshness") is not None or (
            self._signal(msg, "PARAM_GET", "index") is not None
        ):
            return lambda m: (
                m.arbitration_id == self.db.get_message_by_name("AUTH_CHALLENGE").frame_id
            )
        return None

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.bus.send(msg)
        answer = self._answer(msg)
        if answer is None:
            return
        deadline = time.monotonic() + self.timeout
        while (left := deadline - time.monotonic()) > 0:
            got = self.bus.recv(timeout=left)
            if got is not None:
                self.received.append(got)
                if answer(got):
                    return
        raise AssertionError(f"no answer to 0x{msg.arbitration_id:03X} within {self.timeout} s")

    def recv(self, timeout: float | None = None) -> can.Message | None:
        if self.received:
            return self.received.popleft()
        return self.bus.recv(timeout=timeout)


@pytest.mark.parametrize("seed", CUT_SEEDS)
def test_f103_image_halts_within_3_periods_and_ramps_down_when_odometry_is_cut(
    pil: str, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    # make pil's copy of the image holds the simulations' key, not the test
    # key the other tests use (conftest.py).
    monkeypatch.setenv("MSTC_KEY_FILE", str(SIM_KEY_FILE))
    scenario = load_scenario(SCENARIOS / "paper-line.toml", wire_limits())
    with BoardVm(PIL_IMAGES / "stm32f103-pil", serial=True) as vm:
        bus = can.Bus(
            interface="slcan", channel=vm.channel, bitrate=SLCAN_BITRATE, sleep_after_open=0
        )
        try:
            enter_lockstep(bus)
            start = vm.stats()
            _cut_trial(AnsweringBus(bus), scenario, seed, instant=False)  # type: ignore[arg-type]
            end = vm.stats()
        finally:
            bus.shutdown()
    assert end.steps - start.steps == end.frame_steps - start.frame_steps, "no timer step"


# ------------------------------------------------- the wheels, on the board


def _in_process_dc(lib: Path) -> dict[str, Any]:
    """The "dc" line in process, through CAN frames, the firmware an
    integrated board on the wheels it measures: its events.json."""
    scenario = load_scenario(DC, wire_limits())
    wheels = wheels_for(scenario, lib)
    assert wheels is not None
    result, _, _ = simulate_on_sil_bus(scenario, lib, wheels)
    loaded: dict[str, Any] = json.loads(events_json(result))
    return loaded


def _in_process_wheels(folder: Path, lib: Path) -> tuple[list[Any], list[Any]]:
    """The wheel loop in process (the host library of the board's numeric
    mode) under the commands the board gave its own in the run: each STEP
    step's WHEEL_CMD of bus.log, decoded with cantools, in force for a control
    period. Its wheels' true speeds over the first PIL_TRACE_N periods, and
    those commands."""
    db = load_database()
    cmd = db.get_message_by_name("WHEEL_CMD")
    step = db.get_message_by_name("STEP")
    commands: list[tuple[float, float]] = []
    stepping = False
    for m in can.LogReader(folder / "bus.log"):
        if m.arbitration_id == step.frame_id:
            stepping = step.decode(bytes(m.data))["STEP_step"] != 0xFFFF  # not the primer
        elif m.arbitration_id == cmd.frame_id and stepping:
            s = cmd.decode(bytes(m.data))
            commands.append((float(s["WHEEL_CMD_left"]), float(s["WHEEL_CMD_right"])))
    scenario = load_scenario(DC, wire_limits())
    wheels = wheels_for(scenario, lib)
    assert wheels is not None
    wheels.record = PIL_TRACE_N
    plant = UnicyclePlant(Pose(0.0, 0.0, 0.0), 0.05, 0.3, Integrator.EULER)
    for left, right in commands[: PIL_TRACE_N // 20 + 1]:
        wheels.drive(plant, left, right, 0.02)
    return wheels.speeds, wheels.commands


def _matched(ours: list[dict[str, Any]], theirs: list[dict[str, Any]], slack: float) -> bool:
    """Every event of @p ours has one of the same kind, obstacle and side in
    @p theirs within @p slack seconds."""
    key = ("event", "obstacle", "side")
    return all(
        any(
            all(a.get(k) == b.get(k) for k in key) and abs(a["t"] - b["t"]) <= slack for b in theirs
        )
        for a in ours
    )


@pytest.mark.parametrize("board", BOARDS)
def test_pil_dc_line_closes_the_wheel_loop_on_the_board_like_the_simulation(
    pil: str, libs: dict[str, Path], board: str
) -> None:
    folder = _folder(board, "paper-line-dc")
    stats = json.loads((folder / "loop_stats.json").read_text())
    wheel = stats["wheel_loop"]
    steps = stats["steps"]
    # Both loops ran: a wheel period every millisecond of the plant's time
    # (20 a control period), closed on the simulated encoders, no fault.
    assert wheel["periods_on_steps"] == 20 * (steps - 1)
    assert wheel["closed_loop"] and wheel["faults"] == 0
    assert wheel["instructions_per_period"]["mean"] > 0
    assert stats["timer_steps"] == 0
    # The board reported what it measured: a WHEEL_SPEED at every step.
    db = load_database()
    speed_id = db.get_message_by_name("WHEEL_SPEED").frame_id
    reports = [m for m in can.LogReader(folder / "bus.log") if m.arbitration_id == speed_id]
    assert len(reports) >= steps
    # The events: the in-process run's, each within two control steps.
    ours = json.loads((folder / "events.json").read_text())
    theirs = _in_process_dc(libs[MODE[board]])
    slack = 2 * 0.02 + 1e-9
    assert _matched(ours["events"], theirs["events"], slack)
    assert _matched(theirs["events"], ours["events"], slack)
    assert all(d >= D_S for d in ours["min_distance"])
    # The wheel loop's figures from the board's motors: within 5 % of those
    # of the loop in process under the same commands.
    speeds, commands = _in_process_wheels(folder, libs[MODE[board]])
    per_step = 20000 // SUBSTEP_US
    sim = loop_figures(speeds, commands, per_step, 125.0).as_dict()
    got = wheel["figures"]["board"]
    for name, pair in sim.items():
        for wheel_got, wheel_sim in zip(got[name], pair, strict=True):
            assert abs(wheel_got - wheel_sim) <= 0.05 * abs(wheel_sim), (name, got, sim)


def test_pil_image_differs_from_the_slcan_image_in_the_wheel_drivers_only() -> None:
    for board in BOARDS:
        _fresh_app(f"{board}-slcan", f"{board}-pil")
        r = make(f"img-{board}-slcan", f"img-{board}-pil")
        assert r.returncode == 0, (r.stdout + r.stderr)[-4000:]
        sl, pil = _objects(f"{board}-slcan"), _objects(f"{board}-pil")
        assert {Path(p).name for p in set(sl) - set(pil)} == WHEEL_DRIVERS["slcan"]
        assert {Path(p).name for p in set(pil) - set(sl)} == WHEEL_DRIVERS["pil"]
        common = sorted(set(sl) & set(pil))
        assert "hal/stm32/main.o" in common and "firmware/wheel/whl.o" in common
        different = [p for p in common if sl[p].read_bytes() != pil[p].read_bytes()]
        assert different == [], "objects that differ beyond the wheel drivers"


# ------------------------------------------------------ only the transport


def _fresh_app(*images: str) -> None:
    """Remove the images' app.o: it holds the commit of its last compile
    (FW_VERSION's build id), so two images compare equal only when both
    compile it in the same tree (a working tree's images may be of two)."""
    for image in images:
        d = ROOT / "build" / "firmware" / image
        # The image too: make remakes a missing object (an intermediate
        # file) only for a target that is out of date.
        for made in (*d.glob("obj-*/firmware/app/app.o"), d / "mstc.elf"):
            made.unlink(missing_ok=True)


def _objects(image: str) -> dict[str, Path]:
    """The build's objects an image's link map loads, by path in its object
    directory."""
    d = ROOT / "build" / "firmware" / image
    loads = re.findall(r"^LOAD (\S+\.o)$", (d / "mstc.map").read_text(), re.M)
    prefix = f"build/firmware/{image}/"
    objs = {}
    for p in loads:
        assert p.startswith(prefix), p
        objs[p[len(prefix) :].split("/", 1)[1]] = ROOT / p
    return objs


def _libraries(image: str) -> list[str]:
    text = (ROOT / "build" / "firmware" / image / "mstc.map").read_text()
    return sorted(set(re.findall(r"^LOAD (\S+\.a)$", text, re.M)))


@pytest.mark.parametrize("board", BOARDS)
def test_slcan_image_differs_from_the_bxcan_image_in_the_transport_only(board: str) -> None:
    _fresh_app(board, f"{board}-slcan")
    r = make(f"img-{board}", f"img-{board}-slcan")
    assert r.returncode == 0, (r.stdout + r.stderr)[-4000:]
    bx, sl = _objects(board), _objects(f"{board}-slcan")
    assert {Path(p).name for p in set(bx) - set(sl)} == TRANSPORT["bxcan"]
    assert {Path(p).name for p in set(sl) - set(bx)} == TRANSPORT["slcan"]
    common = sorted(set(bx) & set(sl))
    # The application, the main loop, the clock and the timers among them.
    for must in ("firmware/app/app.o", "hal/stm32/main.o", "hal/stm32/time.o", "hal/stm32/tick.o"):
        assert must in common
    different = [p for p in common if bx[p].read_bytes() != sl[p].read_bytes()]
    assert different == [], "objects that differ beyond the transport"
    assert _libraries(board) == _libraries(f"{board}-slcan")
